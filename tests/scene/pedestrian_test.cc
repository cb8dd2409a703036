// The warehouse's people: the walk along a path (triggers, waits, the path's end), one who looks
// standing for the truck and one who does not walking on, the walk's determinism, and the
// loader's refusals of bad `pedestrians` entries.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <filesystem>
#include <fstream>

#include "forklift/scene/pedestrians.h"
#include "pupil_truck.h"

using namespace forklift;
using forklift::scene_test::outline;
using forklift::scene_test::truck_at;
namespace fs = std::filesystem;

namespace {

const std::string kData = FORKLIFT_DATA_DIR;
constexpr double kTick = 1e-3;

PedestrianSpec crosser(bool looks) {
  PedestrianSpec s;
  s.id = looks ? "LOOKS" : "BLIND";
  s.path = {Eigen::Vector2d(10, -5), Eigen::Vector2d(10, 5)};
  s.speed_m_s = 1.0;
  s.looks = looks;
  s.stop_within_m = looks ? 3.0 : 0.0;
  return s;
}

// Ticks for `seconds` with the truck standing at (x, y) (or driven by `truck_x(t)`).
void run(const std::vector<PedestrianSpec>& specs, std::vector<PedestrianState>& st, double& t, double seconds,
         const std::function<double(double)>& truck_x, double truck_y = 0) {
  const int n = int(std::lround(seconds / kTick));
  for (int i = 0; i < n; ++i) {
    t += kTick;
    walk(specs, st, outline(), truck_at(truck_x(t), truck_y), t, kTick);
  }
}

TEST(Pedestrians, WalkTheirPathAtTheirSpeedAfterTheirTriggerThenStand) {
  PedestrianSpec s = crosser(false);
  s.start_at_s = 2.0;
  const std::vector<PedestrianSpec> specs{s};
  std::vector<PedestrianState> st = initial_pedestrians(specs);
  EXPECT_EQ(st[0].at_m, Eigen::Vector2d(10, -5));
  EXPECT_NEAR(st[0].heading_rad, M_PI / 2, 1e-12);
  double t = 0;
  const auto far = [](double) { return -100.0; };
  run(specs, st, t, 2.0 - kTick / 2, far);
  EXPECT_FALSE(st[0].started);
  EXPECT_EQ(st[0].at_m, Eigen::Vector2d(10, -5)) << "waits for his time";
  run(specs, st, t, 4.0, far);
  EXPECT_TRUE(st[0].started);
  EXPECT_NEAR(st[0].at_m.y(), -5 + 4.0, 2e-3) << "1 m/s for 4 s";
  EXPECT_DOUBLE_EQ(st[0].speed_m_s, 1.0);
  run(specs, st, t, 10.0, far);
  EXPECT_TRUE(st[0].arrived);
  EXPECT_EQ(st[0].at_m, Eigen::Vector2d(10, 5)) << "stands at his path's end";
  EXPECT_EQ(st[0].speed_m_s, 0.0);
}

TEST(Pedestrians, StartWhenTheTruckComesWithinTheirTriggerDistance) {
  PedestrianSpec s = crosser(false);
  s.start_truck_within_m = 6.0;
  const std::vector<PedestrianSpec> specs{s};
  std::vector<PedestrianState> st = initial_pedestrians(specs);
  double t = 0;
  // The truck's fork tips reach x = 1.7 + 0.5 t; the person stands 5 m off its line at x = 10,
  // 4.75 m from the forks' side: the forks are 6 m from him at x = 10 - sqrt(6^2 - 4.75^2).
  const auto drive = [](double t) { return 0.5 * t; };
  const double starts = 2 * (10 - std::sqrt(36 - 4.75 * 4.75) - 1.7);
  run(specs, st, t, starts - 0.01, drive);
  EXPECT_FALSE(st[0].started);
  run(specs, st, t, 0.02, drive);
  EXPECT_TRUE(st[0].started);
}

TEST(Pedestrians, WaitAtTheirPointsForTheirTime) {
  PedestrianSpec s = crosser(false);
  s.path = {Eigen::Vector2d(0, 10), Eigen::Vector2d(2, 10), Eigen::Vector2d(2, 12)};
  s.waits = {{1, 3.0}};
  const std::vector<PedestrianSpec> specs{s};
  std::vector<PedestrianState> st = initial_pedestrians(specs);
  double t = 0;
  const auto far = [](double) { return -100.0; };
  run(specs, st, t, 2.5, far);
  EXPECT_EQ(st[0].at_m, Eigen::Vector2d(2, 10)) << "at the corner, waiting";
  EXPECT_GT(st[0].wait_left_s, 0);
  run(specs, st, t, 2.0, far);  // to t = 4.5: 2 s to the corner, 3 s there, not yet off
  EXPECT_EQ(st[0].at_m, Eigen::Vector2d(2, 10));
  run(specs, st, t, 1.5, far);  // t = 6: 1 s on along the second leg
  EXPECT_NEAR(st[0].at_m.y(), 11.0, 2e-3);
  EXPECT_NEAR(st[0].heading_rad, M_PI / 2, 1e-12);
}

TEST(Pedestrians, OneWhoLooksStandsForTheTruckAndOneWhoDoesNotWalksOn) {
  const std::vector<PedestrianSpec> specs{crosser(true), crosser(false)};
  std::vector<PedestrianState> st = initial_pedestrians(specs);
  double t = 0;
  // The truck stands with its fork tips 2 m short of the crossing line x = 10, on it: both
  // people walk towards its nose from 5 m to the side.
  const auto parked = [](double) { return 10 - 2.0 - 1.7; };
  run(specs, st, t, 6.0, parked);
  // The looker stops where the tips are within his 3 m: sqrt(3^2 - 2^2) from the truck's side.
  EXPECT_TRUE(st[0].stopped_for_truck);
  EXPECT_EQ(st[0].speed_m_s, 0.0);
  EXPECT_NEAR(st[0].at_m.y(), -0.25 - std::sqrt(5.0), 2e-3) << "stopped short of the truck";
  EXPECT_FALSE(st[1].stopped_for_truck);
  EXPECT_DOUBLE_EQ(st[1].speed_m_s, 1.0);
  EXPECT_NEAR(st[1].at_m.y(), 1.0, 2e-3) << "walked on past the truck's nose";
  // The truck backs away: the looker walks on.
  const auto away = [](double) { return -20.0; };
  run(specs, st, t, 1.0, away);
  EXPECT_FALSE(st[0].stopped_for_truck);
  EXPECT_DOUBLE_EQ(st[0].speed_m_s, 1.0);
}

// One who does not look but heeds the horn: walks on while the truck is silent, stops once it
// sounds within his hearing distance (and keeps standing while it is near, horn or not), and one
// beyond that distance is not alerted.
TEST(Pedestrians, OneWhoHeedsTheHornStandsOnceItSoundsNearHim) {
  PedestrianSpec heeds = crosser(false);
  heeds.id = "HEEDS";
  heeds.heeds_horn_within_m = 4.0;
  const std::vector<PedestrianSpec> specs{heeds, crosser(false)};
  std::vector<PedestrianState> st = initial_pedestrians(specs);
  double t = 0;
  const auto parked = [](double) { return 10 - 2.0 - 1.7; };  // fork tips 2 m short of his line
  // Silent: both walk on from 5 m to the side, far from the truck (4.4 m at 1 s).
  for (int i = 0; i < 1000; ++i) {
    t += kTick;
    walk(specs, st, outline(), truck_at(parked(t), 0), t, kTick, /*horn=*/false);
  }
  EXPECT_FALSE(st[0].alerted);
  EXPECT_DOUBLE_EQ(st[0].speed_m_s, 1.0);
  // The horn from now on, a moment at a time: he hears it only once the truck is within his 4 m.
  double alerted_at_y = NAN;
  for (int i = 0; i < 3000; ++i) {
    t += kTick;
    const bool horn = i < 2000;
    walk(specs, st, outline(), truck_at(parked(t), 0), t, kTick, horn);
    if (st[0].alerted && std::isnan(alerted_at_y)) alerted_at_y = st[0].at_m.y();
  }
  ASSERT_TRUE(st[0].alerted);
  // Alerted where the truck's outline (the tips, 2 m off his line) came within 4 m: sqrt(4^2 - 2^2)
  // from the forks' side, and he stands there after the horn stops.
  EXPECT_NEAR(alerted_at_y, -0.25 - std::sqrt(12.0), 2e-3);
  EXPECT_TRUE(st[0].stopped_for_truck);
  EXPECT_EQ(st[0].speed_m_s, 0.0);
  EXPECT_NEAR(st[0].at_m.y(), alerted_at_y, 2e-3);
  // The one who does not heed it walked on towards the truck's nose, 4 m in 4 s.
  EXPECT_FALSE(st[1].alerted);
  EXPECT_DOUBLE_EQ(st[1].speed_m_s, 1.0);
  EXPECT_NEAR(st[1].at_m.y(), -1.0, 2e-3);
  // A horn sounded with the truck farther than his distance does not alert him.
  std::vector<PedestrianState> far = initial_pedestrians(specs);
  double t2 = 0;
  for (int i = 0; i < 1000; ++i) {
    t2 += kTick;
    walk(specs, far, outline(), truck_at(-20.0, 0), t2, kTick, /*horn=*/true);
  }
  EXPECT_FALSE(far[0].alerted);
}

TEST(Pedestrians, AStruckPersonStands) {
  const std::vector<PedestrianSpec> specs{crosser(false)};
  std::vector<PedestrianState> st = initial_pedestrians(specs);
  double t = 0;
  run(specs, st, t, 1.0, [](double) { return -50.0; });
  st[0].struck = true;
  const Eigen::Vector2d at = st[0].at_m;
  run(specs, st, t, 1.0, [](double) { return -50.0; });
  EXPECT_EQ(st[0].at_m, at);
  EXPECT_EQ(st[0].speed_m_s, 0.0);
}

TEST(Pedestrians, TheWalkIsAFunctionOfTheTrucksMotionAndTimeBitForBit) {
  std::vector<PedestrianSpec> specs{crosser(true), crosser(false)};
  specs[0].start_truck_within_m = 8.0;
  specs[1].waits = {{0, 0.7}};
  const auto drive = [](double t) { return -3 + 0.9 * t - 0.005 * t * t; };  // past them by 15 s
  std::vector<std::vector<PedestrianState>> seen[2];
  for (auto& trace : seen) {
    std::vector<PedestrianState> st = initial_pedestrians(specs);
    double t = 0;
    for (int k = 0; k < 300; ++k) {
      run(specs, st, t, 0.05, drive);
      trace.push_back(st);
    }
  }
  ASSERT_EQ(seen[0].size(), seen[1].size());
  for (size_t k = 0; k < seen[0].size(); ++k)
    for (size_t i = 0; i < specs.size(); ++i) {
      const PedestrianState &a = seen[0][k][i], &b = seen[1][k][i];
      EXPECT_EQ(std::memcmp(a.at_m.data(), b.at_m.data(), sizeof(double) * 2), 0) << k;
      EXPECT_EQ(a.heading_rad, b.heading_rad);
      EXPECT_EQ(a.stopped_for_truck, b.stopped_for_truck);
    }
  // And the looker did stand for it at some point, and everyone moved.
  bool stood = false;
  for (const auto& st : seen[0]) stood |= st[0].stopped_for_truck;
  EXPECT_TRUE(stood);
  EXPECT_NE(seen[0].back()[1].at_m, specs[1].path[0]);
}

TEST(Pedestrians, DistanceToTheTruckIsToItsOutline) {
  const BodyPoses p = truck_at(0, 0);
  EXPECT_DOUBLE_EQ(distance_to_truck(outline(), p, Eigen::Vector2d(0, 0)), 0.0);
  EXPECT_NEAR(distance_to_truck(outline(), p, Eigen::Vector2d(3.7, 0)), 2.0, 1e-12) << "from the fork tips (1.7)";
  EXPECT_NEAR(distance_to_truck(outline(), p, Eigen::Vector2d(-1, 3.55)), 3.0, 1e-12) << "from the chassis's side";
}

// --- the loader ---

std::string load_error(const std::string& pedestrian) {
  return scene_test::load_error("people.json", R"({"truck": "trucks/linde_e16c.json", "pedestrians": [)" + pedestrian + "]}");
}

TEST(Pedestrians, TheLoaderReadsEveryKey) {
  const fs::path dir = fs::temp_directory_path() / ("pedestrian_test_ok_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / "people.json").string();
  std::ofstream(path) << R"({"truck": "trucks/linde_e16c.json", "pedestrians": [
    {"id": "A", "path": [[1, 2], [3, 4], [5, 4]], "speed_m_s": 1.3, "waits": [{"at_point": 1, "duration_s": 2.5}],
     "trigger": {"truck_within_m": 7}, "looks": true, "stop_within_m": 4, "size_m": [0.6, 0.35, 1.8]},
    {"id": "B", "path": [[0, 0], [0, 1]], "speed_m_s": 0.8, "looks": false, "heeds_horn_within_m": 6, "trigger": {"at_s": 12}}]})";
  const Scene s = load_scene(path, kData);
  fs::remove_all(dir);
  ASSERT_EQ(s.pedestrians.size(), 2u);
  const PedestrianSpec& a = s.pedestrians[0];
  EXPECT_EQ(a.id, "A");
  EXPECT_EQ(a.path.size(), 3u);
  EXPECT_EQ(a.path[1], Eigen::Vector2d(3, 4));
  EXPECT_EQ(a.speed_m_s, 1.3);
  ASSERT_EQ(a.waits.size(), 1u);
  EXPECT_EQ(a.waits[0].at_point, 1);
  EXPECT_EQ(a.waits[0].duration_s, 2.5);
  ASSERT_TRUE(a.start_truck_within_m);
  EXPECT_EQ(*a.start_truck_within_m, 7.0);
  EXPECT_TRUE(a.looks);
  EXPECT_EQ(a.stop_within_m, 4.0);
  EXPECT_EQ(a.size_m, Eigen::Vector3d(0.6, 0.35, 1.8));
  const PedestrianSpec& b = s.pedestrians[1];
  EXPECT_FALSE(b.looks);
  ASSERT_TRUE(b.heeds_horn_within_m);
  EXPECT_EQ(*b.heeds_horn_within_m, 6.0);
  EXPECT_FALSE(a.heeds_horn_within_m);
  EXPECT_FALSE(b.start_truck_within_m);
  EXPECT_EQ(b.start_at_s, 12.0);
  EXPECT_EQ(b.size_m, Eigen::Vector3d(0.5, 0.3, 1.75)) << "the default body";
}

