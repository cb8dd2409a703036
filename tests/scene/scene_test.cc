// The scene module: shipped scenarios and meshes, the loader's geometry, and its refusals.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "forklift/dynamics/dynamics.h"
#include "forklift/scene/scene.h"

using namespace forklift;
namespace fs = std::filesystem;

namespace {

const std::string kData = FORKLIFT_DATA_DIR;

std::vector<std::string> files_in(const std::string& dir, const std::string& ext) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ext) out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// A fresh directory per test (ctest runs tests in parallel processes).
std::string temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("scene_test_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d.string();
}

std::string write_file(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

const MeshPart* part(const Mesh& m, const std::string& name) {
  for (const MeshPart& p : m.parts)
    if (p.name == name) return &p;
  return nullptr;
}

// A box turned about z only: centre, yaw axes and half extents; enough for every object and,
// standing level, the truck.
struct YawBox {
  Eigen::Vector3d c, h;
  Eigen::Matrix2d axes;  // columns: the box's x and y axes in the world
};

YawBox world_box(const Eigen::Isometry3d& pose, const Eigen::AlignedBox3d& local) {
  EXPECT_NEAR(pose.linear()(2, 2), 1.0, 1e-9) << "only yaw rotations are expected here";
  YawBox b;
  b.c = pose * local.center();
  b.h = 0.5 * local.sizes();
  b.axes = pose.linear().topLeftCorner<2, 2>();
  return b;
}

// Separating-axis test in the plane plus the z intervals; a touch up to `margin` is no overlap.
bool overlap(const YawBox& a, const YawBox& b, double margin = 1e-3) {
  if (a.c.z() + a.h.z() <= b.c.z() - b.h.z() + margin || b.c.z() + b.h.z() <= a.c.z() - a.h.z() + margin) return false;
  const Eigen::Vector2d d = (b.c - a.c).head<2>();
  for (const Eigen::Matrix2d* m : {&a.axes, &b.axes})
    for (int i = 0; i < 2; ++i) {
      const Eigen::Vector2d n = m->col(i);
      const double ra = a.h.x() * std::abs(n.dot(a.axes.col(0))) + a.h.y() * std::abs(n.dot(a.axes.col(1)));
      const double rb = b.h.x() * std::abs(n.dot(b.axes.col(0))) + b.h.y() * std::abs(n.dot(b.axes.col(1)));
      if (std::abs(n.dot(d)) >= ra + rb - margin) return false;
    }
  return true;
}

// The solid parts of the truck standing at rest at (x, y, yaw), forks lowered.
std::vector<std::pair<std::string, YawBox>> truck_boxes(const Scene& scene, const TruckShape& shape,
                                                        const TruckParams& truck, double x, double y, double yaw) {
  Environment env;
  env.ground = scene.ground;
  const TruckDynamics dyn(truck, env);
  const BodyPoses poses = body_poses(truck, coordinates(dyn.rest_state(x, y, yaw)));
  std::vector<std::pair<std::string, YawBox>> out;
  auto add = [&](const Mesh& m, const Eigen::Isometry3d& pose) {
    for (const MeshPart& p : m.parts)
      if (p.solid) out.emplace_back(p.name, world_box(pose, p.bounds));
  };
  add(*shape.chassis, poses.chassis);
  add(*shape.mast, poses.mast);
  add(*shape.carriage, poses.carriage);
  add(*shape.front_wheel, poses.wheels[kFrontLeft]);
  add(*shape.front_wheel, poses.wheels[kFrontRight]);
  add(*shape.rear_wheel, poses.wheels[kRear]);
  return out;
}

// The first solid object part the truck at (x, y, yaw) overlaps, or "" when it is clear.
// Surfaces at floor level (a dock's top, the lorry's bed: driven over) are not obstacles;
// pallets in `ignore` are the ones the task picks up.
std::string first_hit(const Scene& scene, const TruckShape& shape, const TruckParams& truck, double x, double y,
                      double yaw, const std::set<std::string>& ignore = {}) {
  const auto truck_parts = truck_boxes(scene, shape, truck, x, y, yaw);
  for (const SceneObject& o : scene.objects) {
    if (!o.collidable || ignore.count(o.id)) continue;
    // Far away: the truck (3 m long with its forks) cannot reach it.
    const double reach = 3.5 + 0.5 * o.mesh->bounds.sizes().head<2>().norm();
    if ((o.pose * o.mesh->bounds.center() - Eigen::Vector3d(x, y, 0)).head<2>().norm() > reach) continue;
    for (const MeshPart& p : o.mesh->parts) {
      if (!p.solid) continue;
      const YawBox b = world_box(o.pose, p.bounds);
      if (b.c.z() + b.h.z() <= 0.005) continue;
      for (const auto& [name, t] : truck_parts)
        if (overlap(t, b)) return o.id + "/" + p.name + " with truck " + name;
    }
  }
  return "";
}

std::string load_error(const std::string& path) {
  try {
    load_scene(path, kData);
  } catch (const SceneError& e) {
    return e.what();
  }
  return "(no error)";
}

const Scene& warehouse_scene() {
  static const Scene s = load_scene(kData + "/scenarios/rack_pick.json", kData);
  return s;
}

}  // namespace

// --- the shipped files ---------------------------------------------------------------------

