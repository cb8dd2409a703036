// The paper's Driver Evaluation module: "every mistake will be associated with a worrying level
// and finally the mark of the exam is shown". Every physics tick the Evaluator looks at the
// truck's state, the contacts and pallet moves of that tick and the scenario's task, and turns
// mistakes into events, one per occurrence; at the end of the session it gives the Score.
//
// The rules are data (data/evaluation/rules.json: identifiers, plain-language descriptions,
// worry levels, the marking-sheet item or regulation each comes from, thresholds with units in
// their names); the code holds only the detectors that measure what the thresholds bound.
// The Evaluator reads no clock and draws no random number: the same ticks give the same events
// and the same mark, so a replay of the control log re-derives them exactly.
//
// Frames: world x, y on the floor, z up, metres; times are sim time in seconds.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <functional>
#include <string>
#include <vector>

#include "forklift/collision/collision.h"  // StepReport, Contact, HandlingEvent
#include "forklift/dynamics/dynamics.h"   // Outputs, BodyPoses, DriverInputs, Load
#include "forklift/dynamics/load_on_forks.h"  // LoadOnForks
#include "forklift/scene/scene.h"      // Scene, PalletState, TruckShape
#include "forklift/session/vocabulary.h"  // Mode
#include "forklift/units/units.h"

namespace forklift {

// A rules file that cannot be used; the message names the file and the key.
class RulesError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One rule of the marking sheet.
struct Rule {
  std::string id;           // the event kind: "speed_near_walkway", "tip_over", ...
  std::string title;        // its name in a few words ("Violent collision"); "" when the file gives none
  std::string description;  // what the pupil did wrong, in words a pupil understands
  int worry_level = 0;      // 0 information or warning (no points), 1 minor, 3 medium, 5 serious
  bool automatic_fail = false;  // one occurrence fails an exam whatever the points
  std::string source;       // the marking-sheet item or regulation clause it follows
  std::vector<std::string> applies_to;  // object kinds (collision rules) or zone kinds (speed rules)
  // Named numbers, units in the names ("min_duration_s"); looked up by const char* without a copy.
  std::map<std::string, double, std::less<>> thresholds;
};

// How events become points and a decision (the UK basic operating skills test's penalty scheme
// by default; see data/evaluation/README.md).
struct Scheme {
  std::string name, source;
  std::map<int, int> points_by_worry_level;  // every worry level a rule uses must be here
  int fail_above_points = 40;                // more points than this fails
  int serious_worry_level = 5;               // the level whose repetition fails ...
  int max_same_serious_fault = 3;            // ... when one such rule occurs more often than this
  double mark_start = 100;                   // mark = max(0, mark_start - points)
  bool task_required = true;                 // a session (training or exam) is failed unless its task is complete
  std::vector<std::string> parking_checked_on_end;  // end reasons after which the truck was left, if its task is done
};

struct Rules {
  std::string file;
  Scheme scheme;
  // Braking, cornering and the stability margin read the chassis's acceleration through a
  // first-order low-pass filter with this time constant (the body's 5 Hz pitch and roll
  // oscillations are not manoeuvres).
  double acceleration_filter_time_constant_s = 0.03;
  std::vector<Rule> rules;
  const Rule* find(const std::string& id) const;  // nullptr if absent
};

// Reads a rules file. Throws RulesError naming the file and the key for a missing or unknown
// key, a wrong type, a worry level the scheme does not score, a repeated id, a rule the
// Evaluator does not know, or a rule it needs that is missing.
Rules load_rules(const std::string& path);
// The rule ids the Evaluator implements (each must appear once in a rules file).
const std::vector<std::string>& rule_ids();

// Mode (training or exam) is the session vocabulary's (forklift/session/vocabulary.h).
const char* mode_name(Mode mode);          // name(mode): "training", "exam"
Mode parse_mode(const std::string& name);  // throws std::invalid_argument

// What one physics tick produced, after dynamics and collision (the worker's pipeline order).
// Everything is read during tick() only; nothing is kept by reference.
struct TickInput {
  double t_s;                              // sim time at the end of the tick
  const Outputs& out;                      // the model's outputs at the tick's state
  const BodyPoses& poses;                  // body_poses(truck, out.q)
  const DriverInputs& inputs;              // what the truck was driven with during the tick
  const StepReport& report;                // Warehouse::step's contacts and pallet handling
  const std::vector<PalletState>& pallets; // HandlingState::pallets() after the step
  const std::optional<Load>& load;         // the load on the forks now, as put there (Simulation::load())
  bool deadman = false;                    // the worker substituted the dead-man inputs
  Eigen::Vector3d gravity_m_s2 = Eigen::Vector3d(0, 0, -kGravity_m_s2);  // the environment's gravity
  // The load on the forks as the truck's model left it after the tick's dynamics (slid along
  // them, fallen off them): what the load rules judge (Simulation::load_on_forks()).
  LoadOnForks load_on_forks{};
  // The scene's walking people after the tick's walk (one per Scene::pedestrians); null or empty
  // when it has none.
  const std::vector<PedestrianState>* pedestrians = nullptr;
  // The scene's other trucks after the tick's drive (one per Scene::trucks); null or empty when
  // it has none.
  const std::vector<OtherTruckState>* trucks = nullptr;
};

struct EvaluationEvent {
  uint32_t seq = 0;     // 1, 2, ... in the order found
  double t_s = 0;       // sim time
  std::string rule;     // Rule::id: the event's kind
  int worry_level = 0;  // the rule's level, or the harder grade it reached (collisions)
  int points = 0;       // from the scheme
  bool automatic_fail = false;
  double x_m = 0, y_m = 0;  // where: the contact point, the pallet, or the truck's CoG
  std::string details;  // JSON object text: the description, the measured values, the thresholds
                        // crossed, the object, and the source followed
};

struct Score {
  double mark = 0;   // mark_start - points, floor 0
  // Points not above fail_above_points, no automatic failure and, when the scheme requires it (the
  // default), the task completed: a session whose task was left undone is not passed, training
  // or exam.
  bool passed = false;
  int points = 0;
  std::map<std::string, int> counts;  // events by rule id (warnings included)
  std::vector<std::string> automatic_failures;  // rule ids, and "repeated:<id>" for a serious fault
                                                // occurring more than max_same_serious_fault times
  bool task_completed = false;
  int steps_done = 0, steps_total = 0;
  std::string end_reason;
  std::string mode;
  double min_stability_fraction = 1;  // lowest stability margin fraction seen
};

// A score as a person reads it, a line each: "mark 92 of 100, passed (training), 8 points off,
// task completed", then each fault counted in the rules' words ("  2 x <description>") and what
// fails by itself; never the log's hex float or a rule's id (the worker's summary, its replay,
// forklift-sim evaluate).
std::string score_words(const Score& score, const Rules& rules);

// The stability triangle (front wheels' and rear wheel's contact points) and the combined CoG
// projected onto its plane along the apparent gravity g - a (a: the chassis's low-pass filtered
// acceleration, so braking and cornering move the point as they move the wheel loads).
struct Stability {
  double margin_m = 0;   // signed distance to the nearest edge, + inside
  double fraction = 1;   // margin_m / the unladen truck's static margin on level ground
  int edge = -1;         // nearest edge: 0 front axle (tip forward), 1 left side, 2 right side
  Eigen::Vector2d cog_projection_m = Eigen::Vector2d::Zero();  // world x, y
};
// The margin of `cog` projected along `g` onto the plane of the triangle of the three wheels'
// contact points (world frame; `g` the apparent gravity). Exposed for tests and tools.
Stability stability_margin(const Eigen::Vector3d& cog, const Eigen::Vector3d& g, const Eigen::Vector3d& front_left,
                           const Eigen::Vector3d& front_right, const Eigen::Vector3d& rear);

// Rated capacity at a load centre (the capacity-plate rule): rated * rated_centre / centre for
// centres beyond the rated one, the rated capacity for nearer ones.
double derated_capacity_kg(const TruckParams& truck, double load_centre_m);

// What the evaluation remembers from tick to tick (events so far, points, debounce timers,
// episodes, the task's progress): a copyable value, so that a session's state can be copied as a
// rewind point. Its contents are the evaluator's business.
class EvaluationMemory {
 public:
  EvaluationMemory();
  EvaluationMemory(const EvaluationMemory&);
  EvaluationMemory& operator=(const EvaluationMemory&);
  EvaluationMemory(EvaluationMemory&&) noexcept;
  EvaluationMemory& operator=(EvaluationMemory&&) noexcept;
  ~EvaluationMemory();

