// Private: view and projection matrices (OpenGL conventions: camera looks down -z, clip
// depth -1..1), and the near/far planes for a camera and the scene's extent.
#pragma once

#include <Eigen/Geometry>

#include "forklift/render/render.h"

namespace forklift::render {

Eigen::Matrix4d look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up);
Eigen::Matrix4d perspective(double fov_y_deg, double aspect, double near_m, double far_m);

// Depth range covering `extent` (world) seen from `eye`: far beyond its farthest corner; near
// as far out as the nearest point of the box allows (a high plan camera gets a large near
// plane and so a precise depth buffer), never under 10 cm (the cab's guard is close).
void depth_range(const Eigen::Vector3d& eye, const Eigen::AlignedBox3d& extent, double& near_m, double& far_m);

// Projection times view for `camera` on a width x height image.
Eigen::Matrix4d view_projection(const Camera& camera, int width, int height, const Eigen::AlignedBox3d& extent);

// An orthographic projection (glOrtho's): x in [-half_x, half_x], y likewise, depth near..far.
Eigen::Matrix4d orthographic(double half_x, double half_y, double near_m, double far_m);

// The volume a view-projection sees, as six planes in world coordinates: what lies wholly
// outside one of them is not drawn (frustum culling). Conservative: a box that only crosses a
// corner region outside the volume may still count as seen, never the other way round.
struct Frustum {
  explicit Frustum(const Eigen::Matrix4d& view_projection);
  bool may_see(const Eigen::AlignedBox3d& box) const;
  Eigen::Matrix<double, 6, 4> planes;  // rows: a.x + b.y + c.z + d >= 0 inside
};

}  // namespace forklift::render
