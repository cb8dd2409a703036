// What a session's end means for its mark (forklift/store/store.h: Outcome): no SQL, shared by
// every backend.
#include <string_view>

#include "forklift/store/store.h"

namespace forklift::store {

const char* outcome_name(Outcome o) {
  switch (o) {
    case Outcome::kOpen: return "open";
    case Outcome::kCompleted: return "completed";
    case Outcome::kTimedOut: return "timed_out";
    case Outcome::kAborted: return "aborted";
    case Outcome::kStopped: return "stopped";
    case Outcome::kFailed: return "failed";
  }
  return "failed";
}

Outcome session_outcome(const Session& s) {
  if (!is_terminal(s.state)) return Outcome::kOpen;
  if (s.state == "aborted") return Outcome::kAborted;
  if (s.state == "failed") return Outcome::kFailed;
  // Ended: as the worker's end reason says (forklift-worker: its SessionStatus and score line).
  const std::string_view r = s.reason;
  if (r == "task_complete" || r == "parked") return Outcome::kCompleted;
  // The time the session was given (the scenario's duration, or the instructor's limit) ran
  // out: the run's course for a drive without a task, out of time for a task left unfinished.
  if (r == "duration") return s.task_left_unfinished ? Outcome::kTimedOut : Outcome::kCompleted;
  if (r == "time_limit") return Outcome::kTimedOut;
  if (r == "aborted") return Outcome::kAborted;
  if (r == "signal") return Outcome::kStopped;
  return Outcome::kFailed;  // "numerical_failure", "worker exited" with no mark, a tip-over end...
}

std::optional<double> mark_of(const Session& s) {
  if (session_outcome(s) != Outcome::kCompleted) return std::nullopt;
  return s.mark;
}

}  // namespace forklift::store
