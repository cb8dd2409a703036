// The checks of `forklift-sim validate`. Each drives the model as a test rig would and compares
// what it measures with a number from outside the model: a standard (ISO 22915-2's tilt angles),
// a data sheet, or physics (a closed form; the truck weighed from its parts' masses by moments
// about the axles, in plain arithmetic here, not through the model's code). Each check names its
// source.
#include "forklift/dynamics/validation.h"

#include <cmath>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "forklift/dynamics/simulation.h"
#include "forklift/dynamics/stability.h"
#include "forklift/units/decimals.h"
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

// ---- The truck weighed from its parts, apart from the model ----
// The file's masses at their centres of gravity (geometry frame), for the truck standing level on
// undeflected tyres with the mast tilted `tilt` (+ forward) and the forks lifted `lift`: the
// chassis as its parts (where the file lists them, whatever chassis.cog_m says), the wheels,
// mast, carriage, a load and ISO 22915's operator.
struct Weighing {
  double mass_kg = 0;
  Eigen::Vector3d cog_m = Eigen::Vector3d::Zero();
  std::array<Eigen::Vector2d, kNumWheels> contact_m;  // below the wheel centres
  std::array<Eigen::Vector3d, kNumWheels> wheel_centre_m;
  std::vector<std::pair<double, Eigen::Vector3d>> parts;  // each mass at its CoG
};

Weighing weigh_parts(const TruckParams& t, const std::optional<Load>& load, double lift, double tilt,
                     double operator_kg = 0) {
  // load_truck shifted the file's positions by the chassis CoG it uses; adding it back restores them.
  const Eigen::Vector3d origin = t.chassis_cog_geometry_m;
  std::vector<std::pair<double, Eigen::Vector3d>> parts;
  if (t.chassis_parts.empty()) parts.push_back({t.chassis.mass_kg, origin});
  for (const MassPart& p : t.chassis_parts) parts.push_back({p.mass_kg, p.cog_geometry_m});
  Weighing w;
  for (int i = 0; i < kNumWheels; ++i) {
    const Eigen::Vector3d centre = origin + t.wheels[i].centre_m;
    parts.push_back({t.wheels[i].mass_kg, centre});
    w.contact_m[i] = centre.head<2>();
    w.wheel_centre_m[i] = centre;
  }
  // The mast and what rides on it turn about the tilt pivot (about +y: + tilt leans the top forward).
  const Eigen::Vector3d pivot = origin + t.mast_pivot_m;
  const double c = std::cos(tilt), s = std::sin(tilt);
  auto mast_frame = [&](const Eigen::Vector3d& v) { return Eigen::Vector3d(pivot.x() + c * v.x() + s * v.z(), pivot.y() + v.y(), pivot.z() - s * v.x() + c * v.z()); };
  const Eigen::Vector3d heel = t.fork_heel_from_pivot_m + Eigen::Vector3d(0, 0, lift);
  parts.push_back({t.mast.mass_kg, mast_frame(t.mast.cog_m)});
  parts.push_back({t.carriage.mass_kg, mast_frame(heel + t.carriage.cog_m)});
  if (load) parts.push_back({load->mass_kg, mast_frame(heel + load->cog_m)});
  if (operator_kg > 0) parts.push_back({operator_kg, t.operator_seat_m});
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();
  for (const auto& [m, p] : parts) {
    w.mass_kg += m;
    moment += m * p;
  }
  w.cog_m = moment / w.mass_kg;
  w.parts = std::move(parts);
  return w;
}

// The wheels' normal loads on a table whose gravity, in the table's axes, is `g`: the weight's
// moments about the table's x and y axes are taken by the loads at the contacts (the chocks'
// forces lie in the table and have none): sum N = -G_z, sum N y = -M_x, sum N x = M_y.
std::array<double, kNumWheels> wheel_loads(const Weighing& w, const Eigen::Vector3d& g) {
  const Eigen::Vector3d G = w.mass_kg * g, M = w.cog_m.cross(G);
  Eigen::Matrix3d A;
  for (int i = 0; i < kNumWheels; ++i) A.col(i) = Eigen::Vector3d(1, w.contact_m[i].y(), w.contact_m[i].x());
  const Eigen::Vector3d n = A.fullPivLu().solve(Eigen::Vector3d(-G.z(), -M.x(), M.y()));
  return {n[0], n[1], n[2]};
}

