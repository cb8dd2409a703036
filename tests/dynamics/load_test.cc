// The load as a body on the forks (load_on_forks.h): held by static friction, sliding under
// kinetic friction, falling off past the fork tips or with the truck, against closed forms of the
// friction on a tilted fork, on the training truck driven through the 1 ms ticks a session uses.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "forklift/dynamics/load_on_forks.h"
#include "forklift/dynamics/simulation.h"
#include "forklift/units/units.h"
#include "test_truck.h"

using namespace forklift;

namespace {

constexpr double kTick_s = 1e-3;

// 600 kg on a EUR pallet (1.2 m along the forks, 0.8 m wide, 1.0 m high with its load), its back
// against the fork face: CoG 0.6 m ahead of the face and 0.5 m above the fork tops.
Load pallet_600kg() { return box_load(600, 1.2, 0.8, 1.0, 0.6, 0); }

struct Drive {
  double largest_slide_m = 0;
  double largest_pitch_deg = 0;
  double braking_decel_m_s2 = 0;  // the truck's largest deceleration while braking
  double largest_energy_rise_J = 0;  // the most the truck and load's energy rose over any stretch
  LoadOnForks end;
  bool fell = false;
  double speed_at_brake_m_s = 0;
};

// Kinetic and gravitational energy of the truck (with its springs) and its load, the load where it
// is and moving as it does.
double total_energy(const Simulation& sim) { return sim.dynamics().energy(sim.state(), true) + sliding_load_energy(sim); }

// From rest with the load lifted `lift_m` and the mast tilted `tilt_deg` (+ forward): up to
// `speed_m_s` under a speed controller, then `brake` applied (inputs as a function of the speed
// reached) for `brake_s`, in 1 ms ticks.
Drive drive_and_brake(const TruckParams& truck, const Load& load, double tilt_deg, double lift_m, double speed_m_s,
                      const std::function<DriverInputs(const Outputs&)>& brake, double brake_s = 4.0,
                      bool track_energy = false, double tick_s = kTick_s) {
  TruckDynamics dyn(truck);
  dyn.attach_load(load);
  StateVector x = dyn.rest_state(0, 0, 0, 0, tilt_deg * kDeg, lift_m);
  EXPECT_TRUE(dyn.settle_static(x));
  Simulation sim(dyn, x, IntegratorOptions{});
  Drive d;
  double t = 0;
  // Accelerate gently (the load rests against the fork face meanwhile), then hold the speed.
  while (t < 20) {
    const Outputs o = sim.outputs();
    if (o.forward_speed_m_s >= speed_m_s - 0.01 && t > 3) break;
    DriverInputs u;
    u.drive_torque_N_m = std::clamp(3000 * (speed_m_s - o.forward_speed_m_s), 0.0, 2000.0);
    sim.set_inputs(u);
    t += tick_s;
    sim.advance_to(t);
  }
  EXPECT_EQ(sim.load_on_forks().phase, LoadPhase::kStuck) << "the drive up to speed moved the load";
  d.speed_at_brake_m_s = sim.outputs().forward_speed_m_s;
  double prev_v = d.speed_at_brake_m_s;
  double lowest_energy = total_energy(sim);
  const double t_brake = t;
  while (t < t_brake + brake_s) {
    const Outputs o = sim.outputs();
    sim.set_inputs(brake(o));
    t += tick_s;
    sim.advance_to(t);
    const Outputs after = sim.outputs();
    d.braking_decel_m_s2 = std::max(d.braking_decel_m_s2, (prev_v - after.forward_speed_m_s) / tick_s);
    prev_v = after.forward_speed_m_s;
    d.largest_pitch_deg = std::max(d.largest_pitch_deg, std::abs(after.q[kAvc]) / kDeg);
    d.largest_slide_m = std::max(d.largest_slide_m, sim.load_on_forks().slide_m);
    if (sim.load_on_forks().phase == LoadPhase::kFallen) {
      d.fell = true;
      break;  // the load is gone: its energy leaves the account
    }
    if (track_energy) {
      const double e = total_energy(sim);
      d.largest_energy_rise_J = std::max(d.largest_energy_rise_J, e - lowest_energy);
      lowest_energy = std::min(lowest_energy, e);
    }
  }
  d.end = sim.load_on_forks();
  return d;
}

DriverInputs full_brake(const Outputs&) {
  DriverInputs u;
  u.brake_torque_N_m = 1e9;  // clamped to the truck's full pedal
  return u;
}

}  // namespace

