// The life of one session around its tick, in one place: which inputs apply at which tick (the
// cab's, the dead man's), what the log records, when and why the session ends, and how its end is
// marked. The live worker, the offline run (run_offline: forklift-sim evaluate, its --replay,
// replay_session, forklift-worker --replay) and the tests all drive a SessionRun, so a session
// and its replay write the same log, byte for byte, and get the same mark.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "forklift/session/session.h"
#include "forklift/session/session_log.h"
#include "forklift/session/vocabulary.h"

namespace forklift {

// The ends a run watches for besides the time limit and a numerical failure (always).
struct SessionEnds {
  double duration_s = 0;      // > 0: "duration" once the sim time reaches it
  bool task_complete = true;  // "task_complete" once the task is done and the truck let be (task_done_and_let_be)
};

class SessionRun {
 public:
  // The worker's tally of the cab's samples, for the log's "controls" line (name=count words).
  using ControlCounts = std::vector<std::pair<std::string, long>>;

  // `log`: where the session is recorded (nullptr: nowhere); its header is the caller's
  // (log_header(model, first, ...)).
  SessionRun(SessionModel model, SessionState first, std::unique_ptr<ControlLogWriter> log = nullptr,
             SessionEnds ends = {});
  ~SessionRun();
  SessionRun(const SessionRun&) = delete;
  SessionRun& operator=(const SessionRun&) = delete;

  const SessionModel& model() const { return model_; }
  const SessionState& state() const { return state_; }
  const SessionWorkspace& workspace() const { return workspace_; }
  const SessionInputs& inputs() const { return held_; }  // what the next tick is driven with
  uint32_t applied_seq() const { return applied_seq_; }  // the cab's sample last applied
  bool deadman_on() const { return held_.deadman; }
  const std::string& failure() const { return failure_; }  // the integrator's words, after a numerical failure

  // The cab's sample `seq`, with these inputs, applied from the current tick on. At most one
  // input is logged per tick ("i", written when the tick is stepped): the last applied in a tick
  // stands for it, and inputs identical to the logged ones are applied (their seq goes out in
  // the states) but not logged again. Returns whether the truck's inputs change.
  bool apply(uint32_t seq, const DriverInputs& inputs);
  // The cab fell silent: throttle off and full brake (deadman_inputs of the held ones, or `stop`
  // as a log recorded them) from this tick on, logged at once as "i" and "dm 1" (an input applied
  // earlier in this tick is dropped). The evaluation reports its deadman_stop on this tick.
  void deadman();
  void deadman(const DriverInputs& stop);
  // The cab spoke again after a dead-man stop: "dm 0" and the worker's controls_resumed ("w"); its
  // sample follows with apply().
  void resume();
  // A worker's own event at the current tick ("w": not marked).
  void worker_event(const std::string& kind);
  // What the instructor did at the current tick: pause stops the session's clock (the caller steps
  // no tick while paused()), resume lets it run on, a message changes nothing here. Logged as an
  // "instructor" line when the tick is stepped (or the session ends), before its input line, so
  // that a replay fed the log's changes writes the same log. A rewind is logged at once (after
  // this tick's other instructions) and puts the state back to the point kept at its to_tick,
  // whose evaluation memory it is too: the faults found since are not in the mark, and stay on
  // the record (the log's "e" lines, the events published); throws std::runtime_error if no
  // point is kept there (a log that rewinds where its run kept nothing).
  // A hazard sets the scene's pedestrian `text` walking at once (his trigger no longer waited
  // for), drops its falling pallet `text`, sets its other truck `text` driving, or puts its spill
  // `text` on the floor (from the next tick's dynamics on), logged when the tick is stepped as the
  // others.
  void instruct(const Instruction& what);
  bool paused() const { return paused_; }
  // Why the scene's hazard `id` (a pedestrian, a falling pallet, another truck, a spill with a
  // trigger) cannot be started now (none of that id; started, fallen, struck or on the floor
  // already), or nullopt.
  std::optional<std::string> hazard_problem(const std::string& id) const;

  // Rewind points: copies of the state, kept as the session runs. The worker's: every
  // `every_ticks` ticks (the current tick too, if it is one), the newest `kept`. A replay's: at
  // the ticks its log rewinds to (the newest pass through each), so that it goes back to the
  // very states the worker did.
  void keep_rewind_points(int64_t every_ticks, size_t kept);
  void keep_rewind_points_at(const std::vector<int64_t>& ticks);
  // The point a rewind of `seconds` goes back to: the newest kept at least that far back from the
  // current tick; nullopt when none is (asked further back than the oldest kept).
  std::optional<int64_t> rewind_point(double seconds) const;
  const std::map<int64_t, SessionState>& rewind_points() const { return points_; }  // by tick

  // One physics tick with the held inputs: the tick's input line, step(), an "e" line per event
  // the session found. `end`: why the session must end after it, if it must: the time limit (the
  // evaluation's time_limit fault), the duration, the task complete, or a numerical failure (the
  // tick was not stepped, and the state is the last good one).
  struct Tick {
    const std::vector<SessionEvent>& events;
    std::optional<EndReason> end;
  };
  Tick tick();

  // Ends the session: the end-of-session checks (their events logged, and in end_events()), the
  // "score" line, the control counts (when given), then "end" and "final". Call once.
  Score end(EndReason reason, const std::optional<ControlCounts>& counts = std::nullopt);
  // Ends the session with no mark (a logged session whose worker died before its end; a cab that
  // never spoke): the control counts (when given), "end" and "final".
  void close(const std::optional<ControlCounts>& counts = std::nullopt);
  const std::vector<SessionEvent>& end_events() const { return events_; }

 private:
  void write_input();
  void write_instructions();
  void keep_point();

  const SessionModel model_;
  SessionState state_;
  SessionWorkspace workspace_;
  std::unique_ptr<ControlLogWriter> log_;
  SessionEnds ends_;
  SessionInputs held_;
  uint32_t applied_seq_ = 0;
  std::optional<DriverInputs> logged_;  // the inputs the log last recorded (none yet: the first is logged)
  bool input_owed_ = false;             // held_.driver is to be logged when the tick is stepped
  std::vector<Instruction> instructions_owed_;  // to be logged when the tick is stepped
  bool paused_ = false;
  int64_t point_every_ = 0;
  size_t points_kept_ = 0;        // 0: no bound (a replay's points, one per tick its log goes back to)
  std::vector<int64_t> point_at_;  // sorted
  std::map<int64_t, SessionState> points_;  // by tick
  std::vector<SessionEvent> events_;
  std::string failure_;
  int64_t let_be_ticks_ = 0;  // the ticks in a row the truck has been let be with its task done
};

// The inputs, dead-man switches and instructions of a log as input changes, merged by tick in the
// order the worker applied them (a dead-man stop after the input it logged, a resume before its
// input; a tick's instructions after its inputs and switches, as SessionRun logs them).
std::vector<InputChange> logged_changes(const ControlLog& log);

// An input change onto a run: an instruction is the instructor's; a change of the dead-man flag is
// a dead-man stop (with its logged inputs) or a resume; any other is the cab's sample.
void feed(SessionRun& run, const InputChange& change);

}  // namespace forklift
