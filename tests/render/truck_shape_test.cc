// The truck's meshes follow its truck file: a copy of the training truck with larger front
// wheels gets larger wheel meshes, fenders that rise with them (collision boxes), and a picture
// that changes where the wheels are and nowhere else. Real OSMesa frames, counted in pixels.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
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


// ---- the view from the seat ------------------------------------------------------------------

// linde_e16c.json with its mast as the files before the clear-view mast drew it: one lift
// cylinder down the middle between the channels (no cylinder_y_m), 80 mm wide, just behind the
// channels' front, and the channels and the inner mast as they were.
std::string truck_with_middle_cylinder() {
  std::ifstream in(kTruck);
  nlohmann::json j = nlohmann::json::parse(in);
  nlohmann::json& mast = j["shape"]["mast"];
  mast.erase("cylinder_y_m");
  mast["channel_y_m"] = {0.27, 0.35};
  mast["cylinder_x_m"] = {0.0, 0.08};
  mast["cylinder_width_m"] = 0.08;
  mast["cylinder_z_m"] = {-0.2, 1.5};
  j["shape"]["carriage"]["inner_mast_y_m"] = {0.2, 0.28};
  const fs::path dir = fs::temp_directory_path() / ("truck_shape_test_middle_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / "truck.json").string();
  std::ofstream(path) << j.dump(2);
  return path;
}

// The pixels inside the convex hull of points (Andrew's monotone chain), pixel centres counted.
template <class Each>
void for_each_pixel_in_hull(std::vector<Eigen::Vector2d> p, int width, int height, Each each) {
  std::sort(p.begin(), p.end(), [](const auto& a, const auto& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); });
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
  };
  std::vector<Eigen::Vector2d> hull(2 * p.size());
  size_t k = 0;
  for (size_t i = 0; i < p.size(); hull[k++] = p[i++])
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], p[i]) <= 0) --k;
  for (size_t i = p.size() - 1, t = k + 1; i-- > 0; hull[k++] = p[i])
    while (k >= t && cross(hull[k - 2], hull[k - 1], p[i]) <= 0) --k;
  hull.resize(k - 1);  // counter-clockwise in x right, y down: every edge has the inside on one side
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector2d c(x + 0.5, y + 0.5);
      bool inside = hull.size() >= 3;
      for (size_t i = 0; inside && i < hull.size(); ++i) inside = cross(hull[i], hull[(i + 1) % hull.size()], c) >= 0;
      if (inside) each(x, y);
    }
}

// The share of a floor pallet's outline, its near face `ahead_m` before the truck's front axle
// and square to it (lengthwise: the way the forks go in), that the driver sees from the seat: the pixels inside the pallet's projected outline that
// change when the pallet is taken away (rack_pick's bare floor pallet P14, the truck facing it).
double floor_pallet_seen(const std::string& truck_file, double ahead_m) {
  const Scene scene = load_scene(std::string(FORKLIFT_DATA_DIR) + "/scenarios/rack_pick.json", FORKLIFT_DATA_DIR);
  const SceneObject* pallet = scene.find("P14");
  if (!pallet || !pallet->mesh) throw std::runtime_error("rack_pick has no floor pallet P14");
  const Vector3d at = pallet->pose.translation();
  const TruckParams truck = load_truck(truck_file);
  const TruckShape shape = load_truck_shape(truck_file, FORKLIFT_DATA_DIR);
  const TruckDynamics dynamics(truck);
  const double half_length = 0.5 * pallet->mesh->bounds.sizes().x();  // the pallet stands at 90 deg: along y
  StateVector x = dynamics.rest_state(at.x(), at.y() - half_length - ahead_m, M_PI / 2);
  EXPECT_TRUE(dynamics.settle_static(x));
  RenderState with;
  with.q = coordinates(x);
  RenderState without = with;
  PalletState away;  // far behind the truck, out of the driver's sight
  away.id = "P14";
  away.pose = Eigen::Translation3d(at.x(), -100, 0) * Eigen::Isometry3d::Identity();
  without.pallets.push_back(away);
  Renderer renderer(scene, shape, truck, kWidth, kHeight);
  const Image seen = renderer.render(with, View::kDriver);
  const Image bare = renderer.render(without, View::kDriver);
  if (const char* dir = std::getenv("TRUCK_SHAPE_DUMP"))
    write_png(std::string(dir) + "/seat_" + fs::path(truck_file).parent_path().filename().string() + "_" +
                  std::to_string(int(ahead_m)) + "m.png", seen);
  const Projector cam{view_camera(View::kDriver, body_poses(truck, with.q), shape, scene), kWidth, kHeight};
  std::vector<Eigen::Vector2d> corners;
  for (int i = 0; i < 8; ++i) corners.push_back(cam.pixel(pallet->pose * pallet->mesh->bounds.corner(Eigen::AlignedBox3d::CornerType(i))));
  long inside = 0, changed = 0;
  for_each_pixel_in_hull(corners, kWidth, kHeight, [&](int x, int y) {
    ++inside;
    changed += differs(seen, bare, x, y);
  });
  EXPECT_GT(inside, 300) << "the pallet is too small in the picture to judge at " << ahead_m << " m";
  return inside > 0 ? double(changed) / inside : 0;
}