TEST(Scenarios, EveryShippedScenarioLoadsWithATask) {
  const auto files = files_in(kData + "/scenarios", ".json");
  ASSERT_GE(files.size(), 5u);
  std::set<std::string> names;
  for (const std::string& f : files) {
    SCOPED_TRACE(f);
    const Scene s = load_scene(f, kData);
    names.insert(s.name);
    EXPECT_EQ(s.name, fs::path(f).stem().string());
    EXPECT_FALSE(s.objects.empty());
    EXPECT_FALSE(s.task.summary.empty());
    EXPECT_FALSE(s.task.steps.empty());
    EXPECT_GT(s.time_limit_s, 0);
    if (s.exam_course) {
      // A test course marks its way with its elements (gates, racks, the face), not a route line
      // the truck must keep to: the exam hall's lanes are driven forwards and in reverse.
      EXPECT_TRUE(std::any_of(s.task.steps.begin(), s.task.steps.end(), [](const TaskStep& t) { return t.kind == "pass"; }));
    } else {
      EXPECT_GE(s.route.points.size(), 2u);
      EXPECT_GT(s.route.width_m, 0);
    }
    EXPECT_FALSE(s.zones.empty());
    EXPECT_TRUE(s.floor.contains(Eigen::Vector2d(s.scenario.x_m, s.scenario.y_m)));
    EXPECT_TRUE(fs::exists(s.scenario.truck_file));
    for (const SceneObject& o : s.objects) {
      ASSERT_TRUE(o.mesh) << o.id;
      EXPECT_FALSE(o.mesh->parts.empty()) << o.id;
    }
    // The start stands in a zone with a speed limit.
    EXPECT_TRUE(s.speed_limit(Eigen::Vector2d(s.scenario.x_m, s.scenario.y_m)).has_value());
  }
  for (const char* n : {"first_drive", "first_drive_yard", "slalom", "rack_pick", "load_lorry", "practical_exam", "counterbalance_exam",
                        "pedestrian_awareness"})
    EXPECT_TRUE(names.count(n)) << n;
}

TEST(Scenarios, ManoeuvreFilesAreAnEmptyFloorWithTheirStart) {
  const auto files = files_in(kData + "/manoeuvres", ".json");
  ASSERT_FALSE(files.empty());
  for (const std::string& f : files) {
    SCOPED_TRACE(f);
    const Scene s = load_scene(f, kData);
    EXPECT_TRUE(s.objects.empty());
    EXPECT_TRUE(s.task.steps.empty());
    EXPECT_DOUBLE_EQ(s.ground.height(5, 5), 0.0);
    EXPECT_TRUE(s.floor.contains(Eigen::Vector2d(s.scenario.x_m, s.scenario.y_m)));
    EXPECT_GE(s.floor.sizes().minCoeff(), 100.0);  // room for 20 s of driving
  }
}

TEST(Meshes, PalletPocketsAreWherePalletSpecSaysAndOpenAlongTheFullLength) {
  const Scene& s = warehouse_scene();
  const SceneObject* p3 = s.find("P3");
  ASSERT_TRUE(p3 && p3->pallet);
  const PalletSpec& spec = *p3->pallet;
  const PalletSpec defaults;
  EXPECT_NEAR(spec.length_m, defaults.length_m, 1e-6);
  EXPECT_NEAR(spec.width_m, defaults.width_m, 1e-6);
  EXPECT_NEAR(spec.height_m, defaults.height_m, 1e-6);
  EXPECT_NEAR(spec.pocket_bottom_m, defaults.pocket_bottom_m, 1e-6);
  EXPECT_NEAR(spec.pocket_top_m, defaults.pocket_top_m, 1e-6);
  ASSERT_EQ(spec.pockets_y_m.size(), 2u);
  EXPECT_NEAR(spec.pockets_y_m[0].x(), -0.255, 1e-6);
  EXPECT_NEAR(spec.pockets_y_m[0].y(), -0.0725, 1e-6);
  EXPECT_NEAR(spec.pockets_y_m[1].x(), 0.0725, 1e-6);
  EXPECT_NEAR(spec.pockets_y_m[1].y(), 0.255, 1e-6);

  // No solid part of the mesh reaches into a pocket anywhere along the pallet.
  const Mesh& mesh = *p3->mesh;
  for (const Eigen::Vector2d& pocket : spec.pockets_y_m) {
    const Eigen::AlignedBox3d hole(Eigen::Vector3d(-0.7, pocket.x(), spec.pocket_bottom_m),
                                   Eigen::Vector3d(0.7, pocket.y(), spec.pocket_top_m));
    for (const MeshPart& p : mesh.parts) {
      const Eigen::AlignedBox3d i = p.bounds.intersection(hole);
      EXPECT_TRUE(i.isEmpty() || i.sizes().minCoeff() < 1e-6) << p.name << " blocks a pocket";
    }
  }
  // And the truck's forks fit into them.
  const TruckShape shape = load_truck_shape(s.scenario.truck_file, kData);
  for (double side : {-1.0, 1.0}) {
    const double lo = side * 0.5 * shape.fork_centres_y_m - 0.5 * shape.fork_width_m;
    const double hi = side * 0.5 * shape.fork_centres_y_m + 0.5 * shape.fork_width_m;
    const Eigen::Vector2d& pocket = spec.pockets_y_m[side < 0 ? 0 : 1];
    EXPECT_GT(lo, pocket.x());
    EXPECT_LT(hi, pocket.y());
  }
  EXPECT_LT(shape.fork_thickness_m, spec.pocket_top_m - spec.pocket_bottom_m);
}

