// The worker's units that need no DDS entity, in-process: the cab's control intake and the
// samples the worker publishes from a SessionRun.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <memory>

#include "control_intake.h"
#include "instructor_intake.h"
#include "forklift/session/session_run.h"
#include "truck_state.h"

namespace {

using namespace forklift;
using namespace forklift::worker;
using Clock = ControlIntake::Clock;

const std::string kData = FORKLIFT_DATA_DIR;

struct Intake : testing::Test {
  TruckParams truck = load_truck(kData + "/trucks/linde_e16c.json");
  std::vector<std::string> said;
  ControlIntake intake{"c1", truck, 1e-3, 0.5, [this](const std::string& s) { said.push_back(s); }};
  Clock::time_point t0 = Clock::now();

  ControlSample sample(uint32_t seq, double accel = 0.2, double at_s = 0) {
    ControlSample s;
    s.seq = seq;
    s.accelerator = accel;
    s.apply_at_sim_s = at_s;
    return s;
  }
};

// The wheel goes on the wire as a fraction of the end stops; this truck's file says what 1 is, and a
// fraction beyond 1 is an angle beyond the truck's stops, refused as any out-of-range value.
TEST_F(Intake, TheWiresSteerIsAFractionOfTheTrucksOwnEndStops) {
  fk_Controls c{};
  c.seq = 1, c.steer = -1.0;
  EXPECT_EQ(control_sample(c, truck).steer_rad, -truck.steer.max_rad);
  EXPECT_NEAR(truck.steer.max_rad, 88 * M_PI / 180, 1e-12);  // the shipped truck's file
  TruckParams narrow = truck;
  narrow.steer.max_rad = 0.5;
  c.steer = 0.5;
  EXPECT_DOUBLE_EQ(control_sample(c, narrow).steer_rad, 0.25);
  c.steer = 1.02;
  intake.offer("c1", control_sample(c, truck), 0, 0, t0);
  EXPECT_FALSE(intake.heard());
  ASSERT_EQ(said.size(), 1u);
  EXPECT_NE(said[0].find("steer_rad"), std::string::npos) << said[0];
  c.steer = 1.0;
  intake.offer("c1", control_sample(c, truck), 0, 0, t0);
  EXPECT_TRUE(intake.heard());
}

TEST_F(Intake, RefusesWhatMustNotReachTheTruckAndCountsIt) {
  intake.offer("c9", sample(1), 0, 0, t0);             // another cab's
  intake.offer("c1", sample(2, NAN), 0, 0, t0);        // not finite
  intake.offer("c1", sample(3, 2.0), 0, 0, t0);        // out of range
  EXPECT_FALSE(intake.heard());
  EXPECT_FALSE(intake.has_pending());
  intake.offer("c1", sample(4), 0, 0, t0);
  intake.offer("c1", sample(4), 0, 0, t0);             // a duplicate
  intake.offer("c1", sample(3), 0, 0, t0);             // old
  EXPECT_TRUE(intake.heard());
  EXPECT_EQ(intake.rejected_cab(), 1);
  EXPECT_EQ(intake.rejected_non_finite(), 1);
  EXPECT_EQ(intake.rejected_range(), 1);
  EXPECT_EQ(intake.sequence_counts().duplicate, 1);
  EXPECT_EQ(intake.sequence_counts().old, 1);
  ASSERT_EQ(said.size(), 5u);
  EXPECT_NE(said[0].find("rejected control 1 from cab 'c9'"), std::string::npos) << said[0];
  const auto s = intake.take_pending();
  ASSERT_TRUE(s);
  EXPECT_EQ(s->seq, 4u);
  EXPECT_FALSE(intake.has_pending());
  const auto tally = intake.tally();
  ASSERT_EQ(tally.size(), 9u);
  EXPECT_EQ(tally[0], std::make_pair(std::string("accepted"), 1L));
}

TEST_F(Intake, OnlyTheFirstFewRefusalsOfAKindAreSaid) {
  for (uint32_t i = 1; i <= 20; ++i) intake.offer("c2", sample(i), 0, 0, t0);
  EXPECT_EQ(intake.rejected_cab(), 20);
  EXPECT_EQ(said.size(), size_t(ControlIntake::kRefusalsSaid));
  EXPECT_NE(said.back().find("further refusals"), std::string::npos);
}

TEST_F(Intake, ScriptedRowsApplyAtTheirTickAndALateResendChangesNothing) {
  intake.offer("c1", sample(1, 0.1, 0.010), 0, 0, t0);  // tick 10
  intake.offer("c1", sample(2, 0.2, 0.020), 0, 0, t0);  // tick 20
  intake.offer("c1", sample(3, 0.3, 5.0), 0, 0, t0);    // more than 2 s ahead: refused
  EXPECT_EQ(intake.rejected_range(), 1);
  EXPECT_FALSE(intake.has_pending());
  EXPECT_FALSE(intake.take_scheduled(9));
  EXPECT_TRUE(intake.take_scheduled(10));
  EXPECT_EQ(intake.take_pending()->seq, 1u);
  EXPECT_TRUE(intake.take_scheduled(25));
  EXPECT_EQ(intake.take_pending()->seq, 2u);
  intake.offer("c1", sample(4, 0.1, 0.010), 25, 0.025, t0);  // a resend of an older row's time
  EXPECT_FALSE(intake.has_pending());
  intake.offer("c1", sample(5, 0.4), 25, 0.025, t0);         // a live sample: at once
  EXPECT_EQ(intake.take_pending()->seq, 5u);
}

TEST_F(Intake, TheDeadManForgetsASilentCabsWishes) {
  ControlSample s = sample(1, 0.2, 0.5);
  s.frames_wanted = true;
  s.camera = 1;
  intake.offer("c1", s, 0, 0, t0);
  ASSERT_TRUE(intake.view_request());
  EXPECT_EQ(intake.view_request()->camera, 1);
  EXPECT_NEAR(intake.silence_s(t0 + std::chrono::milliseconds(600)), 0.6, 1e-9);
  intake.forget();
  EXPECT_FALSE(intake.view_request());
  EXPECT_FALSE(intake.take_scheduled(1000));
}

// The lining-up hint follows the task: with the task's pallet behind the truck and another
// pallet square ahead of its forks, the state names the task's pallet and where it is, never the
// one ahead; once the truck faces the task's pallet, the hint is about it.
// A run on a floor where P1 lies behind the truck on its left and P2 square ahead of its forks,
// one tick in; `task`: the scenario's "task" JSON, or "" for none.
std::unique_ptr<SessionRun> two_pallets(const std::string& name, const std::string& task) {
  const std::string scenario = testing::TempDir() + "/" + name + ".json";
  std::ofstream(scenario) << R"({
    "name": ")" << name << R"(", "description": "P1 behind on the left; P2 square ahead of the forks.",
    "truck": "trucks/linde_e16c.json", "start": {"x_m": 0.0, "y_m": 0.0, "yaw_deg": 0}, "floor_m": [-20, -20, 20, 20],
    "objects": [
      {"id": "P1", "kind": "pallet", "x_m": -6.0, "y_m": 6.0, "yaw_deg": 0, "pallet": {"load_mass_kg": 300, "load_size_m": [1.0, 0.8, 0.5]}},
      {"id": "P2", "kind": "pallet", "x_m": 4.0, "y_m": 0.0, "yaw_deg": 0, "pallet": {"load_mass_kg": 300, "load_size_m": [1.0, 0.8, 0.5]}}
    ])" << (task.empty() ? "" : ",\n    \"task\": " + task) << "\n  }";
  SessionSpec spec;
  spec.scenario_file = scenario;
  const SessionModel model = load_session_model(spec, kData);
  auto run = std::make_unique<SessionRun>(model, initial_state(model));
  run->tick();
  return run;
}

