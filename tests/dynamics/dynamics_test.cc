#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>

#include "forklift/dynamics/simulation.h"
#include "forklift/dynamics/stability.h"
#include "test_truck.h"

using namespace forklift;

namespace {

StateVector settled(const TruckDynamics& d, double lift = 0) {
  StateVector x = d.rest_state(0, 0, 0, 0, 0, lift, 0);
  EXPECT_TRUE(d.settle_static(x));
  return x;
}

Outputs eval(const TruckDynamics& d, const StateVector& x, const DriverInputs& u = {}, StateVector* dx_out = nullptr) {
  Outputs out;
  StateVector dx;
  EXPECT_TRUE(d.derivative(x, u, dx, &out));
  if (dx_out) *dx_out = dx;
  return out;
}

double sum_fz(const Outputs& o) { return o.wheels[0].fz_N + o.wheels[1].fz_N + o.wheels[2].fz_N; }

}  // namespace

TEST(Statics, WheelLoadsCarryTheWholeWeight) {
  TruckDynamics d(shipped_truck());
  Outputs o = eval(d, settled(d));
  EXPECT_NEAR(sum_fz(o), 3200 * kGravity_m_s2, 1e-6 * 3200 * kGravity_m_s2);
  EXPECT_NEAR(o.wheels[kFrontLeft].fz_N, o.wheels[kFrontRight].fz_N, 1e-6);

  d.attach_load(box_load(1000, 1, 1, 1, 0.5, 0));
  const StateVector x = settled(d, 1.0);
  o = eval(d, x);
  EXPECT_NEAR(sum_fz(o), 4200 * kGravity_m_s2, 1e-6 * 4200 * kGravity_m_s2);
  EXPECT_NEAR(o.total_mass_kg, 4200, 1e-9);
  // Moment balance about the front axle: rear load = W * (distance of the CoG behind it) / L.
  const double front_x = x[kX] + shipped_truck().wheels[kFrontLeft].centre_m.x();
  const double rear_expected = 4200 * kGravity_m_s2 * (front_x - o.cog_m.x()) / shipped_truck().wheelbase_m();
  EXPECT_NEAR(o.wheels[kRear].fz_N, rear_expected, 0.01 * rear_expected);
}

