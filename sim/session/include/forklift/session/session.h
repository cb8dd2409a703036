// One session of one cab, as three things (after MuJoCo's mjModel / mjData and CARLA's episode
// settings):
//   SessionModel      what the session is, fixed for its whole life: scene, truck, rules, mode,
//                     tick and integrator, loaded and checked once by load_session_model;
//   SessionState      what changes, as a plain copyable value: the truck's state and time, the
//                     inputs held, the load on the forks, the scene's push-back, every pallet,
//                     the evaluation's memory; a copy is a rewind point;
//   SessionWorkspace  the machinery that steps a state: the integrator, the FCL shapes, the
//                     evaluator's tables, scratch. It holds nothing a copy of the state needs.
// and one step() that the worker, both replays, `forklift-sim evaluate`, the tests and the
// benches call, in named stages: dynamics, collision and handling, evaluation.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "forklift/collision/collision.h"
#include "forklift/dynamics/simulation.h"
#include "forklift/evaluation/evaluation.h"
#include "forklift/scene/falling.h"
#include "forklift/scene/pedestrians.h"
#include "forklift/scene/scene.h"
#include "forklift/scene/spills.h"
#include "forklift/scene/traffic.h"
#include "forklift/session/session_log.h"
#include "forklift/session/vocabulary.h"

namespace forklift {

// What the session is made from. Paths are as given (relative to the working directory); the
// truck and the rules default to the scenario's and data/evaluation/rules.json.
struct SessionSpec {
  std::string scenario_file;  // empty: a bare floor with the default truck
  std::string truck_file;     // instead of the scenario's (empty: the scenario's)
  std::string rules_file;     // empty: <data>/evaluation/rules.json
  std::string mode = "training";
  IntegratorOptions integrator;
};

struct SessionModel {
  Scene scene;                // with its scenario: start pose, initial load
  std::string scenario_file;  // absolute, as logs record it; empty: a bare floor
  TruckParams truck;
  TruckShape shape;
  Rules rules;
  Mode mode = Mode::kTraining;
  double tick_s = 1e-3;       // the physics tick: data/session.json
  double task_end_hold_s = 1.5;  // its task done, the truck let be this long ends it: data/session.json
  IntegratorOptions integrator;
  std::string data_dir;
};

// Reads and checks every file the session needs (throws std::runtime_error naming the file and
// the problem). The tick comes from <data>/session.json.
SessionModel load_session_model(const SessionSpec& spec, const std::string& data_dir);
// The same model for a logged session: its scene, truck, mode, tick and integrator are the log's.
SessionModel load_session_model(const LogHeader& header, const std::string& data_dir);

// What the driver does during a tick (held until changed).
struct SessionInputs {
  DriverInputs driver;
  bool deadman = false;  // the worker substituted the dead-man inputs (the evaluation counts it)
};

struct SessionState {
  int64_t tick = 0;
  double t_s = 0;
  StateVector x = StateVector::Zero();
  SessionInputs inputs;
  std::optional<Load> load;                  // on the forks, as it was put there
  LoadOnForks load_on_forks;                 // how it sits there: stuck, sliding, fallen
  std::vector<ExternalForce> scene_push;     // the scene's push-back, held to the next tick
  HandlingState handling;                    // every pallet, and the one on the forks
  std::vector<PedestrianState> pedestrians;  // one per Scene::pedestrians (pedestrians.h)
  std::vector<FallingPalletState> falls;     // one per Scene::falling_pallets (falling.h)
  std::vector<OtherTruckState> trucks;       // one per Scene::trucks (traffic.h)
  std::vector<SpillState> spills;            // one per Scene::spills (spills.h): which are on the floor
  EvaluationMemory evaluation;
};

// The truck settled at the scene's start pose with the scene's load. Throws std::runtime_error
// (naming the scenario file) for a truck that cannot stand there.
SessionState initial_state(const SessionModel& model);
// A logged session's first state: its initial state and load come from the header.
SessionState initial_state(const SessionModel& model, const LogHeader& header);

// What a pedestrian is doing in a state, in the vocabulary's words (the live view, the replay).
PedestrianActivity activity_of(const PedestrianState& person);
// What another truck is doing in a state, in the vocabulary's words.
TruckActivity activity_of(const OtherTruckState& truck);

// What one tick noticed that the cab, the server and the log must hear about.
struct SessionEvent {
  std::string kind;   // an evaluation rule id ("speed_near_walkway", ...), or a pallet's
                      // "picked_up", "set_down", "sliding", "dropped" (information)
  int worry_level = 0;
  double x_m = 0, y_m = 0;
  std::string details;  // JSON text
};

enum class Stage { kDynamics, kCollision, kOutputs, kEvaluation };
// Told when each stage of a step begins and ends (benches time them; a test counts allocations).
struct StageObserver {
  virtual ~StageObserver() = default;
  virtual void begin(Stage) {}
  virtual void end(Stage) {}
};

class SessionWorkspace {
 public:
  explicit SessionWorkspace(const SessionModel& model);
  ~SessionWorkspace();
  SessionWorkspace(const SessionWorkspace&) = delete;
  SessionWorkspace& operator=(const SessionWorkspace&) = delete;

