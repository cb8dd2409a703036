#include "instructor_intake.h"

namespace forklift::worker {

InstructorIntake::InstructorIntake(std::string cab, std::string session, Mode mode, size_t message_max_chars,
                                   std::function<void(const std::string&)> say)
    : cab_(std::move(cab)), session_(std::move(session)), mode_(mode), message_max_chars_(message_max_chars), say_(std::move(say)) {}

std::optional<std::string> InstructorIntake::problem(const fk_InstructorAction& a, bool paused, Instruction& out) const {
  for (const char* text : {a.cab_id, a.action, a.text, a.by})
    if (!dds::valid_utf8(text)) return "its text is not UTF-8";
  if (cab_ != a.cab_id) return std::string("it is for cab '").append(a.cab_id).append("'");
  if (a.seq <= last_seq_) return "it is not newer than the last one taken (" + std::to_string(last_seq_) + ")";
  const auto action = parse<InstructorAction>(a.action);
  if (!action) return std::string("'").append(a.action).append("' is not an action (pause, resume, message, rewind or hazard)");
  // An exam is the examiner's to watch and, at most, abort: nothing else may change it.
  if (mode_ == Mode::kExam) return "an exam takes no instructor's action but its abort";
  if (*action == InstructorAction::kPause && paused) return "the session is paused already";
  if (*action == InstructorAction::kResume && !paused) return "the session is not paused";
  out = {*action, ""};
  if (*action == InstructorAction::kRewind) {
    if (!(a.seconds > 0 && a.seconds <= kInstructorRewindMaxS)) return "a rewind goes back between 0 and 3600 s";
    out.seconds = a.seconds;
  } else if (a.seconds != 0) {
    return "a " + std::string(a.action) + " takes no seconds";
  }
  if (*action == InstructorAction::kMessage) {
    out.text = a.text;
    if (const auto p = instructor_message_problem(out.text, message_max_chars_)) return *p;
  } else if (*action == InstructorAction::kHazard) {
    out.text = a.text;  // which hazard: the worker knows the scene's (SessionRun::hazard_problem)
    if (instructor_message_problem(out.text, kSceneIdMaxChars))
      return "a hazard names the scenario's pedestrian, falling pallet, truck or spill by its id";
  } else if (a.text[0]) {
    return "a " + std::string(a.action) + " takes no text";
  }
  return std::nullopt;
}

std::optional<Instruction> InstructorIntake::offer(const fk_InstructorAction& a, bool paused) {
  if (session_ != a.session_id) {  // another session's, kept by the topic for a late reader
    ++other_sessions_;
    return std::nullopt;
  }
  Instruction out;
  if (const auto why = problem(a, paused, out)) {
    refuse(a.seq, *why);
    return std::nullopt;
  }
  last_seq_ = a.seq;
  ++taken_;
  return out;
}

void InstructorIntake::refuse(uint64_t seq, const std::string& why) {
  if (++refused_ <= kRefusalsSaid)
    say_("refused the instructor's " + std::to_string(seq) + ": " + why +
         (refused_ == kRefusalsSaid ? " (further refusals are counted, not logged)" : ""));
}

}  // namespace forklift::worker
