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

// --- rack_pick: a pallet from a rack's second level to the dock -------------------------------

// Moves at right angles to an aisle, as a three-wheel truck does them: the front axle's middle
// held on a line through `at` along heading `heading_rad`, or the truck turned on the spot about
// its front axle with the rear wheel at full lock (88 deg on this truck).
struct AisleDriver {
  Session& s;
  Driver d{s};
  Vector2d front() const { return s.poses().chassis.translation().head<2>(); }
  // Steer holding the front axle's middle on the line (forward or backing along it); backing out
  // of a pallet (no line: `at` not finite) the wheel stays straight.
  double steer_on_line(const Vector2d& at, double heading, bool reverse) const {
    if (!at.allFinite()) return d.smooth(0);
    const Vector2d across(-std::sin(heading), std::cos(heading));
    const double off = across.dot(at - front());
    const double want = heading + std::clamp((reverse ? -0.6 : 0.6) * off, -0.3, 0.3);
    return d.smooth(std::clamp((reverse ? 2.0 : -2.0) * wrap(want - s.yaw()), -0.4, 0.4));
  }
  // Along the line until `remaining()` (m) is spent, slowing into it, then stopped.
  void along(const Vector2d& at, double heading, double v, const std::function<double()>& remaining, double max_s = 60) {
    const bool rev = v < 0;
    s.run(max_s,
          [&] {
            Controls c = d.levers();
            d.speed(c, (rev ? -1 : 1) * std::clamp(0.8 * std::max(0.0, remaining()) + 0.03, 0.0, std::abs(v)));
            c.steer_rad = steer_on_line(at, heading, rev);
            return c;
          },
          [&] { return remaining() <= 0.002; });
    d.stop();
  }
  // The wheel to `steer` with the truck braked.
  void wheel_to(double steer) {
    s.run(10,
          [&] { Controls c = d.levers(); d.speed(c, 0); c.steer_rad = d.smooth(steer); return c; },
          [&] { return std::abs(s.q()[kAwr3] - steer) < 0.01; });
  }
  // Turns on the spot to `heading` (left: counter-clockwise) at full lock, creeping forward and
  // back on the accelerator to hold a yaw rate that falls to nothing at the heading.
  void turn_on_spot(double heading) {
    const bool left = wrap(heading - s.yaw()) > 0;
    const double lock = (left ? -1 : 1) * (s.truck.steer.max_rad - 0.01);
    wheel_to(lock);
    const double ccw_forward = left ? 1 : -1;  // forward at this lock turns the truck this way
    s.run(40,
          [&] {
            Controls c = d.levers();
            c.steer_rad = lock;
            const double err = wrap(heading - s.yaw()), rate = s.x()[StateIndex::kQdot + kAwc];
            const double want = std::clamp(1.2 * err, -0.3, 0.3);
            c.accelerator = std::clamp(ccw_forward * (0.05 * (err > 0 ? 1 : -1) + 1.5 * (want - rate)), -0.25, 0.25);
            return c;
          },
          [&] { return std::abs(wrap(heading - s.yaw())) < 0.003 && std::abs(s.x()[StateIndex::kQdot + kAwc]) < 0.003; });
    d.stop();
    wheel_to(0);
  }
  void lift(double heel_z) {
    d.lift_to = heel_z;
    d.settle_levers();
  }
};

// Where the front axle's middle must stop, heading `heading_rad`, so that a turn on the spot to
// the side puts it at `after`: the turn is about a point 4.4 cm beside it (the 88 deg lock), which
// moves the middle that much along the heading and to the side.
Vector2d before_turn(const Session& s, const Vector2d& after, double heading_rad, bool left) {
  const double shift = s.truck.wheelbase_m() / std::tan(s.truck.steer.max_rad);
  const Vector2d ahead(std::cos(heading_rad), std::sin(heading_rad)), side = (left ? 1 : -1) * Vector2d(-ahead.y(), ahead.x());
  return after - shift * (ahead + side);
}

