// The physical facts of the paper's section 11, on the default integrator (CVODE BDF).
#include <gtest/gtest.h>

#include <map>

#include "forklift/dynamics/manoeuvre.h"
#include "forklift/dynamics/stability.h"
#include "test_truck.h"

using namespace forklift;

namespace {

const ManoeuvreResult& run(int n, IntegratorKind kind = IntegratorKind::kCvodeBdf) {
  static std::map<std::pair<int, IntegratorKind>, ManoeuvreResult> cache;
  auto key = std::pair(n, kind);
  auto it = cache.find(key);
  if (it == cache.end()) {
    IntegratorOptions o;
    o.kind = kind;
    it = cache.emplace(key, run_manoeuvre(paper_truck(), n, o, 0.002)).first;
  }
  return it->second;
}

const Sample& at(const ManoeuvreResult& r, double t) {
  for (const Sample& s : r.samples) if (std::abs(s.t - t) < 1e-9) return s;
  throw std::runtime_error("no sample at t = " + std::to_string(t));
}

double static_rear_fz(int n) {
  const ManoeuvreSpec m = manoeuvre(n, paper_truck());
  return static_report(paper_truck(), m.load, m.lift_m).fz_N[kRear];
}

}  // namespace

TEST(Manoeuvre, UnknownNumberIsRefused) {
  EXPECT_THROW(manoeuvre(6, paper_truck()), std::invalid_argument);
}

TEST(Manoeuvre, StartingTorqueAcceleratesWithoutSlidingTheWheels) {
  // Manoeuvres 1-3: more torque, more slip and more speed; Fx max is reached only in braking.
  const ManoeuvreResult &m1 = run(1), &m2 = run(2);
  EXPECT_GT(m2.final_pose.x(), 1.5 * m1.final_pose.x());
  for (int n : {1, 2, 3}) {
    for (const Sample& s : run(n).samples) EXPECT_LT(std::abs(s.out.wheels[kFrontLeft].fx_N), 4500.0);
    EXPECT_FALSE(run(n).rear_wheel_lifted);
  }
  EXPECT_GT(std::abs(at(m2, 10).out.wheels[kFrontLeft].slip_x_m_s), 1.5 * std::abs(at(m1, 10).out.wheels[kFrontLeft].slip_x_m_s));
  // Accelerating, the truck squats back: pitch (+ nose down) is below its static value.
  EXPECT_LT(at(m2, 1).out.q[kAvc], m2.samples.front().out.q[kAvc]);
}

// The time from brake onset until the forward speed falls below `threshold` (0.05 or 0.1 m/s).
double stop_time(const ManoeuvreResult& r, double threshold) {
  for (const ManoeuvreResult::StopTime& stop : r.stop_times)
    if (stop.below_m_s == threshold) return stop.s.value_or(INFINITY);
  ADD_FAILURE() << "no stop time below " << threshold;
  return NAN;
}

TEST(Manoeuvre, HardBrakingUnloadsTheRearWheelAndStopsInAboutOneAndAHalfSeconds) {
  // Manoeuvre 4: "the rear wheel looses contact with the ground and the time spent for braking is
  // 1.5 seconds. The pitch angle reaches a maximum value of 1 deg." Its load falls to zero; it
  // rises less than 2 mm, so we claim the unloading, not a visible lift. The paper does not say
  // when it counts the truck as stopped: below 0.1 m/s it matches (below 0.05 m/s it takes 2 s).
  const ManoeuvreResult& r = run(4);
  EXPECT_EQ(r.min_fz_N[kRear], 0.0);
  EXPECT_FALSE(r.tipped_over);
  EXPECT_NEAR(stop_time(r, 0.1), 1.5, 0.15 * 1.5);
  EXPECT_GT(stop_time(r, 0.05), stop_time(r, 0.1));
  EXPECT_GT(r.max_pitch_deg, 0.5);
  EXPECT_LT(r.max_pitch_deg, 1.5);
  // The front tyres slide: Fx reaches Fx max just after the brake comes on.
  double strongest = 0;
  for (const Sample& s : r.samples) if (s.t > 10 && s.t < 10.5) strongest = std::min(strongest, s.out.wheels[kFrontLeft].fx_N);
  EXPECT_DOUBLE_EQ(strongest, -4500.0);
}

