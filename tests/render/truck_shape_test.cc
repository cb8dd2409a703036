// The truck's meshes follow its truck file: a copy of the training truck with larger front
// wheels gets larger wheel meshes, fenders that rise with them (collision boxes), and a picture
// that changes where the wheels are and nowhere else. Real OSMesa frames, counted in pixels.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "forklift/render/render.h"

namespace forklift {
namespace {

namespace fs = std::filesystem;
using Eigen::Vector3d;

const std::string kTruck = std::string(FORKLIFT_DATA_DIR) + "/trucks/linde_e16c.json";
constexpr double kStockRadiusM = 0.228;  // the truck file's front tyres (18x7-8)
constexpr double kBigRadiusM = 0.30;     // a 24-inch tyre instead: +72 mm
constexpr int kWidth = 640, kHeight = 480;

const MeshPart& part(const Mesh& m, const std::string& name) {
  for (const MeshPart& p : m.parts)
    if (p.name == name) return p;
  throw std::runtime_error("no part " + name);
}

// linde_e16c.json with both front tyres of `radius_m` on axles `axle_m` above the ground,
// written to a fresh directory.
std::string truck_with_front_tyres(double radius_m, double axle_m, const std::string& name) {
  std::ifstream in(kTruck);
  nlohmann::json j = nlohmann::json::parse(in);
  for (const char* w : {"front_left", "front_right"}) {
    j["wheels"][w]["radius_m"] = radius_m;
    j["wheels"][w]["centre_m"][2] = axle_m;
  }
  const fs::path dir = fs::temp_directory_path() / ("truck_shape_test_" + name + "_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / "truck.json").string();
  std::ofstream(path) << j.dump(2);
  return path;
}

// A pinhole camera as the renderer's look-at and perspective make it: image rows top down.
struct Projector {
  Camera c;
  int width, height;
  Vector3d forward() const { return (c.target - c.eye).normalized(); }
  double focal_px() const { return 0.5 * height / std::tan(0.5 * c.fov_y_deg * M_PI / 180.0); }
  Eigen::Vector2d pixel(const Vector3d& world) const {
    const Vector3d f = forward(), s = f.cross(c.up).normalized(), u = s.cross(f), d = world - c.eye;
    const double depth = d.dot(f);
    return {0.5 * width + focal_px() * d.dot(s) / depth, 0.5 * height - focal_px() * d.dot(u) / depth};
  }
  // The pixels a world box covers, with a margin.
  Eigen::AlignedBox2d region(const Eigen::AlignedBox3d& box, const Eigen::Isometry3d& pose, double margin_px) const {
    Eigen::AlignedBox2d r;
    for (int i = 0; i < 8; ++i) r.extend(pixel(pose * box.corner(Eigen::AlignedBox3d::CornerType(i))));
    return Eigen::AlignedBox2d(r.min().array() - margin_px, r.max().array() + margin_px);
  }
};

struct Frame {
  TruckParams truck;
  TruckShape shape;
  BodyPoses poses;
  Image image;
};

// The truck at coordinates q in `view` on an empty floor. Every truck is drawn at the same q
// (the stock truck's settled rest), so only its shape differs.
Frame render(const std::string& truck_file, const CoordVector& q, View view) {
  Frame f;
  f.truck = load_truck(truck_file);
  f.shape = load_truck_shape(truck_file, FORKLIFT_DATA_DIR);
  f.poses = body_poses(f.truck, q);
  Scene scene;
  scene.floor = Eigen::AlignedBox2d(Eigen::Vector2d(-10, -10), Eigen::Vector2d(10, 10));
  Renderer renderer(scene, f.shape, f.truck, kWidth, kHeight);
  RenderState state;
  state.q = q;
  f.image = renderer.render(state, view);
  return f;
}

CoordVector stock_rest() {
  const TruckDynamics dynamics(load_truck(kTruck));
  StateVector x = dynamics.rest_state(0, 0, 0);
  EXPECT_TRUE(dynamics.settle_static(x));
  return coordinates(x);
}

bool differs(const Image& a, const Image& b, int x, int y) {
  const uint8_t *p = a.pixel(x, y), *q = b.pixel(x, y);
  return std::abs(p[0] - q[0]) + std::abs(p[1] - q[1]) + std::abs(p[2] - q[2]) > 24;
}

TEST(TruckShapeFromFile, ALargerFrontTyreGrowsItsMeshAndTheFendersCollisionBoxes) {
  const std::string big = truck_with_front_tyres(kBigRadiusM, kBigRadiusM, "mesh");
  const TruckShape stock = load_truck_shape(kTruck, FORKLIFT_DATA_DIR);
  const TruckShape grown = load_truck_shape(big, FORKLIFT_DATA_DIR);
  const double dr = kBigRadiusM - kStockRadiusM;
  // The tyre: 2 r along x and z, its width along y unchanged.
  const Vector3d before = part(*stock.front_wheel, "tyre").bounds.sizes();
  const Vector3d after = part(*grown.front_wheel, "tyre").bounds.sizes();
  EXPECT_NEAR(before.x(), 2 * kStockRadiusM, 1e-6);
  EXPECT_NEAR(after.x() - before.x(), 2 * dr, 1e-6);
  EXPECT_NEAR(after.z() - before.z(), 2 * dr, 1e-6);
  EXPECT_NEAR(after.y(), before.y(), 1e-9);
  EXPECT_NEAR(grown.front_wheel->bounds.max().z(), kBigRadiusM, 1e-6);
  // The body's solid parts are its collision boxes: the fenders rise by the diameter's growth
  // (the wheel's top rises 2 dr) and the wells reach dr further back; the rear is untouched.
  for (const char* fender : {"chassis_fender_left", "chassis_fender_right"}) {
    const Eigen::AlignedBox3d& a = part(*stock.chassis, fender).bounds;
    const Eigen::AlignedBox3d& b = part(*grown.chassis, fender).bounds;
    EXPECT_NEAR(b.min().z() - a.min().z(), 2 * dr, 1e-6) << fender;
    EXPECT_NEAR(b.min().x() - a.min().x(), -dr, 1e-6) << fender;
    EXPECT_NEAR(b.max().z(), a.max().z(), 1e-9) << fender;
  }
  EXPECT_TRUE(part(*grown.chassis, "chassis_counterweight_top").bounds.isApprox(
      part(*stock.chassis, "chassis_counterweight_top").bounds));
  EXPECT_TRUE(grown.rear_wheel->bounds.isApprox(stock.rear_wheel->bounds));
  fs::remove_all(fs::path(big).parent_path());
}

// The chase view (behind and above, the instructor's): pixels change on the left front tyre, at
// least half as many as its added side area covers seen from there, and nowhere but over the
// front wheels (the tyres and the body section whose wells follow them).
TEST(TruckShapeFromFile, ALargerFrontTyreChangesTheChaseViewAtTheWheelOnly) {
  // The larger tyres standing on the ground (axles raised by the radius' growth); the stock
  // tyres on those raised axles, so that the radius alone tells `grown` from `raised`; and an
  // unchanged copy of the file, which must draw the stock frame.
  const std::string big = truck_with_front_tyres(kBigRadiusM, kBigRadiusM, "chase");
  const std::string lifted = truck_with_front_tyres(kStockRadiusM, kBigRadiusM, "chase_raised");
  const std::string same = truck_with_front_tyres(kStockRadiusM, kStockRadiusM, "chase_same");
  const CoordVector q = stock_rest();
  const Frame stock = render(kTruck, q, View::kChase);
  const Frame grown = render(big, q, View::kChase);
  const Frame raised = render(lifted, q, View::kChase);
  const Frame copy = render(same, q, View::kChase);

  const Projector cam{view_camera(View::kChase, grown.poses, grown.shape, Scene{}), kWidth, kHeight};
  // The left front tyre as it is now (its outer face is what the camera sees), and the front
  // section of the body over both front wheels, whose rear follows the wells: boxes in the
  // geometry frame. Outside the latter nothing may change.
  const Vector3d left = grown.truck.wheels[kFrontLeft].centre_m + grown.truck.chassis_cog_geometry_m;
  const Vector3d tyre_half(kBigRadiusM, 0.5 * part(*grown.shape.front_wheel, "tyre").bounds.sizes().y(), kBigRadiusM);
  const Eigen::AlignedBox2d tyre = cam.region(Eigen::AlignedBox3d(left - tyre_half, left + tyre_half), grown.poses.chassis, 1);
  const Eigen::AlignedBox3d& cowl = part(*grown.shape.chassis, "chassis_cowl").bounds;
  const Eigen::AlignedBox3d front_section(Vector3d(-kBigRadiusM - 0.15, -left.y() - tyre_half.y() - 0.05, -0.05),
                                          Vector3d(kBigRadiusM + 0.05, left.y() + tyre_half.y() + 0.05, cowl.max().z()));
  const Eigen::AlignedBox2d front = cam.region(front_section, grown.poses.chassis, 2);
  long at_tyre = 0, outside = 0, by_radius = 0, copied = 0;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const Eigen::Vector2d at(x + 0.5, y + 0.5);
      copied += differs(stock.image, copy.image, x, y);
      by_radius += tyre.contains(at) && differs(raised.image, grown.image, x, y);
      if (!differs(stock.image, grown.image, x, y)) continue;
      at_tyre += tyre.contains(at);
      outside += !front.contains(at);
    }
  // The tyre's outer face grows by pi (R^2 - r^2); seen at distance d and angle theta from its
  // normal it covers that times cos(theta) (f / d)^2 pixels.
  const Eigen::Isometry3d& wheel = grown.poses.wheels[kFrontLeft];
  const Vector3d to_eye = cam.c.eye - wheel.translation();
  const double cos_theta = std::abs(to_eye.normalized().dot(wheel.linear().col(1)));
  const double scale = cam.focal_px() / to_eye.norm();
  const double added_px = M_PI * (kBigRadiusM * kBigRadiusM - kStockRadiusM * kStockRadiusM) * cos_theta * scale * scale;
  RecordProperty("changed_px_at_tyre", std::to_string(at_tyre));
  RecordProperty("changed_px_by_radius", std::to_string(by_radius));
  RecordProperty("added_tyre_face_px", std::to_string(static_cast<long>(added_px)));
  EXPECT_GT(added_px, 100);  // the test can see a change of this size at all
  EXPECT_GE(at_tyre, 0.5 * added_px) << "expected at least about " << added_px << " px";
  EXPECT_GE(by_radius, 0.5 * added_px) << "the radius alone: expected at least about " << added_px << " px";
  EXPECT_EQ(outside, 0);
  EXPECT_EQ(copied, 0);
  fs::remove_all(fs::path(big).parent_path());
  fs::remove_all(fs::path(lifted).parent_path());
  fs::remove_all(fs::path(same).parent_path());
}

// The renderer draws the truck without haze (kHazeStartM): exact only while every part of every
// shipped truck, forks at full lift and the driver's head turned either way, is nearer the
// driver's and the chase camera than the haze's start.
TEST(TruckShapeFromFile, EveryShippedTruckIsNearerItsCamerasThanTheHazeStarts) {
  for (const auto& file : fs::directory_iterator(std::string(FORKLIFT_DATA_DIR) + "/trucks")) {
    if (file.path().extension() != ".json") continue;
    SCOPED_TRACE(file.path().filename().string());
    const TruckParams truck = load_truck(file.path().string());
    const TruckShape shape = load_truck_shape(file.path().string(), FORKLIFT_DATA_DIR);
    for (double lift : {0.0, truck.limits.lift_max_m}) {
      CoordVector q = CoordVector::Zero();
      q[kS] = lift;
      const BodyPoses poses = body_poses(truck, q);
      const std::pair<const Mesh*, Eigen::Isometry3d> parts[] = {
          {shape.chassis.get(), poses.chassis}, {shape.mast.get(), poses.mast}, {shape.carriage.get(), poses.carriage},
          {shape.front_wheel.get(), poses.wheels[kFrontLeft]}, {shape.front_wheel.get(), poses.wheels[kFrontRight]},
          {shape.rear_wheel.get(), poses.wheels[kRear]}};
      std::vector<Camera> cameras = {view_camera(View::kChase, poses, shape, Scene{})};
      for (double yaw : {-kLookYawMaxRad, 0.0, kLookYawMaxRad}) cameras.push_back(driver_camera(poses, shape, yaw, 0));
      int meshes = 0;
      for (const auto& [mesh, pose] : parts) {
        if (!mesh) continue;
        ++meshes;
        for (const Camera& c : cameras)
          for (int i = 0; i < 8; ++i)
            EXPECT_LT((pose * mesh->bounds.corner(Eigen::AlignedBox3d::CornerType(i)) - c.eye).norm(), kHazeStartM)
                << "lift " << lift;
      }
      EXPECT_GE(meshes, 4);
    }
  }
}


}  // namespace
}  // namespace forklift
