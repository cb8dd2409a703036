// The session's vocabulary: every name parses back to its value, and nothing else parses.
#include <gtest/gtest.h>

#include "forklift/collision/collision.h"
#include "forklift/session/vocabulary.h"
#include "forklift/session/host_vocabulary.h"

namespace {

using namespace forklift;

template <class E>
void round_trips(std::initializer_list<E> all) {
  for (E e : all) {
    const std::string n = name(e);
    EXPECT_NE(n, "?");
    EXPECT_EQ(parse<E>(n), e) << n;
    // Exact words only: no case folding, no spaces, no prefix.
    std::string upper = n;
    upper[0] = static_cast<char>(std::toupper(upper[0]));
    EXPECT_EQ(parse<E>(upper), std::nullopt) << upper;
    EXPECT_EQ(parse<E>(n + " "), std::nullopt);
    EXPECT_EQ(parse<E>(n.substr(0, n.size() - 1)), std::nullopt);
  }
  EXPECT_EQ(parse<E>(""), std::nullopt);
  EXPECT_EQ(parse<E>("nonsense"), std::nullopt);
}

TEST(Vocabulary, EveryNameParsesBackAndNothingElseParses) {
  round_trips({EndReason::kDuration, EndReason::kTimeLimit, EndReason::kTaskComplete, EndReason::kAborted,
               EndReason::kSignal, EndReason::kNumericalFailure, EndReason::kCabGone});
  round_trips({SessionPhase::kStarting, SessionPhase::kWaiting, SessionPhase::kRunning, SessionPhase::kEnded,
               SessionPhase::kAborted, SessionPhase::kFailed});
  round_trips({Mode::kTraining, Mode::kExam});
  round_trips({EventOrigin::kEvaluation, EventOrigin::kHandling, EventOrigin::kWorker});
  round_trips({Outcome::kOpen, Outcome::kCompleted, Outcome::kTimedOut, Outcome::kAborted, Outcome::kStopped,
               Outcome::kFailed});
  round_trips({ExamKind::kTheory, ExamKind::kPractical});
  round_trips({PaperKind::kExam, PaperKind::kPractice});
  round_trips({PaperOutcome::kMarked, PaperOutcome::kTimedOut});
  round_trips({HostState::kReady, HostState::kStopping});
  round_trips({WorkerAction::kStart, WorkerAction::kAbort, WorkerAction::kKill});
  round_trips({InstructorAction::kPause, InstructorAction::kResume, InstructorAction::kMessage, InstructorAction::kRewind,
               InstructorAction::kHazard});
  round_trips({PedestrianActivity::kWaiting, PedestrianActivity::kWalking, PedestrianActivity::kStanding, PedestrianActivity::kStruck});
  round_trips({WorkerReportState::kStarting, WorkerReportState::kRunning, WorkerReportState::kExited,
               WorkerReportState::kRefused});
}

TEST(Vocabulary, TheNamesAreTheWireAndLogWords) {
  EXPECT_STREQ(name(EndReason::kTimeLimit), "time_limit");
  EXPECT_STREQ(name(EndReason::kNumericalFailure), "numerical_failure");
  EXPECT_STREQ(name(EndReason::kCabGone), "cab_gone");
  EXPECT_STREQ(name(SessionPhase::kEnded), "ended");
  EXPECT_STREQ(name(Mode::kExam), "exam");
  EXPECT_STREQ(name(Outcome::kTimedOut), "timed_out");
  EXPECT_STREQ(name(ExamKind::kPractical), "practical");  // the exams table's CHECK
  EXPECT_STREQ(name(PaperKind::kPractice), "practice");   // the theory_attempts table's CHECK
  EXPECT_STREQ(name(PaperOutcome::kTimedOut), "timed_out");
  EXPECT_STREQ(name(HostState::kStopping), "stopping");
  EXPECT_STREQ(name(WorkerAction::kAbort), "abort");
  EXPECT_STREQ(name(WorkerReportState::kExited), "exited");
  EXPECT_EQ(parse<EndReason>("parked"), std::nullopt);  // an evaluation's end word, not a session's end
}

// An instructor's message: one line of UTF-8 text the cab can show, counted in characters.
TEST(Vocabulary, AnInstructorsMessageIsOneLineOfTextWithinItsLength) {
  EXPECT_EQ(instructor_message_problem("Look left", 9), std::nullopt);
  EXPECT_EQ(instructor_message_problem("\u00e9\u00e9\u2014\U0001F6A7", 4), std::nullopt) << "characters, not bytes";
  EXPECT_NE(instructor_message_problem("Look left", 8), std::nullopt);
  for (const char* bad : {"", " ", "  ", " lead", "trail ", "two\nlines", "a\ttab", "del\x7f", "c1 \xc2\x85 control",
                          "\xc3", "\xc3(", "\xc0\xaf", "\xed\xa0\x80", "\xf4\x90\x80\x80", "\xff"})
    EXPECT_NE(instructor_message_problem(bad, 100), std::nullopt) << bad;
}

TEST(Vocabulary, TerminalPhases) {
  EXPECT_FALSE(is_terminal(SessionPhase::kStarting));
  EXPECT_FALSE(is_terminal(SessionPhase::kWaiting));
  EXPECT_FALSE(is_terminal(SessionPhase::kRunning));
  EXPECT_TRUE(is_terminal(SessionPhase::kEnded));
  EXPECT_TRUE(is_terminal(SessionPhase::kAborted));
  EXPECT_TRUE(is_terminal(SessionPhase::kFailed));
}

TEST(Vocabulary, EventOriginsMatchTheirRaisers) {
  using K = HandlingEvent::Kind;
  for (K k : {K::kPickedUp, K::kSetDown, K::kSliding, K::kDropped})
    EXPECT_EQ(event_origin(handling_event_name(k)), EventOrigin::kHandling) << handling_event_name(k);
  EXPECT_EQ(event_origin(kControlsResumedEvent), EventOrigin::kWorker);
  EXPECT_EQ(event_origin(kNoControlsEvent), EventOrigin::kWorker);
  EXPECT_EQ(event_origin("speed_near_walkway"), EventOrigin::kEvaluation);
  EXPECT_EQ(event_origin("deadman_stop"), EventOrigin::kEvaluation);
}

}  // namespace
