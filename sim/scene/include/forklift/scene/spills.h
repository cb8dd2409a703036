// Spills that appear during a session (a scenario's `spills` with a trigger, scene.h): whether
// each is on the floor yet. Whether one has appeared is a pure function of the scene, the truck's
// poses, sim time and the instructor's "hazard" (no clock, no random number), so a replay puts
// every spill down at the same tick, bit for bit, and the states (part of a session's state) are
// copied with a rewind point. The dynamics read them as the ground's absent grip patches.
//
// Frames: world x, y on the floor, z up, metres; sim time in seconds.
#pragma once

#include <cstdint>
#include <vector>

#include "forklift/scene/pedestrians.h"  // TruckOutline, distance_to_truck
#include "forklift/scene/scene.h"

namespace forklift {

// One spill's progress: a copyable value.
struct SpillState {
  bool appeared = false;    // on the floor: its trigger fired (or the instructor started it), or it has none
  double appeared_t_s = 0;  // sim time it appeared (0 for one there from the start)
};

// Every spill as the session starts: those without a trigger on the floor, the others not yet.
std::vector<SpillState> initial_spills(const std::vector<Spill>& spills);

// Each spill with a trigger not yet on the floor appears when its trigger fires at sim time `t_s`
// with the truck at `poses`: the time is reached, or the truck's outline comes within its
// distance of the patch's middle. `states` has one entry per spill (initial_spills).
void spread_spills(const std::vector<Spill>& spills, std::vector<SpillState>& states, const TruckOutline& outline,
                   const BodyPoses& poses, double t_s);

// The ground's grip patches not on the floor (Environment::grip_patches_absent): bit i for
// spill i with a trigger that has not appeared. `states` empty: as the session starts.
uint64_t absent_spills(const std::vector<Spill>& spills, const std::vector<SpillState>& states);

}  // namespace forklift
