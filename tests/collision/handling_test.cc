// Pallet handling driven through a real simulation: a fork tip striking a pallet, a scripted
// pick-up and set-down on a rack level, and a load slid off the forks by hard braking.
#include <gtest/gtest.h>

#include "collision/fixture.h"

namespace {

using namespace fx;

constexpr double kPocketMid = 0.092;  // fork top for forks centred in a EUR pallet's pockets

// 300 kg on a EUR pallet, low enough (0.5 m) to clear the rack's next beam above a level.
PalletSpec test_pallet() { return eur_pallet(300, Vector3d(1.0, 0.8, 0.5)); }

// The driver's moves, as small controllers on the run's state, along a straight line (a point
// on it and its heading) that the truck keeps to.
struct Driver {
  Driven& run;
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  double heading = 0;

  Eigen::Vector2d dir() const { return {std::cos(heading), std::sin(heading)}; }
  double along(const Vector3d& p) const { return (p.head<2>() - origin).dot(dir()); }
  double heel_along() const { return along(run.poses().carriage.translation()); }
  double heel_x() const { return run.poses().carriage.translation().x(); }
  double heel_z() const { return run.poses().carriage.translation().z(); }

  // Lift lever towards a fork-top height, never faster than `rate`.
  double lift_to(double z, double rate = 0.2) const { return std::clamp(4.0 * (z - heel_z()), -rate, rate); }
  // Rear-wheel steer bringing the front axle's middle onto the line, driving forward.
  double steer_to_line() const {
    const BodyPoses p = run.poses();
    const Eigen::Vector2d d = p.chassis.translation().head<2>() - origin;
    const double left_of_line = -d.x() * dir().y() + d.y() * dir().x();
    const double yaw = std::remainder(std::atan2(p.chassis.linear()(1, 0), p.chassis.linear()(0, 0)) - heading, 2 * M_PI);
    const double want = std::clamp(-0.5 * left_of_line, -0.4, 0.4);
    return std::clamp(-2.0 * (want - yaw), -0.6, 0.6);  // + steer turns right going forward
  }
  // Stop, holding levers still, until the truck stands.
  void stop() {
    run.run(5.0, [&] { return hold_speed(0, run.v()); }, [&] { return std::abs(run.v()) < 0.005; });
  }
  // Drive until `remaining` (m, along the line; negative `speed`: backwards) falls to zero,
  // slowing as it nears it (the tyres' braking force falls with speed, eq 8); then stop.
  // Forward it steers onto the line; backward it holds the wheel straight.
  void approach(const std::function<double()>& remaining, double speed) {
    run.run(60.0,
            [&] {
              const double v = std::clamp(0.8 * remaining(), 0.0, std::abs(speed));
              DriverInputs u = hold_speed(speed > 0 ? v : -v, run.v());
              if (speed > 0) u.steer_rad = steer_to_line();
              return u;
            },
            [&] { return remaining() <= 0.002; });
    stop();
  }
  void insert_to(double tip_along) { approach([&] { return tip_along - heel_along() - 1.0; }, 0.3); }
  void lift(double z, double max_s = 20) {
    run.run(max_s, [&] { DriverInputs u = hold_speed(0, run.v()); u.lift_rate_m_s = lift_to(z); return u; },
            [&] { return std::abs(heel_z() - z) < 0.002; });
  }
};

// Forks too high drive into the pallet's deck: contacts of both forks with it, and lifting
// then does not pick it up (the forks are not in its pockets).
TEST(Handling, ForkTipStrikingTheDeckIsAContactNotAPickUp) {
  const PalletSpec spec = test_pallet();
  const Scene scene = scene_of({pallet("P1", pose(3.0, 0), spec)});  // entry face at x = 2.4
  TruckDynamics d(truck());
  Driven run(scene, truck_shape(), settled(d, 0, 0, 0, 0.15));  // forks 0.11 to 0.15 m: the deck is at 0.122 to 0.144
  Driver drv{run};
  const double unladen = run.mass();
  ASSERT_TRUE(run.run(20.0, [&] { return hold_speed(0.3, run.v()); }, [&] { return !run.contacts.empty(); }));
  const Contact& c = run.contacts.front().second;
  EXPECT_EQ(c.object_id, "P1");
  EXPECT_EQ(c.object_kind, ObjectKind::kPallet);
  EXPECT_TRUE(c.truck_part == "fork_left" || c.truck_part == "fork_right") << c.truck_part;
  EXPECT_NEAR(c.point_m.x(), 2.4, 0.005);  // at the pallet's entry face
  EXPECT_NEAR(c.relative_speed_m_s, 0.3, 0.03);
  drv.stop();
  drv.lift(0.5);
  EXPECT_NEAR(drv.heel_z(), 0.5, 0.005);
  EXPECT_EQ(run.count(HandlingEvent::Kind::kPickedUp), 0);
  ASSERT_NE(run.handling.pallet("P1"), nullptr);
  EXPECT_FALSE(run.handling.pallet("P1")->on_forks);
  EXPECT_NEAR(run.mass(), unladen, 1e-9);
  EXPECT_NEAR(run.handling.pallet("P1")->pose.translation().z(), 0.0, 1e-12);  // it never moved
}

// The whole handling cycle: forks at pocket height, in slowly, lift (picked up: the truck's
// mass rises by pallet and load), a lane change to a rack, lower onto level 1 (set down there:
// the mass falls back), and back out.
TEST(Handling, PickUpAndSetDownOnARackLevel) {
  const PalletSpec spec = test_pallet();
  // The rack's length along world y, its depth (1.1 m) along x: level 1's beams at
  // x = 8.45..8.5 and 9.5..9.55, tops 0.9 m.
  const Scene scene = scene_of({pallet("P1", pose(3.0, 0), spec), rack("R1", pose(9.0, 1.0, 0, 90))});
  TruckDynamics d(truck());
  Driven run(scene, truck_shape(), settled(d, 0, 0, 0, kPocketMid));
  Driver drv{run};
  const double unladen = run.mass();
  const PalletState& p1 = *run.handling.pallet("P1");

  drv.insert_to(2.4 + 0.9);
  EXPECT_EQ(run.count(HandlingEvent::Kind::kPickedUp), 0);
  EXPECT_TRUE(run.contacts.empty());  // forks in the pockets, carriage short of the pallet

  drv.lift(1.15);  // pallet underside 1.03 m: over level 1's beams (0.9)
  ASSERT_EQ(run.count(HandlingEvent::Kind::kPickedUp), 1);
  EXPECT_EQ(run.events[0].pallet, "P1");
  EXPECT_NEAR(run.mass() - unladen, spec.pallet_mass_kg + spec.load_mass_kg, 1e-6);
  EXPECT_TRUE(p1.on_forks);
  // On the forks. The unladen truck stands 0.26 deg nose up, so the forks rise towards their
  // tips and the level deck first meets them there: millimetres off the heel's height, not zero.
  EXPECT_NEAR(p1.pose.translation().z(), drv.heel_z() - spec.pocket_top_m, 0.005);
  // The model's load: pallet and box as one body, CoG from the fork heel. The pallet's back
  // face is 0.1 m ahead of the heel (forks 1 m, 0.9 m in), its middle 0.7 m; the CoG height
  // above the fork top: (25 kg x 0.072 m + 300 kg x (0.144 + 0.25) m) / 325 kg - 0.122 m.
  ASSERT_TRUE(run.sim->dynamics().load());
  const Load& load = *run.sim->dynamics().load();
  EXPECT_NEAR(load.mass_kg, 325, 1e-9);
  EXPECT_NEAR(load.cog_m.x(), 0.7, 0.005);
  EXPECT_NEAR(load.cog_m.y(), 0.0, 0.005);
  EXPECT_NEAR(load.cog_m.z(), (25 * 0.072 + 300 * 0.394) / 325 - 0.122, 0.01);
  EXPECT_GT(load.inertia_kg_m2(0, 0), 0);

  // Lane change onto the rack's line, then in until the pallet's centre is over the bay.
  drv.origin = Eigen::Vector2d(0, 1.0);
  drv.approach([&] { return 9.0 - p1.pose.translation().x(); }, 0.8);
  EXPECT_NEAR(p1.pose.translation().y(), 1.0, 0.15);
  EXPECT_TRUE(p1.on_forks);

  // Lower until it is set down, then 5 cm more to free the forks, then back out.
  ASSERT_TRUE(run.run(10.0, [&] { DriverInputs u = hold_speed(0, run.v()); u.lift_rate_m_s = -0.1; return u; },
                      [&] { return run.count(HandlingEvent::Kind::kSetDown) > 0; }));
  const HandlingEvent& down = run.events.back();
  EXPECT_EQ(down.kind, HandlingEvent::Kind::kSetDown);
  EXPECT_EQ(down.on_object, "R1");
  EXPECT_EQ(down.level, 1);
  EXPECT_FALSE(p1.on_forks);
  EXPECT_EQ(p1.resting_on, "R1");
  EXPECT_EQ(p1.level, 1);
  EXPECT_NEAR(p1.pose.translation().z(), 0.9, 1e-12);
  EXPECT_NEAR(p1.pose.linear().col(2).z(), 1.0, 1e-12);  // level: roll and pitch zeroed
  EXPECT_NEAR(run.mass(), unladen, 1e-6);
  const double underside_at_release = drv.heel_z() - spec.pocket_top_m;
  EXPECT_NEAR(underside_at_release, 0.9, 0.01);

  const double z_down = drv.heel_z();
  run.run(3.0, [&] { DriverInputs u = hold_speed(0, run.v()); u.lift_rate_m_s = drv.lift_to(z_down - 0.05, 0.1); return u; },
          [&] { return drv.heel_z() < z_down - 0.049; });
  const double heel_before = drv.heel_x();
  run.run(10.0, [&] { return hold_speed(-0.4, run.v()); }, [&] { return drv.heel_x() < heel_before - 1.5; });
  drv.stop();
  EXPECT_EQ(run.count(HandlingEvent::Kind::kPickedUp), 1);
  EXPECT_EQ(run.count(HandlingEvent::Kind::kSetDown), 1);
  EXPECT_EQ(p1.resting_on, "R1");
  EXPECT_NEAR(p1.pose.translation().z(), 0.9, 1e-12);
  EXPECT_TRUE(run.contacts.empty()) << run.contacts.front().second.truck_part << " with "
                                    << run.contacts.front().second.object_id << " at t = " << run.contacts.front().first;
}

// Forks in only 0.5 m of the pallet's 1.2 m: not engaged, so lifting strikes its deck from
// below (contacts) and does not pick it up.
TEST(Handling, ShallowInsertionIsNoPickUp) {
  const PalletSpec spec = test_pallet();
  const Scene scene = scene_of({pallet("P1", pose(3.0, 0), spec)});
  TruckDynamics d(truck());
  Driven run(scene, truck_shape(), settled(d, 0, 0, 0, kPocketMid));
  Driver drv{run};
  const double unladen = run.mass();
  drv.insert_to(2.4 + 0.5);
  EXPECT_TRUE(run.contacts.empty());
  drv.lift(0.3);
  EXPECT_EQ(run.count(HandlingEvent::Kind::kPickedUp), 0);
  EXPECT_NEAR(run.mass(), unladen, 1e-9);
  ASSERT_FALSE(run.contacts.empty());
  for (const auto& [t, c] : run.contacts) {
    EXPECT_EQ(c.object_id, "P1");
    EXPECT_TRUE(c.truck_part == "fork_left" || c.truck_part == "fork_right") << c.truck_part;
  }
  EXPECT_NEAR(run.contacts.front().second.point_m.z(), spec.pocket_top_m, 0.002);  // the deck's underside
  EXPECT_LT(run.contacts.front().second.normal.z(), -0.99);  // the deck above pushes the forks down
}

// Picked up, carried back 1 m and lowered to the floor: set down on the floor ("" and level
// 0), level, 1 m from where it stood.
TEST(Handling, SetDownOnTheFloor) {
  const PalletSpec spec = test_pallet();
  const Scene scene = scene_of({pallet("P1", pose(3.0, 0), spec)});
  TruckDynamics d(truck());
  Driven run(scene, truck_shape(), settled(d, 0, 0, 0, kPocketMid));
  Driver drv{run};
  const double unladen = run.mass();
  const PalletState& p1 = *run.handling.pallet("P1");
  drv.insert_to(2.4 + 0.9);
  drv.lift(0.35);
  ASSERT_TRUE(p1.on_forks);
  const double heel0 = drv.heel_x();
  drv.approach([&] { return drv.heel_x() - (heel0 - 1.0); }, -0.3);
  ASSERT_TRUE(run.run(10.0, [&] { DriverInputs u = hold_speed(0, run.v()); u.lift_rate_m_s = -0.1; return u; },
                      [&] { return run.count(HandlingEvent::Kind::kSetDown) > 0; }));
  EXPECT_EQ(run.events.back().on_object, "");
  EXPECT_EQ(run.events.back().level, 0);
  EXPECT_FALSE(p1.on_forks);
  EXPECT_FALSE(p1.dropped);
  EXPECT_EQ(p1.resting_on, "");
  EXPECT_NEAR(p1.pose.translation().z(), 0.0, 1e-12);
  EXPECT_NEAR(p1.pose.translation().x(), 2.0, 0.01);
  EXPECT_NEAR(p1.pose.translation().y(), 0.0, 0.01);
  EXPECT_NEAR(run.mass(), unladen, 1e-6);
  EXPECT_NEAR(drv.heel_z() - spec.pocket_top_m, 0.0, 0.005);  // released as the underside met the floor
  EXPECT_TRUE(run.contacts.empty());
}

// The shipped warehouse and truck: P3 (400 kg) from rack R2's level 2 (beam top 1.8 m) up to
// level 3 (2.7 m) of the same bay, in aisle A facing north.
TEST(Handling, ShippedWarehouseMovesP3FromLevel2ToLevel3) {
  const Scene& scene = shipped_warehouse();
  const SceneObject* obj = scene.find("P3");
  ASSERT_TRUE(obj && obj->pallet);
  const PalletSpec& spec = *obj->pallet;
  const Vector3d at = obj->pose.translation();  // (16.7, 28.45, 1.8), its x axis along world +y
  const double near_face = at.y() - 0.5 * spec.length_m;
  const double rack_face = 27.9;
  TruckDynamics d(truck());
  Driven run(scene, shipped_shape(), settled(d, at.x(), 26.1, M_PI / 2, at.z() + kPocketMid));
  Driver drv{run, Eigen::Vector2d(at.x(), 0), M_PI / 2};  // along the line: world y
  const PalletState& p3 = *run.handling.pallet("P3");
  EXPECT_EQ(p3.resting_on, "R2");
  EXPECT_EQ(p3.level, 2);
  const double unladen = run.mass();

  drv.insert_to(near_face + 0.9);
  drv.lift(at.z() + spec.pocket_top_m + 0.05);
  ASSERT_EQ(run.count(HandlingEvent::Kind::kPickedUp), 1);
  EXPECT_NEAR(run.mass() - unladen, spec.pallet_mass_kg + spec.load_mass_kg, 1e-6);
  EXPECT_EQ(p3.resting_on, "");

  // Back out until its far face clears the rack, up to level 3, in again over the bay's middle.
  drv.approach([&] { return p3.pose.translation().y() + 0.5 * spec.length_m - (rack_face - 0.05); }, -0.3);
  drv.lift(2.7 + spec.pocket_top_m + 0.05);
  drv.approach([&] { return at.y() - p3.pose.translation().y(); }, 0.3);
  ASSERT_TRUE(run.run(10.0, [&] { DriverInputs u = hold_speed(0, run.v()); u.lift_rate_m_s = -0.1; return u; },
                      [&] { return run.count(HandlingEvent::Kind::kSetDown) > 0; }));
  EXPECT_EQ(run.events.back().on_object, "R2");
  EXPECT_EQ(run.events.back().level, 3);
  EXPECT_EQ(p3.resting_on, "R2");
  EXPECT_EQ(p3.level, 3);
  EXPECT_NEAR(p3.pose.translation().z(), 2.7, 1e-12);
  EXPECT_NEAR(p3.pose.translation().x(), at.x(), 0.05);
  EXPECT_NEAR(p3.pose.translation().y(), at.y(), 0.05);
  EXPECT_NEAR(run.mass(), unladen, 1e-6);

  const double z_down = drv.heel_z();
  run.run(3.0, [&] { DriverInputs u = hold_speed(0, run.v()); u.lift_rate_m_s = drv.lift_to(z_down - 0.05, 0.1); return u; },
          [&] { return drv.heel_z() < z_down - 0.049; });
  const double heel_before = drv.heel_along();
  drv.approach([&] { return drv.heel_along() - (heel_before - 1.2); }, -0.3);
  EXPECT_EQ(run.count(HandlingEvent::Kind::kPickedUp), 1);
  EXPECT_EQ(run.count(HandlingEvent::Kind::kSetDown), 1);
  EXPECT_EQ(p3.resting_on, "R2");
  EXPECT_TRUE(run.contacts.empty()) << run.contacts.front().second.truck_part << " with "
                                    << run.contacts.front().second.object_id << " at t = " << run.contacts.front().first;
}

// Picks P1 up with the forks in 0.7 m (its CoG 0.1 m short of the tips), lifts the forks to 2 m and tilts the mast fully forward, then
// drives to 2 m/s and stops with `brake_N_m` on each front wheel.
struct BrakeResult {
  bool dropped = false;
  double max_slide_m = 0;
  int sliding_events = 0;
  double unladen = 0, mass_after = 0;
  Vector3d where = Vector3d::Zero();
  double heel_x = 0, heel_x_at_brake = 0;
};

BrakeResult brake_with_load_high(double brake_N_m) {
  const PalletSpec spec = test_pallet();
  const Scene scene = scene_of({pallet("P1", pose(3.0, 0), spec)});
  TruckDynamics d(truck());
  Driven run(scene, truck_shape(), settled(d, 0, 0, 0, kPocketMid));
  Driver drv{run};
  BrakeResult r;
  r.unladen = run.mass();
  drv.insert_to(2.4 + 0.7);
  drv.lift(2.0);
  EXPECT_EQ(run.count(HandlingEvent::Kind::kPickedUp), 1);
  run.run(2.0, [&] { DriverInputs u = hold_speed(0, run.v()); u.tilt_rate_rad_s = 0.1; return u; });
  EXPECT_NEAR(coordinates(run.x())[kBeta], truck().limits.tilt_forward_max_rad, 0.005);
  const PalletState& p1 = *run.handling.pallet("P1");
  auto track = [&] { r.max_slide_m = std::max(r.max_slide_m, p1.slide_m); return false; };
  run.run(15.0, [&] { DriverInputs u; u.drive_torque_N_m = 300; return u; }, [&] { track(); return run.v() >= 2.0; });
  r.heel_x_at_brake = drv.heel_x();
  run.run(5.0, [&] { DriverInputs u; u.brake_torque_N_m = brake_N_m; return u; }, [&] { track(); return run.v() < 0.01; });
  run.run(1.0, [&] { DriverInputs u; u.brake_torque_N_m = brake_N_m; return u; }, track);
  r.dropped = p1.dropped;
  r.sliding_events = run.count(HandlingEvent::Kind::kSliding);
  r.mass_after = run.mass();
  r.where = p1.pose.translation();
  r.heel_x = drv.heel_x();
  if (r.dropped) {
    EXPECT_EQ(run.count(HandlingEvent::Kind::kDropped), 1);
  }
  return r;
}

TEST(Handling, HardBrakingWithTheLoadHighAndTiltedForwardDropsIt) {
  const BrakeResult r = brake_with_load_high(1200);
  EXPECT_TRUE(r.dropped);
  EXPECT_GE(r.sliding_events, 1);
  EXPECT_NEAR(r.mass_after, r.unladen, 1e-6);
  EXPECT_NEAR(r.where.z(), 0.0, 1e-12);  // on the floor below
  EXPECT_GT(r.where.x(), r.heel_x);      // ahead of the truck
}

TEST(Handling, GentleBrakingWithTheSameLoadKeepsIt) {
  const BrakeResult r = brake_with_load_high(150);
  EXPECT_FALSE(r.dropped);
  EXPECT_LT(r.max_slide_m, 0.05);
  EXPECT_GT(r.mass_after, r.unladen + 300);
}

}  // namespace