TEST(Manoeuvre, GentlerBrakingNearlyLiftsItAndTakesTwoSeconds) {
  // Manoeuvre 5: "the wheel nearly looses contact and spends 2 seconds for braking".
  const ManoeuvreResult &r5 = run(5), &r4 = run(4);
  EXPECT_GT(r5.min_fz_N[kRear], 0.0);
  EXPECT_LT(r5.min_fz_N[kRear], 0.6 * static_rear_fz(5));
  EXPECT_NEAR(stop_time(r5, 0.1), 2.0, 0.15 * 2.0);
  EXPECT_GT(stop_time(r5, 0.1), stop_time(r4, 0.1) + 0.2);
}

TEST(Manoeuvre, MetricsAloneAreTheSeriesOwnFiguresBitForBit) {
  // forklift-sim manoeuvre without --csv or --plot keeps the metrics alone (Sampling::kMetrics,
  // the wheels' loads without the rest of the model): the same figures as a run that keeps every
  // output, bit for bit; 4 stops and unloads its rear wheel, 14 turns laden.
  for (int n : {4, 14}) {
    SCOPED_TRACE(n);
    const ManoeuvreResult& series = run(n);
    const ManoeuvreResult metrics = run_manoeuvre(paper_truck(), n, {}, 0.002, Sampling::kMetrics);
    EXPECT_TRUE(metrics.samples.empty());
    ASSERT_FALSE(series.samples.empty());
    EXPECT_EQ(metrics.max_pitch_deg, series.max_pitch_deg);
    EXPECT_EQ(metrics.max_roll_deg, series.max_roll_deg);
    for (int w = 0; w < kNumWheels; ++w) {
      double lowest = INFINITY;
      for (const Sample& s : series.samples) lowest = std::min(lowest, s.out.wheels[w].fz_N);
      EXPECT_EQ(metrics.min_fz_N[w], lowest) << wheel_name(w);
    }
    EXPECT_EQ(metrics.rear_wheel_lifted, series.rear_wheel_lifted);
    EXPECT_EQ(metrics.tipped_over, series.tipped_over);
    for (size_t k = 0; k < series.stop_times.size(); ++k) EXPECT_EQ(metrics.stop_times[k].s, series.stop_times[k].s);
    EXPECT_EQ(metrics.final_pose, series.final_pose);
  }
}

TEST(Manoeuvre, OuterWheelCarriesMoreWhenTurning) {
  // Manoeuvres 10-12: the rear wheel peaks at t = 10.5 s, turning right: left is outside.
  for (int n : {10, 11, 12}) {
    const Outputs& before = at(run(n), 7.9).out;
    const Outputs& turning = at(run(n), 10.5).out;
    EXPECT_NEAR(before.wheels[kFrontLeft].fz_N, before.wheels[kFrontRight].fz_N, 50) << n;
    EXPECT_GT(turning.wheels[kFrontLeft].fz_N, turning.wheels[kFrontRight].fz_N + 2000) << n;
    EXPECT_GT(turning.wheels[kFrontLeft].fz_N, before.wheels[kFrontLeft].fz_N + 1000) << n;
    EXPECT_LT(run(n).final_pose.z(), -0.5) << n;  // it turned right
  }
}

TEST(Manoeuvre, UnbalancedLoadTurnsTheTruckWithZeroSteer) {
  // Manoeuvre 14: the left wheel carries more Fz, gets more torque, and the truck turns right.
  const ManoeuvreResult& r = run(14);
  const Sample& s = at(r, 15.0);
  EXPECT_LT(std::abs(s.out.q[kAwr3]), 0.01);
  EXPECT_GT(s.out.wheels[kFrontLeft].fz_N, 2 * s.out.wheels[kFrontRight].fz_N);
  EXPECT_GT(s.out.wheels[kFrontLeft].drive_torque_N_m, 2 * s.out.wheels[kFrontRight].drive_torque_N_m);
  EXPECT_LT(s.out.q[kAwc] * kRad, -5.0);
}