// P3 from R2 level 2 across aisle A, carried at `travel_heel_m` by the marked route to the dock of
// bay 1 and set down there, the forks drawn out and lowered.
void rack_pick(Session& s, double travel_heel_m) {
  s.control_period_ticks = 20;
  AisleDriver a{s};
  const double east = 0, north = M_PI / 2;
  const Vector2d pick(16.7, 26.3);  // the front axle's middle, facing P3's openings across aisle A
  const Vector2d at = before_turn(s, pick, east, true);
  const Vector2d no_line(NAN, NAN);
  a.lift(0.15);
  a.along(Vector2d(0, at.y()), east, 1.2, [&] { return at.x() - a.front().x(); });
  a.turn_on_spot(north);
  const double face = 28.45 - 0.6;  // P3's near face
  a.lift(1.8 + 0.092);               // level 2's beam, the forks mid-opening
  a.along(Vector2d(pick.x(), 0), north, 0.3, [&] { return (face - 0.02) - (a.front().y() + 0.40); });
  a.lift(1.8 + 0.092 + 0.08);        // picked up, clear of the beam
  a.along(no_line, north, -0.3, [&] { return a.front().y() - 26.2; });
  a.lift(travel_heel_m);
  a.turn_on_spot(east);
  // P3's centre 1 m ahead of the front axle: at D1's middle, (41.7, 5.0).
  a.d.follow(Path({a.front(), {24.5, 26.2}, {24.5, 5.0}, {40.7, 5.0}}), 1.6, 0.6, 0.7);
  a.lift(0.15);
  s.run(15, [&] { Controls c = a.d.levers(); a.d.speed(c, 0); c.lift = -0.25; return c; },
        [&] { return !s.pallet("P3")->on_forks; });
  a.lift(s.heel_z() - 0.03);
  a.along(no_line, east, -0.4, [&] { return a.front().x() - 38.7; });
  a.d.park_forks_down();
}

TEST(ScenarioDrive, RackPickCleanTakesP3FromTheRackToTheDock) {
  Session s(load_scene(data("scenarios/rack_pick.json"), FORKLIFT_DATA_DIR), Mode::kExam);
  rack_pick(s, 0.15);
  const Score score = s.finish("task_complete");
  EXPECT_TRUE(s.events.empty()) << s.summary();
  EXPECT_TRUE(score.task_completed) << score.steps_done << " of " << score.steps_total;
  EXPECT_EQ(score.mark, 100);
  EXPECT_LT(s.t(), s.scene.time_limit_s);
  write_drive(s, "rack_pick_clean.csv", "rack_pick, exam: P3 from R2 level 2 to the dock of bay 1, no fault");
}

TEST(ScenarioDrive, RackPickFaultsCarryTheLoadHigh) {
  // The same drive with P3 carried at 1.2 m, where it is picked, not at a hand's width.
  Session s(load_scene(data("scenarios/rack_pick.json"), FORKLIFT_DATA_DIR), Mode::kTraining);
  rack_pick(s, 1.2);
  const Score score = s.finish("task_complete");
  EXPECT_TRUE(score.task_completed);
  // High, and the braking for the corners and the dock harsh for a load up there.
  EXPECT_EQ(rules_of(s), (std::set<std::string>{"travel_forks_high", "harsh_braking_load_raised"})) << s.summary();
  write_drive(s, "rack_pick_faults.csv", "rack_pick: P3 carried to the dock with the forks at 1.2 m");
}

// --- practical_exam: the slalom's gates, P2 from R1 level 2 to R3 level 3, parked -------------

