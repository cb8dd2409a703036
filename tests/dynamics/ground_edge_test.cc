// The truck against ground with steps: a dock's edge, kerbs. The ground is a few inline steps; the
// truck is the shipped training truck, driven by a speed-holding foot on the accelerator.
#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <string>

#include "forklift/dynamics/dynamics.h"
#include "forklift/dynamics/simulation.h"
#include "ground_contact.h"  // the contact geometry, to count the body's spring energy
#include "test_truck.h"

using namespace forklift;

namespace {

// A step from x = `x_from` to `x_to`, 20 m wide (y within 10 m of 0), its top at `top_m`: a dock
// whose edge faces +x, or a kerb whose face does.
GroundStep step_from(double x_from, double x_to, double top_m) {
  return {Eigen::AlignedBox2d(Eigen::Vector2d(x_from, -10), Eigen::Vector2d(x_to, 10)), top_m};
}

Environment on(const Ground& ground) {
  Environment env;
  env.ground = ground;
  return env;
}

// The energy the body's contact springs hold at coordinates q: K depth^2 / 2 over its points, a
// load's corners and the steps' edges on its edge boxes, found as the dynamics find them.
double body_spring_energy(const TruckDynamics& d, const CoordVector& q) {
  const TruckParams& t = d.truck();
  const BodyPoses p = body_poses(t, q);
  // The dynamics hold the chassis' points from its CoG, the others from the poses' origins.
  const Eigen::Isometry3d chassis = p.chassis * Eigen::Translation3d(t.chassis_cog_geometry_m);
  auto frame = [&](TruckBody b) -> const Eigen::Isometry3d& {
    return b == TruckBody::kChassis ? chassis : b == TruckBody::kMast ? p.mast : p.carriage;
  };
  const Ground& g = d.environment().ground;
  const double k = t.body_contact.stiffness_N_m;
  double energy = 0;
  auto point = [&](const Eigen::Vector3d& at) {
    GroundTouch touch;
    if (point_touch(g, at, touch)) energy += 0.5 * k * touch.depth_m * touch.depth_m;
  };
  for (const BodyContactPoint& b : t.body_contact.points) point(frame(b.body) * b.point_m);
  if (d.load() && d.load()->size_m.minCoeff() > 0)
    for (int c = 0; c < 8; ++c)
      point(p.carriage * (d.load()->cog_m + 0.5 * Eigen::Vector3d(c & 1 ? 1 : -1, c & 2 ? 1 : -1, c & 4 ? 1 : -1)
                                                   .cwiseProduct(d.load()->size_m)));
  for (const BodyEdgeBox& b : t.body_contact.edge_boxes) {
    GroundTouch touch[kMaxGroundTouches];
    const int n = box_edge_touches(g, frame(b.body).linear(), frame(b.body).translation(), b.min_m, b.max_m, touch);
    for (int i = 0; i < n; ++i) energy += 0.5 * k * touch[i].depth_m * touch[i].depth_m;
  }
  return energy;
}

// A drive ahead (+x) from rest at x = 0 on `ground`, the accelerator held to keep `speed_m_s`
// (torque in proportion to the speed's shortfall, up to the truck's limit) until a front wheel
// passes `foot_off_x_m`, then none, in ticks of `tick_s` (a session's 1 ms). Every tick it takes
// the work-energy balance: the kinetic, gravitational and spring energy (tyres, their tread, body
// contacts and a load sliding on the forks) less the drive's work on the wheels can only fall (the brakes are off, so nothing else puts energy in: a landing may only
// take energy out).
struct Drive {
  double largest_pitch_rad = 0, largest_roll_rad = 0;
  double energy_lost_J = 0;  // start + drive work - energy, at the end
  // That balance's largest rise above its lowest yet (zero for contact that only dissipates).
  double largest_rise_J = 0;
  bool load_fell = false;  // a load on the forks fell off (the balance is the truck's alone from then)
  Outputs end;
  StateVector x_end;
};
Drive drive(const Ground& ground, double speed_m_s, double seconds, double lift_m, double foot_off_x_m = INFINITY,
            double yaw_rad = 0, const std::optional<Load>& load = std::nullopt, double tick_s = 1e-3) {
  const TruckParams& t = shipped_truck();
  TruckDynamics d(t, on(ground));
  if (load) d.attach_load(*load);
  StateVector x = d.rest_state(0, 0, yaw_rad, 0, 0, lift_m);
  EXPECT_TRUE(d.settle_static(x));
  IntegratorOptions o;
  o.rtol = 1e-6;
  Simulation sim(d, x, o);
  Drive r;
  const double e0 = d.energy(sim.state());
  const TruckDynamics bare(t, on(ground));
  double work = 0, power_before = 0, lowest = e0, left_with_load = 0;
  const double torque_max = t.drive.drive_torque_max_N_m;
  for (int k = 1; k <= std::lround(seconds / tick_s); ++k) {
    const Outputs now = sim.outputs();
    const bool foot_on = std::max(now.wheels[kFrontLeft].contact_point_m.x(), now.wheels[kFrontRight].contact_point_m.x()) < foot_off_x_m;
    DriverInputs u;
    u.drive_torque_N_m = foot_on ? std::clamp(8000.0 * (speed_m_s - now.forward_speed_m_s), 0.0, torque_max) : 0.0;
    sim.set_inputs(u);
    sim.advance_to(k * tick_s);
    const Outputs out = sim.outputs();
    double power = 0;
    for (int w : {kFrontLeft, kFrontRight}) power += out.wheels[w].drive_torque_N_m * out.qdot[kAvr1 + w];
    work += 0.5 * (power + power_before) * tick_s;
    power_before = power;
    // A load that falls off the forks leaves the truck with its own energy: from then on the
    // balance is the truck's alone (`bare`, the model without the load), from where it stood.
    const bool fell_now = !r.load_fell && sim.load_on_forks().phase == LoadPhase::kFallen;
    r.load_fell = r.load_fell || fell_now;
    const TruckDynamics& now_model = r.load_fell ? bare : d;
    const double e = now_model.energy(sim.state()) + (r.load_fell ? 0.0 : sliding_load_energy(sim));
    const double held = e + body_spring_energy(now_model, out.q) - work;
    if (fell_now) {
      left_with_load = (e0 + work - e) - r.energy_lost_J;
      lowest = held;
    }
    lowest = std::min(lowest, held);
    r.largest_rise_J = std::max(r.largest_rise_J, held - lowest);
    r.energy_lost_J = e0 + work - e - left_with_load;
    r.largest_pitch_rad = std::max(r.largest_pitch_rad, std::abs(out.q[kAvc]));
    r.largest_roll_rad = std::max(r.largest_roll_rad, std::abs(out.q[kAuc]));
    r.end = out;
  }
  r.x_end = sim.state();
  return r;
}

// The front axle's x when the truck's CoG stands at x = 0, heading +x.
double front_axle_x() { return shipped_truck().wheels[kFrontLeft].centre_m.x(); }

// How far the energy (with the body's springs and the tyres' deflected tread, less the drive's
// work) may rise in a drive: the integrator's error alone (measured: at most 0.02 J). Before the
// tyre's tread was renewed as its load rose, a load landing on a deflected tyre raised its force
// and energy out of nothing: 16 J at the unladen truck's rear wheel coming down on the dock again,
// 26-44 J at the kerbs once the tread's energy is counted.
constexpr double kEnergyRiseJ = 0.1;
// The same for a laden truck's fall, whose load slips on the forks as it tips and at the blow (see
// its test): measured 26 J at 1 ms ticks, 13 J at 0.5 ms, of some 18.6 kJ the fall takes out.
constexpr double kLoadBlowRiseJ = 40;
// The same for a truck falling off a dock's side: the edge across the belly near its face, where
// its push fades (see box_edge_touches), is not quite a spring.
constexpr double kSideFallRiseJ = 30;

double weight_N() { return shipped_truck().service_mass_kg * kGravity_m_s2; }

// Where the fork tips are (world), from the truck's body points named fork_tip_*.
double lowest_fork_tip_z(const Outputs& o) {
  const TruckParams& t = shipped_truck();
  const BodyPoses p = body_poses(t, o.q);
  double z = INFINITY;
  for (const BodyContactPoint& b : t.body_contact.points)
    if (b.name.rfind("fork_tip", 0) == 0) z = std::min(z, (p.carriage * b.point_m).z());
  return z;
}

}  // namespace

