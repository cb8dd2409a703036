// Other trucks and crossings through the session's own pipeline (tests/evaluation/scenes/traffic.json):
// a truck giving way at a crossing where the pupil goes first and driving on after, the pupil's
// give-way at a crossing where the traffic goes first (entering with a truck coming is a fault,
// waiting for it is clean), a moving truck striking the pupil's forks, the instructor starting a
// truck, and the trucks' drive reproduced bit for bit by a log's replay, rewinds included.
#include <cstring>
#include <nlohmann/json.hpp>

#include "evaluation/harness.h"
#include "forklift/evaluation/event_words.h"
#include "forklift/session/session_run.h"

namespace {

using namespace evt;
using nlohmann::json;

const std::string kTraffic = scene_file("traffic.json");

const OtherTruckState& truck_state(const Session& s, const std::string& id) {
  for (size_t i = 0; i < s.scene.trucks.size(); ++i)
    if (s.scene.trucks[i].id == id) return s.state.trucks[i];
  throw std::runtime_error("no truck " + id);
}

TEST(Traffic, ATruckGivesWayAtACrossingWhereThePupilGoesFirstAndDrivesOnAfter) {
  // Lane y = 40: the pupil's fork tips 4.85 m from C_yield's middle, within its 6 m watch.
  Session s(scene("traffic.json"), Mode::kTraining, Vector3d(5, 40, 0));
  Driver d{s};
  d.settle_levers();
  const int yield = 1;  // C_yield, the second crossing
  d.hold([&] { return s.t() >= 12.0; });
  const OtherTruckState& t = truck_state(s, "T_yield");
  EXPECT_EQ(t.giving_way, yield);
  EXPECT_EQ(t.speed_m_s, 0.0);
  // Its front's middle stands short of the crossing's edge (y = 42), by less than a tick's drive.
  EXPECT_GT(t.at_m.y() - 1.5, 42.0);
  EXPECT_LT(t.at_m.y() - 1.5, 42.0 + 1.5 * Session::kTick + 1e-9);
  // The pupil drives through; once its truck is 6 m past the middle the other drives on.
  d.along(1.2, 40.0, [&] { return s.pos().x() >= 22.0; });
  d.hold([&] { return truck_state(s, "T_yield").arrived; }, 30);
  EXPECT_TRUE(truck_state(s, "T_yield").arrived) << "it drove on to its route's end";
  EXPECT_EQ(truck_state(s, "T_yield").at_m, Eigen::Vector2d(12, 30));
  EXPECT_EQ(s.count("collision_truck"), 0) << s.summary();
  EXPECT_EQ(s.count("give_way_at_crossing"), 0) << s.summary() << "the pupil goes first here";
}

// Two other trucks meeting at C_trucks (x 28-32, y 18-22): T_east's front is there first (3.25 s),
// so T_north, listed before it, stands short of the crossing until T_east's body has left it
// (6.75 s), then drives on; their bodies' centre lines are never in the crossing together.
TEST(Traffic, OfTwoTrucksMeetingAtACrossingTheSecondThereWaits) {
  Session s(scene("traffic.json"), Mode::kTraining);
  Driver d{s};
  d.settle_levers();
  const int c_trucks = 2;
  double waited_from = -1, waited_to = -1;
  int both_in = 0;
  d.hold([&] {
    const OtherTruckState &n = truck_state(s, "T_north"), &e = truck_state(s, "T_east");
    EXPECT_EQ(e.giving_way, -1) << "at " << s.t() << " s: T_east came first";
    if (n.giving_way == c_trucks) {
      if (waited_from < 0) waited_from = s.t();
      waited_to = s.t();
    }
    const bool n_in = n.at_m.y() + 1.5 > 18.0 && n.at_m.y() - 1.5 < 22.0;
    const bool e_in = e.at_m.x() + 1.5 > 28.0 && e.at_m.x() - 1.5 < 32.0;
    both_in += n_in && e_in;
    return s.t() >= 12.0;
  });
  EXPECT_EQ(both_in, 0);
  EXPECT_NEAR(waited_from, 6.5 / 1.5, 0.01) << "T_north's front at the crossing's edge";
  EXPECT_NEAR(waited_to, 13.5 / 2.0, 0.01) << "until T_east's rear left it";
  const OtherTruckState& n = truck_state(s, "T_north");
  EXPECT_EQ(n.giving_way, -1);
  EXPECT_NEAR(n.at_m.y(), 10 + 1.5 * (12.0 - (13.5 / 2.0 - 6.5 / 1.5)), 0.01) << "it drove on, as late as it waited";
  EXPECT_EQ(s.count("collision_truck"), 0) << s.summary();
}

TEST(Traffic, EnteringACrossingWithATruckComingIsAFaultAndWaitingForItIsNot) {
  // Lane y = 0: T_first comes up x = 12 at 1.5 m/s and has priority at C_first (x 10-14).
  Session faulty(scene("traffic.json"), Mode::kTraining, Vector3d(0, 0, 0));
  Driver f{faulty};
  f.settle_levers();
  f.along(1.0, 0.0, [&] { return faulty.pos().x() >= 18.0; });
  ASSERT_EQ(faulty.count("give_way_at_crossing"), 1) << faulty.summary();
  EXPECT_EQ(faulty.events.size(), 1u) << faulty.summary();
  const EvaluationEvent* e = faulty.first("give_way_at_crossing");
  EXPECT_EQ(e->worry_level, 5);
  EXPECT_NEAR(e->x_m, 10.0, 0.01) << "judged as the CoG enters the crossing";
  const json d = json::parse(e->details);
  EXPECT_EQ(d["crossing"], "C_first");
  EXPECT_EQ(d["truck"], "T_first");
  EXPECT_LE(d["measured"]["distance_m"].get<double>(), 8.0);
  EXPECT_NE(std::string(d["source"]).find("1910.178(n)(1)"), std::string::npos);
  // As the HUD and the debrief word it.
  const Rule* rule = rules().find("give_way_at_crossing");
  ASSERT_NE(rule, nullptr);
  const json words = event_words(rule->title, "give_way_at_crossing", e->details);
  EXPECT_EQ(words["title"], "Did not give way at a crossing");
  const std::string summary = words["summary"];
  EXPECT_NE(summary.find("counted for a truck with priority within 8.00 m"), std::string::npos) << summary;

  // Stopping short (the CoG at x = 6) until the truck is past, then driving through: clean.
  Session clean(scene("traffic.json"), Mode::kTraining, Vector3d(0, 0, 0));
  Driver c{clean};
  c.settle_levers();
  c.approach([&] { return 6.0 - clean.pos().x(); }, 1.0, 0.0);
  c.hold([&] { return truck_state(clean, "T_first").at_m.y() > 1.5; });
  c.along(1.0, 0.0, [&] { return clean.pos().x() >= 18.0; });
  EXPECT_TRUE(clean.events.empty()) << clean.summary();
  EXPECT_GT(clean.pos().x(), 14.0) << "through the crossing";
}

TEST(Traffic, ATruckDrivingIntoTheCarriageIsACollisionAndItsDriverStops) {
  // Lane y = -40: T_hit comes up x = 8 at 0.8 m/s across the standing pupil's carriage and forks.
  Session s(scene("traffic.json"), Mode::kTraining, Vector3d(6.5, -40, 0));
  Driver d{s};
  d.settle_levers();
  d.hold([&] { return s.count("collision_truck") > 0; }, 20);
  ASSERT_EQ(s.count("collision_truck"), 1) << s.summary();
  const EvaluationEvent* e = s.first("collision_truck");
  const json det = json::parse(e->details);
  EXPECT_EQ(det["truck"], "T_hit");
  // The carriage and forks reach across its route; the chassis stops short of it.
  EXPECT_TRUE(det["truck_part"] == "carriage" || det["truck_part"] == "fork_left" || det["truck_part"] == "fork_right")
      << det.dump();
  EXPECT_NEAR(det["measured"]["impact_speed_m_s"].get<double>(), 0.8, 0.05) << "its speed into the standing truck";
  EXPECT_EQ(e->worry_level, 5) << "a hard impact: 0.5 m/s or more";
  const OtherTruckState hit = truck_state(s, "T_hit");
  EXPECT_TRUE(hit.struck);
  d.hold([] { return false; }, 2.0);
  EXPECT_EQ(truck_state(s, "T_hit").at_m, hit.at_m) << "its driver stopped";
  EXPECT_EQ(s.count("collision_truck"), 1) << s.summary();
}

// The trucks' places after every tick of a live run (a hazard, two rewinds) and of its log's
// replay: the same, bit for bit.
TEST(Traffic, ALogsReplayDrivesTheTrucksTheSameWayBitForBitRewindsIncluded) {
  const SessionModel model = load_session_model(SessionSpec{kTraffic}, FORKLIFT_DATA_DIR);
  const SessionState first = initial_state(model);
  const std::string path = testing::TempDir() + "/traffic_replay.ctl";
  SessionRun run(model, first, std::make_unique<ControlLogWriter>(path, log_header(model, first, "traffic", "cab1")),
                 {0, false});
  run.keep_rewind_points(500, 4);
  std::vector<Eigen::Vector2d> live, again;
  const auto keep = [](std::vector<Eigen::Vector2d>& into, const SessionState& st) {
    for (const OtherTruckState& t : st.trucks) into.push_back(t.at_m);
  };
  ASSERT_TRUE(run.hazard_problem("T_nope"));
  EXPECT_NE(run.hazard_problem("T_nope")->find("no pedestrian or truck 'T_nope'"), std::string::npos)
      << *run.hazard_problem("T_nope");
  ControlSample go;
  go.accelerator = 0.3;
  uint32_t seq = 0;
  run.apply(++seq, driver_inputs(go, model.truck));
  for (int64_t tick = 0; tick < 6000; ++tick) {
    if (tick == 1000) {
      ASSERT_EQ(run.hazard_problem("T_late"), std::nullopt);
      run.instruct({InstructorAction::kHazard, "T_late"});
      EXPECT_NE(run.hazard_problem("T_late"), std::nullopt) << "driving already";
    }
    if (tick == 3000 || tick == 4500) {
      const auto point = run.rewind_point(0.8);
      ASSERT_TRUE(point);
      run.instruct({InstructorAction::kRewind, "", *point, 0.8});
      EXPECT_EQ(run.state().trucks.at(3).at_m, run.rewind_points().at(*point).trucks.at(3).at_m);
    }
    run.tick();
    keep(live, run.state());
  }
  run.end(EndReason::kAborted);
  EXPECT_TRUE(run.state().trucks.at(3).started) << "T_late, by the instructor's hand";
  EXPECT_GT((run.state().trucks.at(0).at_m - Eigen::Vector2d(12, -22)).norm(), 3.0) << "T_first drove";
  const ReplayResult r = replay_session(read_control_log(path), model,
                                        [&](const SessionState& st, const SessionWorkspace&) { keep(again, st); });
  ASSERT_EQ(live.size(), again.size());
  EXPECT_EQ(std::memcmp(live.data(), again.data(), live.size() * sizeof(Eigen::Vector2d)), 0);
}

}  // namespace
