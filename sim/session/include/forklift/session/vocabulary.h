// The words a session is told by, once: how it ended, what phase it is in, how it is marked, what
// its end means for its mark, and who raised an event; and the kinds of exam record and theory
// paper and how a paper ended. Every program that reads or writes these names (the worker, the
// session log, the store, the server, the menu, the cab's head-up display)
// goes through name() and parse() here; the IDL, the SQL and the API carry them as strings,
// produced and parsed with these functions only.
// No dependency: the store and the cab link it without the simulation.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace forklift {

// Why a session ended (the SessionStatus reason of "ended", the session log's score line's last
// word, the store's session reason).
enum class EndReason {
  kDuration,          // "duration": the time the session was given (--duration, a script's end) ran out
  kTimeLimit,         // "time_limit": the scene's time limit (the evaluation's time_limit fault)
  kTaskComplete,      // "task_complete": the task done and the truck at rest
  kAborted,           // "aborted": the instructor's abort
  kSignal,            // "signal": the worker was stopped (SIGTERM, SIGINT)
  kNumericalFailure,  // "numerical_failure": the integrator failed; the state is the last good one
  kCabGone,           // "cab_gone": the cab, heard once, sent no controls for longer than the worker's start timeout
};

// Where a session is in its life (SessionStatus.state; the store's session state).
enum class SessionPhase {
  kStarting,  // "starting": the server placed it; no worker has spoken yet
  kWaiting,   // "waiting": the worker is up, waiting for the cab's first sample
  kRunning,   // "running"
  kEnded,     // "ended": with an end reason and a mark
  kAborted,   // "aborted": ended by the instructor, as the store keeps it
  kFailed,    // "failed": it could not run (a broken file, a worker that died, no cab)
};

// How the evaluation marks a session.
enum class Mode { kTraining, kExam };  // "training", "exam"

// What a session's end means for its mark (the store's session_outcome() decides it from the
// phase, the end reason and whether a task was left): the word the API, its lists and exports, the
// pages and the menu carry. Its own enum, not a phase or a reason: a "duration" end is completed
// or timed out by the task, a "signal" end is stopped, and the menu, which links no store, reads it.
enum class Outcome {
  kOpen,       // "open": not over yet
  kCompleted,  // "completed": ran its course; the only outcome with a mark
  kTimedOut,   // "timed_out": the time limit, or its time ran out with its task unfinished
  kAborted,    // "aborted": the instructor stopped it
  kStopped,    // "stopped": its worker was told to stop before its end (the server shut down)
  kFailed,     // "failed": it could not run or ended for any other reason
};

// What an exam record records (the store's exam kind; the exams list's and the certificate's).
enum class ExamKind {
  kTheory,     // "theory": a theory paper sat as an exam; its score the fraction right in [0, 1]
  kPractical,  // "practical": an exam session on the simulator; its score the mark
};

// Whose a theory paper is.
enum class PaperKind {
  kExam,      // "exam": handed out by a supervisor; it counts, and its end makes a theory exam record
  kPractice,  // "practice": taken by the pupil alone; never counts
};

// How a theory paper was finished.
enum class PaperOutcome {
  kMarked,    // "marked": handed in and marked
  kTimedOut,  // "timed_out": its time ran out first (marked on what was answered)
};

// What an instructor does to a live training session (the API's action, the fk_InstructorAction
// sample's, the session log's "instructor" line). An exam takes none of them: only its abort.
enum class InstructorAction {
  kPause,    // "pause": the sim clock stops (no ticks; the dead man and the time limit wait)
  kResume,   // "resume": the clock runs on from where it stopped
  kMessage,  // "message": a line of text on the cab's display for a few seconds
  kRewind,   // "rewind": "try that again": the session goes back to a state it kept, some seconds back
  kHazard,   // "hazard": a scenario's pedestrian starts his walk now, whatever his trigger
};

// What one of a scenario's pedestrians is doing, as the live view, the replay and the cab's sound
// are told (TruckState.pedestrians[].activity carries the value: 0 to 3, in this order).
enum class PedestrianActivity {
  kWaiting,   // "waiting": his cue (a trigger, or the instructor's "hazard") has not come
  kWalking,   // "walking": along his path this tick
  kStanding,  // "standing": at a wait, for the truck near him, or at his path's end
  kStruck,    // "struck": the truck struck him; he stays where he is
};

