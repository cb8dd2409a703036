// The warehouse's people: triggers, the walk along a path, waits, and standing for the truck.
#include "forklift/scene/pedestrians.h"

#include <algorithm>
#include <cmath>

namespace forklift {
namespace {

Eigen::Vector2d leg_direction(const PedestrianSpec& spec, int leg) {
  return (spec.path[leg + 1] - spec.path[leg]).normalized();
}

double wait_at(const PedestrianSpec& spec, int point) {
  for (const PedestrianWait& w : spec.waits)
    if (w.at_point == point) return w.duration_s;
  return 0;
}

// Distance from p to a box in the frame `pose` (its x-y plane), floor distances only.
double box_distance(const Eigen::Isometry3d& pose, const Eigen::AlignedBox2d& box, const Eigen::Vector2d& p) {
  const Eigen::Vector3d local = pose.inverse() * Eigen::Vector3d(p.x(), p.y(), pose.translation().z());
  const Eigen::Vector2d q = local.head<2>();
  const Eigen::Vector2d d = (box.min() - q).cwiseMax(q - box.max()).cwiseMax(0.0);
  return d.norm();
}

}  // namespace

std::vector<PedestrianState> initial_pedestrians(const std::vector<PedestrianSpec>& specs) {
  std::vector<PedestrianState> out(specs.size());
  for (size_t i = 0; i < specs.size(); ++i) {
    out[i].at_m = specs[i].path.front();
    const Eigen::Vector2d d = leg_direction(specs[i], 0);
    out[i].heading_rad = std::atan2(d.y(), d.x());
  }
  return out;
}

TruckOutline truck_outline(const TruckShape& shape) {
  TruckOutline o;
  if (shape.chassis && !shape.chassis->bounds.isEmpty())
    o.chassis_m = Eigen::AlignedBox2d(shape.chassis->bounds.min().head<2>(), shape.chassis->bounds.max().head<2>());
  else
    o.chassis_m = Eigen::AlignedBox2d(Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero());
  const double half = 0.5 * (shape.fork_centres_y_m + shape.fork_width_m);
  o.forks_m = Eigen::AlignedBox2d(Eigen::Vector2d(0, -half), Eigen::Vector2d(shape.fork_length_m, half));
  return o;
}

double distance_to_truck(const TruckOutline& outline, const BodyPoses& poses, const Eigen::Vector2d& p) {
  return std::min(box_distance(poses.chassis, outline.chassis_m, p), box_distance(poses.carriage, outline.forks_m, p));
}

void walk(const std::vector<PedestrianSpec>& specs, std::vector<PedestrianState>& states, const TruckOutline& outline,
          const BodyPoses& poses, double t_s, double dt_s, bool horn) {
  for (size_t i = 0; i < specs.size(); ++i) {
    const PedestrianSpec& spec = specs[i];
    PedestrianState& s = states[i];
    s.speed_m_s = 0;
    if (s.struck || s.arrived) continue;
    // The truck's distance only where a rule of his reads it: a tick of people far away costs
    // little.
    const bool needs_distance = (!s.started && spec.start_truck_within_m) || spec.looks || spec.heeds_horn_within_m;
    const double d = needs_distance ? distance_to_truck(outline, poses, s.at_m) : 0.0;
    if (!s.started) {
      s.started = spec.start_truck_within_m ? d <= *spec.start_truck_within_m : t_s >= spec.start_at_s;
      if (!s.started) continue;
      s.wait_left_s = wait_at(spec, 0);
    }
    // The horn alerts one who heeds it only once he is about (walking or waiting on his path).
    if (horn && spec.heeds_horn_within_m && d <= *spec.heeds_horn_within_m) s.alerted = true;
    s.stopped_for_truck = (spec.looks && d <= spec.stop_within_m) || (s.alerted && d <= *spec.heeds_horn_within_m);
    if (s.stopped_for_truck) continue;
    if (s.wait_left_s > 0) {
      s.wait_left_s = std::max(0.0, s.wait_left_s - dt_s);
      continue;
    }
    double left = spec.speed_m_s * dt_s;
    s.speed_m_s = spec.speed_m_s;
    const int last_leg = int(spec.path.size()) - 2;
    while (left > 0) {
      const double length = (spec.path[s.leg + 1] - spec.path[s.leg]).norm();
      const double go = std::min(left, length - s.along_m);
      s.along_m += go;
      left -= go;
      if (s.along_m < length) break;
      // At the leg's end point: the next leg, a wait there, or the path's end.
      if (s.leg == last_leg) {
        s.arrived = true;
        s.along_m = length;
        break;
      }
      ++s.leg;
      s.along_m = 0;
      s.wait_left_s = wait_at(spec, s.leg);
      if (s.wait_left_s > 0) break;
    }
    const Eigen::Vector2d dir = leg_direction(spec, s.leg);
    s.at_m = spec.path[s.leg] + s.along_m * dir;
    s.heading_rad = std::atan2(dir.y(), dir.x());
  }
}

Eigen::Isometry3d standing_pose(const Eigen::Vector2d& at, double heading_rad, double height_m) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.translation() = Eigen::Vector3d(at.x(), at.y(), 0.5 * height_m);
  p.linear() = Eigen::AngleAxisd(heading_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return p;
}

Eigen::Isometry3d pedestrian_body_pose(const PedestrianSpec& spec, const PedestrianState& state) {
  return standing_pose(state.at_m, state.heading_rad, spec.size_m.z());
}

}  // namespace forklift
