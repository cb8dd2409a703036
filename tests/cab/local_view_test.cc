// A cab drawing its own picture (--render local) draws what the worker's frames would: the
// worker's SceneMotion sample read back gives the renderer the state the worker's own frames take.
#include <gtest/gtest.h>

#include "forklift/protocol/aids.h"
#include "forklift/session/session_run.h"
#include "local_view.h"
#include "truck_state.h"

using namespace forklift;

TEST(LocalPicture, TheSceneMotionGivesTheRendererTheStateTheWorkersFramesDraw) {
  SessionSpec spec;
  spec.scenario_file = std::string(FORKLIFT_DATA_DIR) + "/scenarios/pedestrian_awareness.json";
  const SessionModel model = load_session_model(spec, FORKLIFT_DATA_DIR);
  SessionRun run(model, initial_state(model));
  DriverInputs drive;
  drive.drive_torque_N_m = 0.4 * model.truck.drive.drive_torque_max_N_m;
  drive.steer_rad = 0.2;
  run.apply(1, drive);
  for (int i = 0; i < 2000; ++i) ASSERT_FALSE(run.tick().end);  // 2 s: the truck moving and turning
  const SessionState& s = run.state();
  ASSERT_FALSE(s.handling.pallets().empty());
  ASSERT_FALSE(s.pedestrians.empty());

  std::vector<fk_PalletPose> pallets;
  std::vector<fk_PedestrianPose> people;
  const fk_SceneMotion m = worker::scene_motion(s, "c1", pallets, people);
  EXPECT_STREQ(m.cab_id, "c1");
  EXPECT_EQ(m.sim_time_s, s.t_s);
  const RenderState r = render_state_of(m);
  EXPECT_EQ(r.q, coordinates_of(s));  // bit for bit: doubles on the wire
  EXPECT_GT(std::abs(r.q[kAwc] - model.scene.scenario.yaw_rad), 0.01);  // it did turn
  ASSERT_EQ(r.pallets.size(), s.handling.pallets().size());
  for (size_t i = 0; i < r.pallets.size(); ++i) {
    const PalletState& want = s.handling.pallets()[i];
    EXPECT_EQ(r.pallets[i].id, want.id);
    EXPECT_LT((r.pallets[i].pose.translation() - want.pose.translation()).norm(), 1e-12) << want.id;
    EXPECT_LT((r.pallets[i].pose.linear() - want.pose.linear()).norm(), 1e-12) << want.id;
  }
  ASSERT_EQ(r.pedestrians.size(), s.pedestrians.size());
  for (size_t i = 0; i < r.pedestrians.size(); ++i) {
    EXPECT_EQ(r.pedestrians[i].at_m, s.pedestrians[i].at_m);
    EXPECT_EQ(r.pedestrians[i].heading_rad, s.pedestrians[i].heading_rad);
  }
}

TEST(LocalPicture, AnAidNotGrantedIsNotDrawnAndTheChaseCameraNeedsItsGrant) {
  ViewOptions asked;
  asked.rear_view = asked.see_through_mast = asked.fork_camera = true;
  auto [view, got] = granted_view(1, asked, View::kDriver, 0);
  EXPECT_EQ(view, View::kDriver);
  EXPECT_FALSE(got.rear_view || got.see_through_mast || got.fork_camera);
  std::tie(view, got) = granted_view(1, asked, View::kDriver, aids::kChaseCamera | aids::kForkCamera);
  EXPECT_EQ(view, View::kChase);
  EXPECT_TRUE(got.fork_camera);
  EXPECT_FALSE(got.rear_view || got.see_through_mast);
}
