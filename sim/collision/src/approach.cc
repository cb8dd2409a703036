// The forks against the nearest pallet ahead (or one named pallet): how far, how high, how far to the side and how
// far off square, for the pupil lining up (the engagement test itself is pallet_handling's).
#include <cmath>

#include "collision_world.h"
#include "forklift/collision/collision.h"
#include "pallet_handling.h"

namespace forklift {

std::optional<PalletApproach> pallet_approach(const Scene& scene, const std::vector<PalletState>& pallets,
                                              const BodyPoses& poses, const TruckShape& shape, double range_m,
                                              const std::string& only) {
  const std::array<collision::LocalBox, 2> forks = collision::fork_boxes(shape);
  std::optional<PalletApproach> best;
  for (const PalletState& p : pallets) {
    if (p.on_forks || p.dropped || (!only.empty() && p.id != only)) continue;
    const SceneObject* o = scene.find(p.id);
    if (!o || !o->pallet) continue;
    const PalletSpec& spec = *o->pallet;
    const Eigen::Isometry3d pallet_from_carriage = p.pose.inverse() * poses.carriage;
    // The forks enter through either end face: work in the pallet's frame turned so that they
    // point along +x.
    const Eigen::Vector3d axis = pallet_from_carriage.linear().col(0);
    const double s = axis.x() >= 0 ? 1.0 : -1.0;
    const Eigen::Vector3d heel = pallet_from_carriage.translation();
    const double angle = std::atan2(s * axis.y(), s * axis.x());
    if (std::abs(angle) > M_PI / 4) continue;
    const double hl = 0.5 * spec.length_m;
    // Where the forks' centre line crosses the near face (x' = -hl).
    const double heel_x = s * heel.x();
    const double ax = s * axis.x();
    const double t_face = (-hl - heel_x) / ax;  // along the forks from the heel
    const Eigen::Vector3d at_face = heel + t_face * axis;
    const double lateral = s * at_face.y();
    const double distance = t_face - shape.fork_length_m;  // the tips' distance to the face
    if (distance > range_m || t_face < -0.1 || std::abs(lateral) > 1.0) continue;
    // The forks' top face at the near face, and their middle height against the pockets'.
    const double fork_top = at_face.z();
    const double fork_mid = fork_top - 0.5 * shape.fork_thickness_m;
    const double pocket_mid = 0.5 * (spec.pocket_bottom_m + spec.pocket_top_m);
    PalletApproach a;
    a.pallet = p.id;
    a.distance_m = distance;
    a.height_m = fork_mid - pocket_mid;
    a.lateral_m = lateral;
    a.angle_rad = angle;
    a.height_tolerance_m = std::max(0.0, 0.5 * (spec.pocket_top_m - spec.pocket_bottom_m - shape.fork_thickness_m));
    // Each fork in its pocket: the room it has to either side, the tighter of the two forks'.
    double room = 1e9;
    for (const collision::LocalBox& f : forks) {
      const double y = f.centre.translation().y(), half = f.half.y();
      for (const Eigen::Vector2d& pk : spec.pockets_y_m)
        if (y - half >= pk.x() - 1e-9 && y + half <= pk.y() + 1e-9) room = std::min({room, y - half - pk.x(), pk.y() - y - half});
    }
    a.lateral_tolerance_m = room < 1e9 ? room : 0.0;
    a.angle_tolerance_rad = handling::kForkAxisMaxAngleRad;
    a.engaged = handling::engagement(spec, pallet_from_carriage, forks).engaged;
    if (!best || a.distance_m < best->distance_m) best = a;
  }
  return best;
}

}  // namespace forklift
