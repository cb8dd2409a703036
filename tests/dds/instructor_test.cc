// The instructor's hand on a live session, between real processes over loopback DDS: a worker
// driven by a cab (the test's own participant) takes the instructor's pause, message, resume and
// rewind from its cab's instructor partition, as the server writes them. Paused, its truck's sim time
// stands still while the wall clock runs on, and the dead man does not fire however long the cab
// is silent; the message is on the cab's state; the log replays bit for bit. Every test has its
// own domain id from the allocator (support/ports.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>
#include <thread>
#include <tuple>

#include "forklift/protocol/protocol.h"
#include "forklift/session/session.h"
#include "forklift/session/session_run.h"
#include "support/ports.h"
#include "support/process.h"
#include "support/speaking_cab.h"
#include "support/worker.h"

using namespace forklift;
using nlohmann::json;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR, kData = FORKLIFT_DATA_DIR;
using forklift_test::temp_file;

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

// A worker for `session` on cab c1 in a scenario (the yard unless named; its own domain), driven by a speaking cab, and the
// instructor's writer as a server has it; the cab's states read.
struct LiveSession {
  LiveSession(const std::string& session, const std::string& duration_s, const std::string& deadman_s,
              const std::string& scenario = "first_drive_yard")
      : id(session),
        domain(forklift::test::free_domain()),
        worker(forklift_test::start_worker(kBin, temp_file(""), domain, "c1", session,
                                           {"--duration", duration_s, "--deadman-timeout", deadman_s, "--start-timeout", "60",
                                            "--scenario", kData + "/scenarios/" + scenario + ".json"})),
        p(dds::DomainSettings::resolve(domain, "")),
        instructor(p, dds::instructor_partition("c1")),
        states(p, dds::cab_partition("c1")),
        cab(p, "c1", 0.3) {}
  // Drives until the truck's time passes `t_s`, pauses (`seq`) and returns the sim time it stands at
  // (negative: it never did).
  double drive_then_pause(double t_s, uint64_t seq) {
    if (!states_until(states, 60, [&](const fk_TruckState& s) { return s.sim_time_s > t_s; })) return -1;
    instructor.write(action(id, seq, "pause"));
    double paused_at_s = -1;
    states_until(states, 10, [&](const fk_TruckState& s) {
      if (s.paused) paused_at_s = s.sim_time_s;
      return s.paused;
    });
    return paused_at_s;
  }

  std::string id;
  int domain;
  Process worker;
  dds::Participant p;
  dds::Writer<fk_InstructorAction> instructor;
  dds::Reader<fk_TruckState> states;
  forklift_test::SpeakingCab cab;
};

}  // namespace

TEST(Instructor, APauseHoldsTheClockAndTheDeadManAMessageReachesTheCabAndTheLogReplaysBitForBit) {
  LiveSession live_session("s-7", "3", "0.5");
  const std::string& session = live_session.id;
  Process& w = live_session.worker;
  auto [instructor, states, cab] = std::tie(live_session.instructor, live_session.states, live_session.cab);
  // An earlier session's action on this cab, kept by the topic: passed over.
  instructor.write(action("s-6", 1, "pause"));
  const double paused_at_s = live_session.drive_then_pause(0.5, 10);
  ASSERT_GT(paused_at_s, 0) << w.err();

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
  const ControlLog log = read_control_log(temp_file(session + ".ctl"));
  ASSERT_EQ(log.instructions.size(), 3u);
  EXPECT_EQ(log.instructions[0].second.action, InstructorAction::kPause);
  EXPECT_EQ(log.instructions[1].second.text, said);
  EXPECT_EQ(log.instructions[2].second.action, InstructorAction::kResume);
  EXPECT_EQ(log.instructions[0].first, log.instructions[2].first) << "no tick between the pause and the resume";
  EXPECT_NEAR(log.instructions[0].first * log.header.tick_s, paused_at_s, 1e-9);
  Process replay({kBin + "/forklift-worker", "--replay", temp_file(session + ".ctl"), "--json"}, temp_file(session + ".replay"));
  ASSERT_EQ(replay.wait(60), 0) << replay.out() << replay.err();
  const json again = forklift_test::output_json(replay);
  EXPECT_EQ(again["matches_log"], true);
  EXPECT_EQ(again["events_match_log"], true);
  EXPECT_EQ(again["state_hex"], live["state_hex"]);
  Process evaluate({kBin + "/forklift-sim", "evaluate", "--replay", temp_file(session + ".ctl"), "--json"}, temp_file(session + ".evaluate"));
  ASSERT_EQ(evaluate.wait(60), 0) << evaluate.err();
  const json marked = forklift_test::output_json(evaluate);
  EXPECT_EQ(marked["ticks"], live["ticks"]);
  EXPECT_EQ(marked["score"]["mark"], live["score"]["mark"]);
  EXPECT_EQ(marked["score"]["counts"], live["score"]["counts"]);
}

