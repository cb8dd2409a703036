// Static analyses of the truck: resting loads on flat ground, and a virtual tilt table.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "forklift/dynamics/dynamics.h"

namespace forklift {

struct StaticReport {
  bool settled = false;           // false: no equilibrium with every wheel down (it tips)
  double total_mass_kg = 0;
  Eigen::Vector3d cog_m = Eigen::Vector3d::Zero();        // world, truck at the origin facing +x
  std::optional<Eigen::Vector3d> load_cog_m;              // world
  std::array<Eigen::Vector2d, kNumWheels> wheel_contact_m{};
  std::array<double, kNumWheels> fz_N{};
  bool rear_wheel_lifted = false;
  double grade_pct = 0;
  double drift_m = 0;             // on a grade: how far the parked truck moved in its last 2 s
};

// Settles the truck at rest with the forks at `lift_m` and the load, if any: on level ground by
// Newton's method; on a grade (+ rising ahead of the truck) then also by letting it come to rest
// on its parking brake, so that the tyres' and brakes' friction take the slope's pull.
StaticReport static_report(const TruckParams& truck, const std::optional<Load>& load, double lift_m,
                           double grade_pct = 0);

enum class TiltAxis {
  kLongitudinal,  // about the front axle's contact line, the table's front going down (forward tip)
  kLateral,       // about the line from the front-right contact to the steer pivot, right side down
};

struct TiltResult {
  double critical_angle_deg = 0;  // the table angle at which the first wheel's Fz reaches zero
  int lifted_wheel = -1;          // Wheel index
  double rigid_angle_deg = 0;     // atan(d / h): a rigid truck's angle, CoG d from the tipping line, h high
};

// The truck standing on that tilt table (below) tilted to `angle_deg`, settled: its outputs (wheel
// loads, contact points in the table's frame), or nullopt if a wheel leaves the table on the way.
std::optional<Outputs> on_tilted_table(const TruckParams& truck, const std::optional<Load>& load, double lift_m,
                                       TiltAxis axis, double angle_deg, double tilt_rad = 0);

// A virtual tilt table in the manner of ISO 22915-1: the truck stands on the table with its brakes
// applied (wheels locked to the chassis) and its tyres chocked against sliding; the table tilts in
// quasi-static steps (tilting the table is tilting gravity in its frame) until a wheel leaves it;
// the angle is refined by bisection to 0.01 deg. `tilt_rad` is the mast tilt (+ forward).
// Throws std::runtime_error if the truck does not stand on the level table.
TiltResult tilt_table(const TruckParams& truck, const std::optional<Load>& load, double lift_m, TiltAxis axis,
                      double tilt_rad = 0);

// The four tilt-table tests of ISO 22915-2 for counterbalanced trucks up to 5000 kg, each with the
// standard's load, fork height, mast tilt and a 98 kg operator on the seat.
struct IsoTiltTest {
  int number = 0;                 // 1-4
  std::string name;               // "longitudinal stacking", ...
  TiltAxis axis = TiltAxis::kLongitudinal;
  double load_kg = 0;             // rated load at the rated load centre (a 1 m cube), or none
  double fork_height_m = 0;       // top of the forks above the table
  double mast_tilt_rad = 0;       // + forward
  double required_slope_pct = 0;
  double required_deg = 0;
  TiltResult result;
  double margin_deg = 0;          // result - required
  bool pass = false;
  double lift_m = 0;              // the fork lift s that puts the forks at fork_height_m
};
std::vector<IsoTiltTest> iso_22915_2(const TruckParams& truck);
inline constexpr double kIsoOperatorKg = 98;  // ISO 22915-1: the seated operator's mass

// The fork lift s that puts the top of the forks `height_m` above level ground (mast upright).
double lift_for_fork_height(const TruckParams& truck, double height_m);

// Share of the least-loaded wheel relative to an even split of the total: 1 even, 0 a wheel off.
double stability_margin(const Outputs& o);

}  // namespace forklift