  // The last step's products, for publishers and tools (valid until the next step).
  const Outputs& outputs() const;
  const BodyPoses& poses() const;
  const StepReport& report() const;
  const std::vector<EvaluationEvent>& evaluation_events() const;  // the last step's, in full
  IntegratorStats integrator_stats() const;
  // Sets the outputs and poses to those of a state this workspace did not step to (a rewind's
  // point), so that what is published before the next step is that state's; the next step
  // restarts the integrator from its state, as from any copy.
  void show(const SessionState& state);

 private:
  friend void step(const SessionModel&, SessionState&, SessionWorkspace&, const SessionInputs&,
                   std::vector<SessionEvent>&, StageObserver*);
  friend Score finish(const SessionModel&, SessionState&, SessionWorkspace&, const std::string&,
                      std::vector<SessionEvent>&);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// One physics tick: the inputs held from now on, dynamics to the next tick boundary, the
// pedestrians' walk (seeing the truck where the dynamics left it), collision and pallet handling
// (which may attach or release the load; a person struck stands from then on), then the evaluation. New events are
// appended to `events`. A state the workspace did not produce itself (a copy, a rewind) restarts
// the integrator from that state, so stepping equal states gives equal states, bit for bit.
// Throws IntegratorError on numerical failure (the state is then the last good one).
void step(const SessionModel& model, SessionState& state, SessionWorkspace& workspace, const SessionInputs& inputs,
          std::vector<SessionEvent>& events, StageObserver* observer = nullptr);

// Ends the evaluation: end-of-session checks (parking, the task) append their events; the mark.
// Call once, after the last step.
Score finish(const SessionModel& model, SessionState& state, SessionWorkspace& workspace, const std::string& end_reason,
             std::vector<SessionEvent>& events);

// Whether the session's task is done and the pupil lets the truck be: at rest, the accelerator
// and the lift, tilt and side-shift levers let go, as the parking rule parked_controls_not_neutral
// reads them (its speed_max_m_s and control_max_fraction). The brake and the forks are as the
// pupil leaves them: the parking rules judge them. Held for model.task_end_hold_s, the session
// ends (SessionRun: "task_complete").
bool task_done_and_let_be(const SessionModel& model, const SessionState& state);

// The "score" line of a session log: "score <mark> <passed> <points> <end reason>".
std::string score_line(const Score& s);

// What the renderer needs of a state, copied.
CoordVector coordinates_of(const SessionState& state);

// The header a session log of this session starts with.
LogHeader log_header(const SessionModel& model, const SessionState& first, const std::string& session_id,
                     const std::string& cab_id);

// A session offline, tick by tick, through a SessionRun (session_run.h): inputs changing at given
// ticks (from a script or a log), the dead-man switches the worker logged, until `end_tick`, the
// time limit or a numerical failure.
struct InputChange {
  int64_t tick = 0;
  uint32_t seq = 0;
  SessionInputs inputs;
  std::optional<Instruction> instruction;  // set: the instructor's act at this tick, not an input
};
struct OfflineRun {
  std::vector<std::pair<int64_t, SessionEvent>> events;  // with the tick after which each was found
  std::vector<EvaluationEvent> evaluation_events;        // in full, for reports
  std::optional<Score> score;  // when finished
  // kTimeLimit, kNumericalFailure, or the one asked for; nullopt: it ran to end_tick, unfinished.
  std::optional<EndReason> end_reason;
  std::string failure;     // the integrator's words, when it failed
  int64_t ticks = 0;
  SessionState final_state;
};
// Called after each tick's step with the state and the workspace that stepped it (its outputs and
// poses are that tick's): how a debrief samples a replay without a second model evaluation.
using TickObserver = std::function<void(const SessionState&, const SessionWorkspace&)>;

// `finish_reason`: the reason the session ends with when it runs to end_tick (a replay gives the
// logged one); nullopt: it is not finished (a log whose worker died before its end). `log`, when
// given, records every applied input, the events, the score and the end; `after_tick`, when
// given, sees every tick.
OfflineRun run_offline(const SessionModel& model, SessionState state, const std::vector<InputChange>& changes,
                       int64_t end_tick, const std::optional<EndReason>& finish_reason,
                       std::unique_ptr<ControlLogWriter> log = nullptr, const TickObserver& after_tick = {});

// A cab script's rows as input changes at tick boundaries: a row at time t is applied at the
// first tick boundary at or after t. Rows a cab would have refused are refused here, with their
// line (std::runtime_error).
std::vector<InputChange> script_changes(const std::string& script_file, const SessionModel& model);

// Re-simulates a logged session through step(): its scene, truck and mode from the header, its
// inputs and dead-man switches at their ticks, ended as its score line says (or by a signal).
// Throws std::runtime_error for an end reason no session ends with. `event_lines` and `score_line` are what the log's
// own lines must equal.
struct ReplayResult {
  StateVector final_state = StateVector::Zero();
  int64_t ticks = 0;
  std::vector<std::string> event_lines;  // re-derived
  std::string score_line;                // re-derived, when the log has an end
  Score score;
};
// How a logged session ended: its score line's last word, or a signal for a finished log with no
// score; nullopt for a log whose worker died before its end. Throws std::runtime_error for a word
// that is no end reason.
std::optional<EndReason> logged_end_reason(const ControlLog& log);
ReplayResult replay_session(const ControlLog& log, const std::string& data_dir, const TickObserver& after_tick = {});
// The same replay with a model already loaded from the log's header (load_session_model).
ReplayResult replay_session(const ControlLog& log, const SessionModel& model, const TickObserver& after_tick = {});

}  // namespace forklift