TEST(GroundSteps, HeightIsTheHighestStepHoldingThePointAndDropsAtItsSide) {
  const Ground g({}, {step_from(-20, 5, -1.2), step_from(-20, 0, 0.0), step_from(2, 3, 0.15)});
  EXPECT_EQ(g.height(-1, 0), 0.0);    // the dock: both steps hold it, the higher wins
  EXPECT_EQ(g.height(1, 0), -1.2);    // beyond the dock's edge, the yard below it
  EXPECT_EQ(g.height(2.5, 0), 0.15);  // a kerb in the yard stands on its own top
  EXPECT_EQ(g.height(10, 0), 0.0);    // outside every step, the floor
  EXPECT_EQ(g.gradient(1, 0), Eigen::Vector2d::Zero());
}

TEST(GroundSteps, AWheelOverAnEdgeRestsOnItsCornerAndFallsWhenItRollsOff) {
  // The front wheels' centres 3 cm beyond a 1.2 m dock's edge: each is held by the edge, on the
  // line from the corner to its centre, not by the yard 1.2 m below nor by a floor under it.
  const TruckParams& t = shipped_truck();
  const double r = t.wheels[kFrontLeft].radius_m, edge = front_axle_x() - 0.03;
  TruckDynamics on_dock(t, on(Ground({}, {step_from(-20, edge, 1.2)})));
  StateVector x = on_dock.rest_state(0, 0, 0);
  StateVector dx;
  Outputs o;
  ASSERT_TRUE(on_dock.derivative(x, {}, dx, &o));
  const WheelContact& c = o.wheels[kFrontLeft];
  ASSERT_TRUE(c.on_ground);
  // Tilted forward from the corner to the centre: the edge pushes the wheel on, off the dock.
  EXPECT_NEAR(c.normal.z(), std::sqrt(r * r - 0.03 * 0.03) / r, 0.01);
  EXPECT_NEAR(c.normal.x(), 0.03 / r, 0.01);
  EXPECT_NEAR(c.contact_point_m.x(), edge, 1e-6);
  EXPECT_NEAR(c.contact_point_m.z(), 1.2, 1e-6);
  // Rolled on past its radius, nothing holds it.
  x[StateIndex::kQ + kX] += 0.25;
  ASSERT_TRUE(on_dock.derivative(x, {}, dx, &o));
  EXPECT_FALSE(o.wheels[kFrontLeft].on_ground);
  EXPECT_FALSE(o.wheels[kFrontRight].on_ground);
  EXPECT_TRUE(o.wheels[kRear].on_ground);
}

