// The warehouse's people (a scenario's `pedestrians`, scene.h): where each stands and how each
// walks, tick by tick. The walk is a pure function of the scene, the truck's poses and sim time:
// no clock, no random number, so a replay of a session's inputs walks everyone the same way, bit
// for bit, and a copy of the states (part of a session's state) is a rewind point.
//
// Frames: world x, y on the floor, z up, metres; sim time in seconds.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "forklift/dynamics/dynamics.h"  // BodyPoses
#include "forklift/scene/scene.h"

namespace forklift {

// Where one pedestrian is and what he is doing: a copyable value.
struct PedestrianState {
  Eigen::Vector2d at_m = Eigen::Vector2d::Zero();  // world, the body's middle on the floor
  double heading_rad = 0;   // the way he faces: along the leg he walks (+x = 0)
  int leg = 0;              // walking from path[leg] to path[leg + 1]
  double along_m = 0;       // how far along that leg
  double wait_left_s = 0;   // standing at a path point for this much longer
  double speed_m_s = 0;     // this tick's: 0 standing, the spec's speed walking
  bool started = false;     // his trigger has fired
  bool arrived = false;     // at the path's end: stands there
  bool stopped_for_truck = false;  // one who looks, standing while the truck is near
  bool alerted = false;     // one who does not look heard the horn (heeds_horn_within_m): he looks now
  bool struck = false;      // the truck struck him: he stays where he fell (set by the session)
};

// Everyone at the start: on the first point of the path, facing along it, not yet walking.
std::vector<PedestrianState> initial_pedestrians(const std::vector<PedestrianSpec>& specs);

// The truck's outline on the floor, for distances to people: the chassis's x-y bounds in the
// chassis frame, and the forks' (tips included) in the carriage frame.
struct TruckOutline {
  Eigen::AlignedBox2d chassis_m, forks_m;
};
TruckOutline truck_outline(const TruckShape& shape);
// The floor distance from `p` (world) to the truck's outline at `poses` (0 inside it).
double distance_to_truck(const TruckOutline& outline, const BodyPoses& poses, const Eigen::Vector2d& p);

// One tick of `dt_s` ending at sim time `t_s`, with the truck at `poses` (its state at the tick's
// end) and its horn sounding or not: each pedestrian starts when his trigger fires, walks his
// path at his speed, stands at his waits and, if he looks (or heard the horn he heeds), while the
// truck is within his stop distance; a struck one stands. `states` has one entry per spec
// (initial_pedestrians).
void walk(const std::vector<PedestrianSpec>& specs, std::vector<PedestrianState>& states, const TruckOutline& outline,
          const BodyPoses& poses, double t_s, double dt_s, bool horn = false);

// The body's pose: an upright box of the spec's size standing on z = 0 at the state's place,
// facing its heading (local x: chest to back, y: across the shoulders), its centre at half height.
Eigen::Isometry3d pedestrian_body_pose(const PedestrianSpec& spec, const PedestrianState& state);

// An upright body `height_m` tall standing on z = 0 at `at` (world), facing `heading_rad`: its
// centre's pose (the people's and the other trucks' boxes).
Eigen::Isometry3d standing_pose(const Eigen::Vector2d& at, double heading_rad, double height_m);

}  // namespace forklift
