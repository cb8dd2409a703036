// What a session's end means for its mark (forklift/store/store.h: Outcome): no SQL, shared by
// every backend.
#include <string_view>

#include "forklift/session/vocabulary.h"
#include "forklift/store/store.h"

namespace forklift::store {

Outcome session_outcome(const Session& s) {
  if (!is_terminal(s.state)) return Outcome::kOpen;
  if (s.state == SessionPhase::kAborted) return Outcome::kAborted;
  if (s.state == SessionPhase::kFailed) return Outcome::kFailed;
  // Ended: as the worker's end reason says (forklift-worker: its SessionStatus and score line).
  const std::optional<EndReason> reason = parse<EndReason>(s.reason);
  if (!reason) {
    // "parked": the evaluation's end word for a drive that ended parked, not a worker's reason;
    // anything else ("worker exited" with no mark, a tip-over end...) is a failure.
    return s.reason == "parked" ? Outcome::kCompleted : Outcome::kFailed;
  }
  switch (*reason) {
    case EndReason::kTaskComplete: return Outcome::kCompleted;
    // The time the session was given (the scenario's duration, or the instructor's limit) ran
    // out: the run's course for a drive without a task, out of time for a task left unfinished.
    case EndReason::kDuration: return s.task_left_unfinished ? Outcome::kTimedOut : Outcome::kCompleted;
    case EndReason::kTimeLimit: return Outcome::kTimedOut;
    case EndReason::kAborted: return Outcome::kAborted;
    case EndReason::kSignal: return Outcome::kStopped;
    // The pupil left (the cab closed, or its link failed) before the end: stopped, as a signal.
    case EndReason::kCabGone: return Outcome::kStopped;
    case EndReason::kNumericalFailure: return Outcome::kFailed;
  }
  return Outcome::kFailed;
}

std::optional<double> mark_of(const Session& s) {
  if (session_outcome(s) != Outcome::kCompleted) return std::nullopt;
  return s.mark;
}

}  // namespace forklift::store