TEST(GroundSteps, ABodyPointLeavesAKerbThroughItsFaceNotOntoItsTop) {
  // The fork tips 1 cm above the floor, pressed 5 mm into a 5 cm kerb's face: pushed back, not up.
  const TruckParams& t = shipped_truck();
  TruckDynamics d(t);
  StateVector x = d.rest_state(0, 0, 0);
  ASSERT_TRUE(d.settle_static(x));
  const double tip_x = [&]() -> double {
    const BodyPoses p = body_poses(t, coordinates(x));
    for (const BodyContactPoint& b : t.body_contact.points)
      if (b.name == "fork_tip_left") return (p.carriage * b.point_m).x();
    return NAN;
  }();
  d.environment().ground = Ground({}, {step_from(tip_x - 0.005, tip_x + 5, 0.05)});
  StateVector dx;
  Outputs o;
  ASSERT_TRUE(d.derivative(x, {}, dx, &o));
  EXPECT_LT(o.qddot[kX], -1.0) << "the kerb's face stops the forks";
  EXPECT_GE(o.body_points_on_ground, 2);
  for (const WheelContact& c : o.wheels) EXPECT_TRUE(c.on_ground);
}

namespace {
// The dock's edge 3 m ahead of the front axle, the yard 1.2 m below; driven at 1 m/s with the forks
// at 0.15 m until the front wheels are over the edge, then the foot comes off; 8 s in all.
double dock_edge_x() { return front_axle_x() + 3.0; }
Drive off_the_dock(const std::optional<Load>& load, double tick_s = 1e-3) {
  return drive(Ground({}, {step_from(-30, dock_edge_x(), 1.2)}), 1.0, 8.0, 0.15, dock_edge_x(), 0.0, load, tick_s);
}
void record(const std::string& name, const Drive& r) {
  testing::Test::RecordProperty(name + "_end_pitch_deg", std::to_string(r.end.q[kAvc] / kDeg));
  testing::Test::RecordProperty(name + "_end_cog_z_m", std::to_string(r.end.cog_m.z()));
  testing::Test::RecordProperty(name + "_energy_lost_J", std::to_string(r.energy_lost_J));
  testing::Test::RecordProperty(name + "_largest_rise_J", std::to_string(r.largest_rise_J));
}
}  // namespace

