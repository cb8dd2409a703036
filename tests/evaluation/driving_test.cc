// The rules on the truck's own state, each committed by one scripted run and not by another,
// on tests/evaluation/scenes/zones.json: a straight route along y = 0 with a 2.8 m/s yard, a
// 1.4 m/s walkway across it at x = 60 and a 1.4 m/s corner zone at x = 90.
#include <cstring>

#include "evaluation/harness.h"
#include "forklift/dynamics/manoeuvre.h"  // lift_for_load_height

namespace {

using namespace evt;

// The zones scene with a 1 m box load at the rated load centre, its CoG `cog_height_m` up.
Scene laden(double mass_kg, double cog_height_m) {
  Scene sc = scene("zones.json");
  const TruckParams t = load_truck(sc.scenario.truck_file);
  sc.scenario.load = box_load(mass_kg, 1.0, 1.0, 1.0, t.rated_load_centre_m, 0);
  sc.scenario.lift_m = std::clamp(lift_for_load_height(t, *sc.scenario.load, cog_height_m), 0.0, t.limits.lift_max_m);
  return sc;
}

// A driver holding the forks where the scenario put them, the mast tilted `tilt_deg` (+ forward),
// the levers settled there.
Driver holding_the_load(Session& s, double tilt_deg) {
  Driver d{s};
  d.lift_to = s.heel_z();
  d.tilt_to_deg = tilt_deg;
  d.settle_levers();
  return d;
}

// Straight along y = 0 at `v` until x passes `x_end`, then stops. Forks held by the driver.
// Along y = 0 at `v` until x reaches `x_end`; a drive that never gets there fails the test.
void straight(Session& s, Driver& d, double v, double x_end, double max_s = 120) {
  const bool reached = s.run(max_s, [&] { Controls c = d.levers(); d.speed(c, v); c.steer_rad = d.steer_to_line(0.0); return c; },
                             [&] { return s.pos().x() >= x_end; });
  EXPECT_TRUE(reached) << "the truck stopped at x = " << s.pos().x() << " short of " << x_end << " m";
}

// --- speed above the zone's limit ---

TEST(Speed, OpenYardAboveItsLimitIsOneEventPerOccurrence) {
  Session s(scene("zones.json"));
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  straight(s, d, 3.4, 30);  // one long excursion over 2.8 m/s
  straight(s, d, 2.0, 40);  // back under the limit for well over clear_time_s
  straight(s, d, 3.4, 54);  // a second one
  d.stop();
  ASSERT_EQ(s.count("speed_open_aisle"), 2) << s.summary();
  EXPECT_EQ(s.events.size(), 2u) << s.summary();
  const EvaluationEvent& e = *s.first("speed_open_aisle");
  EXPECT_EQ(e.worry_level, 3);
  EXPECT_EQ(e.points, 3);
  EXPECT_NE(e.details.find("\"zone\":\"Z_yard\""), std::string::npos) << e.details;
  EXPECT_NE(e.details.find("1910.178(n)(1)"), std::string::npos) << "the event names its source: " << e.details;
}

TEST(Speed, OpenYardJustUnderItsLimitIsClean) {
  Session s(scene("zones.json"));
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  straight(s, d, 2.55, 54);
  d.stop();
  EXPECT_TRUE(s.events.empty()) << s.summary();
}

TEST(Speed, TooFastNearAWalkway) {
  Session s(scene("zones.json"), Mode::kTraining, Vector3d(45, 0, 0));
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  straight(s, d, 2.0, 66);  // 2.0 m/s: legal in the yard, not on the 1.4 m/s walkway at x = 60..61.5
  d.stop();
  ASSERT_EQ(s.count("speed_near_walkway"), 1) << s.summary();
  const EvaluationEvent& e = *s.first("speed_near_walkway");
  EXPECT_EQ(e.worry_level, 5);
  // Before the walkway itself: its limit holds from near_distance_m (1 m) out, plus min_duration_s.
  EXPECT_GT(e.x_m, 59.0 - 1e-9);
  EXPECT_LT(e.x_m, 61.5);
  EXPECT_EQ(s.events.size(), 1u) << s.summary();
}

TEST(Speed, SlowingForTheWalkwayIsClean) {
  Session s(scene("zones.json"), Mode::kTraining, Vector3d(45, 0, 0));
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  straight(s, d, 2.0, 54);
  straight(s, d, 1.0, 66);
  d.stop();
  EXPECT_TRUE(s.events.empty()) << s.summary();
}

TEST(Speed, TooFastThroughACorner) {
  Session s(scene("zones.json"), Mode::kTraining, Vector3d(75, 0, 0));
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  straight(s, d, 2.0, 97);
  d.stop();
  ASSERT_EQ(s.count("speed_corner"), 1) << s.summary();
  EXPECT_EQ(s.events.size(), 1u) << s.summary();
  EXPECT_NE(s.first("speed_corner")->details.find("Z_corner"), std::string::npos);
}

TEST(Speed, SlowThroughACornerIsClean) {
  Session s(scene("zones.json"), Mode::kTraining, Vector3d(75, 0, 0));
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  straight(s, d, 2.0, 85);
  straight(s, d, 1.0, 97);
  d.stop();
  EXPECT_TRUE(s.events.empty()) << s.summary();
}

// --- forks and mast while travelling ---

TEST(Forks, TravellingWithTheForksRaised) {
  Session s(scene("zones.json"));
  Driver d{s};
  d.lift_to = 0.6;
  d.settle_levers();
  straight(s, d, 1.0, 15);
  d.stop();
  EXPECT_EQ(s.count("travel_forks_high"), 1) << s.summary();
  EXPECT_EQ(s.events.size(), 1u) << s.summary();
}

TEST(Forks, CreepingWithTheForksRaisedOrTravellingWithThemLowIsClean) {
  Session s(scene("zones.json"));
  Driver d{s};
  d.lift_to = 0.6;
  d.settle_levers();
  straight(s, d, 0.3, 8);  // positioning at a stack: under travel_speed_min_m_s
  d.stop();
  d.lift_to = 0.2;
  d.settle_levers();
  straight(s, d, 1.5, 25);
  d.stop();
  EXPECT_TRUE(s.events.empty()) << s.summary();
}

TEST(Forks, TravellingWithTheForksOnTheFloor) {
  Session s(scene("zones.json"));
  Driver d{s};
  d.lift_to = 0.0;  // fully lowered: the forks' underside a few millimetres off the floor
  straight(s, d, 1.0, 15);
  d.stop();
  ASSERT_EQ(s.count("travel_forks_low"), 1) << s.summary();
  EXPECT_EQ(s.first("travel_forks_low")->worry_level, 1);
  EXPECT_EQ(s.events.size(), 1u) << s.summary();
}

TEST(Mast, TravellingLadenWithTheMastTiltedForward) {
  Session s(laden(500, 0.6));
  Driver d = holding_the_load(s, 3);
  straight(s, d, 1.0, 15);
  d.stop();
  EXPECT_EQ(s.count("travel_tilted_forward_laden"), 1) << s.summary();
  EXPECT_EQ(s.count("travel_forks_high"), 0) << s.summary();
}

TEST(Mast, TravellingLadenTiltedBackOrUnladenTiltedForwardIsClean) {
  {
    Session s(laden(500, 0.6));
    Driver d = holding_the_load(s, -3);
    straight(s, d, 1.0, 15);
    d.stop();
    EXPECT_TRUE(s.events.empty()) << s.summary();
  }
  {
    Session s(scene("zones.json"));
    Driver d{s};
    d.lift_to = 0.2;
    d.tilt_to_deg = 3;
    d.settle_levers();
    straight(s, d, 1.0, 15);
    d.stop();
    EXPECT_TRUE(s.events.empty()) << s.summary();
  }
}

// --- turning and braking ---

// Holds `v` along y = 0, then holds the steer at `steer` for `turn_s`.
void turn(Session& s, Driver& d, double v, double steer, double turn_s) {
  straight(s, d, v, 30);
  s.run(turn_s, [&] { Controls c = d.levers(); d.speed(c, v); c.steer_rad = steer; return c; });
  d.stop();
}

TEST(Turning, TurningAtSpeed) {
  Session s(scene("zones.json"));
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  turn(s, d, 2.2, 0.3, 2.0);
  EXPECT_EQ(s.count("turn_at_speed"), 1) << s.summary();
}

TEST(Turning, TurningSlowlyIsClean) {
  Session s(scene("zones.json"));
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  turn(s, d, 0.6, 0.5, 3.0);
  EXPECT_EQ(s.count("turn_at_speed"), 0) << s.summary();
  EXPECT_EQ(s.count("turn_at_speed_load_raised"), 0) << s.summary();
}

TEST(Turning, TurningWithTheLoadRaised) {
  Session s(laden(800, 2.0));
  Driver d{s};
  d.lift_to = s.heel_z();
  straight(s, d, 1.6, 20);
  s.run(3.0, [&] { Controls c = d.levers(); d.speed(c, 1.6); c.steer_rad = 0.3; return c; });
  d.stop();
  ASSERT_EQ(s.count("turn_at_speed_load_raised"), 1) << s.summary();
  EXPECT_EQ(s.first("turn_at_speed_load_raised")->worry_level, 5);
}

TEST(Turning, TheSameTurnWithTheLoadLowIsClean) {
  Session s(laden(800, 0.6));
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  straight(s, d, 1.6, 20);
  s.run(3.0, [&] { Controls c = d.levers(); d.speed(c, 1.6); c.steer_rad = 0.3; return c; });
  d.stop();
  for (const char* rule : {"turn_at_speed_load_raised", "turn_at_speed", "wheel_lift", "stability_warning"})
    EXPECT_EQ(s.count(rule), 0) << rule << "\n" << s.summary();  // (it does leave the route)
}

// From `v` along y = 0, the brake pedal at `brake` until stopped (forks held).
void brake_from(Session& s, Driver& d, double v, double brake) {
  straight(s, d, v, 25);
  s.run(8.0, [&] { Controls c = d.levers(); c.brake = brake; return c; }, [&] { return std::abs(s.v()) < 0.01; });
  s.run(1.0, [&] { Controls c = d.levers(); c.brake = brake; return c; });
}

// The load's slide is the truck model's friction contact, for a scenario's load as for a pallet:
// full brake from 2.7 m/s with 600 kg carried low and the mast 6 deg forward slides it (0.25 g of braking
// beats 0.35 of static friction on a fork sloping 6 deg down), and it stops short of the tips.
TEST(Braking, HardWithTheMastTiltedForwardSlidesTheLoad) {
  for (const double tilt_deg : {6.0, -5.0}) {
    SCOPED_TRACE("mast at " + std::to_string(tilt_deg) + " deg");
    Session s(laden(600, 0.75));  // the forks 0.25 m up: tilted forward, their tips clear the floor
    Driver d = holding_the_load(s, tilt_deg);
    brake_from(s, d, 2.7, 1.0);
    EXPECT_EQ(s.count("load_slid"), tilt_deg > 0 ? 1 : 0) << s.summary();
    EXPECT_EQ(s.count("load_dropped"), 0) << s.summary();
  }
}

// The load's slide is part of the session's state: a copy taken mid-slide, stepped in a fresh
// workspace and in the live one, gives the same state to the bit, and the live slide to within the
// integrator's tolerance (a rewind restarts CVODE's history, nothing else).
TEST(Braking, ASlidingLoadIsPartOfARewindPoint) {
  Session s(laden(600, 0.75));
  Driver d = holding_the_load(s, 6);
  straight(s, d, 2.7, 25);
  const LoadOnForks& on = s.state.load_on_forks;
  ASSERT_TRUE(s.run(3.0, [&] { Controls c = d.levers(); c.brake = 1.0; return c; },
                    [&] { return on.phase == LoadPhase::kSliding && on.slide_m > 0.05; }));
  const SessionState rewind = s.state;
  const SessionInputs held{s.u, false};
  std::vector<SessionEvent> found;
  for (int i = 0; i < 400; ++i) step(s.model, s.state, *s.ws, held, found);  // the live session goes on
  SessionState a = rewind, b = rewind;
  SessionWorkspace fresh(s.model);
  for (int i = 0; i < 400; ++i) {
    step(s.model, a, fresh, held, found);
    step(s.model, b, *s.ws, held, found);
  }
  EXPECT_EQ(std::memcmp(a.x.data(), b.x.data(), sizeof(double) * a.x.size()), 0);
  EXPECT_EQ(a.load_on_forks.slide_m, b.load_on_forks.slide_m);
  EXPECT_EQ(a.load_on_forks.phase, b.load_on_forks.phase);
  EXPECT_GT(a.load_on_forks.slide_m, rewind.load_on_forks.slide_m + 0.05) << "it slid on";
  EXPECT_NEAR(a.load_on_forks.slide_m, s.state.load_on_forks.slide_m, 0.005);
}

TEST(Braking, HardWithTheLoadRaisedLiftsTheRearWheelAfterAWarning) {
  Session s(laden(1300, 2.0));
  Driver d{s};
  d.lift_to = s.heel_z();
  brake_from(s, d, 2.0, 1.0);
  ASSERT_EQ(s.count("harsh_braking_load_raised"), 1) << s.summary();
  ASSERT_EQ(s.count("wheel_lift"), 1) << s.summary();
  ASSERT_EQ(s.count("stability_warning"), 1) << s.summary();
  EXPECT_NE(s.first("wheel_lift")->details.find("\"wheel\":\"rear\""), std::string::npos) << s.first("wheel_lift")->details;
  EXPECT_LE(s.first("stability_warning")->t_s, s.first("wheel_lift")->t_s) << "the margin warns before the wheel lifts";
  EXPECT_EQ(s.first("stability_warning")->points, 0);
  EXPECT_NE(s.first("stability_warning")->details.find("front axle"), std::string::npos);
  EXPECT_EQ(s.count("tip_over"), 0) << s.summary();
}

TEST(Braking, GentleWithTheLoadRaisedIsClean) {
  Session s(laden(1000, 2.0));
  Driver d{s};
  d.lift_to = s.heel_z();
  brake_from(s, d, 2.0, 0.1);
  EXPECT_EQ(s.count("harsh_braking_load_raised"), 0) << s.summary();
  EXPECT_EQ(s.count("wheel_lift"), 0) << s.summary();
  EXPECT_EQ(s.count("stability_warning"), 0) << s.summary();
  EXPECT_GT(s.finish("signal").min_stability_fraction, 0.2);
}

TEST(Stability, TipOverIsAnAutomaticFailureAndIsWarnedOfFirst) {
  Session s(laden(1600, 3.0), Mode::kExam);
  Driver d{s};
  d.lift_to = s.heel_z();
  brake_from(s, d, 2.5, 1.0);
  ASSERT_EQ(s.count("tip_over"), 1) << s.summary();
  ASSERT_GE(s.count("stability_warning"), 1);
  ASSERT_GE(s.count("wheel_lift"), 1);
  const double tip = s.first("tip_over")->t_s;
  EXPECT_LT(s.first("stability_warning")->t_s, tip);
  EXPECT_LT(s.first("wheel_lift")->t_s, tip);
  EXPECT_EQ(s.events.back().rule, "tip_over") << "nothing is marked after the truck went over:\n" << s.summary();
  const Score sc = s.finish("signal");
  EXPECT_FALSE(sc.passed);
  EXPECT_NE(std::find(sc.automatic_failures.begin(), sc.automatic_failures.end(), "tip_over"), sc.automatic_failures.end());
  EXPECT_LT(sc.min_stability_fraction, 0);
}

TEST(Stability, TheMarginIsLiveEveryTick) {
  Session s(laden(1600, 2.0));
  Driver d{s};
  d.lift_to = s.heel_z();
  s.tick();
  const Stability at_rest = s.stability();
  EXPECT_EQ(at_rest.edge, 0) << "a heavy load leaves the front axle the nearest edge";
  EXPECT_GT(at_rest.fraction, 0.2);
  EXPECT_LT(at_rest.fraction, 0.7);
  straight(s, d, 0.45, 8);  // creeping: the load may be high
  double lowest = 1;
  s.run(8.0, [&] { Controls c = d.levers(); c.brake = 0.1; return c; },
        [&] { lowest = std::min(lowest, s.stability().fraction); return false; });
  EXPECT_LT(lowest, at_rest.fraction - 0.02) << "braking moves the apparent CoG towards the front axle";
  EXPECT_NEAR(s.stability().fraction, at_rest.fraction, 0.02);  // at rest again
  EXPECT_TRUE(s.events.empty()) << s.summary();
}

// --- route, time, parking, dead man ---

TEST(Route, LeavingTheMarkedRoute) {
  Session s(scene("zones.json"));
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  s.run(40, [&] { Controls c = d.levers(); d.speed(c, 1.0); c.steer_rad = d.steer_to_line(3.0); return c; },
        [&] { return s.pos().x() > 30; });
  d.stop();
  ASSERT_EQ(s.count("off_route"), 1) << s.summary();
  EXPECT_GT(s.first("off_route")->y_m, 1.5);
  EXPECT_EQ(s.events.size(), 1u) << s.summary();
}

TEST(Route, KeepingWithinTheRouteIsClean) {
  Session s(scene("zones.json"));
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  s.run(40, [&] { Controls c = d.levers(); d.speed(c, 1.0); c.steer_rad = d.steer_to_line(1.0); return c; },
        [&] { return s.pos().x() > 30; });
  d.stop();
  EXPECT_TRUE(s.events.empty()) << s.summary();
}

TEST(Time, RunningOutOfTimeIsAnAutomaticFailure) {
  Scene sc = scene("zones.json");
  sc.time_limit_s = 3.0;
  Session s(sc, Mode::kExam);
  Driver d{s};
  d.lift_to = 0.2;
  s.run(4.0, [&] { return d.levers(); });
  ASSERT_EQ(s.count("time_limit"), 1) << s.summary();
  EXPECT_NEAR(s.first("time_limit")->t_s, 3.001, 1e-9);
  const Score score = s.finish("time_limit");
  EXPECT_FALSE(score.passed);
  EXPECT_EQ(score.automatic_failures, std::vector<std::string>{"time_limit"});
}

TEST(Time, FinishingInTimeIsClean) {
  Session s(scene("zones.json"), Mode::kExam);
  Driver d{s};
  d.lift_to = 0.2;
  s.run(4.0, [&] { return d.levers(); });
  EXPECT_TRUE(s.events.empty()) << s.summary();
}

TEST(Parking, LeavingTheTruckWithTheForksRaisedOrTheControlsApplied) {
  Session s(scene("zones.json"));
  Driver d{s};
  d.lift_to = 0.25;  // under the travelling limit, over the parked one
  d.settle_levers();
  s.run(1.0, [&] { Controls c; c.accelerator = 0.3; c.lift = 0.2; return c; });
  const Score score = s.finish("parked");
  ASSERT_EQ(s.count("parked_forks_raised"), 1) << s.summary();
  ASSERT_EQ(s.count("parked_controls_not_neutral"), 1) << s.summary();
  const std::string& why = s.first("parked_controls_not_neutral")->details;
  for (const char* what : {"still moving", "accelerator", "brake not set", "lift lever"})
    EXPECT_NE(why.find(what), std::string::npos) << what << " in " << why;
  EXPECT_NE(s.first("parked_forks_raised")->details.find("1910.178(m)(5)(i)"), std::string::npos);
  EXPECT_EQ(score.points, 5 + 3);
}

TEST(Parking, ForksDownControlsNeutralAndBrakeSetIsClean) {
  Session s(scene("zones.json"));
  Driver d{s};
  d.lift_to = 0.5;
  d.settle_levers();
  d.lift_to = 0.0;
  d.settle_levers();
  d.park();
  s.finish("parked");
  EXPECT_TRUE(s.events.empty()) << s.summary();
}

TEST(Parking, NotCheckedWhenTheSessionWasCutOff) {
  Session s(scene("zones.json"));
  Driver d{s};
  d.lift_to = 0.5;
  d.settle_levers();
  s.finish("signal");  // the worker was stopped: the pupil did not leave the truck
  EXPECT_TRUE(s.events.empty()) << s.summary();
}

// The parking rules judge the truck as the pupil left it, never as a session was stopped: only
// after an end the pupil makes (rules.json's parking_checked_on_end) with the task done (a scene
// without a task has none left). The truck is stopped moving, forks raised and levers held.
struct StoppedAs {
  const char* scene;
  const char* reason;
  bool charged;
};
void PrintTo(const StoppedAs& c, std::ostream* os) { *os << c.scene << ", " << c.reason; }  // its name in test lists
class ParkingAtTheEnd : public testing::TestWithParam<StoppedAs> {};

TEST_P(ParkingAtTheEnd, IsChargedOnlyWhenThePupilEndedTheTask) {
  const StoppedAs& c = GetParam();
  Session s(scene(c.scene));
  Driver d{s};
  d.lift_to = 0.25;  // under the travelling limit, over the parked one
  d.settle_levers();
  s.run(1.0, [&] { Controls k; k.accelerator = 0.3; k.lift = 0.2; return k; });
  const Score score = s.finish(c.reason);
  EXPECT_EQ(s.count("parked_forks_raised"), c.charged ? 1 : 0) << c.scene << ", " << c.reason << "\n" << s.summary();
  EXPECT_EQ(s.count("parked_controls_not_neutral"), c.charged ? 1 : 0) << c.scene << ", " << c.reason << "\n" << s.summary();
  EXPECT_EQ(score.end_reason, c.reason);
}

INSTANTIATE_TEST_SUITE_P(
    Ends, ParkingAtTheEnd,
    testing::Values(StoppedAs{"zones.json", "task_complete", true},   // the pupil ended it
                    StoppedAs{"zones.json", "duration", true},        // no task: its time is its course
                    StoppedAs{"pallets.json", "duration", false},     // the instructor's time limit, mid-task
                    StoppedAs{"pallets.json", "time_limit", false},   // the scenario's time limit, mid-task
                    StoppedAs{"zones.json", "time_limit", false},     // the time limit stops it, task or not
                    StoppedAs{"zones.json", "aborted", false},        // the instructor's abort, task or not
                    StoppedAs{"pallets.json", "aborted", false}),
    [](const testing::TestParamInfo<StoppedAs>& i) {
      std::string n = std::string(i.param.scene).substr(0, std::string(i.param.scene).find('.')) + "_" + i.param.reason;
      return n;
    });

TEST(Deadman, ADeadManStopIsInformationOnly) {
  Session s(scene("zones.json"));
  Driver d{s};
  d.lift_to = 0.2;
  s.run(0.5, [&] { return d.levers(); });
  s.deadman = true;
  s.run(0.5, [&] { return d.levers(); });
  s.deadman = false;
  s.run(0.5, [&] { return d.levers(); });
  s.deadman = true;
  s.run(0.5, [&] { return d.levers(); });
  EXPECT_EQ(s.count("deadman_stop"), 2) << s.summary();
  EXPECT_EQ(s.points(), 0);
}

}  // namespace