TEST(Statics, SettledStateHasNoAcceleration) {
  TruckDynamics d(shipped_truck());
  d.attach_load(box_load(800, 1, 1, 1, 0.5, 0.2));
  StateVector dx;
  eval(d, settled(d, 1.5), {}, &dx);
  EXPECT_LT(dx.segment<kNumDynamic>(StateIndex::kQdot).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(Statics, LiftActuatorHoldsTheWeightOfCarriageAndLoad) {
  // Eq (14): at rest, lambda for s is the weight on the forks (times cos of the mast's lean).
  TruckDynamics d(shipped_truck());
  d.attach_load(box_load(700, 1, 1, 1, 0.5, 0));
  const Outputs o = eval(d, settled(d, 1.2));
  const double w = (700 + shipped_truck().carriage.mass_kg) * kGravity_m_s2;
  EXPECT_NEAR(o.driven_force[kS - kNumDynamic], w, 0.002 * w);
  // The load ahead of the mast pulls it forward: the tilt cylinder must push back (negative).
  EXPECT_LT(o.driven_force[kBeta - kNumDynamic], -0.5 * 700 * kGravity_m_s2 * 0.5);
}

TEST(MassMatrix, SymmetricPositiveDefiniteAtRandomStates) {
  TruckDynamics d(shipped_truck());
  d.attach_load(box_load(1200, 1, 1, 1, 0.5, -0.3));
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 200; ++i) {
    StateVector x = StateVector::Zero();
    for (int k = 0; k < kNumDynamic; ++k) x[StateIndex::kQdot + k] = 3 * u(rng);
    x[kX] = 50 * u(rng); x[kY] = 50 * u(rng); x[kZ] = 0.6 + 0.2 * u(rng);
    x[kAwc] = M_PI * u(rng); x[kAuc] = 0.4 * u(rng); x[kAvc] = 0.4 * u(rng);
    x[kAvr1] = 100 * u(rng); x[kAvr2] = 100 * u(rng); x[kAvr3] = 100 * u(rng);
    const double driven[4] = {1.5 * u(rng), 0.1 * u(rng), 1.5 + 1.5 * u(rng), 0.1 * u(rng)};
    for (int k = 0; k < kNumDriven; ++k) x[StateIndex::kDriven + 3 * k] = driven[k];
    Eigen::Matrix<double, kNumCoords, kNumCoords> M;
    CoordVector Q;
    d.mass_matrix_and_forces(x, M, Q);
    EXPECT_LT((M - M.transpose()).norm(), 1e-10 * M.norm());
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, kNumCoords, kNumCoords>> eig(M);
    EXPECT_GT(eig.eigenvalues().minCoeff(), 0.0);
    // The total mass appears on the translational diagonal.
    EXPECT_NEAR(M(kX, kX), 4400, 1e-9);
  }
}

// The integrator's Jacobian takes q-dot's answer to the driven accelerations from
// driven_coupling instead of differences: it must be what derivative() does with z''.
TEST(MassMatrix, DrivenCouplingIsTheDerivativesAnswerToTheDrivenAccelerations) {
  TruckDynamics d(shipped_truck());
  d.attach_load(box_load(1200, 1, 1, 1, 0.5, -0.3));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  StateVector x = settled(d, 1.2);
  for (int k = 0; k < kNumDynamic; ++k) x[StateIndex::kQdot + k] += 0.5 * u(rng);
  for (int k = 0; k < kNumDriven; ++k) {
    x[StateIndex::kDriven + 3 * k + 1] = 0.05 * u(rng);
    x[StateIndex::kDriven + 3 * k + 2] = 0.2 * u(rng);
  }
  const DriverInputs in{};
  StateVector dx;
  ASSERT_TRUE(d.derivative(x, in, dx));
  Eigen::Matrix<double, kNumDynamic, kNumDriven> coupling;
  ASSERT_TRUE(d.driven_coupling(x, coupling));
  for (int k = 0; k < kNumDriven; ++k) {
    StateVector xs = x, dxs;
    xs[StateIndex::kDriven + 3 * k + 2] += 1.0;  // q'' is linear in z'': a unit step is exact
    ASSERT_TRUE(d.derivative(xs, in, dxs));
    const Eigen::Matrix<double, kNumDynamic, 1> diff = (dxs - dx).segment<kNumDynamic>(StateIndex::kQdot);
    EXPECT_LT((diff - coupling.col(k)).norm(), 1e-9 * (1 + coupling.col(k).norm())) << "driven " << k;
    EXPECT_GT(coupling.col(k).norm(), 0) << "driven " << k;  // every driven coordinate moves the truck
  }
  x[kZ] = NAN;
  EXPECT_FALSE(d.driven_coupling(x, coupling));
}

namespace {
// Energy after `seconds` of free motion from a bouncing, rolling, yawing start.
std::pair<double, double> energy_drift(double damping, double seconds) {
  TruckParams t = paper_truck();
  t.contact.damping_N_s_m = damping;
  t.contact.fx_slip_gain_s_m = 0;
  t.contact.fy_mu = 0;
  t.contact.rolling_resistance_N_m_s = 0;
  TruckDynamics d(t);
  d.attach_load(box_load(600, 1, 1, 1, 0.5, 0.2));
  StateVector x = d.rest_state(0, 0, 0.3, 0, 0.02, 1.0, 0.05);
  x[kZ] += 0.03;  // dropped from 3 cm: the wheels leave and meet the ground
  x[StateIndex::kQdot + kX] = 1.5;
  x[StateIndex::kQdot + kAwc] = 0.4;
  x[StateIndex::kQdot + kAuc] = 0.1;
  x[StateIndex::kQdot + kAvr1] = 4;
  x[StateIndex::kQdot + kAvr3] = -2;
  IntegratorOptions o;
  o.rtol = 1e-10;
  Simulation sim(d, x, o);
  const double e0 = d.energy(sim.state());
  sim.advance_to(seconds);
  return {e0, d.energy(sim.state())};
}
}  // namespace

TEST(Energy, ConservedWithoutFrictionDampingOrTorque) {
  const auto [e0, e1] = energy_drift(0, 3.0);
  EXPECT_NEAR(e1, e0, 1e-6 * std::abs(e0));
}

TEST(Energy, DampingDissipatesIt) {
  // The same run with the paper's damper must lose energy: the test above can fail.
  const auto [e0, e1] = energy_drift(3.3e3, 3.0);
  EXPECT_LT(e1, e0 - 10.0);
}

namespace {
// The training truck rolled about its right front wheel's contact, so its left front wheel is
// `lift_m` up (and the rear wheel half that), released at rest or rolling forward at `speed` with
// the rear wheel steered `steer` (its tyres then slip sideways, their tread deflected, while the
// load comes onto them): the energy (kinetic, gravity, the tyres' vertical springs and deflected
// tread) from the last instant the left wheel is in the air, and the largest and last values in
// the 2 s after it lands, every millisecond. Nothing drives or brakes the truck, so the energy may
// only fall.
struct Landing { double before = NAN, largest_after = -INFINITY, last = NAN; };
Landing drop_a_wheel(double lift_m, double speed, double steer = 0) {
  const TruckDynamics d(shipped_truck());
  StateVector x = settled(d);
  x[StateIndex::kDriven] = steer;
  const double roll = std::asin(lift_m / shipped_truck().front_track_m());
  const double h = x[StateIndex::kQ + kZ], half = 0.5 * shipped_truck().front_track_m();
  x[StateIndex::kQ + kAuc] = roll;  // about the chassis' x axis through the right wheel's contact
  x[StateIndex::kQ + kY] += half * (std::cos(roll) - 1) - h * std::sin(roll);
  x[StateIndex::kQ + kZ] += half * std::sin(roll) + h * (std::cos(roll) - 1);
  x[StateIndex::kQdot + kX] = speed;
  for (int w = 0; w < kNumWheels; ++w) x[StateIndex::kQdot + kAvr1 + w] = speed / shipped_truck().wheels[w].radius_m;
  IntegratorOptions o;
  o.rtol = 1e-8;
  Simulation sim(d, x, o);
  Landing l;
  bool landed = false;
  for (int k = 1; k <= 3000 && !(landed && sim.time() > 2.0); ++k) {
    sim.advance_to(k * 1e-3);
    const double e = d.energy(sim.state());
    const bool down = sim.outputs().wheels[kFrontLeft].fz_N > 0;
    if (!down && !landed) l.before = e;
    landed = landed || (down && !std::isnan(l.before));
    if (landed) l.largest_after = std::max(l.largest_after, e);
    l.last = e;
  }
  return l;
}
}  // namespace

TEST(Energy, AWheelLandingDissipatesItNeverCreatesIt) {
  for (double steer : {0.0, 0.3})
    for (double speed : {0.0, 3.0})
      for (double lift : {0.02, 0.05}) {
        if (steer != 0 && speed == 0) continue;
        const std::string name = std::to_string(std::lround(lift * 100)) + "cm_" + std::to_string(std::lround(speed)) + "m_s_steer_" +
                                 std::to_string(std::lround(steer / kDeg)) + "deg";
        SCOPED_TRACE("left front wheel dropped: " + name);
        const Landing l = drop_a_wheel(lift, speed, steer);
        ASSERT_FALSE(std::isnan(l.before)) << "the wheel was in the air, then landed";
        RecordProperty("energy_change_J_" + name,
                       std::to_string(l.largest_after - l.before) + " largest, " + std::to_string(l.last - l.before) + " after 2 s");
        EXPECT_LE(l.largest_after, l.before + 1e-3);  // the integrator's error at rtol 1e-8, no more
        EXPECT_LT(l.last, l.before - 1.0);  // the tyres' damping and friction took some
      }
}

TEST(GroundForces, NoForceOffTheGroundAndFreeFall) {
  TruckDynamics d(shipped_truck());
  StateVector x = d.rest_state(0, 0, 0);
  x[kZ] += 0.5;
  StateVector dx;
  const Outputs o = eval(d, x, {}, &dx);
  for (const WheelContact& c : o.wheels) {
    EXPECT_FALSE(c.on_ground);
    EXPECT_EQ(c.fz_N, 0.0);
    EXPECT_EQ(c.fx_N, 0.0);
  }
  EXPECT_NEAR(dx[StateIndex::kQdot + kZ], -kGravity_m_s2, 1e-9);
}

namespace {
// The rear tyre's steady lateral force per unit load, |Fy| / Fz, with the truck rolling at 3 m/s
// and sliding sideways at the slip angle `alpha`. The bristle's rate is affine in its deflection,
// z' = a - b z, so two evaluations of the model give the steady deflection a / b it settles to.
double steady_lateral_grip(const TruckParams& t, double alpha) {
  const TruckDynamics d(t);
  StateVector x = settled(d);
  const double v = 3.0;
  x[StateIndex::kQdot + kX] = v;
  x[StateIndex::kQdot + kY] = v * std::tan(alpha);
  for (int w = 0; w < kNumWheels; ++w) x[StateIndex::kQdot + kAvr1 + w] = v / t.wheels[w].radius_m;
  const int zy = StateIndex::kTyre + 2 * kRear + 1;
  StateVector dx0, dx1;
  x[zy] = 0;
  eval(d, x, {}, &dx0);
  x[zy] = 1;
  eval(d, x, {}, &dx1);
  x[zy] = dx0[zy] / (dx0[zy] - dx1[zy]);
  StateVector dx;
  const Outputs o = eval(d, x, {}, &dx);
  EXPECT_NEAR(dx[zy], 0, 1e-9);
  return std::abs(o.wheels[kRear].fy_N) / o.wheels[kRear].fz_N;
}
}  // namespace

TEST(GroundForces, AGripPeakTyreRisesToItsPeakThenDropsToItsSlidingGrip) {
  // Pacejka's and TMeasy's shape: the force rises with the slip to the peak, then falls as the
  // contact slides. The brush without a peak only ever rises towards its grip.
  const ContactParams& c = shipped_truck().contact;
  double peak = 0, peak_at = 0;
  for (double deg = 0.5; deg <= 60; deg += 0.5) {
    const double f = steady_lateral_grip(shipped_truck(), deg * kDeg);
    if (f > peak) { peak = f; peak_at = deg; }
  }
  RecordProperty("lateral_peak", std::to_string(peak) + " at " + std::to_string(peak_at) + " deg");
  EXPECT_NEAR(peak, c.mu_static, 0.05 * c.mu_static);  // mu_static holds the peak
  EXPECT_GT(peak_at, 4);
  EXPECT_LT(peak_at, 16);
  EXPECT_NEAR(steady_lateral_grip(shipped_truck(), 45 * kDeg), c.mu_sliding, 0.02);
  EXPECT_NEAR(steady_lateral_grip(shipped_truck(), 60 * kDeg), c.mu_sliding, 0.02);
  double last = 0;
  for (double deg : {2.0, 5.0, 10.0, 20.0, 40.0, 60.0}) {
    const double f = steady_lateral_grip(brush_truck(), deg * kDeg);
    EXPECT_GT(f, last) << deg << " deg";
    last = f;
  }
}

TEST(GroundForces, LongitudinalForceSaturatesAtFxMax) {
  // A locked wheel sliding at 3 m/s: eq (8) asks for k Fz sx, well above 4500 N.
  TruckDynamics d(paper_truck());
  StateVector x = settled(d);
  x[StateIndex::kQdot + kX] = 3.0;
  const Outputs o = eval(d, x);
  EXPECT_DOUBLE_EQ(o.wheels[kFrontLeft].fx_N, -4500);
  EXPECT_NEAR(o.wheels[kRear].slip_x_m_s, 3.0, 1e-9);
  // Rolling freely at the same speed there is no slip and no force. The contact point is below
  // the centre by the compressed radius, so that is the rolling radius.
  const double rolling_radius = paper_truck().wheels[kFrontLeft].radius_m - o.wheels[kFrontLeft].penetration_m;
  x[StateIndex::kQdot + kAvr1] = 3.0 / rolling_radius;
  EXPECT_NEAR(eval(d, x).wheels[kFrontLeft].fx_N, 0.0, 1.0);
}

TEST(GroundForces, LateralForceFollowsEq10AndSurvivesReversing) {
  TruckDynamics d(paper_truck());
  StateVector x = settled(d);
  const double mu = paper_truck().contact.fy_mu;
  for (double vx : {2.0, -2.0}) {  // forward and reversing: the same slip angle, no 180 deg flip
    x[StateIndex::kQdot + kX] = vx;
    x[StateIndex::kQdot + kY] = 2.0 * std::tan(3.0 * M_PI / 180);  // 3 deg of side slip to the left
    const Outputs o = eval(d, x);
    const WheelContact& c = o.wheels[kFrontLeft];
    EXPECT_NEAR(c.slip_angle_rad, 3.0 * M_PI / 180, 2e-3);
    EXPECT_NEAR(c.fy_N, -mu * c.fz_N * std::sin(M_PI * c.slip_angle_rad / (2 * 7.5 * M_PI / 180)), 1e-6);
    EXPECT_LT(c.fy_N, 0);
  }
  x[StateIndex::kQdot + kX] = 2.0;
  x[StateIndex::kQdot + kY] = 2.0;  // 45 deg: saturated
  const Outputs o = eval(d, x);
  EXPECT_NEAR(o.wheels[kRear].fy_N, -mu * o.wheels[kRear].fz_N, 1e-9);
}

TEST(TorqueSplit, FourCriteriaOfSection6) {
  TruckDynamics d(shipped_truck());
  StateVector x = settled(d);
  x[StateIndex::kTorque] = 400;
  const double phi_c = std::atan(2 * shipped_truck().wheelbase_m() / shipped_truck().front_track_m());
  auto torques = [&](double phi) {
    StateVector s = x;
    s[StateIndex::kDriven] = phi;
    const Outputs o = eval(d, s);
    return std::pair(o.wheels[kFrontLeft].drive_torque_N_m, o.wheels[kFrontRight].drive_torque_N_m);
  };
  auto [m1, m2] = torques(0);  // (1) equal halves
  EXPECT_NEAR(m1, 200, 1e-6);
  EXPECT_NEAR(m2, 200, 1e-6);
  std::tie(m1, m2) = torques(phi_c);  // (2) the wheel at the centre of rotation gets nothing
  EXPECT_NEAR(m1, 400, 1e-6);
  EXPECT_NEAR(m2, 0, 1e-6);
  std::tie(m1, m2) = torques(M_PI / 2);  // (3) opposite halves at 90 deg
  EXPECT_NEAR(m1, -m2, 1e-6);
  for (double phi = -1.5; phi <= 1.5; phi += 0.1) {  // (4) |M1| + |M2| = M
    std::tie(m1, m2) = torques(phi);
    EXPECT_NEAR(std::abs(m1) + std::abs(m2), 400, 1e-6) << phi;
  }
}

TEST(TorqueSplit, WeightedByEachWheelsShareOfFz) {
  TruckDynamics d(shipped_truck());
  d.attach_load(box_load(1000, 1, 1, 1, 0.5, 0.6));  // load to the left
  StateVector x = settled(d, 1.0);
  x[StateIndex::kTorque] = -300;  // reversing too
  const Outputs o = eval(d, x);
  const WheelContact &l = o.wheels[kFrontLeft], &r = o.wheels[kFrontRight];
  ASSERT_GT(l.fz_N, 1.2 * r.fz_N);
  EXPECT_NEAR(l.drive_torque_N_m / r.drive_torque_N_m, l.fz_N / r.fz_N, 1e-9);
  EXPECT_NEAR(l.drive_torque_N_m + r.drive_torque_N_m, -300, 1e-9);
}

TEST(Braking, OpposesRotationAndFadesToZeroAtStandstill) {
  TruckDynamics d(paper_truck());
  StateVector x = settled(d);
  x[StateIndex::kBrake] = 1000;
  for (double spin : {5.0, -5.0, 0.0, 0.05}) {
    x[StateIndex::kQdot + kAvr1] = spin;
    const double t = eval(d, x).wheels[kFrontLeft].brake_torque_N_m;
    if (spin == 0) {
      EXPECT_EQ(t, 0.0);
    } else {
      EXPECT_LT(t * spin, 0.0);
    }
    if (std::abs(spin) >= 5) {
      EXPECT_NEAR(std::abs(t), 1000, 1e-3);
    }
    if (std::abs(spin) < 0.1) {
      EXPECT_LT(std::abs(t), 150);
    }
  }
}

TEST(Braking, PedalStepReachesTheWheelThroughAFirstOrderLag) {
  TruckDynamics d(shipped_truck());
  Simulation sim(d, settled(d), {});
  DriverInputs u;
  u.brake_torque_N_m = 1000;
  sim.set_inputs(u);
  const double lag = shipped_truck().drive.brake_lag_s;
  sim.advance_to(lag);
  EXPECT_NEAR(sim.state()[StateIndex::kBrake], 1000 * (1 - std::exp(-1.0)), 5);
}

TEST(DrivenCoordinates, SteerFollowsWithoutJumpInReactionForce) {
  TruckDynamics d(paper_truck());
  Simulation sim(d, settled(d), {});
  const Outputs before = sim.outputs();
  DriverInputs u;
  u.steer_rad = 0.5;
  sim.set_inputs(u);
  const Outputs after = sim.outputs();  // same state, new input: z'' is a state, so no jump
  EXPECT_NEAR(after.driven_force[0], before.driven_force[0], 1e-9);
  sim.advance_to(0.6);
  EXPECT_NEAR(sim.state()[StateIndex::kDriven], 0.5, 0.01);
}

TEST(DrivenCoordinates, SteerKeepsItsRateLimitAndEndStopsWhateverTheCabAsks) {
  // Past full left to past full right, then a cab jerking between them every 50 ms: the servo never turns
  // the wheel faster than the truck file's rate limit nor past its end stops.
  const TruckParams& t = shipped_truck();
  TruckDynamics d(t);
  Simulation sim(d, settled(d), {});
  double rate = 0, angle = 0;
  for (int k = 1; k <= 400; ++k) {
    DriverInputs u;
    u.steer_rad = k <= 150 ? 2.0 : k <= 300 ? -2.0 : ((k / 5) % 2 ? 2.0 : -2.0);  // beyond the end stops
    sim.set_inputs(u);
    sim.advance_to(k * 0.01);
    rate = std::max(rate, std::abs(sim.outputs().qdot[kAwr3]));
    angle = std::max(angle, std::abs(sim.outputs().q[kAwr3]));
  }
  EXPECT_LE(rate, t.steer.rate_max_rad_s * 1.001);
  EXPECT_GT(rate, t.steer.rate_max_rad_s * 0.9) << "a full-lock step reaches the rate limit";
  EXPECT_LE(angle, t.steer.max_rad + 1e-4);
  EXPECT_GT(angle, t.steer.max_rad - 0.01) << "full lock reached";
}

TEST(DrivenCoordinates, LiftStopsAtItsLimit) {
  TruckDynamics d(shipped_truck());
  Simulation sim(d, settled(d), {});
  DriverInputs u;
  u.lift_rate_m_s = 10;  // beyond the truck's 0.45 m/s: clamped
  sim.set_inputs(u);
  sim.advance_to(1.0);
  EXPECT_NEAR(sim.state()[StateIndex::kDriven + 3 * 2 + 1], 0.45, 0.01);
  sim.advance_to(12.0);
  const double s = sim.state()[StateIndex::kDriven + 3 * 2];
  EXPECT_LE(s, shipped_truck().limits.lift_max_m + 0.005);
  EXPECT_GT(s, shipped_truck().limits.lift_max_m - 0.05);
}

TEST(Load, AttachedAndReleasedAtRunTime) {
  TruckDynamics d(shipped_truck());
  Simulation sim(d, settled(d, 0.3), {});
  sim.advance_to(0.5);
  sim.attach_load(box_load(900, 1, 1, 1, 0.5, 0));
  EXPECT_NEAR(sim.outputs().total_mass_kg, 4100, 1e-9);
  sim.advance_to(10.0);  // the truck bounces and settles under the new weight
  EXPECT_NEAR(sum_fz(sim.outputs()), 4100 * kGravity_m_s2, 0.01 * 4100 * kGravity_m_s2);
  sim.release_load();
  EXPECT_NEAR(sim.outputs().total_mass_kg, 3200, 1e-9);
  sim.advance_to(20.0);
  EXPECT_NEAR(sum_fz(sim.outputs()), 3200 * kGravity_m_s2, 0.01 * 3200 * kGravity_m_s2);
}

TEST(Ground, RampHeightIsSmoothAndItsGradientMatches) {
  Ramp r;
  r.start_m = {2, -1};
  r.heading_rad = 0.3;
  r.length_m = 4;
  r.width_m = 3;
  r.rise_m = 0.4;
  r.plateau_m = 5;
  const Ground g({r});
  for (double s = 0.1; s < 9; s += 0.37) {
    const double x = 2 + s * std::cos(0.3), y = -1 + s * std::sin(0.3);
    const double h = 1e-6;
    const Eigen::Vector2d fd((g.height(x + h, y) - g.height(x - h, y)) / (2 * h), (g.height(x, y + h) - g.height(x, y - h)) / (2 * h));
    EXPECT_LT((fd - g.gradient(x, y)).norm(), 1e-5) << s;
  }
  EXPECT_DOUBLE_EQ(g.height(2 + 6 * std::cos(0.3), -1 + 6 * std::sin(0.3)), 0.4);  // on the plateau
  EXPECT_DOUBLE_EQ(g.height(-5, 0), 0.0);
}

TEST(Ground, TruckStandsHigherOnADockPlate) {
  Ramp plate;
  plate.start_m = {-10, 0};
  plate.length_m = 2;
  plate.width_m = 4;
  plate.rise_m = 0.15;
  plate.plateau_m = 20;
  Environment env;
  env.ground = Ground({plate});
  TruckDynamics flat(shipped_truck()), raised(shipped_truck(), env);
  StateVector a = flat.rest_state(0, 0, 0), b = raised.rest_state(0, 0, 0);
  ASSERT_TRUE(flat.settle_static(a));
  ASSERT_TRUE(raised.settle_static(b));
  EXPECT_NEAR(b[kZ] - a[kZ], 0.15, 1e-6);
}

TEST(Ground, TruckDrivesUpARamp) {
  // 0.3 m over 6 m: 7.5% at its steepest, within what 800 N m can climb (about 11%).
  Ramp ramp;
  ramp.start_m = {2, 0};
  ramp.length_m = 6;
  ramp.width_m = 4;
  ramp.rise_m = 0.3;
  ramp.plateau_m = 30;
  Environment env;
  env.ground = Ground({ramp});
  TruckDynamics d(shipped_truck(), env);
  // Forks carried 15 cm up, as a driver travels: lowered, their tips would dig into the ramp.
  StateVector x = d.rest_state(0, 0, 0, 0, 0, 0.15);
  ASSERT_TRUE(d.settle_static(x));
  Simulation sim(d, x, {});
  DriverInputs u;
  u.drive_torque_N_m = 800;
  sim.set_inputs(u);
  sim.advance_to(7.0);
  ASSERT_GT(sim.state()[kX], 9.0);   // the rear wheel too is on the plateau,
  ASSERT_LT(sim.state()[kX], 37.0);  // and the front has not reached its far edge
  EXPECT_NEAR(sim.state()[kZ] - x[kZ], 0.3, 0.01);
}

TEST(BadInput, NonFiniteStateIsRefusedNotIntegrated) {
  TruckDynamics d(shipped_truck());
  StateVector x = settled(d), dx;
  x[StateIndex::kQdot + kY] = NAN;
  EXPECT_FALSE(d.derivative(x, {}, dx));
  EXPECT_THROW(Simulation(d, x, {}), std::invalid_argument);
  EXPECT_THROW(parse_integrator("euler"), std::invalid_argument);
}

TEST(Stability, StaticReportOfTheRatedLoad) {
  const StaticReport r = static_report(shipped_truck(), box_load(1600, 1, 1, 1, 0.5, 0), 0.05);
  EXPECT_TRUE(r.settled);
  EXPECT_FALSE(r.rear_wheel_lifted);
  EXPECT_GT(r.fz_N[kRear], 0.03 * 4800 * kGravity_m_s2);  // a counterbalance truck keeps a margin at rated load
  EXPECT_NEAR(r.wheel_contact_m[kFrontLeft].x(), 0.0, 0.01);  // geometry frame: front axle at x = 0
  EXPECT_NEAR(r.wheel_contact_m[kRear].x(), -1.25, 0.01);
  // Twice the rated load tips it.
  EXPECT_TRUE(static_report(shipped_truck(), box_load(3200, 1, 1, 1, 0.5, 0), 0.05).rear_wheel_lifted);
}

TEST(Stability, LateralTiltAngleMatchesTheStabilityTriangle) {
  // Rigid closed form: the table tilts about the truck's x axis, so the CoG's projection along
  // gravity moves h tan(a) to the right, which crosses the edge from the right front wheel to
  // the rear wheel (normal n) when h tan(a) |n.y| equals the CoG's distance to that edge.
  const TruckParams& t = shipped_truck();
  const StaticReport s = static_report(t, std::nullopt, 0);
  const Eigen::Vector2d a = s.wheel_contact_m[kFrontRight], b = s.wheel_contact_m[kRear];
  const Eigen::Vector2d c = s.cog_m.head<2>();
  const Eigen::Vector2d e = (b - a).normalized();
  const double dist = std::abs(e.x() * (c - a).y() - e.y() * (c - a).x());
  const double rigid = std::atan(dist / (s.cog_m.z() * std::abs(e.x()))) * 180 / M_PI;  // |n.y| = |e.x|
  const TiltResult r = tilt_table(t, std::nullopt, 0, TiltAxis::kLateral);
  EXPECT_EQ(r.lifted_wheel, kFrontLeft);
  // The tyres' compliance lets the CoG move towards the edge: a little below the rigid value.
  EXPECT_LT(r.critical_angle_deg, rigid);
  EXPECT_GT(r.critical_angle_deg, 0.85 * rigid);
}

TEST(Stability, LoadHighUpTipsForwardSooner) {
  const TruckParams& t = shipped_truck();
  const Load l = box_load(1000, 1, 1, 1, 0.5, 0);
  const TiltResult low = tilt_table(t, l, 0.05, TiltAxis::kLongitudinal);
  const TiltResult high = tilt_table(t, l, 2.5, TiltAxis::kLongitudinal);
  EXPECT_EQ(low.lifted_wheel, kRear);
  EXPECT_LT(high.critical_angle_deg, low.critical_angle_deg);
}
