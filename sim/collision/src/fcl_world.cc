// The collision module: FCL boxes, the two broad phases and the truck-against-scene query
// (collision_world.h). Built as lib/libforklift_collision_module.so, the only code that links FCL.
//
// A query first finds the scene boxes whose AABB meets the whole truck's AABB (one broad-phase
// call each), then tests every truck box against those candidates: a tight AABB test, then the
// FCL narrow phase. FCL's own AABB of a rotated box is the cube round its bounding sphere,
// far too loose for a 1 m fork, so the truck's world AABBs are computed here.
#include <fcl/fcl.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>

#include "collision_world.h"

namespace forklift::collision {
namespace {

using Eigen::Isometry3d;
using Eigen::Vector3d;

// A static box whose top lies this close to the ground is the floor, and the floor is the tyre
// model's business, not collision's.
constexpr double kFloorSlabM = 0.005;
// Contacts FCL reports per box pair; box-box gives at most the corners of the touching patch.
constexpr int kMaxContactsPerPair = 8;

fcl::Transform3d to_fcl(const Isometry3d& pose) {
  fcl::Transform3d t = fcl::Transform3d::Identity();
  t.linear() = pose.linear();
  t.translation() = pose.translation();
  return t;
}

std::unique_ptr<fcl::CollisionObjectd> make_object(const LocalBox& box, const Isometry3d& world_from_owner) {
  auto geom = std::make_shared<fcl::Boxd>(2.0 * box.half);
  auto obj = std::make_unique<fcl::CollisionObjectd>(geom, to_fcl(world_from_owner * box.centre));
  obj->computeAABB();
  return obj;
}

// Truck part of a mesh part, by the names the truck's built meshes use (sim/scene/src/mesh_builder.cc).
int classify(Body body, const std::string& name) {
  if (name == "fork_left") return kPartForkLeft;
  if (name == "fork_right") return kPartForkRight;
  if (name.rfind("guard", 0) == 0) return kPartGuard;
  switch (body) {
    case Body::kChassis: return kPartChassis;
    case Body::kMast: return kPartMast;
    case Body::kCarriage: return kPartCarriage;
    case Body::kLoad: return kPartLoad;
  }
  return kPartChassis;
}

// The broad-phase callback: collects every scene box whose AABB meets the query's.
struct Collect {
  const fcl::CollisionObjectd* query;
  std::vector<fcl::CollisionObjectd*>* found;
};
bool collect(fcl::CollisionObjectd* o1, fcl::CollisionObjectd* o2, void* data) {
  auto* c = static_cast<Collect*>(data);
  c->found->push_back(o1 == c->query ? o2 : o1);
  return false;  // keep going: we want them all
}

class FclWorld final : public CollisionWorld {
 public:
  FclWorld(const Scene& scene, const TruckShape& shape, const std::vector<int>& pallet_objects);

  void set_pallet_pose(int pallet, const Isometry3d& pose) override;
  void set_carried(int pallet) override;
  void place_truck(const BodyPoses& poses, const Isometry3d& load_pose) override;
  void place_people(const std::vector<LocalBox>& bodies) override;
  const std::vector<int>& nearby_pallets() const override { return nearby_pallets_; }
  void contacts(const std::vector<bool>& fork_excluded, std::vector<RawContact>& out) override;

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

  void test_pair(fcl::CollisionObjectd* truck_obj, int part, Body body, const SceneBox& s, std::vector<RawContact>& out,
                 int person = -1);
  void add_contact(std::vector<RawContact>& out, const RawContact& c);