TEST(Meshes, RackLevelsInTheLayoutAreTheMeshBeamTops) {
  const Scene& s = warehouse_scene();
  int racks = 0;
  for (const SceneObject& o : s.objects) {
    if (o.kind != ObjectKind::kRack) continue;
    ++racks;
    std::map<int, double> tops;  // level -> beam top
    for (const MeshPart& p : o.mesh->parts)
      if (p.name.rfind("beam_l", 0) == 0) {
        const int level = std::stoi(p.name.substr(6));
        tops[level] = std::max(tops.count(level) ? tops[level] : -1.0, p.bounds.max().z());
      }
    ASSERT_EQ(o.supports.size(), tops.size()) << o.id;
    for (const Support& sup : o.supports) {
      ASSERT_TRUE(tops.count(sup.level)) << o.id << " level " << sup.level;
      EXPECT_NEAR(sup.height_m, tops[sup.level], 1e-6) << o.id << " level " << sup.level;
      // The pallet places lie between the uprights.
      EXPECT_GE(sup.footprint.min().x(), o.mesh->bounds.min().x());
      EXPECT_LE(sup.footprint.max().x(), o.mesh->bounds.max().x());
    }
  }
  EXPECT_EQ(racks, 16);
}

TEST(Meshes, EveryPalletInARackSitsOnItsLevelAcrossBothBeams) {
  const Scene& s = warehouse_scene();
  int in_racks = 0;
  std::vector<std::pair<const SceneObject*, YawBox>> boxes;
  for (const SceneObject& o : s.objects) {
    if (o.kind != ObjectKind::kPallet) continue;
    boxes.emplace_back(&o, world_box(o.pose, o.mesh->bounds));
    if (o.rests_on.empty()) {
      EXPECT_NEAR(o.pose.translation().z(), 0.0, 1e-12) << o.id;
      continue;
    }
    ++in_racks;
    const SceneObject* rack = s.find(o.rests_on);
    ASSERT_TRUE(rack) << o.id;
    ASSERT_EQ(rack->kind, ObjectKind::kRack) << o.id;
    const Support& level = rack->supports.at(o.rest_level - 1);
    EXPECT_EQ(level.level, o.rest_level);
    EXPECT_NEAR(o.pose.translation().z(), rack->pose.translation().z() + level.height_m, 1e-9) << o.id;
    // In the rack's frame the pallet spans both beams (y) and stays inside the uprights (x).
    Eigen::AlignedBox3d in_rack;
    const Eigen::Isometry3d rel = rack->pose.inverse() * o.pose;
    for (int c = 0; c < 8; ++c) in_rack.extend(rel * o.mesh->bounds.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c)));
    const std::string beam = "beam_l" + std::to_string(o.rest_level) + "_";
    for (const char* side : {"0", "1"}) {
      const MeshPart* b = part(*rack->mesh, beam + side);
      ASSERT_TRUE(b) << beam + side;
      EXPECT_LE(in_rack.min().y(), b->bounds.min().y()) << o.id;
      EXPECT_GE(in_rack.max().y(), b->bounds.max().y()) << o.id;
      EXPECT_NEAR(in_rack.min().z(), b->bounds.max().z(), 1e-6) << o.id << " does not stand on the beam";
    }
    EXPECT_GT(in_rack.min().x(), part(*rack->mesh, "upright_0")->bounds.max().x()) << o.id;
    EXPECT_LT(in_rack.max().x(), part(*rack->mesh, "upright_3")->bounds.min().x()) << o.id;
  }
  EXPECT_EQ(in_racks, 10);
  // No two pallets occupy the same space.
  for (size_t i = 0; i < boxes.size(); ++i)
    for (size_t j = i + 1; j < boxes.size(); ++j)
      EXPECT_FALSE(overlap(boxes[i].second, boxes[j].second)) << boxes[i].first->id << " and " << boxes[j].first->id;
}

TEST(Meshes, RegeneratedMeshesEqualTheCommittedFiles) {
  const std::string dir = temp_dir("meshes");
  const std::vector<std::string> written = write_meshes(dir);
  ASSERT_GE(written.size(), 10u);
  std::set<std::string> committed;
  for (const std::string& f : files_in(kData + "/meshes", ".obj")) committed.insert(fs::path(f).filename().string());
  EXPECT_EQ(committed, std::set<std::string>(written.begin(), written.end()));
  for (const std::string& obj : written) {
    for (const std::string& name : {obj, fs::path(obj).replace_extension(".mtl").string()}) {
      SCOPED_TRACE(name);
      const std::string fresh = slurp(dir + "/" + name);
      EXPECT_FALSE(fresh.empty());
      EXPECT_EQ(fresh, slurp(kData + "/meshes/" + name)) << "run `forklift-sim meshes --out data/meshes`";
    }
  }
  fs::remove_all(dir);
}

TEST(Meshes, PartsCarryTheirNamesColoursAndSolidity) {
  const auto cone = load_mesh(kData + "/meshes/cone.obj");
  const MeshPart* band = part(*cone, "mark_band");
  const MeshPart* body = part(*cone, "body_0");
  ASSERT_TRUE(band && body);
  EXPECT_FALSE(band->solid);
  EXPECT_TRUE(body->solid);
  EXPECT_GT(band->colour.minCoeff(), 0.9f);  // white
  EXPECT_GT(body->colour.x(), 0.9f);         // orange
  EXPECT_LT(body->colour.z(), 0.2f);
  EXPECT_NEAR(cone->bounds.max().z(), 0.75, 1e-6);
  // Box parts: 12 triangles with outward unit normals.
  EXPECT_EQ(body->triangles.size(), 36u);
  for (size_t t = 0; t < body->triangles.size(); t += 3) {
    const Eigen::Vector3f a = body->positions[body->triangles[t]], b = body->positions[body->triangles[t + 1]],
                          c = body->positions[body->triangles[t + 2]];
    const Eigen::Vector3f n = (b - a).cross(c - a).normalized();
    const Eigen::Vector3f out = ((a + b + c) / 3 - body->bounds.center().cast<float>());
    EXPECT_GT(n.dot(out), 0) << "triangle " << t / 3 << " faces inwards";
    EXPECT_NEAR(body->normals[body->triangles[t]].dot(n), 1.0f, 1e-5f);
  }
}

