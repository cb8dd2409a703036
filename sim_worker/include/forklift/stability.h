// Static analyses of the truck: resting loads on flat ground, and a virtual tilt table.
#pragma once

#include <optional>

#include "forklift/dynamics.h"

namespace forklift {

struct StaticReport {
  bool settled = false;           // false: no equilibrium with every wheel down (it tips)
  double total_mass_kg = 0;
  Eigen::Vector3d cog_m = Eigen::Vector3d::Zero();        // world, truck at the origin facing +x
  std::optional<Eigen::Vector3d> load_cog_m;              // world
  std::array<Eigen::Vector2d, kNumWheels> wheel_contact_m{};
  std::array<double, kNumWheels> fz_N{};
  bool rear_wheel_lifted = false;
};

// Settles the truck at rest on flat ground with the forks at `lift_m` and the load, if any.
StaticReport static_report(const TruckParams& truck, const std::optional<Load>& load, double lift_m);

enum class TiltAxis {
  kLongitudinal,  // the table's front goes down (forward tip: the laden stacking case)
  kLateral,       // the table's right side goes down (sideways tip)
};

struct TiltResult {
  double critical_angle_deg = 0;  // the table angle at which the first wheel's Fz reaches zero
  int lifted_wheel = -1;          // Wheel index
};

// A virtual tilt-table test in the spirit of ISO 3691-1 / ISO 22915: the table tilts in
// quasi-static steps (tilting the table is tilting gravity in its frame) with the wheels chocked
// against sliding, until a wheel leaves the ground; the angle is refined by bisection to 0.01 deg.
// Throws std::runtime_error if the truck does not stand on the level table.
TiltResult tilt_table(const TruckParams& truck, const std::optional<Load>& load, double lift_m, TiltAxis axis);

}  // namespace forklift