  const std::vector<EvaluationEvent>& events() const;  // every event so far
  int points() const;
  const Stability& stability() const;  // at the last tick
  int steps_done() const;

  struct Data;

 private:
  friend class Evaluator;
  std::unique_ptr<Data> d_;
};

class Evaluator {
 public:
  // Copies what it needs. Throws RulesError when a rule, threshold or scored worry level is
  // missing (rules edited in code) or the scene has a zone kind no speed rule covers. The truck's
  // static margin is computed here (one settle, a few milliseconds).
  Evaluator(const Rules& rules, const Scene& scene, const TruckParams& truck, const TruckShape& shape, Mode mode);
  ~Evaluator();
  Evaluator(const Evaluator&) = delete;
  Evaluator& operator=(const Evaluator&) = delete;

  // One physics tick on a session's memory (part of its state; a fresh EvaluationMemory starts
  // the session); appends the events found to `out` (usually none). After the first tick it
  // allocates nothing unless an event is found. Calling it after finish() is a programming error
  // (aborts). After a tip-over it marks nothing more.
  void tick(EvaluationMemory& memory, const TickInput& in, std::vector<EvaluationEvent>& out);

  // Ends the session: parking checks (when `end_reason` is in the scheme's parking list) and the
  // task check append their events to `out`; returns the Score. Call once per memory.
  Score finish(EvaluationMemory& memory, const std::string& end_reason, std::vector<EvaluationEvent>& out);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  EvaluationMemory initial_;
};

}  // namespace forklift
