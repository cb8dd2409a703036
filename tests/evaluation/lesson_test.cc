// The first lesson (data/scenarios/first_drive.json): its control steps are judged where every
// step is, in the evaluation, one at a time: an action done before its turn does not count, and
// the step in hand advances only once its own action is done.
#include <nlohmann/json.hpp>

#include "evaluation/harness.h"
#include "forklift/session/vocabulary.h"

namespace {

using namespace evt;

struct Lesson {
  Session s{load_scene(data("scenarios/first_drive.json"), FORKLIFT_DATA_DIR)};
  Controls c;
  int done() const { return s.state.evaluation.steps_done(); }
  // Holds the controls for `t_s`, or until `until` holds; returns whether it did.
  bool hold(double t_s, const std::function<bool()>& until = {}) {
    return s.run(t_s, [&] { return c; }, until);
  }
};

TEST(Lesson, TheShippedLessonTeachesTheControlsInOrderAndEndsWithAPalletPick) {
  const Scene sc = load_scene(data("scenarios/first_drive.json"), FORKLIFT_DATA_DIR);
  std::vector<std::string> kinds;
  for (const TaskStep& st : sc.task.steps) kinds.push_back(st.kind == "control" ? st.action : st.kind);
  EXPECT_EQ(kinds, (std::vector<std::string>{"forward", "stop", "reverse", "stop", "steer_left", "steer_right",
                                             "steer_straight", "lift", "lower", "tilt_back", "tilt_level", "take"}));
  for (const TaskStep& st : sc.task.steps) EXPECT_NE(st.description.find('{'), std::string::npos) << st.description;
}

// A lesson left undone: the steps left, as the debrief shows them, name controls in words any
// pupil reads, never a brace.
TEST(Lesson, TheStepsLeftOfALessonLeftUndoneNameTheControlsInWords) {
  EXPECT_EQ(step_words("Lift the forks 30 cm with {lift}, then {unknown}"), "Lift the forks 30 cm with the lift lever, then {unknown}");
  Lesson l;
  l.s.finish();
  ASSERT_EQ(l.s.count("task_incomplete"), 1) << l.s.summary();
  for (const EvaluationEvent& e : l.s.events) {
    if (e.rule != "task_incomplete") continue;
    const nlohmann::json left = nlohmann::json::parse(e.details)["steps_left"];
    ASSERT_EQ(left.size(), 12u) << e.details;
    EXPECT_EQ(left[0], "Press forward (direction lever forward), then hold the accelerator gently until you roll at 2 km/h");
    for (const auto& step : left) EXPECT_EQ(step.get<std::string>().find('{'), std::string::npos) << step;
  }
}

TEST(Lesson, EachStepAdvancesOnlyWhenItsOwnActionIsDone) {
  Lesson l;
  // The wheel, the forks and the mast worked before their turn: the first step (roll forward)
  // is still the one in hand, and none of them counts later.
  l.c.steer_rad = -0.5;
  l.c.lift = 0.6;
  l.c.tilt = -0.6;
  l.hold(1.5);
  EXPECT_EQ(l.done(), 0);
  EXPECT_GT(l.s.q()[kS], 0.3);
  l.c.lift = -1;
  l.c.tilt = 0.6;
  l.hold(4, [&] { return l.s.q()[kS] < 0.005 && l.s.q()[kBeta] > 0; });
  l.c = Controls{};
  l.hold(2.0);
  EXPECT_EQ(l.done(), 0);

  // Backing up first is not rolling forward.
  l.c.accelerator = -0.3;
  l.hold(3, [&] { return l.s.v() < -0.4; });
  EXPECT_EQ(l.done(), 0);
  l.c = Controls{};
  l.c.brake = 1;
  l.hold(3, [&] { return std::abs(l.s.v()) < 0.01; });
  EXPECT_EQ(l.done(), 0);

  // Forward at 2 km/h: step 1 done; the truck still rolling is not yet step 2 (stop).
  l.c = Controls{};
  l.c.accelerator = 0.3;
  ASSERT_TRUE(l.hold(6, [&] { return l.done() == 1; })) << "rolling forward did not complete step 1";
  EXPECT_GE(l.s.v(), 0.5);
  l.hold(0.5);
  EXPECT_EQ(l.done(), 1);
  l.c = Controls{};
  l.c.brake = 1;
  ASSERT_TRUE(l.hold(4, [&] { return l.done() == 2; }));
  EXPECT_LT(std::abs(l.s.v()), 0.06);
  // Reverse, stop.
  l.c = Controls{};
  l.c.accelerator = -0.3;
  ASSERT_TRUE(l.hold(6, [&] { return l.done() == 3; }));
  l.c = Controls{};
  l.c.brake = 1;
  ASSERT_TRUE(l.hold(4, [&] { return l.done() == 4; }));

  // The wheel right before left: still step 5 (left); then left, right and straight in turn.
  l.c = Controls{};
  l.c.steer_rad = 0.5;
  l.hold(2);
  EXPECT_EQ(l.done(), 4);
  l.c.steer_rad = -0.5;
  ASSERT_TRUE(l.hold(3, [&] { return l.done() == 5; }));
  EXPECT_LE(l.s.q()[kAwr3], -20 * kDeg);
  l.hold(0.5);
  EXPECT_EQ(l.done(), 5) << "the wheel held left is not the wheel turned right";
  l.c.steer_rad = 0.5;
  ASSERT_TRUE(l.hold(3, [&] { return l.done() == 6; }));
  EXPECT_GE(l.s.q()[kAwr3], 20 * kDeg);
  l.c.steer_rad = 0;
  ASSERT_TRUE(l.hold(3, [&] { return l.done() == 7; }));
  EXPECT_LE(std::abs(l.s.q()[kAwr3]), 1 * kDeg);

  // Forks: lowering first does nothing (they are down); up 30 cm, then down.
  l.c.lift = -0.5;
  l.hold(1);
  EXPECT_EQ(l.done(), 7);
  l.c.lift = 0.5;
  ASSERT_TRUE(l.hold(4, [&] { return l.done() == 8; }));
  EXPECT_GE(l.s.q()[kS], 0.3);
  l.c.lift = -0.5;
  ASSERT_TRUE(l.hold(4, [&] { return l.done() == 9; }));
  EXPECT_LE(l.s.q()[kS], 0.02);

  // Mast: forward is not back; back 3 deg, then level.
  l.c.lift = 0;
  l.c.tilt = 0.3;
  l.hold(1);
  EXPECT_EQ(l.done(), 9);
  l.c.tilt = -0.5;
  ASSERT_TRUE(l.hold(5, [&] { return l.done() == 10; }));
  EXPECT_LE(l.s.q()[kBeta], -3 * kDeg);
  l.c.tilt = 0.1;
  ASSERT_TRUE(l.hold(10, [&] { return l.done() == 11; }));
  EXPECT_LE(std::abs(l.s.q()[kBeta]), 0.5 * kDeg);
  EXPECT_FALSE(l.s.task_completed()) << "the pallet pick is still to do";
}

}  // namespace