constexpr double kSeenShare = 0.85;  // of the pallet's outline: all of it but its anti-aliased rim

// The training truck's clear-view mast: from the seat, a pallet on the floor 3 to 5 m ahead is
// seen between the mast's channels, whole. The same truck with its lift cylinder down the middle
// (as the files before it drew the mast) hides a third or more of it: the test tells the two apart.
TEST(ViewFromTheSeat, AFloorPalletThreeToFiveMetresAheadIsSeenBetweenTheChannels) {
  const std::string middle = truck_with_middle_cylinder();
  for (double ahead : {3.0, 4.0, 5.0}) {
    const double clear_view = floor_pallet_seen(kTruck, ahead);
    const double one_cylinder = floor_pallet_seen(middle, ahead);
    RecordProperty("seen_at_" + std::to_string(int(ahead)) + "_m", std::to_string(clear_view));
    RecordProperty("seen_past_a_middle_cylinder_at_" + std::to_string(int(ahead)) + "_m", std::to_string(one_cylinder));
    EXPECT_GE(clear_view, kSeenShare) << ahead << " m ahead";
    EXPECT_LT(one_cylinder, kSeenShare - 0.15) << ahead << " m ahead, one cylinder in the middle";
  }
  fs::remove_all(fs::path(middle).parent_path());
}

// The mast's cylinders as the truck file places them: the training truck's two, each behind a
// channel (nearer the seat) and beside it, none in the middle; a file without cylinder_y_m, one
// in the middle, as before.
TEST(ViewFromTheSeat, TheLiftCylindersStandBehindTheChannelsOrInTheMiddleForOlderFiles) {
  const TruckShape e16 = load_truck_shape(kTruck, FORKLIFT_DATA_DIR);
  const Eigen::AlignedBox3d& channel = part(*e16.mast, "mast_left").bounds;
  const Eigen::AlignedBox3d& left = part(*e16.mast, "mast_cylinder_left").bounds;
  const Eigen::AlignedBox3d& right = part(*e16.mast, "mast_cylinder_right").bounds;
  EXPECT_LE(left.max().x(), channel.min().x() + 1e-6);
  EXPECT_GT(left.min().y(), 0.5 * (channel.min().y()));  // beside the channel, not towards the middle
  EXPECT_LE(left.max().y(), channel.max().y() + 1e-6);
  EXPECT_NEAR(right.min().y(), -left.max().y(), 1e-6);
  for (const MeshPart& p : e16.mast->parts) EXPECT_NE(p.name, "mast_cylinder");
  const std::string middle = truck_with_middle_cylinder();
  const TruckShape old = load_truck_shape(middle, FORKLIFT_DATA_DIR);
  const Eigen::AlignedBox3d& one = part(*old.mast, "mast_cylinder").bounds;
  EXPECT_NEAR(one.center().y(), 0, 1e-6);
  EXPECT_NEAR(one.sizes().y(), 0.08, 1e-6);
  fs::remove_all(fs::path(middle).parent_path());
}


}  // namespace
}  // namespace forklift
