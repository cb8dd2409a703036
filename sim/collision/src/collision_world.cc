// Making a CollisionWorld: FCL's side lives in the collision module, loaded on the first world.
#include "collision_world.h"

#include <stdexcept>

#include "forklift/collision/collision.h"
#include "forklift/module/module.h"

namespace forklift {
namespace collision {
namespace {

using MakeFn = CollisionWorld* (*)(const Scene*, const TruckShape*, const std::vector<int>*, char*, unsigned);

MakeFn make_fn() {
  static const MakeFn fn = reinterpret_cast<MakeFn>(module::entry_point(
      "libforklift_collision_module.so", "FORKLIFT_COLLISION_MODULE", "forklift_collision_module_make"));
  return fn;
}

}  // namespace

std::unique_ptr<CollisionWorld> make_collision_world(const Scene& scene, const TruckShape& shape,
                                                     const std::vector<int>& pallet_objects) {
  char error[512] = {};
  CollisionWorld* world = make_fn()(&scene, &shape, &pallet_objects, error, sizeof error);
  if (!world) throw std::runtime_error(error);
  return std::unique_ptr<CollisionWorld>(world);
}

}  // namespace collision

void preload_collision() { collision::make_fn(); }

}  // namespace forklift
