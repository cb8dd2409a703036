// The checks of `forklift-sim validate`. Each drives the model as a test rig would and compares
// what it measures with a closed form or a limit from the truck file or a standard.
#include "forklift/dynamics/validation.h"

#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "forklift/dynamics/simulation.h"
#include "forklift/dynamics/stability.h"
#include "forklift/units/units.h"

namespace forklift {
namespace {

using Policy = std::function<DriverInputs(const Outputs&)>;
using Watch = std::function<void(const Outputs&)>;

// A truck on a level floor, driven by a policy; gravity tilted for a constant grade (+ rising
// ahead of the truck).
struct Rig {
  TruckDynamics dyn;
  std::unique_ptr<Simulation> sim;
  Outputs out;

  Rig(const TruckParams& t, std::optional<Load> load, double lift, double tilt, double grade_pct = 0) : dyn(t) {
    if (load) dyn.attach_load(*load);
    const double a = std::atan(grade_pct / 100);
    dyn.environment().gravity_m_s2 = Eigen::Vector3d(-kGravity_m_s2 * std::sin(a), 0, -kGravity_m_s2 * std::cos(a));
    StateVector x = dyn.rest_state(0, 0, 0, 0, tilt, lift, 0);
    if (!dyn.settle_static(x)) throw std::runtime_error("the truck does not stand still on level ground");
    sim = std::make_unique<Simulation>(dyn, x, IntegratorOptions{});
    out = sim->outputs();
  }
  double v() const { return out.forward_speed_m_s; }
  Eigen::Vector2d xy() const { return Eigen::Vector2d(out.q[kX], out.q[kY]); }
  // Runs for `seconds` in 10 ms steps (a cab's rate), asking the policy for inputs at each.
  void run(double seconds, const Policy& policy, const Watch& watch = {}) {
    const double end = sim->time() + seconds;
    while (sim->time() < end - 1e-9) {
      sim->set_inputs(policy(out));
      sim->advance_to(std::min(end, sim->time() + 0.01));
      out = sim->outputs();
      if (watch) watch(out);
    }
  }
  // Kicks the yaw rate, keeping everything else: a disturbance at speed.
  void kick_yaw(double rate) {
    StateVector x = sim->state();
    x[StateIndex::kQdot + kAwc] += rate;
    sim = std::make_unique<Simulation>(sim->dynamics(), x, IntegratorOptions{}, sim->time());
  }
};

std::string fmt(double v, int digits = 2) {
  std::ostringstream s;
  s.precision(digits);
  s << std::fixed << v;
  return s.str();
}

class Checks {
 public:
  explicit Checks(const TruckParams& t) : t_(t) {}
  std::vector<ValidationCheck> list;

  void add(std::string name, double measured, std::string unit, std::string required, bool pass) {
    list.push_back({std::move(name), measured, std::move(unit), std::move(required), pass && std::isfinite(measured)});
  }
  // |measured / expected - 1| within `tolerance`, reported in percent.
  void relative(const std::string& name, double measured, double expected, double tolerance) {
    const double err = (measured / expected - 1) * 100;
    add(name, err, "% off", "within +-" + fmt(tolerance * 100, 1) + " % of " + fmt(expected, 3), std::abs(err) <= tolerance * 100);
  }

  DriverInputs full_throttle() const { DriverInputs u; u.drive_torque_N_m = t_.drive.drive_torque_max_N_m; return u; }
  DriverInputs full_brake() const { DriverInputs u; u.brake_torque_N_m = t_.drive.brake_torque_max_N_m; return u; }
  Load rated() const { return box_load(t_.rated_capacity_kg, 1, 1, 1, t_.rated_load_centre_m, 0); }
  double travel_lift() const { return lift_for_fork_height(t_, 0.15); }
  double back() const { return -t_.limits.tilt_backward_max_rad; }
  // Holds a speed with a proportional accelerator, steering to `steer`.
  Policy cruise(double speed, double steer = 0) const {
    const double top = t_.drive.drive_torque_max_N_m;
    return [=](const Outputs& o) {
      DriverInputs u;
      u.steer_rad = steer;
      u.drive_torque_N_m = std::clamp(0.1 * top + 1.5 * top * (speed - o.forward_speed_m_s), -top, top);
      return u;
    };
  }

