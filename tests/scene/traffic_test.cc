// The warehouse's other trucks: the drive along a route (a trigger, the route's end, a loop), a
// truck giving way short of a crossing where the pupil goes first and driving on once the pupil's
// truck is beyond the crossing's watch, one standing for the pupil's truck ahead, and the loader's
// refusals of bad `trucks` and `crossings` entries.
#include <gtest/gtest.h>
#include <cmath>

#include "forklift/scene/traffic.h"
#include "pupil_truck.h"

using namespace forklift;

namespace {

using scene_test::outline;
using scene_test::truck_at;
constexpr double kTick = 1e-3;

void run(const std::vector<OtherTruckSpec>& specs, const std::vector<Crossing>& crossings,
         std::vector<OtherTruckState>& st, double& t, double seconds, const BodyPoses& pupil) {
  const int n = int(std::lround(seconds / kTick));
  for (int i = 0; i < n; ++i) {
    t += kTick;
    drive(specs, crossings, st, outline(), pupil, t, kTick);
  }
}

// Up x = 0 from y = -10 at 2 m/s; its body 3 m long, so its front is 1.5 m ahead of its middle.
OtherTruckSpec up_the_aisle() {
  OtherTruckSpec s;
  s.id = "T";
  s.route = {Eigen::Vector2d(0, -10), Eigen::Vector2d(0, 10)};
  s.speed_m_s = 2.0;
  return s;
}

Crossing crossing(const std::string& priority) {
  Crossing c;
  c.id = "X";
  c.polygon = {Eigen::Vector2d(-2, -2), Eigen::Vector2d(2, -2), Eigen::Vector2d(2, 2), Eigen::Vector2d(-2, 2)};
  c.priority = priority;
  c.watch_m = priority == "pupil" ? 5.0 : 0.0;
  return c;
}

TEST(Traffic, DrivesItsRouteFromItsTriggerThenStandsOrLoops) {
  OtherTruckSpec once = up_the_aisle();
  once.start_at_s = 1.0;
  OtherTruckSpec loop = up_the_aisle();
  loop.id = "L";
  loop.route = {Eigen::Vector2d(20, 0), Eigen::Vector2d(24, 0), Eigen::Vector2d(24, 3)};  // 4 + 3 + 5 = 12 m round
  loop.loop = true;
  const std::vector<OtherTruckSpec> specs{once, loop};
  std::vector<OtherTruckState> st = initial_trucks(specs);
  EXPECT_NEAR(st[0].heading_rad, M_PI / 2, 1e-12);
  const BodyPoses far = truck_at(-100, 0);
  double t = 0;
  run(specs, {}, st, t, 0.99, far);
  EXPECT_FALSE(st[0].started);
  EXPECT_EQ(st[0].at_m, Eigen::Vector2d(0, -10));
  run(specs, {}, st, t, 3.0, far);
  EXPECT_NEAR(st[0].at_m.y(), -10 + 2.0 * (t - 1.0), 3e-3) << "2 m/s from 1 s";
  EXPECT_EQ(st[0].speed_m_s, 2.0);
  run(specs, {}, st, t, 10.0, far);
  EXPECT_TRUE(st[0].arrived);
  EXPECT_EQ(st[0].at_m, Eigen::Vector2d(0, 10));
  EXPECT_EQ(st[0].speed_m_s, 0.0);
  // The loop: 13.99 s at 2 m/s is 27.98 m, twice round (24 m) and 3.98 m on along its first leg.
  EXPECT_FALSE(st[1].arrived);
  EXPECT_NEAR((st[1].at_m - Eigen::Vector2d(23.98, 0)).norm(), 0.0, 3e-3) << st[1].at_m.transpose();
}

TEST(Traffic, GivesWayShortOfACrossingWhereThePupilGoesFirstAndDrivesOnAfter) {
  const std::vector<OtherTruckSpec> specs{up_the_aisle()};
  const std::vector<Crossing> crossings{crossing("pupil")};
  std::vector<OtherTruckState> st = initial_trucks(specs);
  double t = 0;
  // The pupil's fork tips 4.3 m from the crossing's middle (within 5 m): it stands with its front
  // at the crossing's edge (y = -2).
  const BodyPoses near = truck_at(-6.0, 0);
  run(specs, crossings, st, t, 8.0, near);
  EXPECT_EQ(st[0].giving_way, 0);
  EXPECT_EQ(st[0].speed_m_s, 0.0);
  EXPECT_LT(st[0].at_m.y() + 1.5, -2.0);
  EXPECT_GT(st[0].at_m.y() + 1.5, -2.0 - 2.0 * kTick - 1e-12);
  // Gone beyond the watch: it drives on through.
  run(specs, crossings, st, t, 2.0, truck_at(-20, 0));
  EXPECT_EQ(st[0].giving_way, -1);
  EXPECT_GT(st[0].at_m.y(), 0.0);
  // Where the traffic goes first it does not wait.
  const std::vector<Crossing> theirs{crossing("traffic")};
  std::vector<OtherTruckState> st2 = initial_trucks(specs);
  t = 0;
  run(specs, theirs, st2, t, 6.0, near);
  EXPECT_EQ(st2[0].giving_way, -1);
  EXPECT_GT(st2[0].at_m.y(), 1.0);
}

TEST(Traffic, ADriverWhoLooksStandsForThePupilsTruckAhead) {
  OtherTruckSpec s = up_the_aisle();
  s.stop_within_m = 2.0;
  const std::vector<OtherTruckSpec> specs{s};
  std::vector<OtherTruckState> st = initial_trucks(specs);
  double t = 0;
  // The pupil's chassis across the aisle at y = 0 (its side at y = -0.55).
  run(specs, {}, st, t, 10.0, truck_at(1.0, 0));
  EXPECT_TRUE(st[0].stopped_for_truck);
  EXPECT_NEAR(st[0].at_m.y() + 1.5, -0.55 - 2.0, 3e-3) << "its front 2 m from the pupil's side";
}

// --- the loader ---

std::string load_error(const std::string& trucks, const std::string& crossings = "[]") {
  return scene_test::load_error("traffic.json", R"({"truck": "trucks/linde_e16c.json", "trucks": [)" + trucks +
                                                    "], \"crossings\": " + crossings + "}");
}

TEST(Traffic, TheLoaderReadsEveryKeyAndRefusesBadEntriesNamingTheKey) {
  EXPECT_EQ(load_error(R"({"id": "A", "route": [[0, 0], [5, 0], [5, 5]], "speed_m_s": 2, "loop": true,
                           "trigger": {"truck_within_m": 9}, "stop_within_m": 2, "size_m": [3.2, 1.2, 2.2]})",
                       R"([{"id": "X", "rect": [1, -1, 3, 1], "priority": "pupil", "watch_m": 6},
                           {"id": "Y", "polygon": [[0, 0], [1, 0], [1, 1]], "priority": "traffic"}])"),
            "(no error)");
  const auto refused = [](const std::string& trucks, const std::string& crossings, const std::string& key) {
    const std::string e = load_error(trucks, crossings);
    EXPECT_NE(e.find(key), std::string::npos) << trucks << crossings << "\n" << e;
  };
  const std::string ok = R"({"id": "A", "route": [[0, 0], [5, 0]], "speed_m_s": 2})";
  refused(R"({"id": "A", "speed_m_s": 2})", "[]", "trucks[0].route");
  refused(R"({"id": "A", "route": [[0, 0], [0, 0]], "speed_m_s": 2})", "[]", "trucks[0].route[1]");
  refused(R"({"id": "A", "route": [[0, 0], [5, 0], [0, 0]], "speed_m_s": 2, "loop": true})", "[]", "trucks[0].route");
  refused(R"({"id": "A", "route": [[0, 0], [5, 0]], "speed_m_s": 0})", "[]", "trucks[0].speed_m_s");
  refused(R"({"id": "A", "route": [[0, 0], [5, 0]], "speed_m_s": 2, "size_m": [3, 0, 2]})", "[]", "trucks[0].size_m[1]");
  refused(R"({"id": "A", "route": [[0, 0], [5, 0]], "speed_m_s": 2, "trigger": {}})", "[]", "trucks[0].trigger");
  refused(R"({"id": "A", "route": [[0, 0], [5, 0]], "speed_m_s": 2, "honks": true})", "[]", "honks");
  refused(ok + ", " + ok, "[]", "trucks[1].id");
  refused(ok, R"([{"id": "X", "rect": [1, -1, 3, 1], "priority": "pupil"}])", "crossings[0].watch_m");
  refused(ok, R"([{"id": "X", "rect": [1, -1, 3, 1], "priority": "traffic", "watch_m": 3}])", "crossings[0].watch_m");
  refused(ok, R"([{"id": "X", "rect": [1, -1, 3, 1], "priority": "whoever"}])", "crossings[0].priority");
  refused(ok, R"([{"id": "X", "priority": "traffic"}])", "crossings[0]");
}

}  // namespace