TEST(Meshes, TruckShapeMatchesItsMeshesAndTheTruckFile) {
  const std::string truck_file = kData + "/trucks/linde_e16c.json";
  const TruckShape shape = load_truck_shape(truck_file, kData);
  const TruckParams truck = load_truck(truck_file);  // the "shape" section must not upset it
  const MeshPart* left = part(*shape.carriage, "fork_left");
  const MeshPart* right = part(*shape.carriage, "fork_right");
  ASSERT_TRUE(left && right);
  EXPECT_NEAR(left->bounds.sizes().x(), shape.fork_length_m, 1e-6);
  EXPECT_NEAR(left->bounds.sizes().y(), shape.fork_width_m, 1e-6);
  EXPECT_NEAR(left->bounds.sizes().z(), shape.fork_thickness_m, 1e-6);
  EXPECT_NEAR(left->bounds.max().z(), 0.0, 1e-6);  // fork tops at the heel's height
  EXPECT_NEAR(left->bounds.min().x(), 0.0, 1e-6);  // from the fork face
  EXPECT_NEAR(left->bounds.center().y() - right->bounds.center().y(), shape.fork_centres_y_m, 1e-6);
  // Wheels as the truck file has them.
  EXPECT_NEAR(shape.front_wheel->bounds.max().z(), truck.wheels[kFrontLeft].radius_m, 1e-6);
  EXPECT_NEAR(shape.rear_wheel->bounds.max().z(), truck.wheels[kRear].radius_m, 1e-6);
  // The chassis clears the floor and its wheels, standing on them.
  const double floor = shape.chassis->bounds.min().z();
  EXPECT_GT(floor, 0.05);
  // Standing at rest, the fork tips reach the load centre plus a pallet's length ahead of the heel.
  const BodyPoses p = body_poses(truck, coordinates(TruckDynamics(truck).rest_state(0, 0, 0)));
  const Eigen::Vector3d heel = p.carriage.translation();
  EXPECT_NEAR(heel.z(), 0.05, 0.02);
  EXPECT_NEAR((p.chassis.inverse() * heel).x(), 0.40, 1e-6);
  // The eye is inside the overhead guard, above the seat.
  const MeshPart* seat = part(*shape.chassis, "seat");
  ASSERT_TRUE(seat);
  EXPECT_GT(shape.eye_m.z(), seat->bounds.max().z() + 0.5);
  EXPECT_LT(shape.eye_m.z(), part(*shape.chassis, "guard_rail_left")->bounds.min().z());
}

// body_ground_contact restates corners of the truck's body; they must stay on its meshes, which
// are now built from the same file's "shape" section.
TEST(Meshes, BodyGroundContactPointsLieOnTheTrucksMeshes) {
  const std::string truck_file = kData + "/trucks/linde_e16c.json";
  const TruckShape shape = load_truck_shape(truck_file, kData);
  const TruckParams truck = load_truck(truck_file);
  ASSERT_GE(truck.body_contact.points.size(), 20u);
  for (const BodyContactPoint& c : truck.body_contact.points) {
    // Into each mesh's own frame: the chassis mesh is in the geometry frame.
    const Mesh& mesh = c.body == TruckBody::kChassis ? *shape.chassis : c.body == TruckBody::kMast ? *shape.mast : *shape.carriage;
    const Eigen::Vector3d at = c.body == TruckBody::kChassis ? Eigen::Vector3d(c.point_m + truck.chassis_cog_geometry_m) : c.point_m;
    bool on = false;
    for (const MeshPart& p : mesh.parts)
      if (p.solid) on |= p.bounds.exteriorDistance(at) < 1e-6;
    EXPECT_TRUE(on) << c.name << " at (" << at.transpose() << ") lies in no part of its mesh";
  }
}

// --- the layout's geometry -------------------------------------------------------------------

TEST(Layout, GroundRisesToTheRampPlateauAndIsFlatElsewhere) {
  const Scene& s = warehouse_scene();
  ASSERT_EQ(s.ramps.size(), 1u);
  const Ramp& r = s.ramps[0];
  const Eigen::Vector2d dir(std::cos(r.heading_rad), std::sin(r.heading_rad));
  const Eigen::Vector2d plateau = r.start_m + dir * (r.length_m + 0.5 * r.plateau_m);
  EXPECT_NEAR(s.ground.height(plateau.x(), plateau.y()), 0.6, 1e-12);
  EXPECT_NEAR(s.ground.height(5.0, 28.0), 0.6, 1e-12);
  EXPECT_DOUBLE_EQ(s.ground.height(20.0, 10.0), 0.0);
  EXPECT_DOUBLE_EQ(s.ground.height(35.0, 26.0), 0.0);
  EXPECT_GT(s.ground.gradient(5.0, 21.5).y(), 0.05);  // climbing north at mid-ramp
  EXPECT_LE(s.ground.gradient(5.0, 21.5).y(), 0.1 + 1e-9);  // steepest grade 1:10

  const Scene yard = load_scene(kData + "/scenarios/first_drive_yard.json", kData);
  EXPECT_NEAR(yard.ground.height(48.0, 30.0), 0.5, 1e-12);  // the hump's top
  EXPECT_DOUBLE_EQ(yard.ground.height(20.0, 20.0), 0.0);
  EXPECT_DOUBLE_EQ(yard.ground.height(58.0, 30.0), 0.0);
}