// The lining-up hint follows the task: with the task's pallet behind the truck and another
// pallet square ahead of its forks, the state names the task's pallet and where it is, never the
// one ahead; with no task, the nearest ahead, as before.
TEST(TruckState, ThePalletHintIsAboutTheTasksPalletNotTheNearestAhead) {
  const auto run = two_pallets("two_pallets",
                                     R"({"summary": "Take P1", "steps": [{"kind": "take", "description": "Take P1", "pallet": "P1"}]})");
  const fk_TruckState s = truck_state(*run, "c1", "s1", 0, 3);
  EXPECT_EQ(std::string(s.pallet_ahead), "") << "P2 is ahead, but the task is about P1";
  EXPECT_EQ(std::string(s.task_pallet), "P1");
  EXPECT_GT(s.task_pallet_bearing_rad, 100 * M_PI / 180);  // behind, on the left
  EXPECT_LT(s.task_pallet_bearing_rad, 170 * M_PI / 180);
  EXPECT_GT(s.task_pallet_range_m, 7.0);  // about 9 m from the carriage
  EXPECT_LT(s.task_pallet_range_m, 11.0);
  EXPECT_NEAR(s.task_pallet_height_m, 0.0, 0.01);

  const auto free_run = two_pallets("two_pallets_no_task", "");
  const fk_TruckState f = truck_state(*free_run, "c1", "s1", 0, 3);
  EXPECT_EQ(std::string(f.pallet_ahead), "P2");
  EXPECT_EQ(std::string(f.task_pallet), "");
}