  std::vector<TruckBox> truck_;
  std::vector<std::unique_ptr<SceneBox>> static_;
  std::vector<std::vector<std::unique_ptr<SceneBox>>> pallet_;  // per pallet
  std::vector<std::unique_ptr<SceneBox>> people_;  // per pedestrian and other truck, moved every tick; few, so no broad phase
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

}  // namespace

FclWorld::FclWorld(const Scene& scene, const TruckShape& shape, const std::vector<int>& pallet_objects) {
  request_ = fcl::CollisionRequestd(kMaxContactsPerPair, true);

  // The truck: every solid part of the chassis, mast and carriage meshes; the forks from the
  // carriage mesh or the shape's dimensions. Wheels are left to the tyre model.
  auto add_truck_mesh = [&](const std::shared_ptr<const Mesh>& mesh, Body body) {
    if (!mesh) return;
    for (const MeshPart& p : mesh->parts) {
      if (!p.solid || p.bounds.isEmpty()) continue;
      const int part = classify(body, p.name);
      if (part == kPartForkLeft || part == kPartForkRight) continue;  // below, from fork_boxes()
      const LocalBox b = box_of(p.bounds);
      truck_.push_back({part, body, b, make_object(b, Isometry3d::Identity()), {}});
    }
  };
  add_truck_mesh(shape.chassis, Body::kChassis);
  add_truck_mesh(shape.mast, Body::kMast);
  add_truck_mesh(shape.carriage, Body::kCarriage);
  const std::array<LocalBox, 2> forks = fork_boxes(shape);
  truck_.push_back({kPartForkLeft, Body::kCarriage, forks[0], make_object(forks[0], Isometry3d::Identity()), {}});
  truck_.push_back({kPartForkRight, Body::kCarriage, forks[1], make_object(forks[1], Isometry3d::Identity()), {}});

  // Static objects: one box per solid mesh part, in one broad phase built once.
  static_manager_ = std::make_unique<fcl::DynamicAABBTreeCollisionManagerd>();
  std::vector<fcl::CollisionObjectd*> objs;
  std::vector<bool> handled(scene.objects.size(), false);
  for (int i : pallet_objects) handled[i] = true;
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    const SceneObject& o = scene.objects[i];
    if (!o.collidable || !o.mesh || handled[i]) continue;
    for (const MeshPart& p : o.mesh->parts) {
      if (!p.solid || p.bounds.isEmpty()) continue;
      auto sb = std::make_unique<SceneBox>();
      sb->object = int(i);
      sb->pallet = -1;
      sb->box = box_of(p.bounds);
      sb->aabb = world_aabb(o.pose * sb->box.centre, sb->box.half);
      const Vector3d c = sb->aabb.center();
      if (sb->aabb.max().z() <= scene.ground.height(c.x(), c.y()) + kFloorSlabM) continue;
      sb->obj = make_object(sb->box, o.pose);
      sb->obj->setUserData(sb.get());
      objs.push_back(sb->obj.get());
      static_.push_back(std::move(sb));
    }
  }
  static_manager_->registerObjects(objs);
  static_manager_->setup();

  // Pallets: their own broad phase, updated when one moves.
  pallet_manager_ = std::make_unique<fcl::DynamicAABBTreeCollisionManagerd>();
  pallet_.resize(pallet_objects.size());
  objs.clear();
  for (size_t k = 0; k < pallet_objects.size(); ++k) {
    const SceneObject& o = scene.objects[pallet_objects[k]];
    for (const LocalBox& b : pallet_boxes(o, *o.pallet)) {
      auto sb = std::make_unique<SceneBox>();
      sb->object = pallet_objects[k];
      sb->pallet = int(k);
      sb->box = b;
      sb->aabb = world_aabb(o.pose * b.centre, b.half);
      sb->obj = make_object(b, o.pose);
      sb->obj->setUserData(sb.get());
      objs.push_back(sb->obj.get());
      pallet_[k].push_back(std::move(sb));
    }
  }
  pallet_manager_->registerObjects(objs);
  pallet_manager_->setup();