void practical_exam(Session& s) {
  s.control_period_ticks = 20;
  AisleDriver a{s};
  const double east = 0, north = M_PI / 2, west = M_PI;
  const Vector2d no_line(NAN, NAN);
  const double aisle_y = 26.3;  // the front axle's middle in aisle A, facing across it
  const double laden_y = 26.2;  // turning with a pallet, whose far corner sweeps 1.65 m out
  a.lift(0.15);
  // The gates, the east corridor and aisle A westwards, stopped to turn north facing P2 (x = 14.0).
  const Vector2d at_p2 = before_turn(s, {14.0, aisle_y}, west, false);
  a.d.follow(Path({a.front(), {8.0, 4.2}, {13.0, 6.8}, {18.0, 4.2}, {23.0, 6.8}, {25.0, 8.5}, {25.0, aisle_y}, at_p2}), 1.4, 0.6, 0.7);
  a.along(Vector2d(0, aisle_y), west, 0.3, [&] { return a.front().x() - at_p2.x(); });
  a.turn_on_spot(north);
  // P2 from level 2.
  const double face = 28.45 - 0.6;
  a.lift(1.8 + 0.092);
  a.along(Vector2d(a.front().x(), 0), north, 0.3, [&] { return (face - 0.02) - (a.front().y() + 0.40); });
  a.lift(1.8 + 0.092 + 0.08);
  a.along(no_line, north, -0.3, [&] { return a.front().y() - laden_y; });
  a.lift(0.15);
  a.turn_on_spot(east);
  // To R3's right-hand place (19.4), turned to face it, P2 set on level 3 with its centre at y = 28.45.
  const Vector2d at_r3 = before_turn(s, {19.4, laden_y}, east, true);
  a.along(Vector2d(0, laden_y), east, 0.8, [&] { return at_r3.x() - a.front().x(); });
  a.turn_on_spot(north);
  a.lift(2.7 + 0.122 + 0.08);  // the pallet's underside 8 cm over the beam
  a.along(Vector2d(a.front().x(), 0), north, 0.3, [&] { return (28.45 - 1.0) - a.front().y(); });
  s.run(15, [&] { Controls c = a.d.levers(); a.d.speed(c, 0); c.lift = -0.25; return c; },
        [&] { return !s.pallet("P2")->on_forks; });
  a.lift(s.heel_z() - 0.05);
  a.along(no_line, north, -0.3, [&] { return a.front().y() - aisle_y; });
  a.lift(0.15);
  a.turn_on_spot(west);
  // Parked west of aisle B, forks lowered: the truck's reference point (q's x, y, 0.8 m behind the
  // front axle) on the marker, so the path runs on past it.
  a.d.follow(Path({a.front(), {9.5, aisle_y}, {9.5, 20.25 - 1.15}}), 1.2, 0.5, 0.7);
  a.d.park_forks_down();
}

TEST(ScenarioDrive, PracticalExamCleanPassesWithNoEvent) {
  Session s(load_scene(data("scenarios/practical_exam.json"), FORKLIFT_DATA_DIR), Mode::kExam);
  practical_exam(s);
  const Score score = s.finish("task_complete");
  EXPECT_TRUE(s.events.empty()) << s.summary();
  EXPECT_TRUE(score.task_completed) << score.steps_done << " of " << score.steps_total;
  EXPECT_EQ(score.mark, 100);
  EXPECT_LT(s.t(), s.scene.time_limit_s);
  std::cout << "practical exam: " << s.t() << " s\n";
  write_drive(s, "practical_exam_clean.csv", "practical_exam, exam: gates, P2 from R1 level 2 to R3 level 3, parked; no fault");
}

TEST(ScenarioDrive, PracticalExamFaultsCutThroughTheGates) {
  // Straight along y = 5 instead of weaving: the gates' cones on the line are knocked, gates 2 and
  // 4 missed, the route left; the pupil stops at the corridor and goes no further.
  Session s(load_scene(data("scenarios/practical_exam.json"), FORKLIFT_DATA_DIR), Mode::kExam);
  Driver d{s};
  set_off(s, d);
  d.follow(Path({s.poses().chassis.translation().head<2>(), {8.0, 5.0}, {24.0, 5.0}}), 1.0, 0.8);
  d.park_forks_down();
  const Score score = s.finish("duration");
  EXPECT_FALSE(score.passed);
  EXPECT_EQ(rules_of(s), (std::set<std::string>{"collision_cone", "off_route", "task_incomplete"})) << s.summary();
  write_drive(s, "practical_exam_faults.csv", "practical_exam: straight through the slalom's gates, knocking cones, then stopped");
}

// --- load_lorry: two floor pallets onto the lorry's bed at dock bay 1 ---------------------------