TEST(TruckState, TellsTheHudWhatTheRunHolds) {
  SessionSpec spec;
  spec.scenario_file = kData + "/scenarios/first_drive_yard.json";
  const SessionModel model = load_session_model(spec, kData);
  SessionRun run(model, initial_state(model));
  ControlSample c;
  c.accelerator = 0.5;
  run.apply(7, driver_inputs(c, model.truck));
  for (int i = 0; i < 200; ++i) run.tick();
  run.deadman();
  run.tick();
  const fk_TruckState s = truck_state(run, "c1", "s1", 10.0, 3);
  EXPECT_EQ(std::string(s.cab_id), "c1");
  EXPECT_EQ(std::string(s.session_id), "s1");
  EXPECT_EQ(s.applied_control_sequence, 7u);
  EXPECT_TRUE(s.deadman);
  EXPECT_NEAR(s.sim_time_s, 0.201, 1e-9);
  EXPECT_NEAR(s.time_left_s, 10.0 - 0.201, 1e-9);
  EXPECT_EQ(s.aids, 3);
  EXPECT_GT(s.speed_m_s, 0.0);
  EXPECT_EQ(truck_state(run, "c1", "s1", 0, 0).time_left_s, -1.0);

  Score score;
  score.mark = 91;
  score.passed = true;
  for (int i = 0; i < 70; ++i) score.counts["rule_" + std::to_string(i)] = i;
  std::vector<fk_FaultCount> counts;
  const fk_Score sc = score_sample("s1", score, counts);
  EXPECT_EQ(sc.counts._length, 64u) << "the IDL's bound";
  EXPECT_EQ(sc.mark, 91);
  EXPECT_TRUE(sc.passed);
}

}  // namespace

namespace {

fk_InstructorAction instructor_action(const std::string& session, uint64_t seq, const std::string& action, const std::string& text = "",
                                      const std::string& cab = "c1") {
  fk_InstructorAction a{};
  dds::set_string(a.session_id, session);
  dds::set_string(a.cab_id, cab);
  a.seq = seq;
  dds::set_string(a.action, action);
  dds::set_string(a.text, text);
  dds::set_string(a.by, "ivan");
  return a;
}

}  // namespace

// The instructor's actions as the worker takes them: once each and in order, for its own session
// and cab; a pause only while running, a resume only while paused, a message the cab can show;
// another session's passed over; nothing at all in an exam.
TEST(InstructorIntakeTest, TakesEachGoodActionOnceAndRefusesTheRest) {
  std::vector<std::string> said;
  InstructorIntake in("c1", "s-1", Mode::kTraining, 20, [&](const std::string& s) { said.push_back(s); });
  EXPECT_FALSE(in.offer(instructor_action("s-0", 5, "pause"), false)) << "an earlier session's, kept by the topic";
  EXPECT_EQ(in.other_sessions(), 1);
  const auto pause = in.offer(instructor_action("s-1", 10, "pause"), false);
  ASSERT_TRUE(pause);
  EXPECT_EQ(pause->action, InstructorAction::kPause);
  EXPECT_FALSE(in.offer(instructor_action("s-1", 10, "resume"), true)) << "not newer";
  EXPECT_FALSE(in.offer(instructor_action("s-1", 11, "pause"), true)) << "paused already";
  EXPECT_FALSE(in.offer(instructor_action("s-1", 12, "resume", "now"), true)) << "a resume takes no text";
  EXPECT_FALSE(in.offer(instructor_action("s-1", 13, "rewind"), true));
  EXPECT_FALSE(in.offer(instructor_action("s-1", 14, "message", "far too long a line for this display"), true));
  EXPECT_FALSE(in.offer(instructor_action("s-1", 15, "message", "two\nlines"), true));
  EXPECT_FALSE(in.offer(instructor_action("s-1", 16, "message", "\xff\xfe"), true)) << "not UTF-8";
  EXPECT_FALSE(in.offer(instructor_action("s-1", 17, "message", "", "c2"), true)) << "another cab's";
  const auto message = in.offer(instructor_action("s-1", 18, "message", "Look left"), true);
  ASSERT_TRUE(message);
  EXPECT_EQ(message->text, "Look left");
  EXPECT_TRUE(in.offer(instructor_action("s-1", 19, "resume"), true));
  EXPECT_FALSE(in.offer(instructor_action("s-1", 20, "resume"), false)) << "not paused";
  EXPECT_EQ(in.taken(), 3);
  EXPECT_EQ(in.refused(), 9);
  ASSERT_EQ(said.size(), size_t(InstructorIntake::kRefusalsSaid)) << "the first few said, the rest counted";
  EXPECT_NE(said[0].find("not newer"), std::string::npos) << said[0];

  InstructorIntake exam("c1", "s-2", Mode::kExam, 120, [](const std::string&) {});
  EXPECT_FALSE(exam.offer(instructor_action("s-2", 1, "pause"), false));
  EXPECT_FALSE(exam.offer(instructor_action("s-2", 2, "message", "Good luck"), false));
  EXPECT_EQ(exam.taken(), 0);
  EXPECT_EQ(exam.refused(), 2);
}
