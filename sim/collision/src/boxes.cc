// The Collision module's boxes: the truck's parts, the pallets' and the scene's, in their owners' frames.
#include <algorithm>

#include "collision_world.h"

namespace forklift::collision {
namespace {

// A mesh part of no thickness (a plane) still gets a box FCL can handle.
constexpr double kMinHalfExtentM = 0.0005;

}  // namespace

LocalBox box_of(const Eigen::AlignedBox3d& b) {
  LocalBox box;
  box.centre = Eigen::Isometry3d::Identity();
  box.centre.translation() = b.center();
  box.half = (0.5 * b.sizes()).cwiseMax(kMinHalfExtentM);
  return box;
}

LocalBox box_between(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) { return box_of(Eigen::AlignedBox3d(lo, hi)); }

const char* part_name(int part) {
  static constexpr const char* kNames[kNumParts] = {"chassis", "guard", "mast", "carriage", "fork_left", "fork_right", "load"};
  return part >= 0 && part < kNumParts ? kNames[part] : "?";
}

Eigen::AlignedBox3d world_aabb(const Eigen::Isometry3d& pose, const Eigen::Vector3d& half) {
  const Eigen::Vector3d r = pose.linear().cwiseAbs() * half;
  return Eigen::AlignedBox3d(pose.translation() - r, pose.translation() + r);
}

std::vector<LocalBox> pallet_boxes(const SceneObject& object, const PalletSpec& spec) {
  std::vector<LocalBox> boxes;
  if (object.mesh) {
    for (const MeshPart& p : object.mesh->parts)
      if (p.solid && !p.bounds.isEmpty()) boxes.push_back(box_of(p.bounds));
  } else {
    // Deck boards above the pockets, bottom boards below, block rows between the pockets.
    const double hl = 0.5 * spec.length_m, hw = 0.5 * spec.width_m;
    boxes.push_back(box_between({-hl, -hw, spec.pocket_top_m}, {hl, hw, spec.height_m}));
    if (spec.pocket_bottom_m > 0) boxes.push_back(box_between({-hl, -hw, 0}, {hl, hw, spec.pocket_bottom_m}));
    std::vector<Eigen::Vector2d> pockets = spec.pockets_y_m;
    std::sort(pockets.begin(), pockets.end(), [](const auto& a, const auto& b) { return a.x() < b.x(); });
    double y = -hw;
    for (const Eigen::Vector2d& p : pockets) {
      if (p.x() > y) boxes.push_back(box_between({-hl, y, spec.pocket_bottom_m}, {hl, p.x(), spec.pocket_top_m}));
      y = std::max(y, p.y());
    }
    if (y < hw) boxes.push_back(box_between({-hl, y, spec.pocket_bottom_m}, {hl, hw, spec.pocket_top_m}));
  }
  if ((spec.load_size_m.array() > 0).all()) {
    const Eigen::Vector3d s = spec.load_size_m;
    boxes.push_back(box_between({-0.5 * s.x(), -0.5 * s.y(), spec.height_m}, {0.5 * s.x(), 0.5 * s.y(), spec.height_m + s.z()}));
  }
  return boxes;
}

std::array<LocalBox, 2> fork_boxes(const TruckShape& shape) {
  std::array<LocalBox, 2> forks;
  std::array<bool, 2> found{false, false};
  if (shape.carriage) {
    for (const MeshPart& p : shape.carriage->parts) {
      const int i = p.name == "fork_left" ? 0 : p.name == "fork_right" ? 1 : -1;
      if (i >= 0 && !p.bounds.isEmpty()) { forks[i] = box_of(p.bounds); found[i] = true; }
    }
  }
  for (int i = 0; i < 2; ++i) {
    if (found[i]) continue;
    const double y = (i == 0 ? 0.5 : -0.5) * shape.fork_centres_y_m;
    forks[i] = box_between({0, y - 0.5 * shape.fork_width_m, -shape.fork_thickness_m}, {shape.fork_length_m, y + 0.5 * shape.fork_width_m, 0});
  }
  return forks;
}

}  // namespace forklift::collision