// "Try that again": paused after five seconds of driving, the instructor takes the session back
// three seconds; the worker goes back to the newest state it kept at least that far back (one every
// 2 s, data/session.json), says where it went in a "rewound" event that the cab hears, and the
// truck drives on from there when resumed. That state is the one the session had at the point's
// tick, bit for bit (the log's inputs up to there, re-simulated here), and the whole log, rewind
// and all, replays bit for bit.
TEST(Instructor, ARewindGoesBackToTheKeptStateAndTheLogReplaysBitForBit) {
  LiveSession live_session("s-8", "7", "2");
  const std::string& session = live_session.id;
  Process& w = live_session.worker;
  auto [instructor, states] = std::tie(live_session.instructor, live_session.states);
  dds::Reader<fk_Event> events(live_session.p, dds::cab_partition("c1"));
  const double paused_at_s = live_session.drive_then_pause(5.3, 20);
  ASSERT_GT(paused_at_s, 0) << w.err();
  fk_InstructorAction back = action(session, 21, "rewind");
  back.seconds = 3;
  instructor.write(back);
  json rewound;
  for (int i = 0; i < 1000 && rewound.is_null(); ++i) {
    events.take_each([&](const fk_Event& e) {
      if (std::string(e.kind) == "rewound" && std::string(e.session_id) == session) rewound = json::parse(e.details);
    });
    if (rewound.is_null()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(rewound.is_object()) << w.err();
  const double expected_to_s = 2.0 * std::floor((paused_at_s - 3) / 2.0 + 1e-9);
  EXPECT_NEAR(rewound["from_s"].get<double>(), paused_at_s, 1e-9);
  EXPECT_NEAR(rewound["to_s"].get<double>(), expected_to_s, 1e-9);
  // Still paused, the states the worker keeps sending are the point's: its time and its truck.
  fk_TruckState at_point{};
  EXPECT_TRUE(states_until(states, 10, [&](const fk_TruckState& s) {
    at_point = s;
    return s.paused && std::abs(s.sim_time_s - expected_to_s) < 1e-9;
  })) << "no paused state at the point";
  auto hex = [](double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%a", v);
    return std::string(buf);
  };
  EXPECT_EQ(hex(at_point.x_m), rewound["state"]["x_m"]);
  EXPECT_EQ(hex(at_point.y_m), rewound["state"]["y_m"]);
  instructor.write(action(session, 22, "resume"));
  EXPECT_TRUE(states_until(states, 10, [&](const fk_TruckState& s) { return !s.paused && s.sim_time_s < paused_at_s - 1; }))
      << "the clock runs on from the point, " << w.err();

  ASSERT_EQ(w.wait(60), 0) << w.err();
  const json live = forklift_test::output_json(w);
  EXPECT_EQ(live["instructor"]["rewinds"], 1);
  EXPECT_EQ(live["instructor"]["taken"], 3);
  const ControlLog log = read_control_log(temp_file(session + ".ctl"));
  const std::vector<InputChange> changes = logged_changes(log);
  const auto rewind = std::find_if(changes.begin(), changes.end(), [](const InputChange& c) {
    return c.instruction && c.instruction->action == InstructorAction::kRewind;
  });
  ASSERT_NE(rewind, changes.end());
  const int64_t to_tick = rewind->instruction->to_tick;
  EXPECT_NEAR(to_tick * log.header.tick_s, expected_to_s, 1e-9);
  // The session as it was at the point's tick, from the log's inputs up to the rewind.
  const SessionModel model = load_session_model(log.header, kData);
  const OfflineRun before = run_offline(model, initial_state(model, log.header), std::vector<InputChange>(changes.begin(), rewind),
                                        to_tick, std::nullopt);
  EXPECT_EQ(rewound["state"]["x_m"], hex(before.final_state.x[kX]));
  EXPECT_EQ(rewound["state"]["y_m"], hex(before.final_state.x[kY]));
  EXPECT_EQ(rewound["state"]["yaw_rad"], hex(before.final_state.x[kAwc]));

  Process replay({kBin + "/forklift-worker", "--replay", temp_file(session + ".ctl"), "--json"}, temp_file(session + ".replay"));
  ASSERT_EQ(replay.wait(60), 0) << replay.out() << replay.err();
  const json again = forklift_test::output_json(replay);
  EXPECT_EQ(again["matches_log"], true);
  EXPECT_EQ(again["events_match_log"], true);
  Process evaluate({kBin + "/forklift-sim", "evaluate", "--replay", temp_file(session + ".ctl"), "--json"}, temp_file(session + ".evaluate"));
  ASSERT_EQ(evaluate.wait(60), 0) << evaluate.err();
  const json marked = forklift_test::output_json(evaluate);
  EXPECT_EQ(marked["ticks"], live["ticks"]);
  EXPECT_EQ(marked["score"]["mark"], live["score"]["mark"]);
  // The debrief's replay: the attempt that stands, its samples in time order, the rewind said.
  Process trace({kBin + "/forklift-sim", "trace", temp_file(session + ".ctl")}, temp_file(session + ".trace"));
  ASSERT_EQ(trace.wait(60), 0) << trace.err();
  const json traced = forklift_test::output_json(trace);
  ASSERT_EQ(traced["rewinds"].size(), 1u) << traced["rewinds"];
  EXPECT_NEAR(traced["rewinds"][0]["to_s"].get<double>(), expected_to_s, 1e-9);
  EXPECT_NEAR(traced["rewinds"][0]["from_s"].get<double>(), paused_at_s, 1e-9);
  for (size_t i = 1; i < traced["samples"].size(); ++i)
    ASSERT_LT(traced["samples"][i - 1]["t"].get<double>(), traced["samples"][i]["t"].get<double>()) << "sample " << i;
}

// The pallet that falls and the spill with a cue, started by the instructor: the cab's states say
// which have started, the pallet leaving its beams and then lying on the floor, so that the
// instructor's page no longer offers them.
TEST(Instructor, AStartedFallingPalletAndSpillAreOnTheCabsStates) {
  LiveSession live_session("s-80801", "4", "1", "pedestrian_awareness");  // an id of its own: the worker's files are named by it
  Process& w = live_session.worker;
  fk_TruckState before{};
  ASSERT_TRUE(states_until(live_session.states, 60, [&](const fk_TruckState& s) { before = s; return s.sim_time_s > 0.5; })) << w.err();
  EXPECT_EQ(before.falls_started, 0u);
  EXPECT_EQ(before.falls_landed, 0u);
  EXPECT_EQ(before.spills_on_floor, 0u) << "S1 waits for its cue";
  live_session.instructor.write(action(live_session.id, 40, "hazard", "P2"));
  live_session.instructor.write(action(live_session.id, 41, "hazard", "S1"));
  EXPECT_TRUE(states_until(live_session.states, 30, [](const fk_TruckState& s) { return s.falls_started == 1u && s.spills_on_floor == 1u; }))
      << w.err();
  EXPECT_TRUE(states_until(live_session.states, 30, [](const fk_TruckState& s) { return s.falls_landed == 1u; })) << "P2 lands";
  ASSERT_EQ(w.wait(60), 0) << w.err();
  EXPECT_EQ(forklift_test::output_json(w)["instructor"]["hazards"], 2);
}

// "Hazard now" over DDS: the instructor sets the walkway's pedestrian walking while the truck is
// still beyond his trigger; a pedestrian the scenario does not have is refused. The log says when,
// the pedestrian has walked in its replay, and the replay is bit for bit.
TEST(Instructor, AHazardSetsThePedestrianWalkingAndTheLogReplaysBitForBit) {
  LiveSession live_session("s-9", "2", "1", "pedestrian_awareness");
  Process& w = live_session.worker;
  ASSERT_TRUE(states_until(live_session.states, 60, [](const fk_TruckState& s) { return s.sim_time_s > 0.5; })) << w.err();
  live_session.instructor.write(action(live_session.id, 30, "hazard", "W9"));
  live_session.instructor.write(action(live_session.id, 31, "hazard", "W1"));
  ASSERT_EQ(w.wait(60), 0) << w.err();
  const json live = forklift_test::output_json(w);
  EXPECT_EQ(live["instructor"]["hazards"], 1);
  EXPECT_EQ(live["instructor"]["refused"], 1);
  EXPECT_NE(w.err().find("no pedestrian, falling pallet, truck or spill 'W9' in this scenario (it has W1, W2, P2, T1, T2, S1)"), std::string::npos) << w.err();
  const ControlLog log = read_control_log(temp_file("s-9.ctl"));
  ASSERT_EQ(log.instructions.size(), 1u);
  EXPECT_EQ(log.instructions[0].second, (Instruction{InstructorAction::kHazard, "W1"}));
  EXPECT_GT(log.instructions[0].first * log.header.tick_s, 0.5);
  PedestrianState last;
  const ReplayResult r = replay_session(log, kData, [&](const SessionState& s, const SessionWorkspace&) { last = s.pedestrians.at(0); });
  EXPECT_EQ(r.final_state, *log.final_state);
  EXPECT_EQ(r.event_lines, log.event_lines);
  EXPECT_TRUE(last.started);
  EXPECT_GT(last.at_m.y(), 1.0 + 0.5) << "he has walked north from his start";
}