// The same with the tyres compressed by their loads (N / K, K the file's vertical stiffness),
// on level ground unless `g` says otherwise: the truck leans towards its most loaded tyres, and a
// load high up moves that way with it. The lean is the plane through the three compressed wheels
// (small angles); a few rounds of loads, lean, loads settle it.
std::array<double, kNumWheels> wheel_loads_on_tyres(Weighing w, double stiffness_N_m,
                                                    const Eigen::Vector3d& g = Eigen::Vector3d(0, 0, -kGravity_m_s2)) {
  const Weighing rigid = w;
  std::array<double, kNumWheels> n = wheel_loads(w, g);
  for (int round = 0; round < 8; ++round) {
    // dz = a + b x + c y through the wheels' sinkings -N_i / K.
    Eigen::Matrix3d A;
    Eigen::Vector3d sink;
    for (int i = 0; i < kNumWheels; ++i) {
      A.row(i) = Eigen::RowVector3d(1, rigid.contact_m[i].x(), rigid.contact_m[i].y());
      sink[i] = -n[i] / stiffness_N_m;
    }
    const Eigen::Vector3d p = A.fullPivLu().solve(sink);
    // A small rotation that tilts z by b x + c y moves a point at height z by -b z along x, -c z along y.
    auto lean = [&](const Eigen::Vector3d& r) {
      return Eigen::Vector3d(r.x() - p[1] * r.z(), r.y() - p[2] * r.z(), r.z() + p[0] + p[1] * r.x() + p[2] * r.y());
    };
    Eigen::Vector3d moment = Eigen::Vector3d::Zero();
    for (const auto& [m, r] : rigid.parts) moment += m * lean(r);
    w.cog_m = moment / w.mass_kg;
    for (int i = 0; i < kNumWheels; ++i) {
      // The contacts stay under the wheel centres, which lean with the truck.
      w.contact_m[i] = lean(rigid.wheel_centre_m[i]).head<2>();
    }
    n = wheel_loads(w, g);
  }
  return n;
}

// The CoG's horizontal distance inside the edge from contact `a` to contact `b`, and that edge's
// outward normal.
double inside_edge(const Eigen::Vector2d& cog, const Eigen::Vector2d& a, const Eigen::Vector2d& b, Eigen::Vector2d* outward = nullptr) {
  const Eigen::Vector2d e = (b - a).normalized();
  Eigen::Vector2d n(-e.y(), e.x());
  if (n.dot(a - cog) < 0) n = -n;
  if (outward) *outward = n;
  return n.dot(a - cog);
}

// The table's tilt at which the wheel off the tipping edge (from contact `a` to contact `b`) loses
// its load, for the truck standing on its tyres: the closed form atan(d / h) of a rigid truck, less
// the lean its tyres give it towards the edge as they take the load (wheel_loads_on_tyres).
double tilt_on_tyres(const Weighing& w, double stiffness_N_m, int a, int b) {
  Eigen::Vector2d outward;
  inside_edge(w.cog_m.head<2>(), w.contact_m[a], w.contact_m[b], &outward);
  const int off = 3 - a - b;  // the wheel that lifts
  double lo = 0, hi = 60 * kDeg;
  for (int i = 0; i < 50; ++i) {
    const double tilt = 0.5 * (lo + hi);
    const Eigen::Vector3d g(kGravity_m_s2 * std::sin(tilt) * outward.x(), kGravity_m_s2 * std::sin(tilt) * outward.y(),
                            -kGravity_m_s2 * std::cos(tilt));
    (wheel_loads_on_tyres(w, stiffness_N_m, g)[off] > 0 ? lo : hi) = tilt;
  }
  return 0.5 * (lo + hi);
}

// The CoG height a test lab measures by weighing (the axle-lift method of ISO 10392): the wheel
// loads level give the weight W and the CoG's x; tilted `angle` about the front axle (nose down),
// the moment about the y axis grows by W h sin(angle).
double weighed_cog_height(const Outputs& level, const Outputs& tilted, double angle) {
  double weight = 0, moment_level = 0, moment_tilted = 0;
  for (int i = 0; i < kNumWheels; ++i) {
    weight += level.wheels[i].fz_N;
    moment_level += level.wheels[i].fz_N * level.wheels[i].contact_point_m.x();
    moment_tilted += tilted.wheels[i].fz_N * tilted.wheels[i].contact_point_m.x();
  }
  const double x = moment_level / weight;
  return (moment_tilted - x * weight * std::cos(angle)) / (weight * std::sin(angle));
}