TEST(Layout, DocksAndTheLorrysBedStand1Point2MetresAboveTheYardWithRealEdges) {
  const Scene& s = warehouse_scene();
  ASSERT_EQ(s.ground_steps.size(), 5u);
  EXPECT_DOUBLE_EQ(s.ground.height(41.7, 5.0), 0.0);    // on dock D1, level with the floor
  EXPECT_DOUBLE_EQ(s.ground.height(43.4, 5.0), 0.0);    // its dock plate
  EXPECT_DOUBLE_EQ(s.ground.height(50.0, 5.0), 0.0);    // the lorry's bed
  EXPECT_DOUBLE_EQ(s.ground.height(41.7, 8.0), -1.2);   // the yard between the docks
  EXPECT_DOUBLE_EQ(s.ground.height(50.0, 7.0), -1.2);   // beside the lorry
  EXPECT_DOUBLE_EQ(s.ground.height(39.9, 8.0), 0.0);    // inside the wall: the floor
  // Each dock's top is the top of its support, and the bed's the bed's: the steps follow the objects.
  for (const char* id : {"D1", "D2", "L1"}) {
    const SceneObject* o = s.find(id);
    ASSERT_NE(o, nullptr);
    const Support& top = o->supports.at(0);
    const Eigen::Vector2d c = (o->pose * Eigen::Vector3d(top.footprint.center().x(), top.footprint.center().y(), 0)).head<2>();
    EXPECT_NEAR(s.ground.height(c.x(), c.y()), o->pose.translation().z() + top.height_m, 1e-9) << id;
  }
}

TEST(Layout, SpeedLimitsFollowTheZones) {
  const Scene& s = warehouse_scene();
  EXPECT_DOUBLE_EQ(*s.speed_limit({17.0, 26.15}), 2.8);  // aisle A
  EXPECT_DOUBLE_EQ(*s.speed_limit({26.75, 10.0}), 1.4);  // walkway across the east floor
  EXPECT_DOUBLE_EQ(*s.speed_limit({20.0, 0.75}), 1.4);   // walkway along the south wall
  EXPECT_DOUBLE_EQ(*s.speed_limit({41.7, 5.0}), 1.4);    // dock 1
  EXPECT_DOUBLE_EQ(*s.speed_limit({5.0, 22.0}), 1.4);    // ramp
  EXPECT_DOUBLE_EQ(*s.speed_limit({11.0, 26.0}), 1.4);   // aisle mouth
  EXPECT_FALSE(s.speed_limit({-10.0, -10.0}).has_value());
  // The pedestrian stands in a walkway.
  const SceneObject* ped = s.find("PED1");
  ASSERT_TRUE(ped);
  const Eigen::Vector2d at = ped->pose.translation().head<2>();
  bool in_walkway = false;
  for (const Zone& z : s.zones) in_walkway |= z.kind == "walkway" && z.contains(at);
  EXPECT_TRUE(in_walkway);
}

TEST(Layout, EveryStartPoseIsClearOfSolidObjects) {
  for (const std::string& f : files_in(kData + "/scenarios", ".json")) {
    SCOPED_TRACE(f);
    const Scene s = load_scene(f, kData);
    const TruckShape shape = load_truck_shape(s.scenario.truck_file, kData);
    const TruckParams truck = load_truck(s.scenario.truck_file);
    EXPECT_EQ(first_hit(s, shape, truck, s.scenario.x_m, s.scenario.y_m, s.scenario.yaw_rad), "");
  }
}

TEST(Layout, TheCheckFindsATruckParkedInARack) {
  // The start-pose check above can fail: the same truck placed in rack R2 hits it.
  const Scene& s = warehouse_scene();
  const TruckShape shape = load_truck_shape(s.scenario.truck_file, kData);
  const TruckParams truck = load_truck(s.scenario.truck_file);
  EXPECT_NE(first_hit(s, shape, truck, 16.05, 28.45, 0), "");
  EXPECT_NE(first_hit(s, shape, truck, 30.0, 14.0, M_PI / 2), "");  // forks into column COL_2
}

TEST(Layout, EveryRouteIsClearWithTheTruckAlongIt) {
  for (const std::string& f : files_in(kData + "/scenarios", ".json")) {
    SCOPED_TRACE(f);
    const Scene s = load_scene(f, kData);
    const TruckShape shape = load_truck_shape(s.scenario.truck_file, kData);
    const TruckParams truck = load_truck(s.scenario.truck_file);
    std::set<std::string> moved;  // the forks go into these on purpose
    for (const TaskStep& st : s.task.steps)
      if (st.kind == "move") moved.insert(st.pallet);
    const auto& pts = s.route.points;
    for (size_t i = 0; i + 1 < pts.size(); ++i) {
      const Eigen::Vector2d d = pts[i + 1] - pts[i];
      const double yaw = std::atan2(d.y(), d.x());
      const int n = static_cast<int>(std::ceil(d.norm() / 0.25));
      for (int k = 0; k <= n; ++k) {
        const Eigen::Vector2d p = pts[i] + d * (double(k) / n);
        const std::string hit = first_hit(s, shape, truck, p.x(), p.y(), yaw, moved);
        EXPECT_EQ(hit, "") << "segment " << i << " at (" << p.x() << ", " << p.y() << ")";
        if (!hit.empty()) break;
      }
    }
  }
}