TEST(Manoeuvre, SharpTurnWithUnbalancedLoadSaturatesTheFrontTyres) {
  // Manoeuvre 15: both front slip angles exceed alpha0, Fy saturates, and the right wheel
  // almost loses contact.
  const ManoeuvreResult& r = run(15);
  const double a0 = paper_truck().contact.fy_alpha0_rad, mu = paper_truck().contact.fy_mu;
  for (int w : {kFrontLeft, kFrontRight}) {
    bool passed = false, saturated = false;
    for (const Sample& s : r.samples) {
      const WheelContact& c = s.out.wheels[w];
      if (s.t < 15 || c.fz_N <= 0) continue;
      if (std::abs(c.slip_angle_rad) > a0) {
        passed = true;
        saturated |= std::abs(std::abs(c.fy_N) - mu * c.fz_N) < 1e-6;
      }
    }
    EXPECT_TRUE(passed) << wheel_name(w);
    EXPECT_TRUE(saturated) << wheel_name(w);
  }
  const double right_before = at(r, 14.9).out.wheels[kFrontRight].fz_N;
  EXPECT_GT(r.min_fz_N[kFrontRight], 0.0);
  EXPECT_LT(r.min_fz_N[kFrontRight], 0.25 * right_before);
  EXPECT_FALSE(r.tipped_over);
}

TEST(Manoeuvre, IntegratorsAgreeOnTheZigZag) {
  // Manoeuvre 17, a normal operating manoeuvre: "all three integrators give analogous results".
  // Each is compared with a converged CVODE run (rtol 1e-9): after 50 m of zig-zag the default
  // tolerance leaves CVODE itself several cm from it, so a rounding change in the model moves the
  // default run by cm, and comparing the integrators with that run measured its tolerance.
  IntegratorOptions tight;
  tight.rtol = 1e-9;
  const ManoeuvreResult ref = run_manoeuvre(paper_truck(), 17, tight, 0.002);
  const ManoeuvreResult &bdf = run(17), &dp = run(17, IntegratorKind::kDopri5), &rk = run(17, IntegratorKind::kRk4);
  for (const ManoeuvreResult* r : {&bdf, &dp, &rk}) {
    // CVODE at the default rtol (chosen for manoeuvre 4's 1 cm) ends 18 cm and 2.3 deg of
    // heading from the converged run here; the explicit methods within 1 cm.
    const bool loose = r == &bdf;
    EXPECT_LT((r->final_pose.head<2>() - ref.final_pose.head<2>()).norm(), loose ? 0.25 : 0.10);
    EXPECT_LT(std::abs(r->final_pose.z() - ref.final_pose.z()) * kRad, loose ? 3.0 : 1.5);
    EXPECT_NEAR(r->max_roll_deg, ref.max_roll_deg, 0.05);
  }
}

TEST(Manoeuvre, StiffnessDependsOnTheForcing) {
  // Section 12: the explicit method needs far more steps on the sharp braking than on the
  // zig-zag; the implicit one does not.
  const long dp4 = run(4, IntegratorKind::kDopri5).stats.steps, dp17 = run(17, IntegratorKind::kDopri5).stats.steps;
  EXPECT_GT(dp4, 2 * dp17);
  EXPECT_LT(run(4).stats.steps, dp4 / 5);
}

TEST(Manoeuvre, WorkEnergyBalanceClosesWithEveryForceOn) {
  // d(kinetic + gravitational energy)/dt is the power of every other force: tyres, ground
  // springs and dampers, rolling resistance, drive and brakes, and the actuators on the driven
  // coordinates. Integrated (Simpson, 0.5 ms) along a tightly solved run, it must account for the
  // energy's change to 1e-4 of the largest change on the way, on both trucks.
  for (const TruckParams* truck : {&paper_truck(), &shipped_truck()})
    for (int n : {4, 15, 17}) {
      SCOPED_TRACE(truck->name + ", manoeuvre " + std::to_string(n));
      const ManoeuvreSpec spec = manoeuvre(n, *truck);
      TruckDynamics dyn(*truck);
      if (spec.load) dyn.attach_load(*spec.load);
      StateVector x0 = dyn.rest_state(0, 0, 0, 0, 0, spec.lift_m, 0);
      ASSERT_TRUE(dyn.settle_static(x0));
      IntegratorOptions o;
      o.rtol = 1e-9;
      Simulation sim(dyn, x0, o);
      sim.set_input_schedule(spec.inputs);
      const double e0 = dyn.energy(x0, false), h = 5e-4;
      double work = 0, peak = 0, p_prev = sim.outputs().applied_power_W;
      for (int k = 1; k <= int(std::llround(spec.duration_s / (2 * h))); ++k) {
        const double t0 = 2 * (k - 1) * h;
        sim.advance_to(t0 + h, 20.0);
        const double p_mid = sim.outputs().applied_power_W;
        sim.advance_to(t0 + 2 * h, 20.0);
        const double p_end = sim.outputs().applied_power_W;
        work += h / 3 * (p_prev + 4 * p_mid + p_end);
        p_prev = p_end;
        peak = std::max(peak, std::abs(dyn.energy(sim.state(), false) - e0));
      }
      ASSERT_GT(peak, 100.0);  // the truck did work: a kilojoule-scale balance
      EXPECT_NEAR(dyn.energy(sim.state(), false) - e0, work, 1e-4 * peak);
    }
}

