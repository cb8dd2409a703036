// Pallets that fall from their rack level (a scenario's `falling_pallets`, scene.h): when each
// starts and where it is as it falls. The fall is a pure function of the scene, the truck's poses
// and sim time (no clock, no random number), so a replay drops every pallet the same way, bit for
// bit, and the states (part of a session's state) are copied with a rewind point.
//
// Frames: world x, y on the floor, z up, metres; sim time in seconds.
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "forklift/scene/pedestrians.h"  // TruckOutline, distance_to_truck
#include "forklift/scene/scene.h"

namespace forklift {

// One falling pallet's progress: a copyable value.
struct FallingPalletState {
  bool started = false;    // its trigger fired (or the instructor started it)
  bool landed = false;     // on the floor: it lies there from now on
  double started_t_s = 0;  // sim time it left the beams
};

// Every pallet still on its beams.
std::vector<FallingPalletState> initial_falls(const std::vector<FallingPalletSpec>& specs);

// Whether a hazard's trigger fires at sim time `t_s` with the truck at `poses`: with a distance
// (`truck_within_m` set), the truck's outline within it of `at` (world); else `t_s` >= `at_s`.
bool trigger_fired(const std::optional<double>& truck_within_m, double at_s, const TruckOutline& outline,
                   const BodyPoses& poses, const Eigen::Vector2d& at, double t_s);

// Whether `spec`'s trigger fires at sim time `t_s` with the truck at `poses`: the time is reached,
// or the truck's outline is within the distance of the pallet's middle (`at`, world).
bool fall_triggered(const FallingPalletSpec& spec, const TruckOutline& outline, const BodyPoses& poses,
                    const Eigen::Vector2d& at, double t_s);

// The pallet's pose `since_s` after it left the beams from `start` (its pose resting there):
// dropping in free fall under g (m/s^2, > 0) to `floor_z` while it slides `throw_m` along
// `toward_rad` (evenly over the fall), level all the way; `landed` says whether it is down.
Eigen::Isometry3d falling_pose(const FallingPalletSpec& spec, const Eigen::Isometry3d& start, double floor_z, double g,
                               double since_s, bool& landed);

}  // namespace forklift