TEST(Layout, TaskTargetsAreFreeAndOnTheirSupports) {
  for (const std::string& f : files_in(kData + "/scenarios", ".json")) {
    SCOPED_TRACE(f);
    const Scene s = load_scene(f, kData);
    for (const TaskStep& st : s.task.steps) {
      if (st.kind != "move") continue;
      const SceneObject* pallet = s.find(st.pallet);
      ASSERT_TRUE(pallet);
      if (st.to_object.empty()) {
        EXPECT_TRUE(st.area.contains(st.point));
        continue;
      }
      const SceneObject* target = s.find(st.to_object);
      ASSERT_TRUE(target);
      const Support* sup = nullptr;
      for (const Support& x : target->supports)
        if (x.level == st.to_level) sup = &x;
      ASSERT_TRUE(sup);
      // The set-down place is over the support, and nothing else stands there at that height.
      const Eigen::Vector3d local = target->pose.inverse() * Eigen::Vector3d(st.point.x(), st.point.y(), 0);
      EXPECT_TRUE(sup->footprint.contains(local.head<2>()));
      Eigen::Isometry3d placed = pallet->pose;
      placed.translation() = target->pose * Eigen::Vector3d(local.x(), local.y(), sup->height_m);
      const YawBox there = world_box(placed, pallet->mesh->bounds);
      for (const SceneObject& o : s.objects) {
        if (o.kind != ObjectKind::kPallet || o.id == st.pallet) continue;
        EXPECT_FALSE(overlap(there, world_box(o.pose, o.mesh->bounds))) << st.pallet << " onto " << o.id;
      }
    }
  }
}

// --- loading rules ----------------------------------------------------------------------------

TEST(Loader, ScaleIsAppliedToTheMeshAndMeshesAreShared) {
  const Scene& s = warehouse_scene();
  const SceneObject* wall = s.find("W_south");
  ASSERT_TRUE(wall);
  EXPECT_NEAR(wall->mesh->bounds.sizes().x(), 40.4, 1e-5);
  EXPECT_NEAR(wall->mesh->bounds.sizes().y(), 0.2, 1e-6);
  EXPECT_NEAR(wall->mesh->bounds.max().z(), 5.0, 1e-6);
  EXPECT_EQ(s.find("P1")->mesh, s.find("P2")->mesh);  // one pallet mesh for all
  EXPECT_EQ(s.find("R1")->mesh, s.find("R16")->mesh);
  EXPECT_NE(s.find("W_south")->mesh, s.find("W_west_a")->mesh);  // different scales
  EXPECT_TRUE(s.find("P3")->load_mesh);
  EXPECT_FALSE(s.find("P14")->load_mesh);  // an empty pallet
  EXPECT_NEAR(s.find("P3")->pallet->load_mass_kg, 400, 1e-12);
}

TEST(Loader, IncludedLayoutIsSharedAndCanBeTrimmed) {
  const std::string dir = temp_dir("include");
  const std::string path = write_file(dir, "trim.json", R"({
    "include": "scenes/warehouse.json", "name": "trim", "floor_m": [0, 0, 10, 10],
    "exclude_objects": ["P14"],
    "objects": [{"id": "extra_cone", "kind": "cone", "x_m": 30, "y_m": 8}]
  })");
  const Scene s = load_scene(path, kData);
  EXPECT_EQ(s.name, "trim");
  EXPECT_EQ(s.find("P14"), nullptr);
  EXPECT_NE(s.find("P13"), nullptr);
  ASSERT_NE(s.find("extra_cone"), nullptr);
  EXPECT_EQ(s.objects.back().id, "extra_cone");  // included objects first
  EXPECT_DOUBLE_EQ(s.floor.max().x(), 10.0);    // the including file wins
  EXPECT_EQ(s.zones.size(), warehouse_scene().zones.size());
  fs::remove_all(dir);
}

TEST(Loader, ZonesAreStoredCounterClockwise) {
  const std::string dir = temp_dir("zones");
  const std::string path = write_file(dir, "z.json", R"({
    "objects": [],
    "zones": [{"id": "cw", "kind": "walkway", "speed_limit_m_s": 1.0,
               "polygon": [[0, 0], [0, 2], [2, 2], [2, 0]]}]
  })");
  const Scene s = load_scene(path, kData);
  ASSERT_EQ(s.zones.size(), 1u);
  double area2 = 0;
  const auto& poly = s.zones[0].polygon;
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) area2 += poly[j].x() * poly[i].y() - poly[i].x() * poly[j].y();
  EXPECT_GT(area2, 0);
  EXPECT_DOUBLE_EQ(*s.speed_limit({1, 1}), 1.0);
  fs::remove_all(dir);
}

struct BadCase {
  const char* name;
  const char* text;
  std::vector<std::string> expect;  // substrings of the message beside the file's path
};

void PrintTo(const BadCase& c, std::ostream* os) { *os << c.name; }

class LoaderRefuses : public testing::TestWithParam<BadCase> {};

TEST_P(LoaderRefuses, NamingTheFileAndTheKey) {
  const BadCase& c = GetParam();
  const std::string dir = temp_dir(c.name);
  const std::string path = write_file(dir, std::string(c.name) + ".json", c.text);
  const std::string msg = load_error(path);
  EXPECT_NE(msg.find(path), std::string::npos) << msg;
  for (const std::string& e : c.expect) EXPECT_NE(msg.find(e), std::string::npos) << "'" << e << "' not in: " << msg;
  fs::remove_all(dir);
}