  void statics() {
    struct Case { const char* name; bool laden; double fork_top_m; };
    for (const Case& c : {Case{"unladen", false, 0}, Case{"rated load low", true, 0.15}, Case{"rated load at 3 m", true, 3.0}}) {
      std::optional<Load> load;
      if (c.laden) load = rated();
      const StaticReport r = static_report(t_, load, c.laden ? lift_for_fork_height(t_, c.fork_top_m) : 0.0);
      const double front_x = r.wheel_contact_m[kFrontLeft].x(), rear_x = r.wheel_contact_m[kRear].x();
      const double expected = r.total_mass_kg * kGravity_m_s2 * (front_x - r.cog_m.x()) / (front_x - rear_x);
      relative(std::string("statics, ") + c.name + ": rear wheel load = W d / L", r.fz_N[kRear], expected, 0.005);
      if (c.laden && c.fork_top_m < 1) {
        const double share = r.fz_N[kRear] / (r.total_mass_kg * kGravity_m_s2) * 100;
        add("rated load low: rear wheel's share of the weight", share, "%", "8-12 % (the class's usual margin)",
            share >= 8 && share <= 12);
      }
    }
    const StaticReport grade = static_report(t_, std::nullopt, 0, 10.0);
    add("static on a 10 % ramp, parking brake: drift in 2 s", grade.drift_m * 1000, "mm", "< 1 mm", grade.settled);
  }

  void tilt_table() {
    for (const IsoTiltTest& test : iso_22915_2(t_)) {
      const std::string name = "ISO 22915-2 test " + std::to_string(test.number) + " (" + test.name + ")";
      add(name + ": tilt angle", test.result.critical_angle_deg, "deg",
          ">= " + fmt(test.required_deg) + " deg (" + fmt(test.required_slope_pct, 1) + " %)", test.pass);
      // Tyre compression lets the truck lean a little towards the tipping line, never away.
      const double ratio = (test.result.critical_angle_deg / test.result.rigid_angle_deg - 1) * 100;
      add(name + ": against the rigid truck's atan(d / h) = " + fmt(test.result.rigid_angle_deg) + " deg", ratio, "%",
          "-8 % to 0 %", ratio >= -8 && ratio <= 0.1);
    }
  }

  void cornering() {
    // Slow and steady: the kinematic radius, and the roll moment on the front axle alone.
    const double steer = 15 * kDeg;
    Rig slow(t_, std::nullopt, 0, 0);
    slow.run(12, cruise(2.0, steer));
    const Outputs& o = slow.out;
    const double yaw_rate = std::abs(o.qdot[kAwc]);
    const Eigen::Vector2d v(o.qdot[kX], o.qdot[kY]), heading(std::cos(o.q[kAwc]), std::sin(o.q[kAwc]));
    const double ay = v.norm() * yaw_rate;
    relative("steady turn at 2 m/s, 15 deg: radius against L / tan(steer)", heading.dot(v) / yaw_rate,
             t_.wheelbase_m() / std::tan(steer), 0.02);
    relative("same: front load transfer against 2 m a_y h / H",
             std::abs(o.wheels[kFrontLeft].fz_N - o.wheels[kFrontRight].fz_N),
             2 * o.total_mass_kg * ay * o.cog_m.z() / t_.front_track_m(), 0.05);

    // 3.2 m/s^2 held for 6 s: no spin, no tyre sliding.
    const double speed = 3.2, radius = speed * speed / 3.2;
    Rig steady(t_, std::nullopt, 0, 0);
    double lo = INFINITY, hi = -INFINITY, use = 0;
    const Policy hold = cruise(speed, -std::atan(t_.wheelbase_m() / radius));
    steady.run(6, hold);
    steady.run(6, hold, [&](const Outputs& s) {
      lo = std::min(lo, s.qdot[kAwc]);
      hi = std::max(hi, s.qdot[kAwc]);
      for (const WheelContact& c : s.wheels) use = std::max(use, c.friction_use);
    });
    const double ay3 = Eigen::Vector2d(steady.out.qdot[kX], steady.out.qdot[kY]).norm() * steady.out.qdot[kAwc];
    add("steady 3 m/s^2 turn: lateral acceleration held", ay3, "m/s^2",
        ">= 3, yaw rate steady within 5 %, no tyre sliding", ay3 >= 3 && hi - lo < 0.05 * hi && use < 1);

    // A sharp turn at top speed: the inner front wheel lifts before any tyre slides.
    Rig sharp(t_, std::nullopt, 0, 0);
    sharp.run(10, [&](const Outputs&) { return full_throttle(); });
    bool lifted = false;
    double at_lift = INFINITY;
    sharp.run(3, [](const Outputs&) { DriverInputs u; u.steer_rad = -35 * kDeg; u.drive_torque_N_m = 0; return u; },
              [&](const Outputs& s) {
                if (lifted) return;
                lifted = s.wheels[kFrontLeft].fz_N <= 0 || s.wheels[kFrontRight].fz_N <= 0;
                if (!lifted) return;
                at_lift = 0;
                for (const WheelContact& c : s.wheels) at_lift = std::max(at_lift, c.friction_use);
              });
    add("35 deg turn at top speed, unladen: friction used when the inner front wheel lifts", at_lift, "of mu Fz",
        "< 0.95 (it tips before it slides)", lifted && at_lift < 0.95);
  }