constexpr const char* kPartsSource =
    "physics: moments about the axles from the truck file's masses (the chassis as 'chassis.parts' where it lists them)";

class Checks {
 public:
  Checks(const TruckParams& t, const ValidationReferences& refs) : t_(t), refs_(refs) {}
  std::vector<ValidationCheck> list;

  void add(std::string name, double measured, std::string unit, std::string required, std::string source, bool pass) {
    list.push_back({std::move(name), measured, std::move(unit), std::move(required), std::move(source), pass && std::isfinite(measured)});
  }
  // |measured / expected - 1| within `tolerance`, reported in percent.
  void relative(const std::string& name, double measured, double expected, double tolerance, const std::string& source) {
    const double err = (measured / expected - 1) * 100;
    add(name, err, "% off", "within +-" + fixed_decimals(tolerance * 100, 1) + " % of " + fixed_decimals(expected, 3), source, std::abs(err) <= tolerance * 100);
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
    // Level: each wheel's load against the parts' moments about the axles.
    struct Case { const char* name; bool laden; double fork_top_m; double table_deg; };
    for (const Case& c : {Case{"unladen", false, 0, 10}, Case{"rated load low", true, 0.15, 5}, Case{"rated load at 3 m", true, 3.0, 0}}) {
      std::optional<Load> load;
      if (c.laden) load = rated();
      const double lift = c.laden ? lift_for_fork_height(t_, c.fork_top_m) : 0.0;
      const StaticReport r = static_report(t_, load, lift);
      const Weighing parts = weigh_parts(t_, load, lift, 0);
      const std::array<double, kNumWheels> expected = wheel_loads_on_tyres(parts, t_.contact.stiffness_N_m);
      double worst = 0;
      for (int w = 0; w < kNumWheels; ++w) {
        const double err = (r.fz_N[w] / expected[w] - 1) * 100;
        if (std::abs(err) > std::abs(worst)) worst = err;
      }
      add(std::string("statics, ") + c.name + ": wheel loads level (the largest error of the three)", worst, "% off",
          "within +-0.1 % of the parts' (rear " + fixed_decimals(expected[kRear] / kGravity_m_s2, 0) + " kg)", kPartsSource,
          r.settled && std::abs(worst) <= 0.1);
      if (c.table_deg <= 0) continue;
      // Weighed again on a table tilted nose down: the CoG's height, as a test lab measures it.
      const auto level = on_tilted_table(t_, load, lift, TiltAxis::kLongitudinal, 0);
      const auto tilted = on_tilted_table(t_, load, lift, TiltAxis::kLongitudinal, c.table_deg);
      const double h = level && tilted ? weighed_cog_height(*level, *tilted, c.table_deg * kDeg) : NAN;
      add(std::string("statics, ") + c.name + ": CoG height weighed level and on a " + fixed_decimals(c.table_deg, 0) + " deg table", h, "m",
          "the parts' " + fixed_decimals(parts.cog_m.z(), 3) + " m +- 0.02 m (tyre compression)",
          "ISO 10392's axle-lift weighing, against the truck file's masses and heights", std::abs(h - parts.cog_m.z()) <= 0.02);
    }
    const StaticReport grade = static_report(t_, std::nullopt, 0, 10.0);
    add("static on a 10 % ramp, parking brake: drift in 2 s", grade.drift_m * 1000, "mm", "< 1 mm",
        "physics: a held brake and tyres below their grip do not creep", grade.settled);
  }