TEST(LoadOnForks, ModelTakesTheLoadsFrictionOrTheTrucks) {
  const TruckParams& t = shipped_truck();
  ASSERT_FALSE(t.load_contact.welded());
  EXPECT_DOUBLE_EQ(t.load_contact.friction_static, 0.35);
  EXPECT_DOUBLE_EQ(t.load_contact.friction_kinetic, 0.3);
  EXPECT_DOUBLE_EQ(t.load_contact.fork_tip_m, 1.0);
  Load l = pallet_600kg();
  LoadOnForksModel m = load_on_forks_model(t, l);
  EXPECT_DOUBLE_EQ(m.mu_static, 0.35);
  EXPECT_DOUBLE_EQ(m.min_slide_m, 0.0);  // its back against the fork face
  l.friction_static = 0.5;
  l.friction_kinetic = 0.4;
  l.cog_m.x() = 0.7;  // 10 cm clear of the face
  m = load_on_forks_model(t, l);
  EXPECT_DOUBLE_EQ(m.mu_static, 0.5);
  EXPECT_DOUBLE_EQ(m.mu_kinetic, 0.4);
  EXPECT_NEAR(m.min_slide_m, -0.1, 1e-12);
  // The paper's truck gives no load contact: its load is welded, as section 5 has it.
  EXPECT_TRUE(paper_truck().load_contact.welded());
}

TEST(LoadOnForks, StandingStillWithTheMastTiltedForwardTheLoadStaysPut) {
  // A fork sloping 6 deg down asks g sin 6 = 0.105 g of friction, well under 0.35 g cos 6.
  TruckDynamics dyn(shipped_truck());
  dyn.attach_load(pallet_600kg());
  StateVector x = dyn.rest_state(0, 0, 0, 0, 6 * kDeg, 0.3);
  ASSERT_TRUE(dyn.settle_static(x));
  Simulation sim(dyn, x, IntegratorOptions{});
  for (int i = 1; i <= 2000; ++i) sim.advance_to(i * kTick_s);
  EXPECT_EQ(sim.load_on_forks().phase, LoadPhase::kStuck);
  EXPECT_EQ(sim.load_on_forks().slips, 0);
  EXPECT_DOUBLE_EQ(sim.load_on_forks().slide_m, 0.0);
}

TEST(LoadOnForks, HardBrakingFrom10KmhWithTheMastTiltedForwardSlidesTheLoadOff) {
  // Closed form: on a fork sloping theta down, a load slips once the truck decelerates at
  // a > g (mu_s cos theta - sin theta) / (cos theta + mu_s sin theta) = 0.236 g for 6 deg; it then
  // lags the truck by a - g (mu_k cos theta - sin theta) and slides on after the truck has stopped,
  // until friction stops it there, at g (mu_k cos theta - sin theta).
  const double th = 6 * kDeg, mu = 0.35;
  const double a_slip = kGravity_m_s2 * (mu * std::cos(th) - std::sin(th)) / (std::cos(th) + mu * std::sin(th));
  // Taken 10 cm short of the fork face, as a pallet picked up without driving fully in: its
  // CoG 0.7 m out, 0.3 m short of the tips.
  Load load = pallet_600kg();
  load.cog_m.x() = 0.7;
  const Drive d = drive_and_brake(shipped_truck(), load, 6, 0.3, 10 / 3.6, full_brake);
  EXPECT_NEAR(d.speed_at_brake_m_s, 10 / 3.6, 0.05);
  EXPECT_GT(d.braking_decel_m_s2, a_slip) << "the brakes cannot reach the slip";
  EXPECT_TRUE(d.fell) << "slid " << d.largest_slide_m << " m, phase " << load_phase_name(d.end.phase);
  EXPECT_GE(d.end.slips, 1);
  EXPECT_GT(d.largest_slide_m, 0.29);  // from 0.7 m to past the tips at 1.0 m
  // It left the forks moving forward, ahead of the truck.
  EXPECT_GT(d.end.fell_velocity_m_s.x(), 0.0);
  EXPECT_GT(d.end.fell_at_m.x(), 1.0);

  // Pushed fully back against the fork face it slides too, most of the way to the tips, and stops
  // on them (the slide alone is a fault for the evaluation).
  const Drive back = drive_and_brake(shipped_truck(), pallet_600kg(), 6, 0.3, 10 / 3.6, full_brake);
  EXPECT_GE(back.end.slips, 1);
  EXPECT_GT(back.largest_slide_m, 0.2);
}

TEST(LoadOnForks, HardBrakingWithTheMastTiltedBackKeepsTheLoad) {
  // Tilted back, the fork slopes up: slipping would need a > g (mu cos + sin) / (cos - mu sin).
  const Drive d = drive_and_brake(shipped_truck(), pallet_600kg(), -5, 0.3, 10 / 3.6, full_brake);
  EXPECT_FALSE(d.fell);
  EXPECT_EQ(d.end.phase, LoadPhase::kStuck);
  EXPECT_LT(d.largest_slide_m, 0.01);
}

