// The instructor's hand on a live session, between real processes over loopback DDS: a worker
// driven by a cab (the test's own participant) takes the instructor's pause, message and resume
// from its cab's instructor partition, as the server writes them. Paused, its truck's sim time
// stands still while the wall clock runs on, and the dead man does not fire however long the cab
// is silent; the message is on the cab's state; the log replays bit for bit. Every test has its
// own domain id from the allocator (support/ports.h).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>
#include <thread>

#include "forklift/protocol/protocol.h"
#include "forklift/session/session_log.h"
#include "support/ports.h"
#include "support/process.h"
#include "support/speaking_cab.h"
#include "support/worker.h"

using namespace forklift;
using nlohmann::json;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;
const std::string kData = FORKLIFT_DATA_DIR;

std::string tmp(const std::string& name) { return testing::TempDir() + "/" + name; }

// What a server writes for an instructor (Fleet::instruct).
fk_InstructorAction action(const std::string& session, uint64_t seq, const std::string& what, const std::string& text = "") {
  fk_InstructorAction a{};
  dds::set_string(a.session_id, session);
  dds::set_string(a.cab_id, "c1");
  a.seq = seq;
  dds::set_string(a.action, what);
  dds::set_string(a.text, text);
  dds::set_string(a.by, "instructor1");
  return a;
}

// Takes the cab's states until `done` says so, at most `timeout_s` of wall time (a bound that only
// stops a test that would hang); whether it did.
bool states_until(dds::Reader<fk_TruckState>& states, double timeout_s, const std::function<bool(const fk_TruckState&)>& done) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < until) {
    bool hit = false;
    states.take_each([&](const fk_TruckState& s) { hit = hit || done(s); });
    if (hit) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

}  // namespace

TEST(Instructor, APauseHoldsTheClockAndTheDeadManAMessageReachesTheCabAndTheLogReplaysBitForBit) {
  const int domain = forklift::test::free_domain();
  const std::string session = "s-7";
  Process w = forklift_test::start_worker(kBin, tmp(""), domain, "c1", session,
                                          {"--duration", "3", "--deadman-timeout", "0.5", "--start-timeout", "60", "--scenario",
                                           kData + "/scenarios/first_drive_yard.json"});
  dds::Participant p(dds::DomainSettings::resolve(domain, ""));
  dds::Writer<fk_InstructorAction> instructor(p, dds::instructor_partition("c1"));
  dds::Reader<fk_TruckState> states(p, dds::cab_partition("c1"));
  forklift_test::SpeakingCab cab(p, "c1", 0.3);

  ASSERT_TRUE(states_until(states, 30, [](const fk_TruckState& s) { return s.sim_time_s > 0.5; })) << w.err();
  // An earlier session's action on this cab, kept by the topic: passed over.
  instructor.write(action("s-6", 1, "pause"));
  instructor.write(action(session, 10, "pause"));
  double paused_at_s = -1;
  ASSERT_TRUE(states_until(states, 10, [&](const fk_TruckState& s) {
    if (s.paused) paused_at_s = s.sim_time_s;
    return s.paused;
  })) << w.err();

  // Paused: the cab falls silent for three dead-man intervals and more; every state the cab gets
  // shows the same sim time, paused, with no dead-man stop, however much wall time passes.
  cab.speaking = false;
  const auto silent_from = std::chrono::steady_clock::now();
  int seen = 0;
  bool moved = false, deadman = false, unpaused = false;
  states_until(states, 2.0, [&](const fk_TruckState& s) {
    ++seen;
    moved = moved || s.sim_time_s != paused_at_s;
    deadman = deadman || s.deadman;
    unpaused = unpaused || !s.paused;
    return false;
  });
  EXPECT_GE(std::chrono::duration<double>(std::chrono::steady_clock::now() - silent_from).count(), 1.5);
  EXPECT_GE(seen, 2) << "the cab hears the paused truck's state";
  EXPECT_FALSE(moved) << "the sim time ran on while paused";
  EXPECT_FALSE(deadman) << "the dead man fired while paused";
  EXPECT_FALSE(unpaused);

  // A message: on the cab's state at once, paused or not; a bad one is refused.
  const std::string said = "Mind the walkway: slow down and sound the horn";
  instructor.write(action(session, 11, "message", "two\nlines"));
  instructor.write(action(session, 12, "message", said));
  EXPECT_TRUE(states_until(states, 10, [&](const fk_TruckState& s) { return std::string(s.instructor_message) == said; })) << w.err();

  // The cab speaks again, then the instructor resumes: the clock runs on from where it stood.
  cab.speaking = true;
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  instructor.write(action(session, 13, "resume"));
  EXPECT_TRUE(states_until(states, 10, [&](const fk_TruckState& s) { return !s.paused && s.sim_time_s > paused_at_s + 0.2; })) << w.err();

  ASSERT_EQ(w.wait(60), 0) << w.err();
  const json live = forklift_test::output_json(w);
  EXPECT_EQ(live["instructor"]["taken"], 3);
  EXPECT_EQ(live["instructor"]["refused"], 1);
  EXPECT_EQ(live["instructor"]["pauses"], 1);
  EXPECT_EQ(live["deadman_stops"], 0);
  EXPECT_NE(w.err().find("instructor1 paused the session"), std::string::npos) << w.err();

  // The log has them at the tick the pause held, and replays bit for bit: the worker's own replay
  // and forklift-sim evaluate's.
  const ControlLog log = read_control_log(tmp(session + ".ctl"));
  ASSERT_EQ(log.instructions.size(), 3u);
  EXPECT_EQ(log.instructions[0].second.action, InstructorAction::kPause);
  EXPECT_EQ(log.instructions[1].second.text, said);
  EXPECT_EQ(log.instructions[2].second.action, InstructorAction::kResume);
  EXPECT_EQ(log.instructions[0].first, log.instructions[2].first) << "no tick between the pause and the resume";
  EXPECT_NEAR(log.instructions[0].first * log.header.tick_s, paused_at_s, 1e-9);
  Process replay({kBin + "/forklift-worker", "--replay", tmp(session + ".ctl"), "--json"}, tmp(session + ".replay"));
  ASSERT_EQ(replay.wait(60), 0) << replay.out() << replay.err();
  const json again = forklift_test::output_json(replay);
  EXPECT_EQ(again["matches_log"], true);
  EXPECT_EQ(again["events_match_log"], true);
  EXPECT_EQ(again["state_hex"], live["state_hex"]);
  Process evaluate({kBin + "/forklift-sim", "evaluate", "--replay", tmp(session + ".ctl")}, tmp(session + ".evaluate"));
  ASSERT_EQ(evaluate.wait(60), 0) << evaluate.err();
  const json marked = forklift_test::output_json(evaluate);
  EXPECT_EQ(marked["ticks"], live["ticks"]);
  EXPECT_EQ(marked["score"]["mark"], live["score"]["mark"]);
  EXPECT_EQ(marked["score"]["counts"], live["score"]["counts"]);
}
