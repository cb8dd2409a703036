// Collisions, graded by the object struck and the impact speed, on
// tests/evaluation/scenes/objects.json: one lane per object, the truck starting on the lane at
// x = 0 facing +x with the object about 6 m ahead (the pallet lane's pallet behind it).
#include "evaluation/harness.h"

namespace {

using namespace evt;

struct Lane {
  const char* object;
  double y;
  double near_face_x;  // the face the truck reaches first (for stopping short of it)
};
constexpr Lane kCone{"CONE", 0, 5.8}, kRack{"RACK", 10, 6.45}, kWall{"WALL", 20, 6.0}, kLorry{"LORRY", 30, 5.95},
    kPedestrian{"PED", 50, 5.88}, kWalkway{"BOX_WW", 70, 5.7};

// Forks at travelling height, then ahead along the lane at `v` until the first contact (or until
// the fork tips are `stop_short_m` from the object's near face, when given); then a stop.
void drive_at(Session& s, const Lane& lane, double v, double stop_short_m = -1) {
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  s.run(30,
        [&] {
          Controls c = d.levers();
          d.speed(c, v);
          c.steer_rad = d.steer_to_line(lane.y);
          return c;
        },
        [&] {
          if (!s.events.empty()) return true;
          return stop_short_m >= 0 && d.heel_x() + s.shape.fork_length_m >= lane.near_face_x - stop_short_m;
        });
  s.run(5, [&] { Controls c = d.levers(); c.brake = 0.5; return c; }, [&] { return std::abs(s.v()) < 0.005; });
  s.run(1.0, [&] { Controls c = d.levers(); c.brake = 0.5; return c; });  // still touching: no second event
}

Session on_lane(const Lane& lane, Mode mode = Mode::kTraining) {
  return Session(scene("objects.json"), mode, Vector3d(0, lane.y, 0));
}

const EvaluationEvent& only_event(const Session& s, const std::string& rule) {
  EXPECT_EQ(s.events.size(), 1u) << s.summary();
  EXPECT_EQ(s.count(rule), 1) << s.summary();
  static const EvaluationEvent none{};
  return s.first(rule) ? *s.first(rule) : none;
}

TEST(Collision, TouchingAConeIsMedium) {
  Session s = on_lane(kCone);
  drive_at(s, kCone, 0.3);
  const EvaluationEvent& e = only_event(s, "collision_cone");
  EXPECT_EQ(e.worry_level, 3);
  EXPECT_EQ(e.points, 3);
  EXPECT_NE(e.details.find("\"object\":\"CONE\""), std::string::npos) << e.details;
  EXPECT_NE(e.details.find("\"grade\":\"touch\""), std::string::npos) << e.details;
  EXPECT_NEAR(e.x_m, 5.8, 0.1);  // at the cone (it tapers)
}

TEST(Collision, HittingAConeHardIsSerious) {
  Session s = on_lane(kCone);
  drive_at(s, kCone, 0.8);
  const EvaluationEvent& e = only_event(s, "collision_cone");
  EXPECT_EQ(e.worry_level, 5);
  EXPECT_NE(e.details.find("\"grade\":\"hard impact\""), std::string::npos) << e.details;
}

TEST(Collision, TouchingARack) {
  Session s = on_lane(kRack);
  drive_at(s, kRack, 0.3);
  EXPECT_EQ(only_event(s, "collision_rack").worry_level, 3);
}

TEST(Collision, TouchingALorry) {
  Session s = on_lane(kLorry);
  drive_at(s, kLorry, 0.3);
  EXPECT_EQ(only_event(s, "collision_lorry").worry_level, 3);
}

TEST(Collision, TouchingAWall) {
  Session s = on_lane(kWall);
  drive_at(s, kWall, 0.3);
  EXPECT_EQ(only_event(s, "collision_structure").worry_level, 3);
}

TEST(Collision, AViolentCollisionIsAnAutomaticFailure) {
  Session s = on_lane(kWall, Mode::kExam);
  drive_at(s, kWall, 1.5);
  // The wall stops the truck dead (it pushes back): the jolt may lift the rear wheel as well,
  // and then the stability warning comes first, but the strike itself is one event.
  EXPECT_EQ(s.count("violent_collision"), 1) << s.summary();
  ASSERT_TRUE(s.first("violent_collision"));
  const EvaluationEvent& e = *s.first("violent_collision");
  EXPECT_TRUE(e.automatic_fail);
  EXPECT_NE(e.details.find("\"object\":\"WALL\""), std::string::npos) << e.details;
  for (const EvaluationEvent& other : s.events)
    EXPECT_TRUE(other.rule == "violent_collision" || other.rule == "wheel_lift" ||
                (other.rule == "stability_warning" && s.count("wheel_lift") == 1))
        << s.summary();
  const Score score = s.finish("signal");
  EXPECT_FALSE(score.passed);
  EXPECT_EQ(score.automatic_failures, std::vector<std::string>{"violent_collision"});
}

TEST(Collision, TouchingAPersonIsAnAutomaticFailure) {
  Session s = on_lane(kPedestrian, Mode::kExam);
  drive_at(s, kPedestrian, 0.3);
  const EvaluationEvent& e = only_event(s, "collision_pedestrian");
  EXPECT_EQ(e.worry_level, 5);
  EXPECT_TRUE(e.automatic_fail);
  EXPECT_FALSE(s.finish("signal").passed);
}

TEST(Collision, StrikingAnythingOnAWalkwayIsSerious) {
  Session s = on_lane(kWalkway);
  drive_at(s, kWalkway, 0.3);
  const EvaluationEvent& e = only_event(s, "collision_in_walkway");
  EXPECT_EQ(e.worry_level, 5);
  EXPECT_NE(e.details.find("BOX_WW"), std::string::npos) << e.details;
}

TEST(Collision, ReversingIntoAPallet) {
  Session s(scene("objects.json"), Mode::kTraining, Vector3d(0, 40, 0));
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  s.run(30, [&] { Controls c = d.levers(); d.speed(c, -0.3); c.steer_rad = d.steer_to_line(40, true); return c; },
        [&] { return !s.events.empty(); });
  d.stop();
  const EvaluationEvent& e = only_event(s, "collision_pallet");
  EXPECT_EQ(e.worry_level, 3);
  EXPECT_NE(e.details.find("\"object\":\"PALLET\""), std::string::npos) << e.details;
  EXPECT_EQ(e.details.find("\"truck_part\":\"fork"), std::string::npos) << "struck by the truck, not its forks: " << e.details;
}

TEST(Collision, StoppingShortOfEverythingIsClean) {
  for (const Lane& lane : {kCone, kRack, kWall, kLorry, kPedestrian, kWalkway}) {
    Session s = on_lane(lane);
    drive_at(s, lane, 0.5, 0.8);
    EXPECT_TRUE(s.events.empty()) << lane.object << "\n" << s.summary();
  }
  Session s(scene("objects.json"), Mode::kTraining, Vector3d(0, 40, 0));
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  s.run(30, [&] { Controls c = d.levers(); d.speed(c, -0.3); c.steer_rad = d.steer_to_line(40, true); return c; },
        [&] { return s.pos().x() < -3.0; });  // the counterweight about 0.6 m short of the pallet
  d.stop();
  EXPECT_TRUE(s.events.empty()) << "PALLET\n" << s.summary();
}

}  // namespace
