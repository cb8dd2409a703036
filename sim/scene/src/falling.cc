#include "forklift/scene/falling.h"

#include <algorithm>
#include <cmath>

namespace forklift {

std::vector<FallingPalletState> initial_falls(const std::vector<FallingPalletSpec>& specs) {
  return std::vector<FallingPalletState>(specs.size());
}

bool trigger_fired(const std::optional<double>& truck_within_m, double at_s, const TruckOutline& outline,
                   const BodyPoses& poses, const Eigen::Vector2d& at, double t_s) {
  if (truck_within_m) return distance_to_truck(outline, poses, at) <= *truck_within_m;
  return t_s >= at_s;
}

bool fall_triggered(const FallingPalletSpec& spec, const TruckOutline& outline, const BodyPoses& poses,
                    const Eigen::Vector2d& at, double t_s) {
  return trigger_fired(spec.start_truck_within_m, spec.start_at_s, outline, poses, at, t_s);
}

Eigen::Isometry3d falling_pose(const FallingPalletSpec& spec, const Eigen::Isometry3d& start, double floor_z, double g,
                               double since_s, bool& landed) {
  const double drop = std::max(0.0, start.translation().z() - floor_z);
  const double fall_s = std::sqrt(2 * drop / g);
  const double s = std::max(0.0, since_s);
  landed = s >= fall_s;
  const double share = landed || fall_s <= 0 ? 1.0 : s / fall_s;
  Eigen::Isometry3d pose = start;
  pose.translation().x() += share * spec.throw_m * std::cos(spec.toward_rad);
  pose.translation().y() += share * spec.throw_m * std::sin(spec.toward_rad);
  pose.translation().z() = landed ? floor_z : start.translation().z() - 0.5 * g * s * s;
  return pose;
}

}  // namespace forklift