#define CONE(id) R"({"id": ")" id R"(", "kind": "cone", "x_m": 1, "y_m": 1})"
INSTANTIATE_TEST_SUITE_P(
    Scene, LoaderRefuses,
    testing::Values(
        BadCase{"malformed", R"({"objects": [)", {"not valid JSON"}},
        BadCase{"nan_literal", R"({"objects": [{"id": "c", "kind": "cone", "x_m": NaN, "y_m": 0}]})", {"not valid JSON"}},
        // JSON has no non-finite numbers: the parser refuses both, naming the line and column.
        BadCase{"infinite", R"({"objects": [{"id": "c", "kind": "cone", "x_m": 1e999, "y_m": 0}]})",
                {"not valid JSON", "1e999"}},
        BadCase{"unknown_kind", R"({"objects": [{"id": "x", "kind": "spaceship", "x_m": 0, "y_m": 0}]})",
                {"'objects[0].kind'", "spaceship"}},
        BadCase{"duplicate_id", R"({"objects": [)" CONE("c1") "," CONE("c1") "]}", {"'objects[1].id'", "c1"}},
        BadCase{"missing_mesh",
                R"({"objects": [{"id": "x", "kind": "cone", "mesh": "meshes/nope.obj", "x_m": 0, "y_m": 0}]})",
                {"'objects[0]'", "meshes/nope.obj", "missing"}},
        BadCase{"missing_pallet",
                R"({"objects": [)" CONE("c1") R"(], "task": {"summary": "s", "steps": [
                   {"kind": "move", "pallet": "P99", "to_object": "c1"}]}})",
                {"'task.steps[0].pallet'", "P99"}},
        BadCase{"control_without_its_measure",
                R"({"task": {"steps": [{"kind": "control", "action": "lift"}]}})",
                {"'task.steps[0].height_m'", "missing"}},
        BadCase{"control_with_another_measure",
                R"({"task": {"steps": [{"kind": "control", "action": "lift", "height_m": 0.3, "speed_m_s": 1}]}})",
                {"'task.steps[0].speed_m_s'", "lift", "height_m"}},
        BadCase{"step_naming_no_control",
                R"({"task": {"steps": [{"kind": "control", "action": "lift", "height_m": 0.3, "description": "Lift with {lfit}"}]}})",
                {"'task.steps[0].description'", "{lfit}", "no control"}},
        BadCase{"missing_target",
                R"({"objects": [{"id": "P1", "kind": "pallet", "x_m": 0, "y_m": 0}], "task": {"steps": [
                   {"kind": "move", "pallet": "P1", "to_object": "R9"}]}})",
                {"'task.steps[0].to_object'", "R9"}},
        BadCase{"no_such_level",
                R"({"objects": [{"id": "R1", "kind": "rack", "x_m": 0, "y_m": 0, "levels_m": [0.9, 1.8, 2.7]},
                                {"id": "P1", "kind": "pallet", "x_m": 5, "y_m": 0}],
                    "task": {"steps": [{"kind": "move", "pallet": "P1", "to_object": "R1", "to_level": 4}]}})",
                {"'task.steps[0].to_level'", "R1"}},
        BadCase{"pallet_on_missing_level",
                R"({"objects": [{"id": "R1", "kind": "rack", "x_m": 0, "y_m": 0, "levels_m": [0.9, 1.8]},
                                {"id": "P1", "kind": "pallet", "x_m": 0, "y_m": 0, "yaw_deg": 90, "on": "R1", "level": 3}]})",
                {"'objects[1].level'", "R1"}},
        BadCase{"pallet_beside_rack",
                R"({"objects": [{"id": "R1", "kind": "rack", "x_m": 0, "y_m": 0, "levels_m": [0.9]},
                                {"id": "P1", "kind": "pallet", "x_m": 3, "y_m": 0, "on": "R1", "level": 1}]})",
                {"'objects[1]'", "off the support"}},
        BadCase{"negative_scale", R"({"objects": [{"id": "w", "kind": "wall", "x_m": 0, "y_m": 0, "scale": [-1, 1, 1]}]})",
                {"'objects[0].scale[0]'", "positive"}},
        BadCase{"negative_load", R"({"objects": [{"id": "P1", "kind": "pallet", "x_m": 0, "y_m": 0,
                                     "pallet": {"load_size_m": [1, -0.5, 1], "load_mass_kg": 10}}]})",
                {"'objects[0].pallet.load_size_m[1]'", "negative"}},
        BadCase{"unknown_key", R"({"objects": [{"id": "c", "kind": "cone", "x_m": 0, "y_m": 0, "colour": "red"}]})",
                {"'objects[0].colour'"}},
        BadCase{"rack_without_levels", R"({"objects": [{"id": "R1", "kind": "rack", "x_m": 0, "y_m": 0}]})",
                {"'objects[0].levels_m'", "missing"}},
        BadCase{"missing_include", R"({"include": "scenes/nope.json"})", {"'include'", "nope.json"}},
        BadCase{"zone_without_limit", R"({"zones": [{"id": "z", "kind": "aisle", "rect": [0, 0, 1, 1]}]})",
                {"'zones[0]'", "speed_limit_m_s"}},
        BadCase{"bad_start", R"({"start": {"x_m": "north", "y_m": 0}})", {"'start.x_m'", "not a number"}},
        BadCase{"step_without_top", R"({"ground_steps": [{"id": "kerb", "rect": [0, 0, 1, 1]}]})",
                {"'ground_steps[0].top_m'", "missing"}},
        BadCase{"step_upside_down", R"({"ground_steps": [{"id": "kerb", "rect": [1, 0, 0, 1], "top_m": 0.15}]})",
                {"'ground_steps[0].rect'"}},
        BadCase{"step_without_area", R"({"ground_steps": [{"id": "kerb", "rect": [0, 0, 0, 1], "top_m": 0.15}]})",
                {"'ground_steps[0].rect'", "xmax > xmin"}},
        BadCase{"negative_levels", R"({"objects": [{"id": "R1", "kind": "rack", "x_m": 0, "y_m": 0, "levels_m": [-0.9]}]})",
                {"'objects[0].levels_m[0]'", "positive"}}),
    [](const testing::TestParamInfo<BadCase>& i) { return std::string(i.param.name); });

