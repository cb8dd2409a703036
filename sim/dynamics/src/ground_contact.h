// Where the truck's parts meet the ground's discontinuities: the steps' sides and top edges, and
// the ramps' sides and ends (Ground, dynamics.h). Geometry only: the evaluation in dynamics.cc
// turns each touch into a penalty force.
#pragma once

#include <Eigen/Core>

#include "forklift/dynamics/dynamics.h"

namespace forklift {

// One contact: how deep the part is into the ground along `normal` (unit, out of the ground,
// towards the part), and where (world).
struct GroundTouch {
  double depth_m = 0;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d point_m = Eigen::Vector3d::Zero();
};

// The most touches one query reports; more are dropped (a wheel meets at most a few edges).
inline constexpr int kMaxGroundTouches = 6;

// A wheel's rim against the edges and faces ahead of and behind it, beyond the level under its
// centre (which the caller's plane contact handles). The rim is the circle of radius `reach`
// (the radius times the cosine of the camber) in the vertical plane through `centre` across
// `axle`; its profile along that plane meets each level higher than every level between it and
// the centre at its near corner (an edge below the centre) or its face (a kerb above it).
// Returns how many touches it wrote to `out`.
int wheel_edge_touches(const Ground& ground, const Eigen::Vector3d& centre, const Eigen::Vector3d& axle,
                       double reach, GroundTouch* out);

// A point below the ground leaves it the shortest way: up through the level over it (along the
// ramp's normal on a ramp), or sideways through a step's side where the ground beyond is lower
// than the point. False (t unset) if the point is not below the ground.
bool point_touch(const Ground& ground, const Eigen::Vector3d& p, GroundTouch& t);

// The steps' top edges (where the ground beyond a side is lower than the top) against a box of a
// rigid part: `R`, `origin` its frame in the world, `lo`, `hi` its corners in that frame. Each
// edge crossing the box pushes it out through the face it leaves by the shortest way, at the
// middle of the part of the edge inside it. Returns how many touches it wrote to `out`.
int box_edge_touches(const Ground& ground, const Eigen::Matrix3d& R, const Eigen::Vector3d& origin,
                     const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, GroundTouch* out);

}  // namespace forklift
