// Private: the geometry and mechanics of pallet handling, as pure functions of poses and specs
// (the Warehouse keeps the state and calls these every tick).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>

#include "collision_world.h"
#include "forklift/scene/scene.h"
#include "forklift/dynamics/truck.h"

namespace forklift::handling {

// Thresholds. Each is small beside the geometry it guards and large beside one tick's motion
// (lift at most 0.45 m/s: 0.45 mm per 1 ms tick).
inline constexpr double kForkAxisMaxAngleRad = 10.0 * M_PI / 180.0;  // fork axis vs the pallet's x axis
inline constexpr double kPocketToleranceM = 0.01;   // a fork may lie this far outside a pocket's walls
inline constexpr double kMinInsertion = 0.5;        // of the pallet's length, along the forks
inline constexpr double kPickArmClearanceM = 0.005; // forks this far below the deck arm a pick-up
inline constexpr double kLiftedClearM = 0.01;       // carried pallet this far above where it was picked up
inline constexpr double kSinkM = 0.015;             // lowered this far below its pick-up support: set down anyway
inline constexpr double kSupportWindowM = 0.02;     // underside this far below a support still lands on it
inline constexpr double kTouchM = 0.001;            // underside this close above a support touches it
// A carried load this deep into a surface below it rests on it (just picked up, the truck
// settling under the new weight) or is being set down there: not a strike.
inline constexpr double kRestingTouchDepthM = kSinkM;

// Where the forks are relative to one pallet.
struct Engagement {
  bool engaged = false;       // both forks in (different) pockets, aligned, inserted far enough
  double fork_top_m = -1e9;   // highest point of the forks' top faces inside the pallet, pallet frame z
};

// `pallet_from_carriage`: the carriage frame (fork heel) in the pallet's local frame.
Engagement engagement(const PalletSpec& spec, const Eigen::Isometry3d& pallet_from_carriage,
                      const std::array<collision::LocalBox, 2>& forks);

// The pallet and its load as one rigid load on the forks: mass, CoG and inertia (about the CoG)
// in the carriage frame, its base's length along the forks and its friction on them, for
// Simulation::attach_load (which slides it and lets it fall as friction says). `carriage_from_pallet`: the pallet's pose
// on the forks.
Load pallet_load(const PalletSpec& spec, const Eigen::Isometry3d& carriage_from_pallet);
// The combined CoG in the pallet's local frame.
Eigen::Vector3d pallet_cog(const PalletSpec& spec);

}  // namespace forklift::handling