TEST(Loader, AnErrorInAnIncludedFileNamesThatFile) {
  const std::string dir = temp_dir("bad_include");
  const std::string inner = write_file(dir, "inner.json", R"({"objects": [)" CONE("c1") R"(, {"id": "c2", "kind": "tank", "x_m": 1, "y_m": 0}]})");
  const std::string outer = write_file(dir, "outer.json", R"({"include": ")" + inner + R"("})");
  const std::string msg = load_error(outer);
  EXPECT_EQ(msg.rfind(inner, 0), 0u) << msg;
  EXPECT_NE(msg.find("'objects[1].kind'"), std::string::npos) << msg;
  // A layout may not carry a start pose: load_scenario reads only the scenario file itself.
  const std::string with_start = write_file(dir, "with_start.json", R"({"include": "scenarios/rack_pick.json"})");
  const std::string smsg = load_error(with_start);
  EXPECT_EQ(smsg.rfind(kData + "/scenarios/rack_pick.json: 'start'", 0), 0u) << smsg;
  // And a duplicate across the include is refused in the including file.
  const std::string dup = write_file(dir, "dup.json", R"({"include": ")" + dir + R"(/ok.json", "objects": [)" CONE("c1") "]}");
  write_file(dir, "ok.json", R"({"objects": [)" CONE("c1") "]}");
  const std::string dmsg = load_error(dup);
  EXPECT_EQ(dmsg.rfind(dup, 0), 0u) << dmsg;
  EXPECT_NE(dmsg.find("'objects[0].id'"), std::string::npos) << dmsg;
  fs::remove_all(dir);
}

TEST(Loader, MeshErrorsNameTheFile) {
  const std::string dir = temp_dir("mesh_errors");
  for (const std::string& name : {std::string("absent.obj")}) {
    try {
      load_mesh(dir + "/" + name);
      ADD_FAILURE() << "no error";
    } catch (const SceneError& e) {
      EXPECT_NE(std::string(e.what()).find(dir + "/" + name), std::string::npos) << e.what();
    }
  }
  for (const auto& [name, text] : std::vector<std::pair<std::string, std::string>>{
           {"empty.obj", ""}, {"points.obj", "v 0 0 0\nv 1 0 0\n"}, {"garbage.obj", "\x01\x02 not a mesh \x7f\n"}}) {
    const std::string path = write_file(dir, name, text);
    try {
      load_mesh(path);
      ADD_FAILURE() << name << ": no error";
    } catch (const SceneError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
  fs::remove_all(dir);
}

TEST(Loader, TruckShapeErrorsNameTheFileAndKey) {
  const std::string dir = temp_dir("shape_errors");
  const std::string none = write_file(dir, "none.json", R"({"name": "x"})");
  try {
    load_truck_shape(none, kData);
    ADD_FAILURE();
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find(none + ": 'shape'"), std::string::npos) << e.what();
  }
  // The training truck with one change each; the message names the file and the key.
  const nlohmann::json stock = nlohmann::json::parse(slurp(kData + "/trucks/linde_e16c.json"));
  auto expect_refused = [&](const std::string& name, const std::function<void(nlohmann::json&)>& change,
                            const std::string& key, const std::string& says) {
    nlohmann::json j = stock;
    change(j);
    const std::string path = write_file(dir, name + ".json", j.dump(2));
    try {
      load_truck_shape(path, kData);
      ADD_FAILURE() << name << ": no error";
    } catch (const SceneError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(path + ": '" + key + "'"), std::string::npos) << what;
      EXPECT_NE(what.find(says), std::string::npos) << what;
    }
  };
  expect_refused("fork", [](nlohmann::json& j) { j["shape"]["fork_length_m"] = -1; }, "shape.fork_length_m", "positive");
  // The OBJ files the shape section once named are refused, not silently ignored.
  expect_refused("old_key", [](nlohmann::json& j) { j["shape"]["chassis_mesh"] = "meshes/truck_chassis.obj"; },
                 "shape.chassis_mesh", "no longer read");
  expect_refused("no_body", [](nlohmann::json& j) { j["shape"].erase("body"); }, "shape.body", "missing");
  expect_refused("span", [](nlohmann::json& j) { j["shape"]["overhead_guard"]["x_m"] = {0.15, -1.0}; },
                 "shape.overhead_guard.x_m", "from < to");
  // A front tyre too big for its fenders: the body no longer fits around the wheels.
  expect_refused("big_wheel", [](nlohmann::json& j) {
    for (const char* w : {"front_left", "front_right"}) {
      j["wheels"][w]["radius_m"] = 0.4;
      j["wheels"][w]["centre_m"][2] = 0.4;
    }
  }, "shape.body.cowl_bottom_m", "fenders");
  expect_refused("odd_front", [](nlohmann::json& j) { j["wheels"]["front_right"]["radius_m"] = 0.25; },
                 "wheels.front_right.radius_m", "one mesh");
  // What load_truck refuses is refused here too, named as it names it.
  expect_refused("mass", [](nlohmann::json& j) { j["service_mass_kg"] = -5; }, "service_mass_kg", "");
  fs::remove_all(dir);
}
