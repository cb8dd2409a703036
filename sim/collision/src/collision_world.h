// Private: the FCL side of the Collision module. Boxes for the scene's static objects (one
// broad phase, built once), for the pallets (a second, small broad phase, changed only when a
// pallet is set down or dropped) and for the truck's parts (moved every query).
//
// A query first finds the scene boxes whose AABB meets the whole truck's AABB (one broad-phase
// call each), then tests every truck box against those candidates: a tight AABB test, then the
// FCL narrow phase. FCL's own AABB of a rotated box is the cube round its bounding sphere,
// far too loose for a 1 m fork, so the truck's world AABBs are computed here.
#pragma once

#include <fcl/fcl.h>

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
  int object = 0;  // index into Scene::objects
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   // world
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ(); // world, from the object towards the truck
  double depth = 0;
};

class CollisionWorld {
 public:
  // `pallet_objects`: the scene object index of each handled pallet (they move, so they get a
  // broad phase of their own); every other collidable object is static.
  CollisionWorld(const Scene& scene, const TruckShape& shape, const std::vector<int>& pallet_objects);
  ~CollisionWorld();
  CollisionWorld(const CollisionWorld&) = delete;
  CollisionWorld& operator=(const CollisionWorld&) = delete;

  // A pallet standing somewhere new (set down, dropped); not for the carried one.
  void set_pallet_pose(int pallet, const Eigen::Isometry3d& pose);
  // A carried pallet leaves the pallets' broad phase and rides on the forks as part "load".
  void set_carried(int pallet);  // -1: none

  // Moves the truck's boxes (and the carried pallet's, at `load_pose`) and finds the scene
  // boxes near the truck. Then nearby_pallets() lists the free pallets near it.
  void place_truck(const BodyPoses& poses, const Eigen::Isometry3d& load_pose);
  const std::vector<int>& nearby_pallets() const { return nearby_pallets_; }

  // The contacts of the placed truck, one per (part, object), deepest. `fork_excluded[p]` set:
  // pallet p's boxes are not tested against the forks (the forks are in its pockets).
  void contacts(const std::vector<bool>& fork_excluded, std::vector<RawContact>& out);

 private:
  struct TruckBox {
    int part;
    Body body;
    LocalBox box;
    std::unique_ptr<fcl::CollisionObjectd> obj;
    Eigen::AlignedBox3d aabb;  // world, at the last placement
  };
  struct SceneBox {
    int object;
    int pallet;  // -1 for a static box
    LocalBox box;
    std::unique_ptr<fcl::CollisionObjectd> obj;
    Eigen::AlignedBox3d aabb;  // world
  };

  void test_pair(fcl::CollisionObjectd* truck_obj, int part, Body body, const SceneBox& s, std::vector<RawContact>& out);
  void add_contact(std::vector<RawContact>& out, const RawContact& c);

  std::vector<TruckBox> truck_;
  std::vector<std::unique_ptr<SceneBox>> static_;
  std::vector<std::vector<std::unique_ptr<SceneBox>>> pallet_;  // per pallet
  std::unique_ptr<fcl::DynamicAABBTreeCollisionManagerd> static_manager_, pallet_manager_;
  int carried_ = -1;

  // The query: an axis-aligned box round the whole truck.
  std::shared_ptr<fcl::Boxd> query_box_;
  std::unique_ptr<fcl::CollisionObjectd> query_;
  Eigen::AlignedBox3d truck_aabb_;
  std::vector<SceneBox*> near_;          // scene boxes near the truck, this placement
  std::vector<int> nearby_pallets_;
  fcl::CollisionRequestd request_;
  fcl::CollisionResultd result_;
};

}  // namespace forklift::collision