  void tilt_table() {
    for (const IsoTiltTest& test : iso_22915_2(t_)) {
      const std::string name = "ISO 22915-2 test " + std::to_string(test.number) + " (" + test.name + ")";
      add(name + ": tilt angle", test.result.critical_angle_deg, "deg",
          ">= " + fixed_decimals(test.required_deg, 2) + " deg (" + fixed_decimals(test.required_slope_pct, 1) + " %)",
          "ISO 22915-2, table 1 (counterbalanced trucks up to 5000 kg)", test.pass);
      // The rigid truck's angle from its parts: the CoG's distance d inside the tipping line (the
      // front axle's contacts, or a front contact to the rear's) over its height h.
      std::optional<Load> load;
      if (test.load_kg > 0) load = box_load(test.load_kg, 1.0, 1.0, 1.0, t_.rated_load_centre_m, 0);
      const Weighing w = weigh_parts(t_, load, test.lift_m, test.mast_tilt_rad, kIsoOperatorKg);
      const bool lateral = test.axis == TiltAxis::kLateral;
      const double d = inside_edge(w.cog_m.head<2>(), w.contact_m[lateral ? kFrontRight : kFrontLeft],
                                   w.contact_m[lateral ? kRear : kFrontRight]);
      const double rigid = std::atan2(d, w.cog_m.z()) / kDeg;
      // Tyre compression lets the truck lean a little towards the tipping line, never away: the
      // measured angle lies below the rigid truck's, by about what its tyres' lean takes.
      const int a = lateral ? kFrontRight : kFrontLeft, b = lateral ? kRear : kFrontRight;
      const double on_tyres = tilt_on_tyres(w, t_.contact.stiffness_N_m, a, b) / kDeg;
      const double ratio = (test.result.critical_angle_deg / rigid - 1) * 100;
      const double lean = (on_tyres / rigid - 1) * 100;
      add(name + ": against the rigid truck's atan(d / h) = " + fixed_decimals(rigid, 2) + " deg, less its tyres' lean (" +
              fixed_decimals(lean, 1) + " %, to " + fixed_decimals(on_tyres, 2) + " deg)",
          ratio, "%", fixed_decimals(lean - 3, 1) + " % to " + fixed_decimals(std::min(lean + 3, 0.0), 1) + " %",
          std::string(kPartsSource) + "; the tyres' compression N / K", ratio >= lean - 3 && ratio <= std::min(lean + 3, 0.1));
    }
  }

