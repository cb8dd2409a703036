// Private: the Collision module's boxes, and its FCL side behind CollisionWorld. FCL is built
// into a module of its own (fcl_world.cc, lib/libforklift_collision_module.so), loaded the first
// time a world is made, so that a program that never checks collisions (forklift-sim manoeuvre)
// does not pay FCL's 10-15 ms of loading at start-up.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "forklift/scene/scene.h"

namespace forklift::collision {

// The rigid bodies truck boxes ride on; kLoad is the carried pallet (on the carriage).
enum class Body { kChassis, kMast, kCarriage, kLoad };

// Contact.truck_part names, by index.
enum Part : int { kPartChassis, kPartGuard, kPartMast, kPartCarriage, kPartForkLeft, kPartForkRight, kPartLoad, kNumParts };
const char* part_name(int part);

// A box in its owner's frame: centre pose and half extents.
struct LocalBox {
  Eigen::Isometry3d centre = Eigen::Isometry3d::Identity();
  Eigen::Vector3d half = Eigen::Vector3d::Zero();
};

// The box between two corners, and the box of an AABB; a plane gets a little thickness, as FCL
// needs.
LocalBox box_between(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi);
LocalBox box_of(const Eigen::AlignedBox3d& b);

// World AABB of a box at `pose` (the owner's world pose composed with the box's centre).
Eigen::AlignedBox3d world_aabb(const Eigen::Isometry3d& pose, const Eigen::Vector3d& half);

// The collision boxes of a pallet in its local frame: its mesh's solid parts (or, without a
// mesh, deck, bottom boards and block rows built from the spec) and the load box on its deck.
std::vector<LocalBox> pallet_boxes(const SceneObject& object, const PalletSpec& spec);

// The fork boxes in the carriage frame: the carriage mesh's parts "fork_left" and "fork_right",
// or, if it has none, boxes from the shape's fork dimensions. [0] left, [1] right.
std::array<LocalBox, 2> fork_boxes(const TruckShape& shape);

// One touching pair, the deepest of all the boxes of one truck part against one scene object.
struct RawContact {
  int part = 0;
  Body body = Body::kChassis;
  int object = 0;  // index into Scene::objects (when person < 0)
  int person = -1; // index into the bodies place_people was given: a person (or another truck) struck
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   // world
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ(); // world, from the object towards the truck
  double depth = 0;
};

// The scene's boxes in FCL: the scene's static objects in one broad phase (built once), the
// pallets in a second, small one (changed only when a pallet is set down or dropped), and the
// truck's parts (moved every query). Made by make_collision_world (fcl_world.cc has the how).
class CollisionWorld {
 public:
  virtual ~CollisionWorld() = default;

  // A pallet standing somewhere new (set down, dropped); not for the carried one.
  virtual void set_pallet_pose(int pallet, const Eigen::Isometry3d& pose) = 0;
  // A carried pallet leaves the pallets' broad phase and rides on the forks as part "load".
  virtual void set_carried(int pallet) = 0;  // -1: none

  // Moves the truck's boxes (and the carried pallet's, at `load_pose`) and finds the scene
  // boxes near the truck. Then nearby_pallets() lists the free pallets near it.
  virtual void place_truck(const BodyPoses& poses, const Eigen::Isometry3d& load_pose) = 0;
  // The people's bodies this tick, one per Scene::pedestrians, then the other trucks' (one per
  // Scene::trucks), each a box at its world pose (LocalBox::centre). contacts() tests them against the truck's parts and the carried load.
  virtual void place_people(const std::vector<LocalBox>& bodies) = 0;
  virtual const std::vector<int>& nearby_pallets() const = 0;

  // The contacts of the placed truck, one per (part, object), deepest. `fork_excluded[p]` set:
  // pallet p's boxes are not tested against the forks (the forks are in its pockets).
  virtual void contacts(const std::vector<bool>& fork_excluded, std::vector<RawContact>& out) = 0;
};

// `pallet_objects`: the scene object index of each handled pallet (they move, so they get a
// broad phase of their own); every other collidable object is static. Loads the FCL module on
// first use (FORKLIFT_COLLISION_MODULE, or lib/ beside bin/); throws std::runtime_error if it
// cannot.
std::unique_ptr<CollisionWorld> make_collision_world(const Scene& scene, const TruckShape& shape,
                                                     const std::vector<int>& pallet_objects);

}  // namespace forklift::collision