TEST(LoadOnForks, WeldedOnTheForksItNeverSlides) {
  // The paper's model, where the truck file gives no load contact.
  const TruckParams welded = load_truck(shipped_truck_variant("welded", [](nlohmann::json& j) { j.erase("load_contact"); }));
  const Drive d = drive_and_brake(welded, pallet_600kg(), 6, 0.3, 10 / 3.6, full_brake);
  EXPECT_FALSE(d.fell);
  EXPECT_EQ(d.end.slips, 0);
  EXPECT_DOUBLE_EQ(d.largest_slide_m, 0.0);
}

TEST(LoadOnForks, AForwardTipDropsTheLoad) {
  // The rated load high up, driving at 2.5 m/s, then full reverse pedal: the truck pitches over its
  // front wheels, and the load leaves the forks (slid off as they steepen, or with the truck gone over).
  const Load rated = box_load(1600, 1.2, 0.8, 1.0, 0.6, 0);
  const Drive d = drive_and_brake(shipped_truck(), rated, 0, 2.5, 2.5, [](const Outputs&) {
    DriverInputs u;
    u.drive_torque_N_m = -1e9;  // clamped to the truck's full reverse torque
    return u;
  }, 6.0);
  EXPECT_GT(d.largest_pitch_deg, 10.0) << "the truck did not tip forward";
  EXPECT_TRUE(d.fell) << "pitch " << d.largest_pitch_deg << " deg, slid " << d.largest_slide_m << " m";
}

TEST(LoadOnForks, TheLoadContactCreatesNoEnergy) {
  // Braking with the mast forward: the load sticks, slips and slides, and falls. Until it falls,
  // the truck's and load's kinetic, gravitational and tyre-spring energy may only fall: brakes,
  // tyres and the sliding friction take energy out, and taking the load in and out of the mass
  // matrix at zero relative speed moves none. A little comes back from the tyres' and brakes'
  // bristles, which store it outside this account: the same run with the load welded bounds that.
  const Drive sliding = drive_and_brake(shipped_truck(), pallet_600kg(), 6, 0.3, 10 / 3.6, full_brake, 4.0, true);
  const TruckParams welded = load_truck(shipped_truck_variant("welded_energy", [](nlohmann::json& j) { j.erase("load_contact"); }));
  const Drive stuck = drive_and_brake(welded, pallet_600kg(), 6, 0.3, 10 / 3.6, full_brake, 4.0, true);
  ASSERT_GE(sliding.end.slips, 1);
  EXPECT_LT(sliding.largest_energy_rise_J, stuck.largest_energy_rise_J + 5.0)
      << "welded: " << stuck.largest_energy_rise_J << " J";
}


TEST(LoadOnForks, TheSlideForceATickLateChangesNothingTheDriverSees) {
  // The forks give the carriage back friction's difference from the rigid hold a tick late (the
  // load's step comes after the truck's, load_on_forks.h). Hard braking that slides the load off
  // the tips, and one that slides it along them, in ticks of 1, 0.5 and 0.25 ms: where and how fast
  // the load leaves the forks, and how far it slides, do not depend on the tick (a lag that
  // mattered would change them in proportion to it).
  Load out = pallet_600kg();
  out.cog_m.x() = 0.7;
  const Drive off = drive_and_brake(shipped_truck(), out, 6, 0.3, 10 / 3.6, full_brake);
  const Drive along = drive_and_brake(shipped_truck(), pallet_600kg(), 6, 0.3, 10 / 3.6, full_brake);
  ASSERT_TRUE(off.fell);
  ASSERT_FALSE(along.fell);
  for (double tick : {0.5e-3, 0.25e-3}) {
    SCOPED_TRACE("ticks of " + std::to_string(tick * 1e3) + " ms");
    const Drive f = drive_and_brake(shipped_truck(), out, 6, 0.3, 10 / 3.6, full_brake, 4.0, false, tick);
    ASSERT_TRUE(f.fell);
    EXPECT_NEAR(f.end.fell_at_m.x(), off.end.fell_at_m.x(), 0.005);
    EXPECT_NEAR(f.end.fell_velocity_m_s.x(), off.end.fell_velocity_m_s.x(), 0.005);
    EXPECT_NEAR(f.largest_slide_m, off.largest_slide_m, 0.002);
    const Drive a = drive_and_brake(shipped_truck(), pallet_600kg(), 6, 0.3, 10 / 3.6, full_brake, 4.0, false, tick);
    EXPECT_NEAR(a.largest_slide_m, along.largest_slide_m, 0.002);
    EXPECT_EQ(a.end.phase, along.end.phase);
  }
}