TEST(Manoeuvre, DefaultToleranceHoldsManoeuvre4WithinACentimetreInAtMost500Steps) {
  // The accuracy goal, on both shipped trucks: CVODE at its default tolerance (with the
  // structured Newton solver and Jacobian) against a converged run.
  for (const TruckParams* truck : {&paper_truck(), &shipped_truck()}) {
    SCOPED_TRACE(truck->name);
    IntegratorOptions tight;
    tight.rtol = 1e-9;
    const ManoeuvreResult ref = run_manoeuvre(*truck, 4, tight, 0);
    const ManoeuvreResult r = run_manoeuvre(*truck, 4, IntegratorOptions{}, 0);
    EXPECT_LE(r.stats.steps, 500);
    EXPECT_LT((r.final_pose.head<2>() - ref.final_pose.head<2>()).norm(), 0.01);
    EXPECT_GT(ref.final_pose.x(), 1.0);  // it drove
    // As `forklift-sim manoeuvre 4` runs it: sampled every 2 ms between the integrator's steps.
    const ManoeuvreResult sampled = run_manoeuvre(*truck, 4, IntegratorOptions{}, 0.002, Sampling::kMetrics);
    EXPECT_LE(sampled.stats.steps, 500);
    EXPECT_DOUBLE_EQ(sampled.sim_time_s, 20.0);
    EXPECT_LT((sampled.final_pose.head<2>() - ref.final_pose.head<2>()).norm(), 0.01);
  }
}

TEST(Manoeuvre, SamplesBetweenTheIntegratorsStepsAreTheStatesAdvanceToLandsOn) {
  // A run timed by its steps alone samples between them by the integrator's interpolant: the
  // states must be those a run landing on every sample reads, bit for bit (CVODE interpolates both).
  const ManoeuvreSpec spec = manoeuvre(4, paper_truck());
  TruckDynamics dynamics(paper_truck());
  if (spec.load) dynamics.attach_load(*spec.load);
  StateVector x0 = dynamics.rest_state(0, 0, 0, 0, 0, spec.lift_m, 0);
  ASSERT_TRUE(dynamics.settle_static(x0));
  Simulation landing(dynamics, x0, {}), stepping(dynamics, x0, {});
  landing.set_input_schedule(spec.inputs);
  stepping.set_input_schedule(spec.inputs);
  const double dt = 0.002, horizon = spec.breakpoints_s.front();  // up to the brake's onset
  int compared = 0, between = 0, k = 1;
  while (stepping.time() < horizon - 1e-9) {
    stepping.step_toward(horizon, dt);
    const double reached = stepping.time();
    for (; k * dt <= reached + 1e-9; ++k, ++compared) {
      const double t = std::min(k * dt, reached);
      landing.advance_to(t, horizon);
      between += t < reached - 1e-9;
      ASSERT_EQ((stepping.state_at(t) - landing.state()).cwiseAbs().maxCoeff(), 0.0) << "at t = " << t;
    }
  }
  EXPECT_EQ(compared, std::lround(horizon / dt));
  EXPECT_GT(between, 0.8 * compared);  // most samples fall inside a step, not on its end
  EXPECT_LT(stepping.stats().steps, 200);
  EXPECT_EQ(stepping.stats().steps, landing.stats().steps);
  EXPECT_THROW(stepping.state_at(0.5 * horizon), std::invalid_argument);  // not in the last step
}