TEST(GroundSteps, ALadenTruckDrivenOffADockFallsAndEndsOnItsForksOrOverturned) {
  // 1000 kg on the forks, its centre 0.6 m ahead of their face: the truck and load's CoG is then
  // near the front axle, ahead of where the belly meets the edge once the wheels are over it.
  const TruckParams& t = shipped_truck();
  // Strapped to the carriage (friction far beyond any slope it meets): this test is of the dock's
  // edge; how a load slides on the forks is load_test.cc's.
  Load strapped = box_load(1000, 1.2, 0.8, 1.0, 0.6, 0);
  strapped.friction_static = strapped.friction_kinetic = 10;
  const Drive r = off_the_dock(strapped);
  record("laden", r);
  const double cog_on_dock = 1.2 + 0.55;
  EXPECT_LT(r.end.cog_m.z(), cog_on_dock - 0.25) << "it fell";
  const bool overturned = std::abs(r.end.q[kAvc]) > t.tipped_over_rad || std::abs(r.end.q[kAuc]) > t.tipped_over_rad;
  const bool on_forks = lowest_fork_tip_z(r.end) < 0.03 && r.end.q[kAvc] > 10 * kDeg;  // nose down, tips on the yard
  EXPECT_TRUE(overturned || on_forks) << "pitch " << r.end.q[kAvc] / kDeg << " deg, roll " << r.end.q[kAuc] / kDeg
                                      << " deg, lowest fork tip at " << lowest_fork_tip_z(r.end) << " m";
  // Nothing went through the yard's floor or the dock's edge.
  EXPECT_LT(r.end.body_penetration_max_m, 0.03);
  // The landing took energy out and never put in more than the load's contact does at the fork
  // tips' blow on the yard, where the load slips for 2-3 ms under some 10 g (the ground's own
  // contact keeps kEnergyRiseJ). Counted with the load where it slides and moving as it does (it
  // was once counted as the model holds it, at its last attachment moving with the carriage,
  // which made 64-70 J of nothing at the blow).
  EXPECT_LE(r.largest_rise_J, kLoadBlowRiseJ);
  // Half of that is the slide's force on the carriage acting a tick late (load_on_forks.h): with
  // ticks of half a millisecond it halves, and what it puts in is a thousandth of what the fall
  // takes out: harmless.
  const Drive half = off_the_dock(strapped, 0.5e-3);
  RecordProperty("laden_largest_rise_half_tick_J", std::to_string(half.largest_rise_J));
  EXPECT_LT(half.largest_rise_J, r.largest_rise_J);
  EXPECT_LT(r.largest_rise_J - half.largest_rise_J, 1e-3 * r.energy_lost_J);
  EXPECT_GT(r.energy_lost_J, t.service_mass_kg * kGravity_m_s2 * 0.25);
  EXPECT_LT(Eigen::Vector3d(r.end.qdot[kX], r.end.qdot[kY], r.end.qdot[kZ]).norm(), 0.05) << "at rest";
}

TEST(GroundSteps, AnUnladenTruckDrivenOffADockDropsOntoItsBellyAcrossTheEdge) {
  // Unladen, the CoG stands well behind the front axle: when the front wheels drop over the edge
  // the belly (8 cm up) lands on it and the CoG is still behind it, so the truck hangs there,
  // high-centred, front wheels in the air; the edge neither passes through the belly nor flips it.
  const TruckParams& t = shipped_truck();
  const Drive r = off_the_dock(std::nullopt);
  record("unladen", r);
  EXPECT_FALSE(r.end.wheels[kFrontLeft].on_ground);
  EXPECT_FALSE(r.end.wheels[kFrontRight].on_ground);
  EXPECT_TRUE(r.end.wheels[kRear].on_ground);
  EXPECT_GT(r.end.q[kAvc], 2 * kDeg);  // nose down
  EXPECT_LT(r.largest_pitch_rad, t.tipped_over_rad);
  EXPECT_GE(r.end.body_points_on_ground, 1);
  EXPECT_LT(r.end.body_penetration_max_m, 0.01);
  EXPECT_LE(r.largest_rise_J, kEnergyRiseJ);
  EXPECT_LT(Eigen::Vector3d(r.end.qdot[kX], r.end.qdot[kY], r.end.qdot[kZ]).norm(), 0.05) << "at rest";
}

namespace {
// A kerb of `height_m` whose face stands 2 m ahead of the front axle (0.6 m ahead of the fork
// tips), driven into at walking pace (1.4 m/s asked for, the foot held down) for 6 s with the forks
// at `lift_m`.
double kerb_face_x() { return front_axle_x() + 2.0; }
Drive into_kerb(double height_m, double lift_m) {
  const double face = kerb_face_x();
  return drive(Ground({}, {step_from(face, face + 20, height_m)}), 1.4, 6.0, lift_m);
}
// On its three wheels, carrying its weight on them: neither flipped nor stranded on its forks.
void expect_on_its_wheels(const Drive& r) {
  double fz = 0;
  for (const WheelContact& c : r.end.wheels) {
    EXPECT_TRUE(c.on_ground);
    fz += c.fz_N;
  }
  EXPECT_GT(fz, 0.97 * weight_N()) << "the wheels carry the truck, not its forks or body";
  EXPECT_LT(r.largest_pitch_rad, shipped_truck().tipped_over_rad);
  EXPECT_LT(r.largest_roll_rad, shipped_truck().tipped_over_rad);
  EXPECT_LE(r.largest_rise_J, kEnergyRiseJ);
}
}  // namespace

