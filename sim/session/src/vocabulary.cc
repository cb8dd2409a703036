#include "forklift/session/vocabulary.h"
#include "forklift/session/host_vocabulary.h"

#include <array>
#include <cstdint>
#include <utility>

namespace forklift {
namespace {

template <class E, size_t N>
using Names = std::array<std::pair<E, const char*>, N>;

constexpr Names<EndReason, 7> kEndReasons{{{EndReason::kDuration, "duration"},
                                           {EndReason::kTimeLimit, "time_limit"},
                                           {EndReason::kTaskComplete, "task_complete"},
                                           {EndReason::kAborted, "aborted"},
                                           {EndReason::kSignal, "signal"},
                                           {EndReason::kNumericalFailure, "numerical_failure"},
                                           {EndReason::kCabGone, "cab_gone"}}};
constexpr Names<SessionPhase, 6> kPhases{{{SessionPhase::kStarting, "starting"},
                                          {SessionPhase::kWaiting, "waiting"},
                                          {SessionPhase::kRunning, "running"},
                                          {SessionPhase::kEnded, "ended"},
                                          {SessionPhase::kAborted, "aborted"},
                                          {SessionPhase::kFailed, "failed"}}};
constexpr Names<Mode, 2> kModes{{{Mode::kTraining, "training"}, {Mode::kExam, "exam"}}};
constexpr Names<EventOrigin, 3> kOrigins{
    {{EventOrigin::kEvaluation, "evaluation"}, {EventOrigin::kHandling, "handling"}, {EventOrigin::kWorker, "worker"}}};
constexpr Names<Outcome, 6> kOutcomes{{{Outcome::kOpen, "open"},
                                       {Outcome::kCompleted, "completed"},
                                       {Outcome::kTimedOut, "timed_out"},
                                       {Outcome::kAborted, "aborted"},
                                       {Outcome::kStopped, "stopped"},
                                       {Outcome::kFailed, "failed"}}};
constexpr Names<ExamKind, 2> kExamKinds{{{ExamKind::kTheory, "theory"}, {ExamKind::kPractical, "practical"}}};
constexpr Names<PaperKind, 2> kPaperKinds{{{PaperKind::kExam, "exam"}, {PaperKind::kPractice, "practice"}}};
constexpr Names<PaperOutcome, 2> kPaperOutcomes{{{PaperOutcome::kMarked, "marked"}, {PaperOutcome::kTimedOut, "timed_out"}}};
constexpr Names<InstructorAction, 5> kInstructorActions{{{InstructorAction::kPause, "pause"},
                                                         {InstructorAction::kResume, "resume"},
                                                         {InstructorAction::kMessage, "message"},
                                                         {InstructorAction::kRewind, "rewind"},
                                                         {InstructorAction::kHazard, "hazard"}}};
constexpr Names<PedestrianActivity, 4> kPedestrianActivities{{{PedestrianActivity::kWaiting, "waiting"},
                                                             {PedestrianActivity::kWalking, "walking"},
                                                             {PedestrianActivity::kStanding, "standing"},
                                                             {PedestrianActivity::kStruck, "struck"}}};
constexpr Names<TruckActivity, 5> kTruckActivities{{{TruckActivity::kWaiting, "waiting"},
                                                    {TruckActivity::kDriving, "driving"},
                                                    {TruckActivity::kGivingWay, "giving_way"},
                                                    {TruckActivity::kStanding, "standing"},
                                                    {TruckActivity::kStruck, "struck"}}};
constexpr Names<HostState, 2> kHostStates{{{HostState::kReady, "ready"}, {HostState::kStopping, "stopping"}}};
constexpr Names<WorkerAction, 3> kWorkerActions{
    {{WorkerAction::kStart, "start"}, {WorkerAction::kAbort, "abort"}, {WorkerAction::kKill, "kill"}}};
constexpr Names<WorkerReportState, 4> kReportStates{{{WorkerReportState::kStarting, "starting"},
                                                     {WorkerReportState::kRunning, "running"},
                                                     {WorkerReportState::kExited, "exited"},
                                                     {WorkerReportState::kRefused, "refused"}}};

template <class E, size_t N>
const char* name_in(const Names<E, N>& names, E value) {
  for (const auto& [v, n] : names)
    if (v == value) return n;
  return "?";  // not reached: every enumerator is in its table (vocabulary_test checks)
}

template <class E, size_t N>
std::optional<E> parse_in(const Names<E, N>& names, std::string_view text) {
  for (const auto& [v, n] : names)
    if (text == n) return v;
  return std::nullopt;
}

// The kinds only pallet handling and the worker raise (collision's handling_event_name() gives
// the first four; vocabulary_test holds the two lists together).
constexpr std::array<const char*, 4> kHandlingKinds{"picked_up", "set_down", "sliding", "dropped"};

}  // namespace

const char* name(EndReason r) { return name_in(kEndReasons, r); }
const char* name(SessionPhase p) { return name_in(kPhases, p); }
const char* name(Mode m) { return name_in(kModes, m); }
const char* name(EventOrigin o) { return name_in(kOrigins, o); }
const char* name(Outcome o) { return name_in(kOutcomes, o); }
const char* name(ExamKind k) { return name_in(kExamKinds, k); }
const char* name(PaperKind k) { return name_in(kPaperKinds, k); }
const char* name(PaperOutcome o) { return name_in(kPaperOutcomes, o); }
const char* name(InstructorAction a) { return name_in(kInstructorActions, a); }
const char* name(PedestrianActivity a) { return name_in(kPedestrianActivities, a); }
const char* name(TruckActivity a) { return name_in(kTruckActivities, a); }
const char* name(HostState s) { return name_in(kHostStates, s); }
const char* name(WorkerAction a) { return name_in(kWorkerActions, a); }
const char* name(WorkerReportState s) { return name_in(kReportStates, s); }

template <> std::optional<EndReason> parse<EndReason>(std::string_view s) { return parse_in(kEndReasons, s); }
template <> std::optional<SessionPhase> parse<SessionPhase>(std::string_view s) { return parse_in(kPhases, s); }
template <> std::optional<Mode> parse<Mode>(std::string_view s) { return parse_in(kModes, s); }
template <> std::optional<EventOrigin> parse<EventOrigin>(std::string_view s) { return parse_in(kOrigins, s); }
template <> std::optional<Outcome> parse<Outcome>(std::string_view s) { return parse_in(kOutcomes, s); }
template <> std::optional<ExamKind> parse<ExamKind>(std::string_view s) { return parse_in(kExamKinds, s); }
template <> std::optional<PaperKind> parse<PaperKind>(std::string_view s) { return parse_in(kPaperKinds, s); }
template <> std::optional<PaperOutcome> parse<PaperOutcome>(std::string_view s) { return parse_in(kPaperOutcomes, s); }
template <> std::optional<InstructorAction> parse<InstructorAction>(std::string_view s) { return parse_in(kInstructorActions, s); }
template <> std::optional<PedestrianActivity> parse<PedestrianActivity>(std::string_view s) { return parse_in(kPedestrianActivities, s); }
template <> std::optional<TruckActivity> parse<TruckActivity>(std::string_view s) { return parse_in(kTruckActivities, s); }
template <> std::optional<HostState> parse<HostState>(std::string_view s) { return parse_in(kHostStates, s); }
template <> std::optional<WorkerAction> parse<WorkerAction>(std::string_view s) { return parse_in(kWorkerActions, s); }
template <> std::optional<WorkerReportState> parse<WorkerReportState>(std::string_view s) { return parse_in(kReportStates, s); }

bool is_terminal(SessionPhase p) {
  return p == SessionPhase::kEnded || p == SessionPhase::kAborted || p == SessionPhase::kFailed;
}

EventOrigin event_origin(std::string_view kind) {
  for (const char* k : kHandlingKinds)
    if (kind == k) return EventOrigin::kHandling;
  if (kind == kControlsResumedEvent || kind == kNoControlsEvent || kind == kRewoundEvent) return EventOrigin::kWorker;
  return EventOrigin::kEvaluation;
}

const std::vector<std::pair<std::string, std::string>>& step_controls() {
  static const std::vector<std::pair<std::string, std::string>> controls = {
      {"accelerator", "the accelerator"},      {"brake", "the brake"},
      {"steer_left", "the steering"},          {"steer_right", "the steering"},
      {"centre", "the steering's centring"},   {"forward", "forward"},
      {"neutral", "neutral"},                  {"reverse", "reverse"},
      {"lift", "the lift lever"},              {"lower", "the lift lever"},
      {"tilt_back", "the tilt lever"},         {"tilt_forward", "the tilt lever"},
      {"parking_brake", "the parking brake"},  {"horn", "the horn"},
  };
  return controls;
}

std::string fill_braces(const std::string& text, const std::function<std::optional<std::string>(const std::string&)>& word) {
  std::string out;
  size_t at = 0;
  for (size_t open; (open = text.find('{', at)) != std::string::npos;) {
    const size_t close = text.find('}', open);
    if (close == std::string::npos) break;
    const std::optional<std::string> w = word(text.substr(open + 1, close - open - 1));
    out += text.substr(at, open - at);
    out += w ? *w : text.substr(open, close - open + 1);
    at = close + 1;
  }
  return out + text.substr(at);
}

std::string step_words(const std::string& description) {
  return fill_braces(description, [](const std::string& name) -> std::optional<std::string> {
    for (const auto& [control, words] : step_controls())
      if (control == name) return words;
    return std::nullopt;
  });
}

// The words a person reads, one switch each: -Wswitch names a value left without its words.
const char* words(SessionPhase phase) {
  switch (phase) {
    case SessionPhase::kStarting: return "starting";
    case SessionPhase::kWaiting: return "waiting for the cab";
    case SessionPhase::kRunning: return "running";
    case SessionPhase::kEnded: return "ended";
    case SessionPhase::kAborted: return "aborted";
    case SessionPhase::kFailed: return "failed";
  }
  return "?";
}

const char* words(EndReason reason) {
  switch (reason) {
    case EndReason::kDuration: return "its time was up";
    case EndReason::kTimeLimit: return "the time limit was reached";
    case EndReason::kTaskComplete: return "the task was done";
    case EndReason::kAborted: return "aborted by an instructor";
    case EndReason::kSignal: return "stopped before its end";
    case EndReason::kNumericalFailure: return "the simulation failed";
    case EndReason::kCabGone: return "the cab stopped sending its controls";
  }
  return "?";
}

const char* words(Outcome outcome) {
  switch (outcome) {
    case Outcome::kOpen: return "under way";
    case Outcome::kCompleted: return "completed";
    case Outcome::kTimedOut: return "timed out";
    case Outcome::kAborted: return "aborted";
    case Outcome::kStopped: return "stopped";
    case Outcome::kFailed: return "failed";
  }
  return "?";
}


std::optional<std::string> instructor_message_problem(std::string_view text, size_t max_chars) {
  size_t chars = 0;
  bool visible = false;
  for (size_t i = 0; i < text.size();) {
    // One character: its lead byte says how many continuation bytes follow, and the smallest code
    // point that length may carry (no overlong forms); no surrogates, nothing past U+10FFFF.
    const unsigned char c = static_cast<unsigned char>(text[i]);
    const int more = c < 0x80 ? 0 : (c & 0xE0) == 0xC0 ? 1 : (c & 0xF0) == 0xE0 ? 2 : (c & 0xF8) == 0xF0 ? 3 : -1;
    if (more < 0 || i + more >= text.size()) return "the message is not UTF-8 text";
    uint32_t cp = more == 0 ? c : c & (0x3F >> more);
    for (int k = 1; k <= more; ++k) {
      const unsigned char b = static_cast<unsigned char>(text[i + k]);
      if ((b & 0xC0) != 0x80) return "the message is not UTF-8 text";
      cp = (cp << 6) | (b & 0x3F);
    }
    static constexpr uint32_t kSmallest[] = {0, 0x80, 0x800, 0x10000};
    if (cp < kSmallest[more] || (cp >= 0xD800 && cp <= 0xDFFF) || cp > 0x10FFFF) return "the message is not UTF-8 text";
    i += 1 + more;
    ++chars;
    if (cp < 0x20 || (cp >= 0x7F && cp <= 0x9F)) return "the message holds a control character (a line break, a tab): it must be one line of text";
    if (cp != ' ') visible = true;
  }
  if (!visible) return "the message is empty";
  if (text.front() == ' ' || text.back() == ' ') return "the message starts or ends with a space";
  if (chars > max_chars) return "the message is longer than " + std::to_string(max_chars) + " characters";
  return std::nullopt;
}

}  // namespace forklift
