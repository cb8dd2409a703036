// View names, the three views' cameras, and the camera matrices.
#include "camera.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "forklift/protocol/aids.h"
#include "forklift/units/units.h"

namespace forklift {
namespace {

using Eigen::Vector3d;

// The cab view: from the driver's eye, along the truck, pitched down a little so the fork
// tips and the floor ahead of them are in the lower part of the picture.
constexpr double kDriverPitchDownDeg = 10;
constexpr double kDriverFovDeg = 75;
// Turning the head: the eyes move sideways by this much times the sine of the turn (a driver
// leans to look round the mast), and the mirror looks back from the eye, pitched down a little
// to show the floor behind, with a mirror's narrow field.
constexpr double kHeadLeanM = 0.15;
constexpr double kMirrorPitchDownDeg = 8;
constexpr double kMirrorFovDeg = 30;
// The fork camera: above the forks' top face at their heel, looking down this much, this wide.
constexpr double kForkCameraUpM = 0.06, kForkCameraPitchDownDeg = 4, kForkCameraFovDeg = 60;
// The instructor's view: behind, above and to the left of the truck (in its heading frame, so
// it neither rolls nor pitches with the chassis), looking down at about 45 degrees on a point
// ahead of the front axle, so that both forks and their load show past the cab and the mast.
const Vector3d kChaseEye(-3.0, 3.0, 4.2);
const Vector3d kChaseTarget(0.5, 0.0, 0.6);
constexpr double kChaseFovDeg = 55;
// Plan: straight down on the floor's middle from high enough to see all of it (a narrow field
// of view, so nearly orthographic); with no floor, 30 m of the truck's surroundings.
constexpr double kPlanFovDeg = 20;
constexpr double kPlanMarginM = 1.0;
constexpr double kPlanAspect = 4.0 / 3.0;  // fit the floor's width for 4:3 pictures and wider

// The truck's heading frame: at the chassis origin, yaw only.
Eigen::Isometry3d heading_frame(const Eigen::Isometry3d& chassis) {
  const Vector3d x = chassis.linear().col(0);
  Eigen::Isometry3d f = Eigen::Isometry3d::Identity();
  f.linear() = Eigen::AngleAxisd(std::atan2(x.y(), x.x()), Vector3d::UnitZ()).toRotationMatrix();
  f.translation() = chassis.translation();
  return f;
}

}  // namespace

const char* view_name(View v) {
  switch (v) {
    case View::kDriver: return "driver";
    case View::kChase: return "chase";
    case View::kPlan: return "plan";
  }
  return "unknown";
}

View parse_view(const std::string& name) {
  for (View v : {View::kDriver, View::kChase, View::kPlan})
    if (name == view_name(v)) return v;
  throw std::invalid_argument("unknown view '" + name + "' (driver, chase or plan)");
}

Camera view_camera(View view, const BodyPoses& poses, const TruckShape& shape, const Scene& scene) {
  Camera c;
  switch (view) {
    case View::kDriver: c = driver_camera(poses, shape, 0, 0); break;
    case View::kChase: {
      const Eigen::Isometry3d f = heading_frame(poses.chassis);
      c.eye = f * kChaseEye;
      c.target = f * kChaseTarget;
      c.up = Vector3d::UnitZ();
      c.fov_y_deg = kChaseFovDeg;
      break;
    }
    case View::kPlan: {
      Eigen::AlignedBox2d area = scene.floor;
      const Eigen::Vector2d truck = poses.chassis.translation().head<2>();
      if (area.isEmpty()) area = Eigen::AlignedBox2d(truck.array() - 15.0, truck.array() + 15.0);
      area.extend(truck);
      const Eigen::Vector2d half = 0.5 * area.sizes().array() + kPlanMarginM;
      const double t = std::tan(0.5 * kPlanFovDeg * kDeg);
      const double height = std::max(half.y() / t, half.x() / (t * kPlanAspect));
      const Eigen::Vector2d mid = area.center();
      c.target = Vector3d(mid.x(), mid.y(), 0);
      c.eye = c.target + Vector3d(0, 0, height);
      c.up = Vector3d::UnitY();  // world x to the right, y up the picture, as on a map
      c.fov_y_deg = kPlanFovDeg;
      break;
    }
  }
  return c;
}

std::pair<View, ViewOptions> granted_view(int camera, ViewOptions asked, View camera0, uint8_t aids) {
  asked.rear_view = asked.rear_view && (aids & aids::kRearView);
  asked.see_through_mast = asked.see_through_mast && (aids & aids::kSeeThroughMast);
  asked.fork_camera = asked.fork_camera && (aids & aids::kForkCamera);
  const View view = camera == 1 && (aids & aids::kChaseCamera) ? View::kChase : camera0;
  return {view, asked};
}

Camera driver_camera(const BodyPoses& poses, const TruckShape& shape, double look_yaw_rad, double look_pitch_rad) {
  // Non-finite angles (never from a checked sample) look straight ahead.
  const double yaw = std::isfinite(look_yaw_rad) ? std::clamp(look_yaw_rad, -kLookYawMaxRad, kLookYawMaxRad) : 0.0;
  const double pitch =
      (std::isfinite(look_pitch_rad) ? std::clamp(look_pitch_rad, -kLookPitchMaxRad, kLookPitchMaxRad) : 0.0) -
      kDriverPitchDownDeg * kDeg;
  const Eigen::Matrix3d R = poses.chassis.linear();
  Camera c;
  c.eye = poses.chassis * (shape.eye_m + Vector3d(0, kHeadLeanM * std::sin(yaw), 0));
  c.target = c.eye + R * Vector3d(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw), std::sin(pitch));
  c.up = R.col(2);
  c.fov_y_deg = kDriverFovDeg;
  return c;
}

