// Pallet handling, on tests/evaluation/scenes/pallets.json: P1 (300 kg) on the floor at x = 6
// with its openings towards the truck, rack R1's bay at (14, 2) open towards -x (level 1 beams
// at 0.9 m), and HEAVY (1300 kg) at y = -10. The task: put P1 on R1 level 1, centred (0.15 m).
#include "evaluation/harness.h"

namespace {

using namespace evt;

constexpr double kPocketMid = 0.092;  // fork top for forks centred in a EUR pallet's openings
constexpr double kEntryFace = 5.4;    // P1's near face (HEAVY's too, on its lane)

struct Handler {
  Session& s;
  Driver d{s};
  const PalletState& pallet(const std::string& id) const { return *s.pallet(id); }

  // Forks level at the openings' height, then in along the line y = `lane` until the tips are
  // `depth` m past the entry face; then stop.
  void insert(double lane, double depth = 0.9, double fork_top = kPocketMid) {
    d.lift_to = fork_top;
    d.settle_levers();
    d.approach([&] { return kEntryFace + depth - s.shape.fork_length_m - d.heel_x(); }, 0.4, lane);
  }
  // Forks to `to` (fork top at the heel above the floor), the truck braked.
  void lift(double to) {
    d.lift_to = to;
    d.settle_levers();
  }
  // P1 from the floor to R1's bay: lift to travelling height, back off, change lane to y = 2 and
  // drive up until the load is just short of the rack, raise it over the level-1 beams, then creep
  // in until the pallet's centre is at `centre_x`.
  void carry_to_rack(double centre_x) {
    const PalletState& p = pallet("P1");
    lift(0.2);
    d.approach([&] { return d.heel_x() - 3.0; }, -0.6, 0.0);
    d.approach([&] { return 12.7 - p.pose.translation().x(); }, 1.0, 2.0);
    lift(1.15);  // underside 1.03 m: over the level-1 beams (0.9 m)
    d.approach([&] { return centre_x - p.pose.translation().x(); }, 0.3, 2.0);
  }
  // Lower until the pallet is set down, then 5 cm more to free the forks.
  void lower_onto_support(const std::string& id = "P1") {
    const PalletState& p = pallet(id);
    s.run(10, [&] { Controls c; c.brake = 0.3; c.lift = -0.25; return c; }, [&] { return !p.on_forks; });
    d.lift_to = s.heel_z() - 0.05;
    d.settle_levers();
  }
  // Back out along y = 2, forks down, brake on, controls neutral.
  void leave_and_park(double heel_x) {
    d.approach([&] { return d.heel_x() - heel_x; }, -0.4, 2.0);
    d.lift_to = 0.0;
    d.settle_levers();
    d.park();
  }
};

TEST(Handling, TheWholeMoveDoneWellIsCleanAndCompletesTheTask) {
  Session s(scene("pallets.json"), Mode::kExam);
  Handler h{s};
  h.insert(0.0);
  h.lift(0.15);
  ASSERT_TRUE(h.pallet("P1").on_forks);
  h.carry_to_rack(14.0);
  h.lower_onto_support();
  EXPECT_EQ(h.pallet("P1").resting_on, "R1");
  EXPECT_EQ(h.pallet("P1").level, 1);
  EXPECT_TRUE(s.task_completed());
  h.leave_and_park(10.5);
  const Score score = s.finish("parked");
  EXPECT_TRUE(s.events.empty()) << s.summary();
  EXPECT_TRUE(score.passed);
  EXPECT_TRUE(score.task_completed);
  EXPECT_EQ(score.mark, 100);
}

TEST(Handling, ForksStrikingThePalletInsteadOfEnteringIt) {
  Session s(scene("pallets.json"));
  Handler h{s};
  // Forks 0.11 to 0.15 m up: into the deck (0.122 to 0.144 m), not the openings.
  h.d.lift_to = 0.15;
  h.d.settle_levers();
  s.run(20, [&] { Controls c = h.d.levers(); h.d.speed(c, 0.3); c.steer_rad = h.d.steer_to_line(0); return c; },
        [&] { return !s.events.empty(); });
  h.d.stop();
  ASSERT_EQ(s.count("fork_strike_pallet"), 1) << s.summary();
  EXPECT_EQ(s.events.size(), 1u) << s.summary();
  const EvaluationEvent& e = *s.first("fork_strike_pallet");
  EXPECT_EQ(e.worry_level, 3);
  EXPECT_NE(e.details.find("\"object\":\"P1\""), std::string::npos) << e.details;
  EXPECT_NEAR(e.x_m, kEntryFace, 0.01);
}

TEST(Handling, EnteringTheOpeningsIsClean) {
  Session s(scene("pallets.json"));
  Handler h{s};
  h.insert(0.0);
  h.lift(0.15);
  EXPECT_TRUE(h.pallet("P1").on_forks);
  EXPECT_TRUE(s.events.empty()) << s.summary();
}

TEST(Handling, LiftingWithTheSteeredWheelTurned) {
  Session s(scene("pallets.json"));
  Handler h{s};
  h.insert(0.0);
  // Standing still, the steered wheel turned 20 degrees.
  s.run(3, [&] { Controls c = h.d.levers(); c.brake = 0.5; c.steer_rad = 0.35; return c; });
  s.run(5, [&] { Controls c = h.d.levers(); c.brake = 0.5; c.steer_rad = 0.35; c.lift = 0.3; return c; },
        [&] { return h.pallet("P1").on_forks; });
  ASSERT_TRUE(h.pallet("P1").on_forks);
  ASSERT_EQ(s.count("wheels_not_straight_stacking"), 1) << s.summary();
  const EvaluationEvent& e = *s.first("wheels_not_straight_stacking");
  EXPECT_EQ(e.worry_level, 1);
  EXPECT_NE(e.details.find("picked_up"), std::string::npos) << e.details;
  EXPECT_EQ(s.events.size(), 1u) << s.summary();
}

TEST(Handling, SettingThePalletDownAwayFromItsPlace) {
  Session s(scene("pallets.json"), Mode::kExam);
  Handler h{s};
  h.insert(0.0);
  h.lift(0.15);
  ASSERT_TRUE(h.pallet("P1").on_forks);
  h.lower_onto_support();  // back onto the floor where it was: not R1 level 1
  ASSERT_EQ(s.count("set_down_off_place"), 1) << s.summary();
  const EvaluationEvent& e = *s.first("set_down_off_place");
  EXPECT_NE(e.details.find("\"expected\":{\"level\":1,\"object\":\"R1\""), std::string::npos) << e.details;
  EXPECT_EQ(s.events.size(), 1u) << s.summary();
  EXPECT_FALSE(s.task_completed());
  const Score score = s.finish("signal");
  EXPECT_FALSE(score.passed) << "an exam needs its task done";
  EXPECT_EQ(score.steps_done, 0);
}

TEST(Handling, SettingThePalletDownOverhangingTheBeamsIsUnsafeStacking) {
  Session s(scene("pallets.json"), Mode::kExam);
  Handler h{s};
  h.insert(0.0);
  h.lift(0.15);
  h.carry_to_rack(13.55);  // 0.45 m short: 0.5 m of pallet hangs over the aisle, off the back beam
  h.lower_onto_support();
  EXPECT_EQ(h.pallet("P1").resting_on, "R1");
  ASSERT_EQ(s.count("unsafe_stacking"), 1) << s.summary();
  EXPECT_EQ(s.count("set_down_off_place"), 1) << s.summary();
  EXPECT_TRUE(s.first("unsafe_stacking")->automatic_fail);
  EXPECT_FALSE(s.finish("signal").passed);
}

// P1 picked up with its CoG near the fork tips, lifted to 2 m, mast fully forward, to 2 m/s,
// then the brake at `brake`.
Session& brake_with_load_high(Session& s, double brake) {
  Handler h{s};
  h.insert(0.0, 0.7);
  h.lift(2.0);
  s.run(2.0, [&] { Controls c = h.d.levers(); c.brake = 0.3; c.tilt = 1.0; return c; });
  s.run(15, [&] { Controls c; c.accelerator = 0.33; c.steer_rad = h.d.steer_to_line(0); return c; }, [&] { return s.v() >= 2.0; });
  s.run(6, [&] { Controls c; c.brake = brake; return c; }, [&] { return std::abs(s.v()) < 0.01; });
  s.run(1, [&] { Controls c; c.brake = brake; return c; });
  return s;
}

TEST(Handling, BrakingHardWithTheLoadHighAndTiltedForwardSlidesAndDropsIt) {
  Session s(scene("pallets.json"), Mode::kExam);
  brake_with_load_high(s, 0.8);
  ASSERT_EQ(s.count("load_dropped"), 1) << s.summary();
  EXPECT_EQ(s.count("load_slid"), 1) << "one slide, one event\n" << s.summary();
  EXPECT_LT(s.first("load_slid")->t_s, s.first("load_dropped")->t_s);
  EXPECT_TRUE(s.first("load_dropped")->automatic_fail);
  EXPECT_TRUE(s.pallet("P1")->dropped);
  const Score score = s.finish("signal");
  EXPECT_FALSE(score.passed);
  EXPECT_NE(std::find(score.automatic_failures.begin(), score.automatic_failures.end(), "load_dropped"),
            score.automatic_failures.end());
}

TEST(Handling, GentleBrakingWithTheSameLoadKeepsIt) {
  Session s(scene("pallets.json"), Mode::kExam);
  brake_with_load_high(s, 0.15);
  EXPECT_EQ(s.count("load_dropped"), 0) << s.summary();
  EXPECT_EQ(s.count("load_slid"), 0) << s.summary();
  EXPECT_TRUE(s.pallet("P1")->on_forks);
}

TEST(Handling, LiftingMoreThanTheCapacityAtThatLoadCentre) {
  Session s(scene("pallets.json"), Mode::kExam, Vector3d(0, -10, 0));
  Handler h{s};
  h.insert(-10.0);
  h.lift(0.15);
  ASSERT_EQ(s.count("overload"), 1) << s.summary();
  const EvaluationEvent& e = *s.first("overload");
  EXPECT_TRUE(e.automatic_fail);
  // 1325 kg (pallet and load) with its CoG about 0.64 m from the fork face: the plate allows
  // 1600 kg x 0.5 m / 0.64 m = 1250 kg there.
  EXPECT_NE(e.details.find("\"load_mass_kg\":1325"), std::string::npos) << e.details;
  EXPECT_FALSE(s.finish("signal").passed);
}

}  // namespace
