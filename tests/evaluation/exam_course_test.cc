// The shipped practical exam course (data/scenarios/counterbalance_exam.json): a clean drive
// through it passes with no event; the same course with the task left unfinished, with the time
// exceeded, or with each automatic failure that can happen on it, fails, with its reason in the
// score. The clean drive is also a cab script (data/evaluation/scripts/counterbalance_exam_clean.csv)
// that forklift-sim evaluate marks the same way.
//
// A worker crosses the hall once, through the chicane between its first and second gates, 36 s
// into the test: the clean drive is at the racks by then; a drive that waits for him and then
// comes at him fast is marked for it (counterbalance_exam_worker_faults.csv).
//
// FORKLIFT_EVAL_SCRIPT_DIR=data/evaluation/scripts build/tests/evaluation_test --gtest_filter='ExamCourse.*'
// rewrites the shipped scripts from these drives.
#include "evaluation/forklift_sim.h"
#include "evaluation/harness.h"

namespace {

using namespace evt;
using nlohmann::json;

const std::string kCourse = data("scenarios/counterbalance_exam.json");

// The course's measures (data/scenes/exam_hall.json): racks R1 and R2 at x = 38, their pallet
// places' entry face (the pallet's near face) at x = 37.4, their front beams' face at 37.45; the vertical face at x = 38.5; lanes
// A, B and C at y = 4, 8 and 12.
constexpr double kLaneA = 4.0, kLaneB = 8.0, kLaneC = 12.0;
constexpr double kRackX = 38.0, kEntryFace = 37.4, kRackFront = 37.45, kFaceX = 38.5;
constexpr double kTopBeam = 2.7;
constexpr double kPocketMid = 0.092;  // fork top for forks centred in a EUR pallet's openings
constexpr double kUnderside = 0.122;  // a pallet on the forks: its underside this far below the fork top
constexpr double kTravel = 0.15;      // fork top when travelling: a hand's width
constexpr double kPalletHalf = 0.6;   // a EUR pallet along its fork openings

struct CourseDriver {
  Session& s;
  Driver d{s};

  const PalletState& p1() const { return *s.pallet("P1"); }
  double pallet_front() const { return p1().pose.translation().x() + kPalletHalf; }
  double tips() const { return d.heel_x() + s.shape.fork_length_m; }
  void lift(double to) {
    d.lift_to = to;
    d.settle_levers();
  }
  void to_tips(double x, double lane, double v) { d.approach([&] { return x - tips(); }, v, lane); }
  void back_tips_to(double x, double lane, double v = 0.3) { d.approach([&] { return tips() - x; }, -v, lane); }

