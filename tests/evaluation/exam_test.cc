// Whole sessions: a clean exam in the first-drive yard that passes with no events, the same drive
// and a faulty one through `forklift-sim evaluate` (the same events, run after run, and again
// from the control log), and the scheme's arithmetic.
//
// FORKLIFT_EVAL_SCRIPT_DIR=data/evaluation/scripts build/tests/evaluation_test --gtest_filter='Exam.*'
// rewrites the shipped scripts (data/evaluation/scripts/) from these drives.
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>

#include "evaluation/forklift_sim.h"
#include "evaluation/harness.h"

namespace {

using namespace evt;
using nlohmann::json;

const std::string kYard = data("scenarios/first_drive_yard.json");

// The clean drive: forks to travelling height, the route at walking pace and slower in the
// corners and on the ramp, stop at the start, forks down, brake on, hands off.
void clean_yard_drive(Session& s) {
  s.control_period_ticks = 50;  // 20 Hz is enough at walking pace, and keeps the script short
  Driver d{s};
  d.lift_to = 0.22;
  d.settle_levers();
  d.follow(Path(s.scene.route.points), 1.4, 0.5, 0.7);
  d.park_forks_down();
}

// A drive with faults: off with the forks on the floor and 3 m left of the marked route (so
// missing the first marker), forks up too high, too fast, then leaving the truck with the forks
// up and the brake off, mid-task.
void faulty_yard_drive(Session& s) {
  s.control_period_ticks = 50;
  Driver d{s};
  s.run(20, [&] { Controls c = d.levers(); c.lift = 0; d.speed(c, 1.2); c.steer_rad = d.steer_to_line(23); return c; },
        [&] { return s.pos().x() > 16; });
  d.lift_to = 0.5;
  s.run(20, [&] { Controls c = d.levers(); d.speed(c, 3.3); c.steer_rad = std::clamp(d.steer_to_line(23), -0.02, 0.02); return c; },
        [&] { return s.pos().x() > 36; });
  s.run(10, [&] { Controls c = d.levers(); c.brake = 0.3; return c; }, [&] { return std::abs(s.v()) < 0.01; });
  s.run(0.5, [&] { return Controls{}; });
}

std::string write_script(const Session& s, const std::string& name, const std::string& what) {
  return evt::write_script(s, name, what, "tests/evaluation/exam_test.cc");
}

// The events as (seq, t, rule, level), for comparing runs.
std::vector<std::tuple<int, double, std::string, int>> listed(const json& events) {
  std::vector<std::tuple<int, double, std::string, int>> v;
  for (const json& e : events) v.emplace_back(e["seq"], e["t_s"], e["rule"], e["worry_level"]);
  return v;
}
std::vector<std::tuple<int, double, std::string, int>> listed(const std::vector<EvaluationEvent>& events) {
  std::vector<std::tuple<int, double, std::string, int>> v;
  for (const EvaluationEvent& e : events) v.emplace_back(e.seq, e.t_s, e.rule, e.worry_level);
  return v;
}

TEST(Exam, ACleanDriveThroughTheFirstDriveYardPassesWithNoEvents) {
  Session s(load_scene(kYard, FORKLIFT_DATA_DIR), Mode::kExam);
  clean_yard_drive(s);
  const Score score = s.finish("duration");
  EXPECT_TRUE(s.events.empty()) << s.summary();
  EXPECT_TRUE(score.task_completed);
  EXPECT_EQ(score.steps_done, 5);
  EXPECT_TRUE(score.passed);
  EXPECT_EQ(score.mark, 100);
  EXPECT_LT(s.t(), s.scene.time_limit_s);

  // The same drive as a cab script, offline through forklift-sim.
  const std::string script = write_script(s, "first_drive_yard_exam.csv", "first_drive_yard, exam: a clean drive that completes the task");
  const json out = evaluate({"--scenario", kYard, "--script", script, "--mode", "exam"}, "clean");
  EXPECT_TRUE(out["events"].empty()) << out["events"].dump(2);
  EXPECT_EQ(out["score"]["passed"], true);
  EXPECT_EQ(out["score"]["mark"], 100.0);
  EXPECT_EQ(out["score"]["task_completed"], true);
  EXPECT_EQ(out["score"]["end_reason"], "duration");
  EXPECT_EQ(out["mode"], "exam");
}

TEST(Exam, TheShippedCleanScriptPasses) {
  const json out = evaluate({"--scenario", kYard, "--script", data("evaluation/scripts/first_drive_yard_exam.csv"), "--mode",
                             "exam"},
                            "shipped");
  EXPECT_TRUE(out["events"].empty()) << out["events"].dump(2)
                                     << "\nIf the truck model changed, regenerate the script (see this file's head).";
  EXPECT_EQ(out["score"]["passed"], true);
}

TEST(Exam, AFaultyDriveIsMarkedAlikeInProcessByForkliftSimAndFromItsLog) {
  Session s(load_scene(kYard, FORKLIFT_DATA_DIR), Mode::kTraining);
  faulty_yard_drive(s);
  const Score score = s.finish("duration");
  for (const char* rule : {"travel_forks_low", "travel_forks_high", "speed_open_aisle", "off_route", "task_incomplete"})
    EXPECT_GE(s.count(rule), 1) << rule << "\n" << s.summary();
  // It stops with the forks up and the brake off, but mid-task: the time it was given ran out
  // on it, so the parking rules do not judge the truck.
  for (const char* rule : {"parked_forks_raised", "parked_controls_not_neutral"}) EXPECT_EQ(s.count(rule), 0) << rule << "\n" << s.summary();
  int points = 0;
  for (const EvaluationEvent& e : s.events) points += e.points;
  EXPECT_EQ(score.points, points);
  EXPECT_GE(points, 1 + 3 + 3 + 3);
  EXPECT_LE(points, 40) << s.summary();
  EXPECT_EQ(score.mark, 100 - score.points);
  EXPECT_FALSE(score.passed) << "within the points, but the task was left undone";
  EXPECT_EQ(score.steps_done, 0);

  const std::string script = write_script(s, "first_drive_yard_faults.csv", "first_drive_yard: a drive with faults, for trying the marking");
  const std::string log = testing::TempDir() + "/faults.ctl";
  std::string first, second;
  const json a = evaluate({"--scenario", kYard, "--script", script, "--out-log", log}, "faults_a", &first);
  const json b = evaluate({"--scenario", kYard, "--script", script}, "faults_b", &second);
  EXPECT_EQ(first, second) << "the same script, the same output";
  EXPECT_EQ(listed(a["events"]), listed(s.events)) << a["events"].dump(1) << "\n" << s.summary();
  EXPECT_EQ(a["score"]["points"], score.points);
  EXPECT_EQ(a["score"]["mark"], score.mark);

  // From the control log alone: the same events and the same mark.
  const json r = evaluate({"--replay", log}, "faults_replay");
  EXPECT_EQ(r["events"], a["events"]);
  EXPECT_EQ(r["score"], a["score"]);
  EXPECT_EQ(r["ticks"], a["ticks"]);

  // In an exam the same drive fails as well: the task was not done.
  const json e = evaluate({"--scenario", kYard, "--script", script, "--mode", "exam"}, "faults_exam");
  EXPECT_EQ(e["score"]["passed"], false);
  EXPECT_EQ(e["score"]["points"], score.points);
}

TEST(Exam, BadScriptsAreRefused) {
  const std::string script = testing::TempDir() + "/bad.csv";
  std::ofstream(script) << "t,steer,accelerator,brake,lift,tilt,shift\n0,0,0,0,0,0,0\n1,0,2.5,0,0,0,0\n";
  Process p({std::string(FORKLIFT_BIN_DIR) + "/forklift-sim", "evaluate", "--scenario", kYard, "--script", script},
            testing::TempDir() + "/evaluate_bad");
  EXPECT_EQ(p.wait(60), 2);
  EXPECT_NE(p.err().find("row 2 (t = 1"), std::string::npos) << p.err();
  EXPECT_NE(p.err().find("accelerator = 2.5 is outside [-1, 1]"), std::string::npos) << p.err();
}

// --- the scheme: points, the pass mark, repeated serious faults, the exam's task ---

// Forks on the floor for `runs` separate stretches of 3 s at 1 m/s (one minor fault each).
Session& forks_low_runs(Session& s, int runs) {
  Driver d{s};
  for (int i = 0; i < runs; ++i) {
    s.run(3.0, [&] { Controls c; d.speed(c, 1.0); c.steer_rad = d.steer_to_line(0); return c; });
    s.run(3.0, [&] { Controls c; d.speed(c, 0); return c; });
  }
  return s;
}

TEST(Scheme, PointsMarkAndThePassMark) {
  Session s(scene("zones.json"));
  forks_low_runs(s, 2);
  const Score score = s.finish("signal");
  EXPECT_EQ(score.counts.at("travel_forks_low"), 2);
  EXPECT_EQ(score.points, 2);
  EXPECT_EQ(score.mark, 98);
  EXPECT_TRUE(score.passed);

  Rules strict = rules();
  strict.scheme.fail_above_points = 1;
  Session t(scene("zones.json"), Mode::kTraining, std::nullopt, strict);
  forks_low_runs(t, 2);
  EXPECT_FALSE(t.finish("signal").passed) << "2 points, more than 1";

  Rules harsh = rules();
  harsh.scheme.points_by_worry_level[1] = 150;
  Session u(scene("zones.json"), Mode::kTraining, std::nullopt, harsh);
  forks_low_runs(u, 1);
  EXPECT_EQ(u.finish("signal").mark, 0) << "the mark stops at 0";
}

TEST(Scheme, ASeriousFaultMoreThanItsLimitIsAnAutomaticFailure) {
  Rules r = rules();
  for (Rule& rule : r.rules)
    if (rule.id == "travel_forks_low") rule.worry_level = 5;
  r.scheme.max_same_serious_fault = 2;
  {
    Session s(scene("zones.json"), Mode::kExam, std::nullopt, r);
    forks_low_runs(s, 2);
    EXPECT_TRUE(s.finish("signal").automatic_failures.empty());
  }
  Session s(scene("zones.json"), Mode::kExam, std::nullopt, r);
  forks_low_runs(s, 3);
  const Score score = s.finish("signal");
  EXPECT_EQ(score.points, 15);
  EXPECT_EQ(score.automatic_failures, std::vector<std::string>{"repeated:travel_forks_low"});
  EXPECT_FALSE(score.passed);
}

// Passed means the task was done, in training as in an exam: a session with no points at all but
// its task undone is not passed (training used to pass it, and a worker's summary said
// "passed": true beside "task_completed": false).
TEST(Scheme, ATaskLeftUndoneIsNotPassedInTrainingOrInAnExam) {
  for (Mode mode : {Mode::kTraining, Mode::kExam}) {
    Session s(load_scene(kYard, FORKLIFT_DATA_DIR), mode);
    Driver d{s};
    d.lift_to = 0.22;
    d.settle_levers();
    const Score score = s.finish("signal");
    ASSERT_EQ(s.count("task_incomplete"), 1) << s.summary();
    EXPECT_EQ(s.first("task_incomplete")->points, 0);
    EXPECT_EQ(score.points, 0);
    EXPECT_FALSE(score.task_completed);
    EXPECT_FALSE(score.passed) << mode_name(mode);
    EXPECT_EQ(score.mode, mode_name(mode));
  }
}

}  // namespace