// Takes the floor pallet whose openings face south at (x, 15.5) from the line x, carries it back
// down to y = 5 and along it onto the lorry's bed, and sets it down with its centre at `set_x`;
// backs off the bed to x = 44, forks at a hand's width.
void pallet_onto_lorry(Session& s, AisleDriver& a, const std::string& id, double x, double set_x) {
  const double north = M_PI / 2, east = 0;
  const Vector2d no_line(NAN, NAN);
  const double heel_at_no_lift = s.heel_z() - s.q()[kS];
  const double face = 15.5 - 0.6;
  a.along(Vector2d(x, 0), north, 1.2, [&] { return (face - 0.4) - (a.front().y() + 1.40); });
  a.lift(heel_at_no_lift + 0.042);  // mid-opening of a floor pallet
  a.along(Vector2d(x, 0), north, 0.3, [&] { return (face - 0.02) - (a.front().y() + 0.40); });
  a.lift(heel_at_no_lift + 0.15);
  const Vector2d turn_at = before_turn(s, {x, 5.0}, north, false);
  a.along(Vector2d(x, 0), north, -0.8, [&] { return a.front().y() - turn_at.y(); });
  a.turn_on_spot(east);
  // The pallet's centre 1 m ahead of the front axle.
  a.along(Vector2d(0, 5.0), east, 0.9, [&] { return (set_x - 1.0) - a.front().x(); });
  s.run(15, [&] { Controls c = a.d.levers(); a.d.speed(c, 0); c.lift = -0.25; return c; },
        [&] { return !s.pallet(id)->on_forks; });
  a.lift(s.heel_z() - 0.03);
  a.along(no_line, east, -0.6, [&] { return a.front().x() - 44.0; });
  a.lift(heel_at_no_lift + 0.15);
}

// Both pallets to their places on the bed; `p11_x`: where P11's centre is set (55.8 its place),
// and with `p12` false the pupil stops after P11.
void load_lorry(Session& s, double p11_x = 55.8, bool p12 = true) {
  s.control_period_ticks = 20;
  AisleDriver a{s};
  const double east = 0, north = M_PI / 2;
  a.lift(0.15);
  // Along y = 11 to below P11, turned to face it.
  const Vector2d at_p11 = before_turn(s, {36.0, 11.0}, east, true);
  a.along(Vector2d(0, 11.0), east, 1.0, [&] { return at_p11.x() - a.front().x(); });
  a.turn_on_spot(north);
  pallet_onto_lorry(s, a, "P11", 36.0, p11_x);
  if (!p12) {
    a.d.park_forks_down();
    return;
  }
  // Back along y = 5 to below P12, turned north to face it.
  const Vector2d at_p12 = before_turn(s, {37.5, 5.0}, M_PI, false);
  a.along(Vector2d(0, 5.0), east, -1.0, [&] { return a.front().x() - at_p12.x(); });
  a.turn_on_spot(north);
  pallet_onto_lorry(s, a, "P12", 37.5, 54.4);
  a.d.park_forks_down();
}

TEST(ScenarioDrive, LoadLorryCleanPutsBothPalletsOnTheBed) {
  Session s(load_scene(data("scenarios/load_lorry.json"), FORKLIFT_DATA_DIR), Mode::kExam);
  load_lorry(s);
  const Score score = s.finish("task_complete");
  EXPECT_TRUE(s.events.empty()) << s.summary();
  EXPECT_TRUE(score.task_completed) << score.steps_done << " of " << score.steps_total;
  EXPECT_EQ(score.mark, 100);
  EXPECT_LT(s.t(), s.scene.time_limit_s);
  std::cout << "load lorry: " << s.t() << " s\n";
  write_drive(s, "load_lorry_clean.csv", "load_lorry, exam: P11 and P12 onto the lorry's bed, no fault");
}

TEST(ScenarioDrive, LoadLorryFaultsSetTheFirstPalletShortAndStop) {
  // P11 set down 0.8 m short of the front of the body, and P12 left on the dock floor.
  Session s(load_scene(data("scenarios/load_lorry.json"), FORKLIFT_DATA_DIR), Mode::kTraining);
  load_lorry(s, 55.0, false);
  s.finish("duration");
  EXPECT_EQ(rules_of(s), (std::set<std::string>{"set_down_off_place", "task_incomplete"})) << s.summary();
  write_drive(s, "load_lorry_faults.csv", "load_lorry: P11 set down short of its place, P12 left behind");
}

}  // namespace