  void cornering() {
    // Slow and steady: the kinematic radius, and the roll moment on the front axle alone.
    const double steer = 15 * kDeg;
    const Weighing unladen = weigh_parts(t_, std::nullopt, 0, 0);
    Rig slow(t_, std::nullopt, 0, 0);
    slow.run(12, cruise(2.0, steer));
    const Outputs& o = slow.out;
    const double yaw_rate = std::abs(o.qdot[kAwc]);
    const Eigen::Vector2d v(o.qdot[kX], o.qdot[kY]), heading(std::cos(o.q[kAwc]), std::sin(o.q[kAwc]));
    const double ay = v.norm() * yaw_rate;
    relative("steady turn at 2 m/s, 15 deg: radius against L / tan(steer)", heading.dot(v) / yaw_rate,
             t_.wheelbase_m() / std::tan(steer), 0.02, "physics: the kinematic turn of a truck steered by its rear wheel");
    relative("same: front load transfer against 2 m a_y h / H, h the parts' CoG height",
             std::abs(o.wheels[kFrontLeft].fz_N - o.wheels[kFrontRight].fz_N),
             2 * unladen.mass_kg * ay * unladen.cog_m.z() / t_.front_track_m(), 0.05,
             "physics: the roll moment m a_y h taken across the front track (the rear wheel is one point)");

    // 3.2 m/s^2 held for 6 s: no spin, no tyre sliding.
    const double speed = 3.2, radius = speed * speed / 3.2;
    Rig steady(t_, std::nullopt, 0, 0);
    double lo = INFINITY, hi = -INFINITY, use = 0;
    const Policy hold = cruise(speed, -std::atan(t_.wheelbase_m() / radius));
    steady.run(6, hold);
    steady.run(6, hold, [&](const Outputs& s) {
      lo = std::min(lo, s.qdot[kAwc]);
      hi = std::max(hi, s.qdot[kAwc]);
      for (const WheelContact& c : s.wheels) use = std::max(use, c.grip_share);
    });
    const double ay3 = Eigen::Vector2d(steady.out.qdot[kX], steady.out.qdot[kY]).norm() * steady.out.qdot[kAwc];
    add("steady 3 m/s^2 turn: lateral acceleration held", ay3, "m/s^2",
        ">= 3, yaw rate steady within 5 %, every tyre below 0.9 of its grip peak",
        "physics: 0.31 g is within rubber's grip on dry concrete (0.6-0.9) and below the stability triangle's g d / h",
        ay3 >= 3 && hi - lo < 0.05 * hi && use < 0.9);

    // A sharp turn at top speed: the inner front wheel lifts before any tyre slides. Turning left,
    // the truck tips about the edge from the front-right contact to the rear's.
    Eigen::Vector2d outward;
    const double d = inside_edge(unladen.cog_m.head<2>(), unladen.contact_m[kFrontRight], unladen.contact_m[kRear], &outward);
    const double a_tip = kGravity_m_s2 * d / unladen.cog_m.z();
    // The first tyre-ground contact to lift: how much of each loaded tyre's grip peak is in use
    // then, and the chassis CoG's acceleration along the edge's outward normal (the truck's axes).
    struct Lift {
      bool lifted = false;
      double share = NAN, a = NAN;  // NaN: it never lifted
      void watch(const Outputs& s, const Eigen::Vector2d& outward) {
        if (lifted) return;
        lifted = s.wheels[kFrontLeft].fz_N <= 0 || s.wheels[kFrontRight].fz_N <= 0;
        if (!lifted) return;
        share = 0;
        for (const WheelContact& c : s.wheels)
          if (c.fz_N > 0) share = std::max(share, c.grip_share);
        const double yaw = s.q[kAwc];
        const Eigen::Vector2d n(std::cos(yaw) * outward.x() - std::sin(yaw) * outward.y(),
                                std::sin(yaw) * outward.x() + std::cos(yaw) * outward.y());
        a = -Eigen::Vector2d(s.qddot[kX], s.qddot[kY]).dot(n);
      }
    };
    // A step to 35 deg, past twice the angle at which it tips: a violent turn, which must still
    // lift a wheel before any tyre slides.
    Rig sharp(t_, std::nullopt, 0, 0);
    sharp.run(10, [&](const Outputs&) { return full_throttle(); });
    Lift step;
    sharp.run(3, [](const Outputs&) { DriverInputs u; u.steer_rad = -35 * kDeg; u.drive_torque_N_m = 0; return u; },
              [&](const Outputs& s) { step.watch(s, outward); });
    add("35 deg turn at top speed, unladen: the most any loaded tyre uses of its grip peak when the inner front wheel lifts",
        step.share, "of peak", "< 0.9 (it tips before it slides)",
        "physics: |(Fx, Fy)| / (peak mu Fz) of each tyre on the ground", step.lifted && step.share < 0.9);
    // The closed form is a steady turn's: the steer wound on slowly (5 deg/s) at top speed, the
    // throttle held, so that the lateral acceleration rises through g d / h with the truck in
    // equilibrium in roll. (A step's rear-steer swing rocks the truck on its tyres first, and the
    // wheel then lifts some 20 % early, as it would on a real truck: a dynamic, not a static, limit.)
    Rig ramp(t_, std::nullopt, 0, 0);
    ramp.run(10, [&](const Outputs&) { return full_throttle(); });
    Lift wound;
    const double ramp_start = ramp.sim->time();
    ramp.run(15, [&](const Outputs&) {
               DriverInputs u = full_throttle();
               u.steer_rad = -std::min(t_.steer.max_rad, 5 * kDeg * (ramp.sim->time() - ramp_start));
               return u;
             },
             [&](const Outputs& s) { wound.watch(s, outward); });
    relative("steer wound on at 5 deg/s at top speed, unladen: lateral acceleration when the inner front wheel lifts, against the stability triangle's g d / h (the parts' d, h)",
             wound.a, a_tip, 0.15, "physics: a rigid truck in a steady turn tips about the edge from the outer front contact to the rear's");
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
            (r.xy() - start).norm() * 1000, "mm", "< 10 mm",
            "the class's data sheets: 15 % laden gradeability; physics: a held brake does not creep", (r.xy() - start).norm() < 0.01);
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
                               fixed_decimals(v0 * 3.6, 1) + " km/h";
      relative(what + ": stopping distance against v^2 / 2a", (r.xy() - start).norm(), v0 * v0 / (2 * a), 0.15,
               "physics: the brakes' torque at the tyres and rolling resistance on the mass with its spinning parts");
      if (laden) add(what + ": largest pitch", pitch / kDeg, "deg", "< 5 deg (no tip)",
                     "ISO 22915-2 test 2: the laden truck travelling stands 18 % (10.2 deg); a braking that stays below it does not tip",
                     pitch < 5 * kDeg);
      const Eigen::Vector2d stopped = r.xy();
      r.run(5, [&](const Outputs&) { return full_brake(); });
      add(what + ": drift in the 5 s after", (r.xy() - stopped).norm() * 1000, "mm", "< 5 mm",
          "physics: a held brake on level ground does not creep", (r.xy() - stopped).norm() < 0.005);
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
    const double c_rr = (v1 - coast.v()) / (coast.sim->time() - t1) / kGravity_m_s2;
    add("coast-down from 3 m/s: rolling resistance, deceleration over g", c_rr, "",
        fixed_decimals(refs_.rolling_resistance_min, 3) + "-" + fixed_decimals(refs_.rolling_resistance_max, 3), refs_.rolling_resistance_source,
        c_rr >= refs_.rolling_resistance_min && c_rr <= refs_.rolling_resistance_max);
    coast.run(30, idle);
    add("coast-down: speed 35 s later", std::abs(coast.v()), "m/s", "< 0.001 (at rest)",
        "physics: rolling resistance brings a coasting truck to rest", std::abs(coast.v()) < 1e-3);