TEST(Pedestrians, BadEntriesAreRefusedNamingTheKey) {
  const auto refused = [](const std::string& entry, const std::string& key) {
    const std::string e = load_error(entry);
    EXPECT_NE(e.find(key), std::string::npos) << entry << "\n" << e;
    return e;
  };
  refused(R"({"id": "A", "speed_m_s": 1})", "path");
  refused(R"({"id": "A", "path": [[0, 0], [1, 0]], "speed_m_s": -1, "looks": false})", "speed_m_s");
  refused(R"({"id": "A", "path": [[0, 0], [1, 0]], "speed_m_s": 0, "looks": false})", "speed_m_s");
  refused(R"({"id": "A", "path": [[0, 0], [1, 0]], "speed_m_s": 1e300, "looks": false})", "pedestrians[0].speed_m_s");
  refused(R"({"id": "A", "path": [[0, 0], [1e300, 0]], "speed_m_s": 1, "looks": false})", "pedestrians[0].path[1][0]");
  // NaN and 1e999 are not JSON numbers: the file does not parse, and the message says so.
  for (const char* bad : {R"({"id": "A", "path": [[0, 0], [NaN, 0]], "speed_m_s": 1, "looks": false})",
                          R"({"id": "A", "path": [[0, 0], [1, 0]], "speed_m_s": 1e999, "looks": false})"}) {
    const std::string e = load_error(bad);
    EXPECT_NE(e.find("people.json: not valid JSON"), std::string::npos) << e;
  }
  refused(R"({"id": "A", "path": [[0, 0]], "speed_m_s": 1, "looks": false})", "path");
  refused(R"({"id": "A", "path": [[0, 0], [0, 0]], "speed_m_s": 1, "looks": false})", "pedestrians[0].path[1]");
  refused(R"({"id": "A", "path": [[0, 0], [1, 0]], "speed_m_s": 1})", "pedestrians[0].stop_within_m");
  refused(R"({"id": "A", "path": [[0, 0], [1, 0]], "speed_m_s": 1, "looks": false, "stop_within_m": 2})", "stop_within_m");
  refused(R"({"id": "A", "path": [[0, 0], [1, 0]], "speed_m_s": 1, "stop_within_m": 2, "heeds_horn_within_m": 5})", "heeds_horn_within_m");
  refused(R"({"id": "A", "path": [[0, 0], [1, 0]], "speed_m_s": 1, "looks": false, "heeds_horn_within_m": 0})", "pedestrians[0].heeds_horn_within_m");
  refused(R"({"id": "A", "path": [[0, 0], [1, 0]], "speed_m_s": 1, "looks": false, "waits": [{"at_point": 2, "duration_s": 1}]})",
          "pedestrians[0].waits[0].at_point");
  refused(R"({"id": "A", "path": [[0, 0], [1, 0]], "speed_m_s": 1, "looks": false, "trigger": {}})", "pedestrians[0].trigger");
  refused(R"({"id": "A", "path": [[0, 0], [1, 0]], "speed_m_s": 1, "looks": false, "trigger": {"at_s": 1, "truck_within_m": 2}})",
          "pedestrians[0].trigger");
  refused(R"({"id": "A", "path": [[0, 0], [1, 0]], "speed_m_s": 1, "looks": false, "walks": true})", "walks");
  refused(R"({"id": "A", "path": [[0, 0], [1, 0]], "speed_m_s": 1, "looks": false}, {"id": "A", "path": [[0, 0], [1, 0]], "speed_m_s": 1, "looks": false})",
          "pedestrians[1].id");
}

}  // namespace