  void brakes() {
    for (bool laden : {false, true})
      for (bool parking : {false, true}) {
        std::optional<Load> load;
        if (laden) load = rated();
        Rig r(t_, load, laden ? travel_lift() : 0, back(), -15.0);  // facing down a 15 % grade
        const Policy hold = [&](const Outputs&) {
          DriverInputs u;
          if (parking) u.parking_brake = true; else u.brake_torque_N_m = t_.drive.brake_torque_max_N_m;
          return u;
        };
        r.run(1.0, hold);
        const Eigen::Vector2d start = r.xy();
        r.run(10.0, hold);
        add(std::string(laden ? "rated load" : "unladen") + ", 15 % grade, " + (parking ? "parking brake" : "full service brake") +
                ": drift in 10 s",
            (r.xy() - start).norm() * 1000, "mm", "< 10 mm", (r.xy() - start).norm() < 0.01);
      }

    // From top speed, full pedal: the deceleration the brakes allow, 2 b / r at the front tyres
    // plus rolling resistance, on the mass with the wheels' and drivetrain's spin reflected.
    const double rf = t_.wheels[kFrontLeft].radius_m, rr = t_.wheels[kRear].radius_m;
    const double spin_mass = 2 * (t_.wheels[kFrontLeft].spin_inertia_kg_m2 + t_.drive.drivetrain_inertia_kg_m2) / (rf * rf) +
                             t_.wheels[kRear].spin_inertia_kg_m2 / (rr * rr);
    for (bool laden : {false, true}) {
      std::optional<Load> load;
      if (laden) load = rated();
      Rig r(t_, load, laden ? travel_lift() : 0, back());
      r.run(12, [&](const Outputs&) { return full_throttle(); });
      const double v0 = r.v(), m = r.out.total_mass_kg;
      const double a = (2 * t_.drive.brake_torque_max_N_m / rf + t_.contact.rolling_resistance_coefficient * m * kGravity_m_s2) / (m + spin_mass);
      const Eigen::Vector2d start = r.xy();
      double pitch = 0;
      r.run(6, [&](const Outputs&) { return full_brake(); },
            [&](const Outputs& s) { pitch = std::max(pitch, std::abs(s.q[kAvc])); });
      const std::string what = std::string(laden ? "rated load low, mast back" : "unladen") + ", full brake from " +
                               fmt(v0 * 3.6, 1) + " km/h";
      relative(what + ": stopping distance against v^2 / 2a", (r.xy() - start).norm(), v0 * v0 / (2 * a), 0.15);
      if (laden) add(what + ": largest pitch", pitch / kDeg, "deg", "< 5 deg (no tip)", pitch < 5 * kDeg);
      const Eigen::Vector2d stopped = r.xy();
      r.run(5, [&](const Outputs&) { return full_brake(); });
      add(what + ": drift in the 5 s after", (r.xy() - stopped).norm() * 1000, "mm", "< 5 mm", (r.xy() - stopped).norm() < 0.005);
    }
  }