  query_box_ = std::make_shared<fcl::Boxd>(1, 1, 1);
  query_ = std::make_unique<fcl::CollisionObjectd>(query_box_);
}

void FclWorld::set_pallet_pose(int pallet, const Isometry3d& pose) {
  for (auto& sb : pallet_[pallet]) {
    sb->obj->setTransform(to_fcl(pose * sb->box.centre));
    sb->obj->computeAABB();
    sb->aabb = world_aabb(pose * sb->box.centre, sb->box.half);
    if (pallet != carried_) pallet_manager_->update(sb->obj.get());
  }
}

void FclWorld::set_carried(int pallet) {
  if (pallet == carried_) return;
  if (carried_ >= 0)
    for (auto& sb : pallet_[carried_]) pallet_manager_->registerObject(sb->obj.get());
  if (pallet >= 0)
    for (auto& sb : pallet_[pallet]) pallet_manager_->unregisterObject(sb->obj.get());
  carried_ = pallet;
  pallet_manager_->update();
}

void FclWorld::place_truck(const BodyPoses& poses, const Isometry3d& load_pose) {
  truck_aabb_.setEmpty();
  for (TruckBox& t : truck_) {
    const Isometry3d& owner = t.body == Body::kChassis ? poses.chassis : t.body == Body::kMast ? poses.mast : poses.carriage;
    const Isometry3d pose = owner * t.box.centre;
    t.obj->setTransform(to_fcl(pose));
    t.aabb = world_aabb(pose, t.box.half);
    truck_aabb_.extend(t.aabb);
  }
  if (carried_ >= 0) {
    for (auto& sb : pallet_[carried_]) {
      const Isometry3d pose = load_pose * sb->box.centre;
      sb->obj->setTransform(to_fcl(pose));
      sb->aabb = world_aabb(pose, sb->box.half);
      truck_aabb_.extend(sb->aabb);
    }
  }

  // One broad-phase call per manager with an axis-aligned box round the whole truck.
  query_box_->side = truck_aabb_.sizes();
  query_box_->computeLocalAABB();
  fcl::Transform3d t = fcl::Transform3d::Identity();
  t.translation() = truck_aabb_.center();
  query_->setTransform(t);
  query_->computeAABB();
  std::vector<fcl::CollisionObjectd*> found;
  Collect c{query_.get(), &found};
  static_manager_->collide(query_.get(), &c, collect);
  pallet_manager_->collide(query_.get(), &c, collect);
  near_.clear();
  nearby_pallets_.clear();
  for (fcl::CollisionObjectd* o : found) {
    auto* sb = static_cast<SceneBox*>(o->getUserData());
    near_.push_back(sb);
    if (sb->pallet >= 0 && std::find(nearby_pallets_.begin(), nearby_pallets_.end(), sb->pallet) == nearby_pallets_.end())
      nearby_pallets_.push_back(sb->pallet);
  }
}

void FclWorld::place_people(const std::vector<LocalBox>& bodies) {
  for (size_t i = people_.size(); i < bodies.size(); ++i) {
    auto sb = std::make_unique<SceneBox>();
    sb->object = 0;
    sb->pallet = -1;
    sb->box = bodies[i];
    sb->obj = make_object(LocalBox{Isometry3d::Identity(), bodies[i].half}, Isometry3d::Identity());
    people_.push_back(std::move(sb));
  }
  people_.resize(bodies.size());
  for (size_t i = 0; i < bodies.size(); ++i) {
    SceneBox& sb = *people_[i];
    // A body of another size in this place (people and trucks share the list): its own shape.
    if (sb.box.half != bodies[i].half) sb.obj = make_object(LocalBox{Isometry3d::Identity(), bodies[i].half}, Isometry3d::Identity());
    sb.box = bodies[i];
    sb.obj->setTransform(to_fcl(bodies[i].centre));
    sb.obj->computeAABB();
    sb.aabb = world_aabb(bodies[i].centre, bodies[i].half);
  }
}

void FclWorld::add_contact(std::vector<RawContact>& out, const RawContact& c) {
  for (RawContact& r : out) {
    if (r.part == c.part && r.object == c.object && r.person == c.person) {
      if (c.depth > r.depth) r = c;
      return;
    }
  }
  out.push_back(c);
}

void FclWorld::test_pair(fcl::CollisionObjectd* truck_obj, int part, Body body, const SceneBox& s,
                         std::vector<RawContact>& out, int person) {
  result_.clear();
  fcl::collide(truck_obj, s.obj.get(), request_, result_);
  const size_t n = result_.numContacts();
  if (n == 0) return;
  // The deepest point's depth and normal; the point is the middle of the touching patch (FCL
  // gives its corners, all at the same depth for two boxes face to face).
  double depth = -1;
  Vector3d normal = Vector3d::UnitZ(), point = Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    const fcl::Contactd& k = result_.getContact(i);
    if (k.penetration_depth > depth) { depth = k.penetration_depth; normal = k.normal; }
    point += k.pos;
  }
  // FCL's normal points from o1 (the truck) to o2.
  add_contact(out, RawContact{part, body, s.object, person, point / double(n), -normal.normalized(), std::max(0.0, depth)});
}

void FclWorld::contacts(const std::vector<bool>& fork_excluded, std::vector<RawContact>& out) {
  out.clear();
  for (SceneBox* s : near_) {
    const bool forks_in_it = s->pallet >= 0 && fork_excluded[s->pallet];
    for (TruckBox& t : truck_) {
      if (forks_in_it && (t.part == kPartForkLeft || t.part == kPartForkRight)) continue;
      if (t.aabb.intersects(s->aabb)) test_pair(t.obj.get(), t.part, t.body, *s, out);
    }
    if (carried_ >= 0)
      for (auto& lb : pallet_[carried_])
        if (lb->aabb.intersects(s->aabb)) test_pair(lb->obj.get(), kPartLoad, Body::kLoad, *s, out);
  }
  for (size_t i = 0; i < people_.size(); ++i) {
    const SceneBox& s = *people_[i];
    if (!truck_aabb_.intersects(s.aabb)) continue;
    for (TruckBox& t : truck_)
      if (t.aabb.intersects(s.aabb)) test_pair(t.obj.get(), t.part, t.body, s, out, int(i));
    if (carried_ >= 0)
      for (auto& lb : pallet_[carried_])
        if (lb->aabb.intersects(s.aabb)) test_pair(lb->obj.get(), kPartLoad, Body::kLoad, s, out, int(i));
  }
}

}  // namespace forklift::collision

// The module's one entry point (make_collision_world): nullptr and the reason in `error` when the
// world cannot be made (no exception crosses dlopen).
extern "C" __attribute__((visibility("default"))) forklift::collision::CollisionWorld* forklift_collision_module_make(
    const forklift::Scene* scene, const forklift::TruckShape* shape, const std::vector<int>* pallet_objects, char* error,
    unsigned error_size) {
  try {
    return new forklift::collision::FclWorld(*scene, *shape, *pallet_objects);
  } catch (const std::exception& e) {
    std::snprintf(error, error_size, "%s", e.what());
  } catch (...) {
    std::snprintf(error, error_size, "unknown error");
  }
  return nullptr;
}
