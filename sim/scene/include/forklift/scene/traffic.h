// The warehouse's other trucks (a scenario's `trucks`, scene.h): where each is and how each drives
// its route, tick by tick, and how it gives way at the crossings where the pupil has priority.
// The drive is a pure function of the scene, the pupil's truck's poses and sim time: no clock, no
// random number, so a replay of a session's inputs drives every truck the same way, bit for bit,
// and a copy of the states (part of a session's state) is a rewind point.
//
// Frames: world x, y on the floor, z up, metres; sim time in seconds.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "forklift/dynamics/dynamics.h"  // BodyPoses
#include "forklift/scene/pedestrians.h"  // TruckOutline, distance_to_truck
#include "forklift/scene/scene.h"

namespace forklift {

// Where one other truck is and what it is doing: a copyable value.
struct OtherTruckState {
  Eigen::Vector2d at_m = Eigen::Vector2d::Zero();  // world, the body's middle on the floor
  double heading_rad = 0;  // along the leg it drives (+x = 0)
  int leg = 0;             // driving from route[leg] to route[leg + 1] (a loop's last: back to route[0])
  double along_m = 0;      // how far along that leg
  double speed_m_s = 0;    // this tick's: 0 standing, the spec's speed driving
  bool started = false;    // its trigger has fired (or the instructor started it)
  bool arrived = false;    // at the end of a route that does not loop: stands there
  int giving_way = -1;     // >= 0: standing short of this crossing (Scene::crossings) for the pupil's truck or another
  bool stopped_for_truck = false;  // standing: the pupil's truck is within its stop_within_m ahead
  bool struck = false;     // the pupil's truck struck it: its driver stops there (set by the session)
};

// Every truck at the start: on the first point of its route, facing along it, not yet driving.
std::vector<OtherTruckState> initial_trucks(const std::vector<OtherTruckSpec>& specs);

// One tick of `dt_s` ending at sim time `t_s`, with the pupil's truck at `poses`: each truck
// starts when its trigger fires and drives its route at its speed; it stands (a) short of a
// crossing where the pupil has priority, when the move would take the middle of its front into
// the crossing's area while the pupil's truck's outline is within the crossing's watch_m of the
// crossing's middle, (b) short of any crossing, when the move would take its front into the
// crossing's area while another truck's body (its centre line, rear to front) is in it: the one
// that reached it first goes first, and of two reaching it in the same tick the one listed first
// (the trucks move in the scene's order), (c) while the pupil's truck is within its stop_within_m
// of its front, and (d) once struck. `states` has one entry per spec (initial_trucks).
void drive(const std::vector<OtherTruckSpec>& specs, const std::vector<Crossing>& crossings,
           std::vector<OtherTruckState>& states, const TruckOutline& outline, const BodyPoses& poses, double t_s,
           double dt_s);

// The body's pose: an upright box of the spec's size standing on z = 0 at the state's place,
// facing its heading (local x: along its length), its centre at half height.
Eigen::Isometry3d other_truck_pose(const OtherTruckSpec& spec, const OtherTruckState& state);

}  // namespace forklift
