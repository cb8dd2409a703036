// The load on the forks as a body of its own: a block resting on the forks' top faces, held there
// by friction, that slides along them, and leaves them when its centre of gravity passes the fork
// tips or the truck goes over (the paper, section 5, leaves this for "future releases": its load
// is welded to the pitchfork).
//
// Cheap: the load keeps the carriage's orientation and moves only along the forks (carriage x), by
// `slide_m`. Per unit mass, s = g - a is the specific force the load feels in the carriage's axes
// (a: the carriage point's acceleration under the load's centre of gravity); holding it there
// takes N = -m s_z pressing up and -m s_x along the forks.
//   stuck    while |s_x| <= mu_static (-s_z): the load is part of the carriage's rigid body in the
//            truck's mass matrix (TruckDynamics::attach_load), exact;
//   sliding  beyond it: slide'' = s_x - sign(slide') mu_kinetic (-s_z). The load stays in the mass
//            matrix (moved with the slide every few millimetres), which carries its weight, its
//            normal force and its inertia across the forks exactly; along them the forks take only
//            friction, so the carriage is given back -m slide'' there (an ExternalForce at the
//            load's centre of gravity, held for the tick, as the scene's push-back is). That
//            force's lag is a fraction m / (truck + load) of itself, so it is stable, and
//            harmless: where and how fast a load braked off the forks leaves them is the same at
//            1, 0.5 and 0.25 ms ticks (load_test.cc), and at a fall's blow it puts in some 13 J,
//            halving with the tick, of the 18.6 kJ the fall takes out (ground_edge_test.cc). The load
//            sticks again when its speed along the forks reaches zero and friction holds it;
//   fallen   its centre of gravity past the fork tips (it topples over them), or the truck rolled
//            or pitched past TruckParams::tipped_over_rad: it leaves the mass matrix and the scene
//            drops it.
// Sliding starts and stops at zero relative speed, so nothing jumps; sliding friction only takes
// energy out. The load does not topple on the forks before its centre of gravity leaves them:
// tipping about the front of its base takes a / g > d / h (d: its CoG's distance behind that edge,
// h: its height above the forks), and friction lets go first, at mu_static (0.35), for any load
// whose CoG sits lower than about three times d: every pallet carried as the rules ask.
#pragma once

#include <Eigen/Core>
#include "forklift/dynamics/dynamics.h"
#include "forklift/dynamics/truck.h"

namespace forklift {

enum class LoadPhase { kNone, kStuck, kSliding, kFallen };
const char* load_phase_name(LoadPhase phase);  // "none", "stuck", "sliding", "fallen"

// What a load put on the forks is, for as long as it stays there: fixed when it is put on.
struct LoadOnForksModel {
  Load load;                        // as put on the forks (slide 0), carriage frame
  double mu_static = 0, mu_kinetic = 0;
  double min_slide_m = 0;           // <= 0: its base's back against the fork face
  double fork_tip_m = 0;            // carriage x
  double tipped_over_rad = 0;       // the truck's roll or pitch beyond which it falls
};
// The model of `load` put on the forks of `truck` (its friction, or the truck's load_contact).
LoadOnForksModel load_on_forks_model(const TruckParams& truck, const Load& load);

// How it sits there now: a plain value (part of a session's state, a copy is a rewind point).
struct LoadOnForks {
  LoadPhase phase = LoadPhase::kNone;
  double slide_m = 0;               // its CoG along the forks from where it was put, + towards the tips
  double slide_rate_m_s = 0;
  int slips = 0;                    // times it has started to slide since it was put on
  double attached_slide_m = 0;      // the slide at which the truck's mass matrix holds it
  // Once fallen: its centre of gravity's position and velocity, world, as it left the forks.
  Eigen::Vector3d fell_at_m = Eigen::Vector3d::Zero(), fell_velocity_m_s = Eigen::Vector3d::Zero();
  // While sliding: the difference between friction and the rigid hold that the mass matrix gives
  // it, on the carriage, held until the next step.
  ExternalForce push{TruckBody::kCarriage};
};

// The load where the truck's mass matrix holds it: the put-on load moved `attached_slide_m`.
Load load_at(const LoadOnForksModel& model, const LoadOnForks& state);

// What one step changed, for the caller to give the truck's model.
enum class LoadChangeInModel {
  kNone,
  kAttach,   // it has moved along the forks: load_at(model, state) replaces it in the mass matrix
  kRelease,  // it fell: it leaves the mass matrix
};

// Advances the load by dt (s) on the carriage whose motion `out` gives (Outputs::carriage; its q
// for the truck's roll and pitch), under gravity `g` (world). Semi-implicit Euler on the slide, one
// step per physics tick (1 ms), with the specific force of the tick's end. Allocates nothing.
LoadChangeInModel step_load(const LoadOnForksModel& model, LoadOnForks& state, const Outputs& out,
                            const Eigen::Vector3d& g, double dt);

// True when the truck at coordinates q has rolled or pitched past `tipped_over_rad`.
bool truck_gone_over(const CoordVector& q, double tipped_over_rad);

}  // namespace forklift
