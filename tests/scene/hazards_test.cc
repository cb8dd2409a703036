// A scenario's hazards as the loader reads them: markers (blind corners, doors, cross aisles: where
// the driver sounds the horn), spills (floor patches where the tyres grip less) and pallets that
// fall from their racks, into the scene and its ground, joined across an include, and refused,
// naming the key, when malformed; a spill that waits for its trigger; a falling pallet's free fall.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>

#include "forklift/scene/falling.h"
#include "forklift/scene/scene.h"
#include "forklift/scene/spills.h"

using namespace forklift;
namespace fs = std::filesystem;

namespace {

const std::string kData = FORKLIFT_DATA_DIR;

// Writes `text` as a scenario in a folder of its own and loads it: the scene, or the loader's message.
struct Loaded {
  std::optional<Scene> scene;
  std::string error;
};
Loaded load(const std::string& text) {
  const fs::path dir = fs::temp_directory_path() / ("scene_hazards_test_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / "hazards.json").string();
  std::ofstream(path) << text;
  Loaded out;
  try {
    out.scene = load_scene(path, kData);
  } catch (const SceneError& e) {
    out.error = e.what();
  }
  fs::remove_all(dir);
  return out;
}

std::string with(const std::string& key, const std::string& entries) {
  return R"({"truck": "trucks/linde_e16c.json", ")" + key + R"(": [)" + entries + "]}";
}

TEST(SceneHazards, MarkersAreReadAsAreasOfTheirKind) {
  const Loaded l = load(with("markers", R"({"id": "C1", "kind": "blind_corner", "rect": [1, 2, 4, 6]},
      {"id": "D1", "kind": "door", "polygon": [[10, 0], [10, 3], [12, 3], [12, 0]]},
      {"id": "X1", "kind": "cross_aisle", "rect": [20, 0, 22, 30]})"));
  ASSERT_TRUE(l.scene) << l.error;
  const std::vector<Marker>& m = l.scene->markers;
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[0].id, "C1");
  EXPECT_EQ(m[0].kind, "blind_corner");
  EXPECT_TRUE(m[0].contains(Eigen::Vector2d(2, 3)));
  EXPECT_FALSE(m[0].contains(Eigen::Vector2d(5, 3)));
  EXPECT_EQ(m[1].kind, "door");
  EXPECT_TRUE(m[1].contains(Eigen::Vector2d(11, 1.5))) << "a clockwise polygon is stored counter-clockwise and still holds its inside";
  EXPECT_FALSE(m[1].contains(Eigen::Vector2d(13, 1.5)));
  EXPECT_EQ(m[2].kind, "cross_aisle");
}

TEST(SceneHazards, ASpillScalesTheGroundsGripInsideItOnly) {
  const Loaded l = load(with("spills", R"({"id": "OIL", "rect": [5, -1, 8, 1], "friction_scale": 0.3},
      {"id": "WATER", "rect": [7, -1, 9, 1], "friction_scale": 0.6})"));
  ASSERT_TRUE(l.scene) << l.error;
  ASSERT_EQ(l.scene->spills.size(), 2u);
  EXPECT_EQ(l.scene->spills[0].id, "OIL");
  const Ground& g = l.scene->ground;
  EXPECT_EQ(g.grip(0, 0), 1.0);
  EXPECT_EQ(g.grip(6, 0), 0.3);
  EXPECT_EQ(g.grip(7.5, 0), 0.3) << "where two overlap, the slipperier";
  EXPECT_EQ(g.grip(8.5, 0), 0.6);
  EXPECT_EQ(g.grip(8.5, 2), 1.0);
  EXPECT_EQ(g.height(6, 0), 0.0) << "a spill is no step";
  EXPECT_FALSE(l.scene->spills[0].triggered) << "no trigger: on the floor from the start";
  // A patch named absent grips as the floor around it.
  EXPECT_EQ(g.grip(6, 0, 0b01), 1.0);
  EXPECT_EQ(g.grip(7.5, 0, 0b01), 0.6) << "the other one still there";
  EXPECT_EQ(g.grip(7.5, 0, 0b11), 1.0);
}

TEST(SceneHazards, ASpillWithATriggerIsAbsentUntilItFires) {
  const Loaded l = load(with("spills", R"({"id": "DRY", "rect": [1, -1, 2, 1], "friction_scale": 0.5},
      {"id": "LATER", "rect": [5, -1, 8, 1], "friction_scale": 0.3, "trigger": {"at_s": 10}},
      {"id": "NEAR", "rect": [20, -1, 22, 1], "friction_scale": 0.3, "trigger": {"truck_within_m": 2.5}})"));
  ASSERT_TRUE(l.scene) << l.error;
  const std::vector<Spill>& sp = l.scene->spills;
  ASSERT_EQ(sp.size(), 3u);
  EXPECT_TRUE(sp[1].triggered);
  EXPECT_EQ(sp[1].start_at_s, 10.0);
  EXPECT_EQ(sp[2].start_truck_within_m, 2.5);
  std::vector<SpillState> st = initial_spills(sp);
  EXPECT_EQ(absent_spills(sp, st), 0b110u) << "the two with a trigger";
  EXPECT_EQ(absent_spills(sp, {}), 0b110u) << "no states yet: as the session starts";
  // The truck at the origin, its outline the default truck's: the time fires LATER at 10 s only;
  // NEAR (its middle 21 m ahead) stays away.
  const TruckShape shape = load_truck_shape(kData + "/trucks/linde_e16c.json", kData);
  const TruckParams truck = load_truck(kData + "/trucks/linde_e16c.json");
  CoordVector q = CoordVector::Zero();
  const BodyPoses poses = body_poses(truck, q);
  spread_spills(sp, st, truck_outline(shape), poses, 9.999);
  EXPECT_EQ(absent_spills(sp, st), 0b110u);
  spread_spills(sp, st, truck_outline(shape), poses, 10.0);
  EXPECT_EQ(absent_spills(sp, st), 0b100u);
  EXPECT_EQ(st[1].appeared_t_s, 10.0);
  q[kX] = 17.0;  // fork tips about 19.2: within 2.5 m of x = 21
  spread_spills(sp, st, truck_outline(shape), body_poses(truck, q), 11.0);
  EXPECT_EQ(absent_spills(sp, st), 0u);
}

TEST(SceneHazards, AnIncludedLayoutsMarkersAndSpillsAreJoinedWithTheScenariosOwn) {
  // data/scenarios/pedestrian_awareness.json adds its door and blind corner to the warehouse.
  const Scene s = load_scene(kData + "/scenarios/pedestrian_awareness.json", kData);
  ASSERT_EQ(s.markers.size(), 2u);
  EXPECT_EQ(s.markers[0].kind, "door");
  EXPECT_EQ(s.markers[1].kind, "blind_corner");
  EXPECT_NE(s.find("DOOR_partition"), nullptr);
  EXPECT_NE(s.find("STACK_blind"), nullptr);
}

TEST(SceneHazards, BadMarkersAndSpillsAreRefusedNamingTheKey) {
  const auto refused = [](const std::string& key, const std::string& entries, const std::string& named) {
    const Loaded l = load(with(key, entries));
    EXPECT_FALSE(l.scene) << entries;
    EXPECT_NE(l.error.find(named), std::string::npos) << entries << "\n" << l.error;
  };
  refused("markers", R"({"id": "M", "kind": "ramp", "rect": [0, 0, 1, 1]})", "markers[0].kind");
  refused("markers", R"({"id": "M", "kind": "door"})", "markers[0]");
  refused("markers", R"({"id": "M", "kind": "door", "rect": [0, 0, 1, 1], "polygon": [[0, 0], [1, 0], [1, 1]]})", "markers[0]");
  refused("markers", R"({"id": "M", "kind": "door", "polygon": [[0, 0], [1, 1], [2, 2]]})", "no area");
  refused("markers", R"({"id": "M", "kind": "door", "rect": [0, 0, 1, 1], "horn": true})", "horn");
  refused("markers", R"({"id": "M", "kind": "door", "rect": [0, 0, 1, 1]}, {"id": "M", "kind": "door", "rect": [2, 0, 3, 1]})",
          "repeats");
  refused("markers", R"({"id": "M", "kind": "door", "rect": [0, 0, 1e300, 1]})", "markers[0].rect");
  refused("spills", R"({"id": "S", "rect": [0, 0, 1, 1], "friction_scale": 0})", "spills[0].friction_scale");
  refused("spills", R"({"id": "S", "rect": [0, 0, 1, 1], "friction_scale": 1.5})", "spills[0].friction_scale");
  refused("spills", R"({"id": "S", "rect": [0, 0, 1, 1], "friction_scale": -0.5})", "spills[0].friction_scale");
  refused("spills", R"({"id": "S", "rect": [0, 0, 1, 1]})", "friction_scale");
  refused("spills", R"({"id": "S", "rect": [2, 0, 1, 1], "friction_scale": 0.5})", "spills[0].rect");
  refused("spills", R"({"id": "S", "rect": [0, 0, 1, 1], "friction_scale": 0.5}, {"id": "S", "rect": [0, 0, 1, 1], "friction_scale": 0.5})",
          "repeats");
  refused("spills", R"({"id": "S", "rect": [0, 0, 1, 1], "friction_scale": 0.5, "trigger": {}})", "spills[0].trigger");
  refused("spills", R"({"id": "S", "rect": [0, 0, 1, 1], "friction_scale": 0.5, "trigger": {"at_s": 1, "truck_within_m": 2}})",
          "spills[0].trigger");
  refused("spills", R"({"id": "S", "rect": [0, 0, 1, 1], "friction_scale": 0.5, "trigger": {"at_s": -1}})", "spills[0].trigger.at_s");
  refused("spills", R"({"id": "S", "rect": [0, 0, 1, 1], "friction_scale": 0.5, "starts": "now"})", "starts");
}

TEST(SceneHazards, AFallingPalletNamesAPalletOnASupportAboveTheFloor) {
  const std::string rack = R"({"truck": "trucks/linde_e16c.json", "objects": [
      {"id": "R", "kind": "rack", "x_m": 10, "y_m": 0, "levels_m": [0.9, 1.8, 2.7]},
      {"id": "P", "kind": "pallet", "x_m": 10, "y_m": 0, "yaw_deg": 90, "on": "R", "level": 2},
      {"id": "F", "kind": "pallet", "x_m": 20, "y_m": 0}],
    "falling_pallets": [)";
  const Loaded ok = load(rack + R"({"pallet": "P", "trigger": {"truck_within_m": 4}, "toward_deg": -90, "throw_m": 1.5}]})");
  ASSERT_TRUE(ok.scene) << ok.error;
  ASSERT_EQ(ok.scene->falling_pallets.size(), 1u);
  const FallingPalletSpec& f = ok.scene->falling_pallets[0];
  EXPECT_EQ(f.pallet, "P");
  ASSERT_TRUE(f.start_truck_within_m);
  EXPECT_EQ(*f.start_truck_within_m, 4.0);
  EXPECT_NEAR(f.toward_rad, -M_PI / 2, 1e-15);
  EXPECT_EQ(f.throw_m, 1.5);
  const auto refused = [&](const std::string& entries, const std::string& named) {
    const Loaded l = load(rack + entries + "]}");
    EXPECT_FALSE(l.scene) << entries;
    EXPECT_NE(l.error.find(named), std::string::npos) << entries << "\n" << l.error;
  };
  refused(R"({"pallet": "F", "trigger": {"at_s": 1}, "toward_deg": 0})", "stands on the floor");
  refused(R"({"pallet": "R", "trigger": {"at_s": 1}, "toward_deg": 0})", "names no pallet 'R'");
  refused(R"({"pallet": "Q", "trigger": {"at_s": 1}, "toward_deg": 0})", "names no pallet 'Q'");
  refused(R"({"pallet": "P", "trigger": {}, "toward_deg": 0})", "falling_pallets[0].trigger");
  refused(R"({"pallet": "P", "trigger": {"at_s": 1, "truck_within_m": 2}, "toward_deg": 0})", "falling_pallets[0].trigger");
  refused(R"({"pallet": "P", "toward_deg": 0})", "trigger");
  refused(R"({"pallet": "P", "trigger": {"at_s": 1}, "toward_deg": 0, "throw_m": -1})", "falling_pallets[0].throw_m");
  refused(R"({"pallet": "P", "trigger": {"at_s": 1}, "toward_deg": 0, "throw_m": 1e9})", "falling_pallets[0].throw_m");
  refused(R"({"pallet": "P", "trigger": {"at_s": 1}, "toward_deg": 0}, {"pallet": "P", "trigger": {"at_s": 2}, "toward_deg": 0})",
          "repeats");
}

TEST(SceneHazards, APalletFallsFreelyToTheFloorAndSlidesItsThrowEvenly) {
  FallingPalletSpec f;
  f.toward_rad = M_PI / 2;
  f.throw_m = 1.0;
  const Eigen::Isometry3d start(Eigen::Translation3d(3, 4, 1.8));
  bool landed = true;
  const double g = 9.81, fall_s = std::sqrt(2 * 1.8 / g);
  Eigen::Isometry3d p = falling_pose(f, start, 0.0, g, 0.0, landed);
  EXPECT_FALSE(landed);
  EXPECT_TRUE(p.isApprox(start));
  p = falling_pose(f, start, 0.0, g, fall_s / 2, landed);
  EXPECT_FALSE(landed);
  EXPECT_NEAR(p.translation().z(), 1.8 - 0.5 * g * (fall_s / 2) * (fall_s / 2), 1e-12) << "a quarter of the drop at half the time";
  EXPECT_NEAR(p.translation().y(), 4.5, 1e-12);
  p = falling_pose(f, start, 0.0, g, fall_s + 1.0, landed);
  EXPECT_TRUE(landed);
  EXPECT_EQ(p.translation(), Eigen::Vector3d(3, 5, 0));
  EXPECT_TRUE(p.linear().isApprox(start.linear())) << "level all the way";
}

}  // namespace
