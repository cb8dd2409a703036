#include "forklift/stability.h"

#include <cmath>
#include <stdexcept>

namespace forklift {
namespace {

constexpr double kG = 9.81;

// Runs the evaluator once at rest and returns its outputs.
Outputs outputs_at(const TruckDynamics& dyn, const StateVector& x) {
  Outputs out;
  StateVector dx;
  dyn.derivative(x, DriverInputs{}, dx, &out);
  return out;
}

}  // namespace

StaticReport static_report(const TruckParams& truck, const std::optional<Load>& load, double lift_m) {
  TruckDynamics dyn(truck);
  if (load) dyn.attach_load(*load);
  // Placed so that the geometry frame (ground below the front axle) is the world origin.
  StateVector x = dyn.rest_state(truck.chassis_cog_geometry_m.x(), 0, 0, 0, 0, lift_m, 0);
  StaticReport r;
  r.settled = dyn.settle_static(x);
  const Outputs out = outputs_at(dyn, x);
  r.total_mass_kg = out.total_mass_kg;
  r.cog_m = out.cog_m;
  for (int w = 0; w < kNumWheels; ++w) {
    r.wheel_contact_m[w] = out.wheels[w].contact_point_m.head<2>();
    r.fz_N[w] = r.settled ? out.wheels[w].fz_N : 0.0;
  }
  // A truck that has no equilibrium with all wheels down tips about its front axle.
  r.rear_wheel_lifted = !r.settled || r.fz_N[kRear] <= 0;
  if (load) {
    // The load's CoG: carriage frame origin (fork heel) plus its offset, through the mast tilt.
    const Eigen::Vector3d pivot = Eigen::Vector3d(out.q[kX], out.q[kY], out.q[kZ]) + truck.mast_pivot_m;
    const Eigen::Vector3d heel = truck.fork_heel_from_pivot_m + Eigen::Vector3d(0, out.q[kR], out.q[kS]);
    r.load_cog_m = pivot + heel + load->cog_m;  // level truck, mast upright: a static report
  }
  return r;
}

TiltResult tilt_table(const TruckParams& truck, const std::optional<Load>& load, double lift_m, TiltAxis axis) {
  TruckDynamics dyn(truck);
  if (load) dyn.attach_load(*load);
  StateVector level = dyn.rest_state(0, 0, 0, 0, 0, lift_m, 0);
  if (!dyn.settle_static(level)) throw std::runtime_error("tilt table: the truck does not stand on the level table");
  std::array<Eigen::Vector2d, kNumWheels> anchors;
  const Outputs at_rest = outputs_at(dyn, level);
  for (int w = 0; w < kNumWheels; ++w) anchors[w] = at_rest.wheels[w].contact_point_m.head<2>();
  dyn.environment().chock_anchors_m = anchors;

  StateVector x = level;
  // Stands at angle a: an equilibrium exists with every wheel loaded. Warm-started from `x`.
  auto stands = [&](double a_deg, StateVector& s, int* lifted) {
    const double a = a_deg * M_PI / 180;
    dyn.environment().gravity_m_s2 = axis == TiltAxis::kLongitudinal
                                         ? Eigen::Vector3d(kG * std::sin(a), 0, -kG * std::cos(a))
                                         : Eigen::Vector3d(0, -kG * std::sin(a), -kG * std::cos(a));
    const bool ok = dyn.settle_static(s);
    const Outputs out = outputs_at(dyn, s);
    int lowest = 0;
    for (int w = 1; w < kNumWheels; ++w) if (out.wheels[w].fz_N < out.wheels[lowest].fz_N) lowest = w;
    if (lifted) *lifted = lowest;
    return ok && out.wheels[lowest].fz_N > 0;
  };

  TiltResult r;
  double good = 0, bad = -1;
  for (double a = 0.5; a <= 60.0; a += 0.5) {
    StateVector trial = x;
    if (!stands(a, trial, &r.lifted_wheel)) { bad = a; break; }
    x = trial;
    good = a;
  }
  if (bad < 0) { r.critical_angle_deg = good; return r; }
  while (bad - good > 0.01) {
    const double mid = 0.5 * (good + bad);
    StateVector trial = x;
    int lifted;
    if (stands(mid, trial, &lifted)) { good = mid; x = trial; } else { bad = mid; r.lifted_wheel = lifted; }
  }
  r.critical_angle_deg = 0.5 * (good + bad);
  return r;
}

}  // namespace forklift
