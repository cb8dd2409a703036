// One cab's session, tick by tick: the pipeline that the live worker, its replay and
// `forklift-sim evaluate` share, so that all three derive the same truck state, the same pallet
// moves, the same events and the same mark from the same inputs. Each tick reads like the
// pipeline: inputs (set beforehand), dynamics, collision and pallet handling, evaluation.
#pragma once

#include <cstdint>
#include <optional>
#include <memory>
#include <string>
#include <vector>

#include "forklift/collision/collision.h"
#include "forklift/evaluation/evaluation.h"
#include "forklift/render/render.h"
#include "forklift/scene/scene.h"
#include "forklift/session/controls.h"
#include "forklift/session/session_log.h"
#include "forklift/dynamics/simulation.h"

namespace forklift {

// What a session noticed during a tick that the cab, the server and the log must hear about.
struct SessionEvent {
  std::string kind;   // an evaluation rule id ("speed_near_walkway", ...), or a pallet's
                      // "picked_up", "set_down", "sliding", "dropped" (information)
  int worry_level = 0;
  double x_m = 0, y_m = 0;
  std::string details;  // JSON text
};

class CabSession {
 public:
  // The truck stands settled at the scene's start pose, with the scene's initial load.
  // Throws std::runtime_error (naming the file) for a truck that cannot stand there.
  // `mode` is "training" or "exam": the driver evaluation (data/evaluation/rules.json) marks it.
  CabSession(const Scene& scene, const std::string& data_dir, IntegratorOptions integrator = {}, double tick_s = 1e-3,
             const std::string& mode = "training");
  // Resumes from a logged initial state (replay): the state and load come from the header.
  CabSession(const Scene& scene, const std::string& data_dir, const LogHeader& header);
  ~CabSession();
  CabSession(const CabSession&) = delete;
  CabSession& operator=(const CabSession&) = delete;

  // Held from the next tick on.
  void set_inputs(const DriverInputs& u);
  const DriverInputs& inputs() const;

  // The worker substituted the dead-man inputs (the evaluator counts it).
  void set_deadman(bool on);

  // One physics tick: dynamics to the next tick boundary, collision and pallet handling, then
  // the evaluation. New events are appended to `events`. Throws IntegratorError on numerical failure.
  void tick(std::vector<SessionEvent>& events);

  // Whether the session's task is done and the truck has come to rest (the session may end).
  bool task_done_and_stopped() const;
  // Ends the evaluation: end-of-session checks (parking, task) append their events; the mark.
  // Call once, after the last tick.
  Score finish(const std::string& end_reason, std::vector<SessionEvent>& events);

  int64_t ticks() const;
  double tick_s() const;
  const Simulation& sim() const;
  const Scene& scene() const;
  const TruckParams& truck() const;
  const TruckShape& shape() const;
  const StepReport& last_report() const;
  const std::vector<PalletState>& pallets() const;
  RenderState render_state() const;  // what the renderer needs, copied
  // The header a control log of this session starts with.
  LogHeader log_header(const std::string& session_id, const std::string& cab_id, const std::string& scenario_file) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Re-simulates a logged session through the same pipeline (scene from the header). Returns the
// final state; the events derived on the way are appended to `events` when given.
// The session log's lines for events and the score (written beside the control log, compared by
// replay): "e <tick> <kind> <worry level>" and "score <mark> <passed> <points> <end reason>".
std::string event_line(int64_t tick, const SessionEvent& e);
std::string score_line(const Score& s);

struct ReplayResult {
  StateVector final_state = StateVector::Zero();
  int64_t ticks = 0;
  std::vector<std::string> event_lines;  // re-derived
  std::string score_line;                // re-derived, when the log has an end
};
ReplayResult replay_session(const ControlLog& log, const std::string& data_dir);

}  // namespace forklift