  // Forwards through the chicane's three gates, forks at travelling height; stops on lane A.
  void chicane() {
    lift(kTravel);
    d.follow(Path({{4.75, kLaneA}, {9.0, kLaneA}, {18.0, 7.0}, {27.0, kLaneA}, {31.0, kLaneA}}), 1.6, 0.7, 0.7);
  }
  // Takes P1 from the top level of the rack at the end of `lane`, and carries it back out at
  // travelling height.
  void destack(double lane) {
    to_tips(kEntryFace - 0.4, lane, 1.2);
    lift(kTopBeam + kPocketMid);
    to_tips(kEntryFace + 0.9, lane, 0.3);
    lift(kTopBeam + kPocketMid + 0.08);  // picked up, clear of the beams
    back_tips_to(kEntryFace - 0.3, lane);
    lift(kTravel);
  }
  // Backs out to x = 25, then forwards to `to` (heading +x), stopping there.
  void change_lane(double from, double to) {
    d.approach([&] { return s.pos().x() - 25.0; }, -1.2, from);
    d.follow(Path({{25.75, from}, {28.0, from}, {32.0, to}, {33.5, to}}), 1.2, 0.5, 0.7);
  }
  // Sets P1 down on the top level of the rack at the end of `lane`, its centre at x = centre_x,
  // and backs out, forks at travelling height.
  void stack(double lane, double centre_x = kRackX) {
    d.approach([&] { return (kRackFront - 0.35) - pallet_front(); }, 1.0, lane);
    lift(kTopBeam + kUnderside + 0.08);  // the pallet's underside 8 cm over the beam
    d.approach([&] { return centre_x - p1().pose.translation().x(); }, 0.3, lane);
    lower_until_set_down();
    back_tips_to(kEntryFace - 0.3, lane);
    lift(kTravel);
  }
  void lower_until_set_down() {
    s.run(15, [&] { Controls c; c.brake = 0.3; c.lift = -0.25; return c; }, [&] { return !p1().on_forks; });
    d.lift_to = s.heel_z() - 0.05;
    d.settle_levers();
  }
  // P1 on the floor square to the vertical face, `gap` m from it; backs out to travelling height.
  void place_at_face(double gap = 0.05) {
    d.approach([&] { return (kFaceX - gap) - pallet_front(); }, 1.0, kLaneC);
    lower_until_set_down();
    back_tips_to(kFaceX - gap - 2 * kPalletHalf - 0.3, kLaneC);
    lift(kTravel);
  }
  // Backs along lane C into the parking bay, lowers the forks and leaves the truck braked.
  void park() {
    d.approach([&] { return s.pos().x() - 6.0; }, -1.2, kLaneC);
    lift(0.0);
    d.park(3.0);  // longer than data/session.json's task_end_hold_s: a live session ends in it
  }
  void whole_course() {
    chicane();
    destack(kLaneA);
    change_lane(kLaneA, kLaneB);
    stack(kLaneB);
    destack(kLaneB);
    change_lane(kLaneB, kLaneC);
    place_at_face();
    park();
  }
};

bool automatic_failure(const Score& score, const std::string& rule) {
  return std::find(score.automatic_failures.begin(), score.automatic_failures.end(), rule) != score.automatic_failures.end();
}

// The session's end as a failed exam with `rule` among its automatic failures.
void expect_automatic_failure(Session& s, const std::string& rule) {
  const Score score = s.finish("signal");
  EXPECT_FALSE(score.passed);
  EXPECT_TRUE(automatic_failure(score, rule)) << s.summary();
}

TEST(ExamCourse, TheShippedCourseIsAnExamCourseWithATimeLimit) {
  const Scene sc = load_scene(kCourse, FORKLIFT_DATA_DIR);
  ASSERT_TRUE(sc.exam_course);
  EXPECT_FALSE(sc.exam_course->standard.empty());
  EXPECT_GT(sc.time_limit_s, 0);
  EXPECT_EQ(sc.task.steps.size(), 8u);
  // The paper's manoeuvres and the training scenarios are not.
  for (const char* other : {"manoeuvres/manoeuvre_1.json", "scenarios/first_drive_yard.json", "scenarios/practical_exam.json"})
    EXPECT_FALSE(load_scene(data(other), FORKLIFT_DATA_DIR).exam_course) << other;
}

TEST(ExamCourse, ACleanDrivePassesWithNoEvent) {
  Session s(load_scene(kCourse, FORKLIFT_DATA_DIR), Mode::kExam);
  s.control_period_ticks = 20;  // 50 Hz: a cab's rate, and a shorter script
  CourseDriver c{s};
  c.whole_course();
  const Score score = s.finish("parked");
  EXPECT_TRUE(s.events.empty()) << s.summary();
  EXPECT_TRUE(score.task_completed) << score.steps_done << " of " << score.steps_total << "\n" << s.summary();
  EXPECT_TRUE(score.passed);
  EXPECT_EQ(score.mark, 100);
  EXPECT_LT(s.t(), s.scene.time_limit_s);
  std::cout << "clean drive: " << s.t() << " s of " << s.scene.time_limit_s << " s\n";

  // The same drive as a cab script, offline through forklift-sim, in exam mode.
  const std::string script = write_script(s, "counterbalance_exam_clean.csv",
                                          "counterbalance_exam, exam: a clean drive that completes the course",
                                          "tests/evaluation/exam_course_test.cc");
  const json out = evaluate({"--scenario", kCourse, "--script", script, "--mode", "exam"}, "course_clean");
  EXPECT_TRUE(out["events"].empty()) << out["events"].dump(2);
  EXPECT_EQ(out["score"]["passed"], true);
  EXPECT_EQ(out["score"]["task_completed"], true);
}

// Training on the course: waits at the start for the worker to set off, then at 2 m/s along lane A
// straight at him as he crosses it, braking late, 2.5 m short of his line; on at walking pace once
// he is across, stopping short of the second gate (the task left there).
TEST(ExamCourse, DrivingFastAtTheWorkerCrossingTheChicaneIsMarked) {
  Session s(load_scene(kCourse, FORKLIFT_DATA_DIR), Mode::kTraining);
  s.control_period_ticks = 50;
  CourseDriver c{s};
  ASSERT_EQ(s.scene.pedestrians.size(), 1u);
  const auto worker = [&]() -> const PedestrianState& { return s.state.pedestrians.at(0); };
  const double line = s.scene.pedestrians[0].path[0].x();
  c.lift(kTravel);
  s.run(60, [&] { Controls k = c.d.levers(); c.d.speed(k, 0); return k; }, [&] { return worker().started; });
  s.run(20, [&] { Controls k = c.d.levers(); c.d.speed(k, 2.0); k.steer_rad = c.d.steer_to_line(kLaneA); return k; },
        [&] { return c.tips() >= line - 2.5; });
  s.run(10, [&] { Controls k = c.d.levers(); k.brake = 0.6; k.steer_rad = s.c.steer_rad; return k; },
        [&] { return std::abs(s.v()) < 0.003; });
  s.run(30, [&] { Controls k = c.d.levers(); c.d.speed(k, 0); return k; }, [&] { return worker().at_m.y() > kLaneA + 3.0; });
  c.to_tips(line + 1.0, kLaneA, 1.0);
  c.d.stop();
  const Score score = s.finish("duration");
  EXPECT_EQ(s.count("pedestrian_struck"), 0) << s.summary();
  EXPECT_EQ(s.count("speed_near_pedestrian"), 1) << s.summary();
  EXPECT_EQ(s.count("pedestrian_in_path"), 1) << s.summary();
  EXPECT_FALSE(score.passed);
  const EvaluationEvent* e = s.first("speed_near_pedestrian");
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(json::parse(e->details)["pedestrian"], "WORKER");

  const std::string script = write_script(s, "counterbalance_exam_worker_faults.csv",
                                          "counterbalance_exam, training: fast at the worker crossing the chicane",
                                          "tests/evaluation/exam_course_test.cc");
  const json out = evaluate({"--scenario", kCourse, "--script", script}, "course_worker");
  std::set<std::string> rules;
  for (const json& ev : out["events"]) rules.insert(ev["rule"]);
  EXPECT_TRUE(rules.count("speed_near_pedestrian") && rules.count("pedestrian_in_path")) << out["events"].dump(1);
}

TEST(ExamCourse, TheShippedCleanScriptPasses) {
  const json out = evaluate({"--scenario", kCourse, "--script", data("evaluation/scripts/counterbalance_exam_clean.csv"),
                             "--mode", "exam"},
                            "course_shipped");
  EXPECT_TRUE(out["events"].empty()) << out["events"].dump(2)
                                     << "\nIf the truck model changed, regenerate the script (see this file's head).";
  EXPECT_EQ(out["score"]["passed"], true);
}

TEST(ExamCourse, TheTaskLeftUnfinishedFails) {
  Session s(load_scene(kCourse, FORKLIFT_DATA_DIR), Mode::kExam);
  CourseDriver c{s};
  c.chicane();
  c.destack(kLaneA);
  c.lift(0.0);
  c.d.park(1.0);
  const Score score = s.finish("parked");
  EXPECT_FALSE(score.passed);
  EXPECT_FALSE(score.task_completed);
  EXPECT_EQ(score.steps_done, 4);
  ASSERT_EQ(s.count("task_incomplete"), 1) << s.summary();
  EXPECT_NE(s.first("task_incomplete")->details.find("Stack P1 on rack R2"), std::string::npos);
}

TEST(ExamCourse, RunningOutOfTimeFails) {
  Session s(load_scene(kCourse, FORKLIFT_DATA_DIR), Mode::kExam);
  CourseDriver c{s};
  s.run(s.scene.time_limit_s - 30, [&] { Controls k; k.brake = 0.5; return k; });  // a hesitant start
  c.chicane();
  c.destack(kLaneA);
  const Score score = s.finish("time_limit");
  EXPECT_FALSE(score.passed);
  EXPECT_TRUE(automatic_failure(score, "time_limit")) << s.summary();
}

TEST(ExamCourse, StrikingTheExaminerFails) {
  Session s(load_scene(kCourse, FORKLIFT_DATA_DIR), Mode::kExam);
  CourseDriver c{s};
  c.lift(kTravel);
  c.d.go({22.0, 15.2}, 0.6, 0.1, 60);
  expect_automatic_failure(s, "collision_pedestrian");
}

TEST(ExamCourse, AViolentCollisionFails) {
  Session s(load_scene(kCourse, FORKLIFT_DATA_DIR), Mode::kExam);
  CourseDriver c{s};
  c.lift(kTravel);
  // Straight at the west wall in reverse, fast.
  s.run(20, [&] { Controls k = c.d.levers(); c.d.speed(k, -2.0); k.steer_rad = c.d.steer_to_line(kLaneA, true); return k; },
        [&] { return s.count("violent_collision") > 0; });
  expect_automatic_failure(s, "violent_collision");
}

TEST(ExamCourse, StackingOverhangingTheBeamsFails) {
  Session s(load_scene(kCourse, FORKLIFT_DATA_DIR), Mode::kExam);
  CourseDriver c{s};
  c.chicane();
  c.destack(kLaneA);
  c.change_lane(kLaneA, kLaneB);
  c.stack(kLaneB, kRackX - 0.45);  // half a metre of pallet hangs over the aisle, off the back beam
  expect_automatic_failure(s, "unsafe_stacking");
}

// P1 taken with its weight near the fork tips, backed out to the middle of the hall with the load
// still at the top level, the mast tilted fully forward; then forwards fast and a hard stop.
void load_high_in_the_open(CourseDriver& c, double insert) {
  Session& s = c.s;
  c.chicane();
  c.to_tips(kEntryFace - 0.4, kLaneA, 1.2);
  c.lift(kTopBeam + kPocketMid);
  c.to_tips(kEntryFace + insert, kLaneA, 0.3);
  c.lift(kTopBeam + kPocketMid + 0.08);
  c.d.approach([&] { return s.pos().x() - 20.0; }, -0.4, kLaneA);
}

TEST(ExamCourse, DroppingTheLoadFails) {
  Session s(load_scene(kCourse, FORKLIFT_DATA_DIR), Mode::kExam);
  CourseDriver c{s};
  load_high_in_the_open(c, 0.9);
  // Away at full throttle with the load still at the top level, then the wheel thrown over: a
  // wheel lifts and the load slides off sideways.
  s.run(15, [&] { Controls k; k.accelerator = 1.0; k.steer_rad = c.d.steer_to_line(kLaneA); return k; },
        [&] { return s.v() >= 3.5 || s.pos().x() > 30; });
  s.run(5, [&] { Controls k; k.accelerator = 1.0; k.steer_rad = -1.5; return k; }, [&] { return s.count("load_dropped") > 0; });
  expect_automatic_failure(s, "load_dropped");
}

TEST(ExamCourse, TippingTheTruckOverFails) {
  Session s(load_scene(kCourse, FORKLIFT_DATA_DIR), Mode::kExam);
  CourseDriver c{s};
  load_high_in_the_open(c, 0.9);
  // Away fast with the load still at the top level, then a turn (unladen at this truck's top
  // speed, even the sharpest turn only lifts a wheel: this model's truck goes over laden).
  s.run(15, [&] { Controls k = c.d.levers(); k.accelerator = 1.0; k.steer_rad = c.d.steer_to_line(kLaneA); return k; },
        [&] { return s.v() >= 3.5 || s.pos().x() > 30; });
  s.run(5, [&] { Controls k = c.d.levers(); k.accelerator = 1.0; k.steer_rad = -0.6; return k; },
        [&] { return s.count("tip_over") > 0; });
  expect_automatic_failure(s, "tip_over");
}

TEST(ExamCourse, TheSameSeriousFaultAFourthTimeFails) {
  Session s(load_scene(kCourse, FORKLIFT_DATA_DIR), Mode::kExam);
  CourseDriver c{s};
  c.lift(kTravel);
  // Backing into the west wall four times, each hard enough to be serious (0.5 m/s or more) but
  // not violent (under 1 m/s): the fourth is an automatic failure.
  for (int i = 0; i < 4; ++i) {
    const int before = s.count("collision_structure");
    s.run(20, [&] { Controls k = c.d.levers(); c.d.speed(k, -0.8); k.steer_rad = c.d.steer_to_line(kLaneA, true); return k; },
          [&] { return s.count("collision_structure") > before; });
    c.d.approach([&] { return 4.0 - s.pos().x(); }, 0.6, kLaneA);
  }
  EXPECT_EQ(s.count("collision_structure"), 4) << s.summary();
  expect_automatic_failure(s, "repeated:collision_structure");
}

}  // namespace