    // Top speed, and a yaw kick at it that dies away.
    for (bool laden : {false, true}) {
      std::optional<Load> load;
      if (laden) load = rated();
      Rig r(t_, load, laden ? travel_lift() : 0, back());
      r.run(25, [&](const Outputs&) { return full_throttle(); });
      const std::string what = laden ? "rated load" : "unladen";
      add(what + ": top speed at full throttle", r.v() * 3.6, "km/h",
          fixed_decimals(refs_.top_speed_m_s * 3.6, 1) + " +- " + fixed_decimals(refs_.top_speed_tolerance_m_s * 3.6, 1) + " km/h", refs_.top_speed_source,
          std::abs(r.v() - refs_.top_speed_m_s) <= refs_.top_speed_tolerance_m_s);
      r.kick_yaw(0.1);
      r.run(4, [&](const Outputs&) { return full_throttle(); });
      add(what + ": yaw rate 4 s after a 0.1 rad/s kick at top speed", std::abs(r.out.qdot[kAwc]), "rad/s", "< 0.01",
          "physics: a truck whose tyres' cornering force grows with slip runs straight again", std::abs(r.out.qdot[kAwc]) < 0.01);
    }
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
        "physics: its CoG past the stability triangle's edge, the truck falls onto its side and stops there",
        roll > 60 && speed < 0.05 && r.out.body_points_on_ground > 1);
    add("forced tip: deepest point below the floor", deepest * 100, "cm", "< 5 cm", "physics: the floor is solid", deepest < 0.05);
    add("forced tip: highest centre of gravity", cog, "m", "< 2 m (nothing launched)",
        "physics: a fall takes energy out; nothing throws the truck up", cog < 2.0);
  }

 private:
  const TruckParams& t_;
  const ValidationReferences& refs_;
};

}  // namespace

ValidationReferences load_validation_references(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot be read");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path + ": is not JSON (" + e.what() + ")");
  }
  auto number = [&](const nlohmann::json& v, const std::string& key) {
    if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() < 0)
      throw std::runtime_error(path + ": '" + key + "' must be a number, not negative");
    return v.get<double>();
  };
  auto text = [&](const std::string& key) {
    if (!j.contains(key) || !j[key].is_string()) throw std::runtime_error(path + ": '" + key + "' must say where the number comes from");
    return j[key].get<std::string>();
  };
  for (const char* key : {"top_speed_km_h", "top_speed_tolerance_km_h", "rolling_resistance"})
    if (!j.contains(key)) throw std::runtime_error(path + ": '" + std::string(key) + "' is missing");
  ValidationReferences r;
  r.top_speed_m_s = number(j["top_speed_km_h"], "top_speed_km_h") / 3.6;
  r.top_speed_tolerance_m_s = number(j["top_speed_tolerance_km_h"], "top_speed_tolerance_km_h") / 3.6;
  r.top_speed_source = text("_top_speed_why");
  const nlohmann::json& rr = j["rolling_resistance"];
  if (!rr.is_array() || rr.size() != 2) throw std::runtime_error(path + ": 'rolling_resistance' must be [least, most]");
  r.rolling_resistance_min = number(rr[0], "rolling_resistance");
  r.rolling_resistance_max = number(rr[1], "rolling_resistance");
  if (r.rolling_resistance_min > r.rolling_resistance_max)
    throw std::runtime_error(path + ": 'rolling_resistance' must be [least, most]");
  r.rolling_resistance_source = text("_rolling_resistance_why");
  return r;
}

std::vector<ValidationCheck> validate_truck(const TruckParams& truck, const ValidationReferences& references) {
  Checks c(truck, references);
  c.statics();
  c.tilt_table();
  c.cornering();
  c.brakes();
  c.driving();
  c.tip_over();
  return c.list;
}

}  // namespace forklift
