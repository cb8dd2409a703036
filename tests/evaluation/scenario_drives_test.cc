// A clean and a faulty drive of each shipped scenario that had no cab script: each driven here by
// a closed-loop driver through the session's own pipeline, checked, and written as the cab script
// data/evaluation/scripts/ ships (drives.json lists what each gives; ShippedDrive in
// session_run_test.cc drives the shipped files through a SessionRun as the worker does).
//
// FORKLIFT_EVAL_SCRIPT_DIR=data/evaluation/scripts build/tests/evaluation_test --gtest_filter='ScenarioDrive.*'
// rewrites the shipped scripts from these drives (after a change to the truck or the scenes).
#include "evaluation/forklift_sim.h"
#include "evaluation/harness.h"

namespace {

using namespace evt;

std::string write_drive(const Session& s, const std::string& name, const std::string& what) {
  return write_script(s, name, what, "tests/evaluation/scenario_drives_test.cc");
}

std::set<std::string> rules_of(const Session& s) {
  std::set<std::string> r;
  for (const EvaluationEvent& e : s.events) r.insert(e.rule);
  return r;
}

// The scenario's own route, from the truck's start, as a path to follow.
Path route_of(const Session& s) {
  std::vector<Vector2d> pts;
  for (const Vector2d& p : s.scene.route.points) pts.push_back(p);
  return Path(pts);
}

// --- slalom: five gates of cones, then the finish marker -------------------------------------

// Controls at a cab's 50 Hz, the forks raised to travelling height before the truck moves.
void set_off(Session& s, Driver& d) {
  s.control_period_ticks = 20;
  d.lift_to = 0.15;
  d.settle_levers();
}

TEST(ScenarioDrive, SlalomCleanWeavesThroughEveryGateAndStopsAtTheFinish) {
  Session s(load_scene(data("scenarios/slalom.json"), FORKLIFT_DATA_DIR), Mode::kExam);
  Driver d{s};
  set_off(s, d);
  ASSERT_TRUE(d.follow(route_of(s), 1.6, 0.9)) << s.summary();
  d.park_forks_down();
  const Score score = s.finish("task_complete");
  EXPECT_TRUE(s.events.empty()) << s.summary();
  EXPECT_TRUE(score.task_completed) << score.steps_done << " of " << score.steps_total;
  EXPECT_EQ(score.mark, 100);
  EXPECT_LT(s.t(), s.scene.time_limit_s);
  write_drive(s, "slalom_clean.csv", "slalom, exam: a clean drive through the five gates to the finish");
}

TEST(ScenarioDrive, SlalomFaultsKnockTheCones) {
  // Straight down the middle: each gate's inner cone stands on the line, so the truck passes every
  // gate at its edge and knocks its cone.
  Session s(load_scene(data("scenarios/slalom.json"), FORKLIFT_DATA_DIR), Mode::kTraining);
  Driver d{s};
  set_off(s, d);
  d.follow(Path({s.pos(), Vector2d(44.0, 15.0)}), 0.8, 0.8);  // slowly: a touch, not a blow
  d.park_forks_down();
  s.finish("task_complete");
  EXPECT_EQ(rules_of(s), (std::set<std::string>{"collision_cone"})) << s.summary();
  EXPECT_EQ(s.count("collision_cone"), 5) << s.summary();
  write_drive(s, "slalom_faults.csv", "slalom: a drive straight down the line that knocks a cone at every gate");
}

// --- first_drive: the first lesson's controls one by one, then a pallet picked ----------------

struct LessonDriver {
  Session& s;
  Driver d{s};
  int done() const { return s.state.evaluation.steps_done(); }
  // Runs `control` until the lesson's step in hand is done.
  bool until_next_step(const std::function<Controls()>& control, double max_s = 30) {
    const int at = done();
    return s.run(max_s, control, [&] { return done() > at; });
  }
  Controls braked() const {
    Controls c = d.levers();
    d.speed(c, 0);
    c.steer_rad = s.c.steer_rad;
    return c;
  }
  Controls rolling(double v) const {
    Controls c = d.levers();
    d.speed(c, v);
    c.steer_rad = 0;
    return c;
  }
  Controls wheel_at(double rad) const {
    Controls c = braked();
    c.steer_rad = d.smooth(rad);
    return c;
  }
  // The pallet ahead on the line y = `lane`, its near face at x = `face`: forks at its openings,
  // in until the heel is 2 cm short of it, then lifted clear.
  void take(double face, double lane, double fork_length) {
    const auto tips = [&] { return d.heel_x() + fork_length; };
    const double heel_at_no_lift = s.heel_z() - s.q()[kS];
    d.lift_to = 0.15;  // travelling: a hand's width
    d.settle_levers();
    d.approach([&] { return (face - 0.4) - tips(); }, 0.8, lane);
    d.lift_to = heel_at_no_lift + 0.042;  // 4 cm of lift: the forks mid-opening of a floor pallet
    d.settle_levers();
    d.approach([&] { return (face - 0.02) - d.heel_x(); }, 0.3, lane);
    d.lift_to = heel_at_no_lift + 0.15;
    d.settle_levers();
  }
  // The pallet set down where it was and the forks drawn out of it, as a lesson ends.
  void put_back(double face, double lane, double fork_length) {
    const auto on_forks = [&] {
      for (const PalletState& p : s.state.handling.pallets()) if (p.on_forks) return true;
      return false;
    };
    s.run(15, [&] { Controls c = braked(); c.lift = -0.25; c.tilt = 0; return c; }, [&] { return !on_forks(); });
    d.lift_to = s.heel_z() - 0.02;
    d.settle_levers();
    d.approach([&] { return d.heel_x() + fork_length - (face - 0.3); }, -0.3, lane);
  }
};

TEST(ScenarioDrive, FirstDriveCleanDoesEachControlInTurnAndTakesThePallet) {
  Session s(load_scene(data("scenarios/first_drive.json"), FORKLIFT_DATA_DIR), Mode::kTraining);
  s.control_period_ticks = 20;
  LessonDriver l{s};
  const double deg = M_PI / 180;
  ASSERT_TRUE(l.until_next_step([&] { return l.rolling(0.6); })) << "forward";
  ASSERT_TRUE(l.until_next_step([&] { return l.braked(); })) << "stop";
  ASSERT_TRUE(l.until_next_step([&] { return l.rolling(-0.4); })) << "reverse";
  ASSERT_TRUE(l.until_next_step([&] { return l.braked(); })) << "stop again";
  ASSERT_TRUE(l.until_next_step([&] { return l.wheel_at(-22 * deg); })) << "steer left";
  ASSERT_TRUE(l.until_next_step([&] { return l.wheel_at(22 * deg); })) << "steer right";
  ASSERT_TRUE(l.until_next_step([&] { return l.wheel_at(0); })) << "straight";
  l.d.lift_to = 0.42;  // the heel stands above the floor with the lift at 0: 30 cm of lift
  ASSERT_TRUE(l.until_next_step([&] { return l.braked(); })) << "lift";
  l.d.lift_to = 0.0;
  ASSERT_TRUE(l.until_next_step([&] { return l.braked(); })) << "lower";
  l.d.tilt_to_deg = -3.3;
  ASSERT_TRUE(l.until_next_step([&] { return l.braked(); })) << "tilt back";
  l.d.tilt_to_deg = 0;
  ASSERT_TRUE(l.until_next_step([&] { return l.braked(); })) << "tilt level";
  l.take(16.0 - 0.6, 20.0, s.shape.fork_length_m);
  EXPECT_TRUE(s.task_completed()) << l.done() << " steps done\n" << s.summary();
  l.put_back(16.0 - 0.6, 20.0, s.shape.fork_length_m);
  l.d.park_forks_down();
  const Score score = s.finish("task_complete");
  EXPECT_TRUE(s.events.empty()) << s.summary();
  EXPECT_TRUE(score.task_completed);
  EXPECT_EQ(score.mark, 100);
  write_drive(s, "first_drive_clean.csv", "first_drive, training: each control in its turn, then pallet LP1 taken");
}

TEST(ScenarioDrive, FirstDriveFaultsRushAtThePalletWithTheForksOnTheFloor) {
  // The pupil does the first four steps, then skips the wheel, the forks and the mast and drives
  // at the pallet with the forks on the floor, into its bottom boards.
  Session s(load_scene(data("scenarios/first_drive.json"), FORKLIFT_DATA_DIR), Mode::kTraining);
  s.control_period_ticks = 20;
  LessonDriver l{s};
  ASSERT_TRUE(l.until_next_step([&] { return l.rolling(0.6); }));
  ASSERT_TRUE(l.until_next_step([&] { return l.braked(); }));
  ASSERT_TRUE(l.until_next_step([&] { return l.rolling(-0.4); }));
  ASSERT_TRUE(l.until_next_step([&] { return l.braked(); }));
  l.d.lift_to = 0.0;
  const auto struck = [&] { return s.count("fork_strike_pallet") + s.count("collision_pallet") + s.count("violent_collision") > 0; };
  s.run(40, [&] { return l.rolling(0.8); }, struck);
  l.d.stop();
  s.finish("duration");
  EXPECT_EQ(rules_of(s), (std::set<std::string>{"travel_forks_low", "fork_strike_pallet", "task_incomplete"})) << s.summary();
  write_drive(s, "first_drive_faults.csv", "first_drive: the lesson's steps skipped, the forks driven on the floor into the pallet");
}

}  // namespace