// What one of a scenario's other trucks is doing (TruckState.trucks[].activity: 0 to 4, in this order).
enum class TruckActivity {
  kWaiting,    // "waiting": its cue (a trigger, or the instructor's "hazard") has not come
  kDriving,    // "driving": along its route this tick
  kGivingWay,  // "giving_way": standing short of a crossing where the pupil goes first
  kStanding,   // "standing": for the pupil's truck ahead of it, or at its route's end
  kStruck,     // "struck": the pupil's truck struck it; its driver stopped there
};

// Who raised an event of a session, by its kind.
enum class EventOrigin {
  kEvaluation,  // a rule of the evaluation (counted in the mark, by its worry level)
  kHandling,    // pallet handling: "picked_up", "set_down", "sliding", "dropped" (information)
  kWorker,      // the worker's own: "controls_resumed", "no_controls_from_cab" (not marked)
};

const char* name(EndReason reason);
const char* name(SessionPhase phase);
const char* name(Mode mode);
const char* name(EventOrigin origin);
const char* name(Outcome outcome);
const char* name(ExamKind kind);
const char* name(PaperKind kind);
const char* name(PaperOutcome outcome);
const char* name(InstructorAction action);
const char* name(PedestrianActivity activity);
const char* name(TruckActivity activity);

// The same values in the words a person reads (the menu, the worker's summary, forklift-sim
// evaluate): "time_limit" is "the time limit was reached", "waiting" is "waiting for the cab",
// "timed_out" is "timed out". One switch each, so a new value does not compile without its words.
const char* words(EndReason reason);
const char* words(SessionPhase phase);
const char* words(Outcome outcome);

// The value a name stands for; nullopt for a name that is not one of them (exact, case and all).
template <class E>
std::optional<E> parse(std::string_view name);
template <> std::optional<EndReason> parse<EndReason>(std::string_view name);
template <> std::optional<SessionPhase> parse<SessionPhase>(std::string_view name);
template <> std::optional<Mode> parse<Mode>(std::string_view name);
template <> std::optional<EventOrigin> parse<EventOrigin>(std::string_view name);
template <> std::optional<Outcome> parse<Outcome>(std::string_view name);
template <> std::optional<ExamKind> parse<ExamKind>(std::string_view name);
template <> std::optional<PaperKind> parse<PaperKind>(std::string_view name);
template <> std::optional<PaperOutcome> parse<PaperOutcome>(std::string_view name);
template <> std::optional<InstructorAction> parse<InstructorAction>(std::string_view name);
template <> std::optional<PedestrianActivity> parse<PedestrianActivity>(std::string_view name);
template <> std::optional<TruckActivity> parse<TruckActivity>(std::string_view name);

// Why an instructor's message cannot go to the cab, or nullopt: it must be well-formed UTF-8 (it
// comes from the wire, or from a log), hold a visible character, no control character (a line
// break, a tab, an escape: the display and the log line keep one line), no space at either end,
// and at most `max_chars` characters.
std::optional<std::string> instructor_message_problem(std::string_view text, size_t max_chars);
// The longest message data/session.json may allow (its instructor.message_max_chars): the wire's
// string (2048 bytes) holds this many characters of four bytes, and a log line holds it.
inline constexpr size_t kInstructorMessageCharsCeiling = 500;
// The longest id a scene's object or pedestrian has (data/schema/scenario.schema.json's "id").
inline constexpr size_t kSceneIdMaxChars = 64;
// The furthest back a rewind may be asked to go, s: an hour, beyond any session's time limit.
inline constexpr double kInstructorRewindMaxS = 3600;

// Ended, aborted or failed: the session will not change again.
bool is_terminal(SessionPhase phase);

// Who raises events of this kind: the handling and worker kinds above, every other kind is an
// evaluation rule's.
EventOrigin event_origin(std::string_view kind);

// The worker's own events (EventOrigin::kWorker).
inline constexpr const char* kControlsResumedEvent = "controls_resumed";
inline constexpr const char* kNoControlsEvent = "no_controls_from_cab";  // a "w" line at tick 0: no cab spoke
inline constexpr const char* kRewoundEvent = "rewound";  // the instructor took the session back (its details: from when to when)

// The controls a scenario's step may name in braces ("{lift}"), each with its words for a person
// away from a cab (the debrief, the plan, the evaluation's events); a cab's display writes the
// key bound to it instead.
const std::vector<std::pair<std::string, std::string>>& step_controls();
// `text` with each "{name}" replaced by what `word` gives for the name; a brace it gives nothing
// for, or left open, stays as it is.
std::string fill_braces(const std::string& text, const std::function<std::optional<std::string>(const std::string&)>& word);
// A step's description in those words ("with {lift}" -> "with the lift lever").
std::string step_words(const std::string& description);

}  // namespace forklift
