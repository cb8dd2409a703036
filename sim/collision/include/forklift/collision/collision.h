// The paper's Collision module, with pallet handling: every physics tick the truck's parts
// (chassis, overhead guard, mast, carriage, forks and the pallet it carries) are checked with
// FCL against every scene object through a broad phase, and the pallets are picked up and set
// down as the truck moves them (sliding and falling off the forks are the truck model's).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <optional>
#include <vector>

#include "forklift/scene/pedestrians.h"
#include "forklift/scene/traffic.h"
#include "forklift/scene/scene.h"
#include "forklift/dynamics/simulation.h"

namespace forklift {

// One touching pair. Feeds the driver evaluation.
struct Contact {
  std::string truck_part;   // "chassis", "guard", "mast", "carriage", "fork_left", "fork_right", "load"
  std::string object_id;    // the scene object struck (a pallet's id for pallets), or the pedestrian
  ObjectKind object_kind = ObjectKind::kObstacle;  // kPedestrian for a standing figure and a walking one
  int pedestrian = -1;      // >= 0: a walking person struck, index into Scene::pedestrians
  int other_truck = -1;     // >= 0: another truck struck, index into Scene::trucks (object_kind kObstacle)
  Eigen::Vector3d point_m = Eigen::Vector3d::Zero();   // world
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();   // world, unit, from the object towards the truck
  double depth_m = 0;                                  // penetration, >= 0
  double relative_speed_m_s = 0;  // speed of the truck part's point into the object (along -normal), >= 0
                                  // (into a walking person or a moving truck: less its own velocity)
};

struct HandlingEvent {
  enum class Kind { kPickedUp, kSetDown, kSliding, kDropped };
  Kind kind = Kind::kPickedUp;
  std::string pallet;
  std::string on_object;  // set down: the object it was set on ("" floor)
  int level = 0;
  Eigen::Vector3d where_m = Eigen::Vector3d::Zero();  // the pallet's centre, world
};
const char* handling_event_name(HandlingEvent::Kind kind);  // "picked_up", "set_down", "sliding", "dropped"

// What a tick's handling does to the load on the forks.
enum class LoadChange {
  kNone,      // as it was
  kAttached,  // StepReport::load is on the forks now (picked up)
  kReleased,  // set down or dropped: the forks are empty
};

struct StepReport {
  std::vector<Contact> contacts;       // this tick's contacts (empty in a clear aisle)
  std::vector<HandlingEvent> handling; // what happened to pallets this tick
  // What the truck's model must take on for the next tick (apply()): the load change, and the
  // fixed objects' push-back (TruckParams::scene_contact), world, empty when nothing pushes.
  LoadChange load_change = LoadChange::kNone;
  Load load;                                // kAttached: the load now on the forks
  std::vector<ExternalForce> scene_push;
};

// Gives a step's load change and push-back to the simulation (attaching or releasing the load
// restarts its integrator, as Simulation::attach_load says).
void apply(const StepReport& report, Simulation& sim);

// What pallet handling remembers from tick to tick: every pallet's pose and support, the one on
// the forks and how it sits there. A copyable value (part of a session's state).
class HandlingState {
 public:
  HandlingState();
  HandlingState(const HandlingState&);
  HandlingState& operator=(const HandlingState&);
  HandlingState(HandlingState&&) noexcept;
  HandlingState& operator=(HandlingState&&) noexcept;
  ~HandlingState();

  const std::vector<PalletState>& pallets() const;  // empty before the first step
  const PalletState* pallet(const std::string& id) const;  // nullptr: no such pallet

  struct Data;

 private:
  friend class Warehouse;
  std::unique_ptr<Data> d_;
};

// How the forks stand to the nearest pallet ahead of them that they could take (not on the
// forks, not dropped): for the cab's hint while a pupil lines up. Signs are the correction's
// opposite: + height: the forks are too high; + lateral: they are left of the pockets; + angle:
// they point left of the pallet's axis. The tolerances are what the pockets leave.
struct PalletApproach {
  std::string pallet;           // its id
  double distance_m = 0;        // fork tips to the pallet's near face along the forks (< 0: inside)
  double height_m = 0;          // fork centre minus pocket centre, vertically
  double lateral_m = 0;         // the forks' centre line minus the pallet's, at its near face
  double angle_rad = 0;         // fork axis minus the pallet's axis
  double height_tolerance_m = 0, lateral_tolerance_m = 0, angle_tolerance_rad = 0;
  bool engaged = false;         // both forks in the pockets far enough to lift it
};
// nullopt when no pallet's near face is within `range_m` ahead of the fork tips, within 1 m to
// either side of the forks and 45 degrees of square. `only` not empty: that pallet alone is
// looked at (the one a task's step is about), however near the others are.
std::optional<PalletApproach> pallet_approach(const Scene& scene, const std::vector<PalletState>& pallets,
                                              const BodyPoses& poses, const TruckShape& shape, double range_m = 3.0,
                                              const std::string& only = {});

// FCL is loaded the first time a Warehouse is built (a module of its own, 10-15 ms to map and
// relocate). A program that will build one soon can load it now, on a thread of its own, while it
// does something else; throws std::runtime_error if it cannot be loaded.
void preload_collision();

class Warehouse {
 public:
  // Builds the collision shapes (one FCL box per solid mesh part) and the broad phase.
  Warehouse(const Scene& scene, const TruckShape& shape, const TruckParams& truck);
  ~Warehouse();
  Warehouse(const Warehouse&) = delete;
  Warehouse& operator=(const Warehouse&) = delete;

  // Call after every physics tick, with the session's handling state (a fresh HandlingState
  // starts as the scene stands the pallets). Moves the truck's shapes to the simulation's state,
  // finds the contacts, has fixed objects (racks, walls, doors, docks, lorries, obstacles) push
  // back on the truck for the next tick (StepReport::scene_push, TruckParams::scene_contact), then
  // handles pallets: forks inside a pallet's pockets that lift it make it the attached load
  // (LoadChange::kAttached: the model's runtime mass change); lowered onto a rack level, a lorry
  // bed or the floor, it is released there (kReleased); while carried it is drawn and collided
  // where the truck's model has slid it along the forks (Simulation::load_on_forks), and when the
  // model lets it fall it is dropped on the floor below (kReleased, a `dropped` event). A fork tip
  // striking a pallet outside its pockets is a contact, not a pick-up.
  // The scene's pedestrians stand as `people` says (one state per Scene::pedestrians, walked to
  // this tick; empty when the scene has none): their bodies are struck like objects, but they
  // push nothing back (a person gives way) and are never handled. The other trucks stand as
  // `trucks` says (one state per Scene::trucks; empty when none): struck like objects, and, as
  // heavy as the truck, they push back as a fixed obstacle does.
  // The simulation is only read: the caller applies the report (apply()) before the next tick.
  const StepReport& step(const Simulation& sim, HandlingState& state,
                         const std::vector<PedestrianState>& people = {},
                         const std::vector<OtherTruckState>& trucks = {});

  // The pallets as the scene stands them, before any step.
  const HandlingState& initial_handling() const { return initial_; }

  // A pallet the scene itself moves (one falling from its rack, forklift/scene/falling.h): at
  // `pose` from now on, on nothing, fallen (never picked up again), and struck there from the
  // next step. Returns false, and moves nothing, for an unknown id or a pallet on the forks.
  bool move_pallet(HandlingState& state, const std::string& id, const Eigen::Isometry3d& pose) const;

  // The contacts the truck would have at coordinates q, without handling (for tests and tools).
  std::vector<Contact> contacts_at(const CoordVector& q);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  HandlingState initial_;
};

}  // namespace forklift