namespace {
// Into a kerb of `height_m` with the forks at `lift_m`: on its wheels at the end, and whether the
// rear wheel ended on the kerb's top or the truck stopped before it.
struct KerbOutcome { bool climbed, stopped; };
KerbOutcome kerb_outcome(double height_m, double lift_m) {
  const Drive r = into_kerb(height_m, lift_m);
  const std::string name = "kerb" + std::to_string(std::lround(height_m * 100)) + "cm_lift" +
                           std::to_string(std::lround(lift_m * 100)) + "cm";
  testing::Test::RecordProperty(name + "_front_wheel_x_m", std::to_string(r.end.wheels[kFrontLeft].contact_point_m.x()));
  testing::Test::RecordProperty(name + "_rear_wheel_z_m", std::to_string(r.end.wheels[kRear].contact_point_m.z()));
  testing::Test::RecordProperty(name + "_largest_pitch_deg", std::to_string(r.largest_pitch_rad / kDeg));
  testing::Test::RecordProperty(name + "_largest_rise_J", std::to_string(r.largest_rise_J));
  expect_on_its_wheels(r);
  return {r.end.wheels[kRear].contact_point_m.z() > height_m - 0.005,
          r.end.wheels[kFrontLeft].contact_point_m.x() < kerb_face_x() + 0.01 && std::abs(r.end.forward_speed_m_s) < 0.05};
}
}  // namespace

TEST(GroundSteps, AFifteenCentimetreKerbAtWalkingPaceStopsTheTruckOrIsClimbedNeverFlipsIt) {
  for (double lift : {0.0, 0.2}) {
    SCOPED_TRACE("forks lifted " + std::to_string(lift) + " m");
    const KerbOutcome k = kerb_outcome(0.15, lift);
    EXPECT_TRUE(k.climbed || k.stopped);
  }
}

TEST(GroundSteps, AFiveCentimetreKerbIsClimbedOrStopsTheTruckNeverStrandsItOnItsForks) {
  for (double lift : {0.0, 0.1}) {
    SCOPED_TRACE("forks lifted " + std::to_string(lift) + " m");
    const KerbOutcome k = kerb_outcome(0.05, lift);
    EXPECT_TRUE(k.climbed || k.stopped);
    if (lift > 0) {
      EXPECT_TRUE(k.climbed) << "with its forks clear, a wheel of 0.23 m climbs 5 cm";
    }
  }
}



TEST(GroundSteps, AnUnladenTruckDrivenObliquelyOffADocksSideOverturnsIntoTheYard) {
  // Heading 30 deg towards the dock's side edge (y = 1 m, the yard 1.2 m below) at 1 m/s, the foot
  // held: the front wheel on that side goes over first, the belly catches on the edge, and as the
  // truck is pushed on, its CoG passes the edge and it rolls off onto its side in the yard, the
  // three-wheel truck's dock accident. The edge presses on the belly at the end of its segment in
  // the belly where its depth is measured: at the segment's middle it put in 500 J here.
  const TruckParams& t = shipped_truck();
  const Ground g({}, {GroundStep{Eigen::AlignedBox2d(Eigen::Vector2d(-30, -10), Eigen::Vector2d(30, 1.0)), 1.2}});
  const Drive r = drive(g, 1.0, 14.0, 0.15, INFINITY, 30 * kDeg);
  record("side", r);
  EXPECT_GT(std::abs(r.end.q[kAuc]), t.tipped_over_rad) << "roll " << r.end.q[kAuc] / kDeg << " deg";
  EXPECT_LT(r.end.cog_m.z(), 0.8) << "in the yard, on its side";
  EXPECT_GT(r.end.cog_m.y(), 1.0) << "beyond the edge";
  EXPECT_LT(r.end.body_penetration_max_m, 0.03);
  EXPECT_LE(r.largest_rise_J, kSideFallRiseJ);
  EXPECT_LT(Eigen::Vector3d(r.end.qdot[kX], r.end.qdot[kY], r.end.qdot[kZ]).norm(), 0.05) << "at rest";
}