  void driving() {
    // Coast-down from 3 m/s: rolling resistance alone.
    Rig coast(t_, std::nullopt, 0, 0);
    coast.run(20, [&](const Outputs& o) { return o.forward_speed_m_s < 3.0 ? cruise(3.2)(o) : DriverInputs{}; });
    const Policy idle = [](const Outputs&) { return DriverInputs{}; };
    coast.run(0.5, idle);
    const double v1 = coast.v(), t1 = coast.sim->time();
    coast.run(5, idle);
    relative("coast-down from 3 m/s: deceleration against C_rr g", (v1 - coast.v()) / (coast.sim->time() - t1),
             t_.contact.rolling_resistance_coefficient * kGravity_m_s2, 0.2);
    coast.run(30, idle);
    add("coast-down: speed 35 s later", std::abs(coast.v()), "m/s", "< 0.001 (at rest)", std::abs(coast.v()) < 1e-3);

    // Top speed, and a yaw kick at it that dies away.
    for (bool laden : {false, true}) {
      std::optional<Load> load;
      if (laden) load = rated();
      Rig r(t_, load, laden ? travel_lift() : 0, back());
      r.run(25, [&](const Outputs&) { return full_throttle(); });
      const std::string what = laden ? "rated load" : "unladen";
      const double cap = t_.drive.speed_max_m_s * 3.6;
      add(what + ": top speed at full throttle", r.v() * 3.6, "km/h",
          std::isfinite(cap) ? "the file's " + fmt(cap, 1) + " +- 1 km/h" : "a speed cap in the truck file",
          std::abs(r.v() * 3.6 - cap) <= 1.0);
      r.kick_yaw(0.1);
      r.run(4, [&](const Outputs&) { return full_throttle(); });
      add(what + ": yaw rate 4 s after a 0.1 rad/s kick at top speed", std::abs(r.out.qdot[kAwc]), "rad/s", "< 0.01",
          std::abs(r.out.qdot[kAwc]) < 0.01);
    }

    // Steering: full left to full right, then a cab jerking between them every 50 ms.
    Rig s(t_, std::nullopt, 0, 0);
    double rate = 0, angle = 0;
    const Watch track = [&](const Outputs& o) {
      rate = std::max(rate, std::abs(o.qdot[kAwr3]));
      angle = std::max(angle, std::abs(o.q[kAwr3]));
    };
    s.run(1.5, [](const Outputs&) { DriverInputs u; u.steer_rad = 1.5; return u; }, track);
    s.run(1.5, [](const Outputs&) { DriverInputs u; u.steer_rad = -1.5; return u; }, track);
    int k = 0;
    s.run(1.0, [&](const Outputs&) { DriverInputs u; u.steer_rad = (k++ / 5) % 2 ? 1.5 : -1.5; return u; }, track);
    const double limit = t_.steer.rate_max_rad_s;
    add("steer rate, any cab input", rate / kDeg, "deg/s",
        std::isfinite(limit) ? "<= the file's " + fmt(limit / kDeg, 0) + " deg/s" : "a rate limit in the truck file",
        std::isfinite(limit) && rate <= limit * 1.001);
    add("steer angle, any cab input", angle / kDeg, "deg", "<= the end stop, " + fmt(t_.steer.max_rad / kDeg, 1) + " deg",
        angle <= t_.steer.max_rad + 1e-4);
  }

  void tip_over() {
    // A fast full-lock turn with the rated load at 3 m: it goes over and comes to rest on its side.
    Rig r(t_, rated(), lift_for_fork_height(t_, 3.0), 0);
    double deepest = 0, cog = 0;
    const Watch watch = [&](const Outputs& o) {
      deepest = std::max(deepest, o.body_penetration_max_m);
      for (const WheelContact& c : o.wheels) deepest = std::max(deepest, c.penetration_m);
      cog = std::max(cog, o.cog_m.z());
    };
    r.run(6, cruise(2.5), watch);
    const double torque = 0.3 * t_.drive.drive_torque_max_N_m;
    r.run(10, [&](const Outputs&) { DriverInputs u; u.steer_rad = -1.5; u.drive_torque_N_m = torque; return u; }, watch);
    r.run(6, [](const Outputs&) { return DriverInputs{}; }, watch);
    const double roll = std::abs(r.out.q[kAuc]) / kDeg;
    const double speed = Eigen::Vector3d(r.out.qdot[kX], r.out.qdot[kY], r.out.qdot[kZ]).norm();
    add("forced tip (rated load at 3 m, full lock at 2.5 m/s): final roll", roll, "deg", "> 60 deg (on its side), at rest",
        roll > 60 && speed < 0.05 && r.out.body_points_on_ground > 1);
    add("forced tip: deepest point below the floor", deepest * 100, "cm", "< 5 cm", deepest < 0.05);
    add("forced tip: highest centre of gravity", cog, "m", "< 2 m (nothing launched)", cog < 2.0);
  }

 private:
  const TruckParams& t_;
};

}  // namespace

std::vector<ValidationCheck> validate_truck(const TruckParams& truck) {
  Checks c(truck);
  c.statics();
  c.tilt_table();
  c.cornering();
  c.brakes();
  c.driving();
  c.tip_over();
  return c.list;
}

}  // namespace forklift