Camera mirror_camera(const BodyPoses& poses, const TruckShape& shape) {
  const Eigen::Matrix3d R = poses.chassis.linear();
  const double p = kMirrorPitchDownDeg * kDeg;
  Camera c;
  c.eye = poses.chassis * shape.eye_m;
  c.target = c.eye + R * Vector3d(-std::cos(p), 0, -std::sin(p));
  c.up = R.col(2);
  c.fov_y_deg = kMirrorFovDeg;
  return c;
}

Camera fork_camera(const BodyPoses& poses) {
  const Eigen::Matrix3d R = poses.carriage.linear();
  const double p = kForkCameraPitchDownDeg * kDeg;
  Camera c;
  c.eye = poses.carriage * Vector3d(0, 0, kForkCameraUpM);
  c.target = c.eye + R * Vector3d(std::cos(p), 0, -std::sin(p));
  c.up = R.col(2);
  c.fov_y_deg = kForkCameraFovDeg;
  return c;
}

namespace render {

Eigen::Matrix4d look_at(const Vector3d& eye, const Vector3d& target, const Vector3d& up) {
  Vector3d f = target - eye;
  if (f.norm() < 1e-12) f = Vector3d::UnitX();
  f.normalize();
  Vector3d s = f.cross(up);
  if (s.norm() < 1e-9) s = f.cross(std::abs(f.z()) < 0.9 ? Vector3d::UnitZ() : Vector3d::UnitY());
  s.normalize();
  const Vector3d u = s.cross(f);
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.block<1, 3>(0, 0) = s.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -s.dot(eye);
  m(1, 3) = -u.dot(eye);
  m(2, 3) = f.dot(eye);
  return m;
}

Eigen::Matrix4d perspective(double fov_y_deg, double aspect, double near_m, double far_m) {
  const double f = 1.0 / std::tan(0.5 * std::clamp(fov_y_deg, 1.0, 170.0) * kDeg);
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  m(0, 0) = f / aspect;
  m(1, 1) = f;
  m(2, 2) = (far_m + near_m) / (near_m - far_m);
  m(2, 3) = 2.0 * far_m * near_m / (near_m - far_m);
  m(3, 2) = -1.0;
  return m;
}

void depth_range(const Vector3d& eye, const Eigen::AlignedBox3d& extent, double& near_m, double& far_m) {
  constexpr double kMinNear = 0.1;
  if (extent.isEmpty()) {
    near_m = kMinNear;
    far_m = 500;
    return;
  }
  double farthest = 0;
  for (int i = 0; i < 8; ++i)
    farthest = std::max(farthest, (extent.corner(Eigen::AlignedBox3d::CornerType(i)) - eye).norm());
  far_m = farthest * 1.05 + 1.0;
  near_m = std::max(kMinNear, 0.9 * std::sqrt(extent.squaredExteriorDistance(eye)));
  // Keep the depth buffer's resolution sane however far away the scene is.
  near_m = std::min(near_m, 0.5 * far_m);
}

Eigen::Matrix4d view_projection(const Camera& camera, int width, int height, const Eigen::AlignedBox3d& extent) {
  double near_m = 0, far_m = 0;
  depth_range(camera.eye, extent, near_m, far_m);
  return perspective(camera.fov_y_deg, double(width) / std::max(height, 1), near_m, far_m) *
         look_at(camera.eye, camera.target, camera.up);
}

Eigen::Matrix4d orthographic(double half_x, double half_y, double near_m, double far_m) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m(0, 0) = 1.0 / half_x;
  m(1, 1) = 1.0 / half_y;
  m(2, 2) = -2.0 / (far_m - near_m);
  m(2, 3) = -(far_m + near_m) / (far_m - near_m);
  return m;
}

// Gribb and Hartmann: a clip-space point is inside when -w <= x, y, z <= w, each a plane in world.
Frustum::Frustum(const Eigen::Matrix4d& m) {
  for (int axis = 0; axis < 3; ++axis) {
    planes.row(2 * axis) = m.row(3) + m.row(axis);
    planes.row(2 * axis + 1) = m.row(3) - m.row(axis);
  }
}

bool Frustum::may_see(const Eigen::AlignedBox3d& box) const {
  if (box.isEmpty()) return false;
  for (int i = 0; i < 6; ++i) {
    // The box's corner furthest along the plane's normal: if even that is outside, all is.
    const Eigen::Vector3d n = planes.row(i).head<3>().transpose();
    const Eigen::Vector3d far_corner = (n.array() >= 0).select(box.max(), box.min());
    if (n.dot(far_corner) + planes(i, 3) < 0) return false;
  }
  return true;
}

}  // namespace render
}  // namespace forklift
