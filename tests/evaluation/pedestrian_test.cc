// People walking in the warehouse, through the session's own pipeline: a person struck fails an
// exam and is a serious fault in training; the rules of speed near a person and of driving on
// towards one in the path, on the shipped pedestrian_awareness drives (clean and faulty, in
// process and through forklift-sim); the walk reproduced bit for bit from a session's log and
// from a copy of its state.
//
// FORKLIFT_EVAL_SCRIPT_DIR=data/evaluation/scripts build/tests/evaluation_test --gtest_filter='Pedestrians.*Script*'
// rewrites the shipped pedestrian_awareness scripts (data/evaluation/scripts/) from these drives.
#include <cstring>
#include <nlohmann/json.hpp>

#include "evaluation/forklift_sim.h"
#include "evaluation/harness.h"

namespace {

using namespace evt;
using nlohmann::json;

const std::string kAwareness = data("scenarios/pedestrian_awareness.json");
const std::string kCleanScript = "pedestrian_awareness_clean.csv";
const std::string kFaultyScript = "pedestrian_awareness_faults.csv";
const std::string kCutInScript = "pedestrian_awareness_crossing_faults.csv";

// Ahead along the line y = `lane` (heading +x) at `v` until `done`; forks held.
void drive(Session&, Driver& d, double v, double lane, const std::function<bool()>& done, double max_s = 60) {
  d.along(v, lane, done, max_s);
}

// Braked, forks held, until `done`.
void hold(Session&, Driver& d, const std::function<bool()>& done, double max_s = 60) { d.hold(done, max_s); }

const PedestrianState& walker(const Session& s) { return s.state.pedestrians.at(0); }
// The worker past the door who heeds the horn, and the truck that goes first at the crossing.
const PedestrianState& listener(const Session& s) { return s.state.pedestrians.at(1); }
const OtherTruckState& traffic(const Session& s) { return s.state.trucks.at(1); }

// Both drives begin alike: forks to travelling height, walking pace to 3 m short of the walkway,
// stop (the worker has stepped out by then).
void to_the_walkway(Session& s, Driver& d) {
  s.control_period_ticks = 50;  // 20 Hz is enough at these speeds, and keeps the scripts short
  d.lift_to = 0.2;
  d.settle_levers();
  drive(s, d, 1.0, 5.0, [&] { return d.heel_x() + s.shape.fork_length_m >= 23.0; });
  d.stop();
}

// The clean drive: the horn before the door (the worker there hears it and stands) and the blind
// corner, stopped while the walkway's worker crosses the aisle and walks on to his path's end;
// on at walking pace to 3.5 m short of the crossing's traffic lane (fork tips at x = 25.5),
// stopped until the truck that goes first there has gone by, then on to the marker, stop, forks
// down, parked. `give_way` false: the same drive on into the crossing as the truck comes.
void clean_drive(Session& s, bool give_way = true) {
  s.horn = [&s] { return horn_due(s); };
  Driver d{s};
  to_the_walkway(s, d);
  hold(s, d, [&] { return walker(s).arrived; });
  if (give_way) {
    d.approach([&] { return 25.5 - (d.heel_x() + s.shape.fork_length_m); }, 1.0, 5.0);
    hold(s, d, [&] { return traffic(s).arrived; });
  }
  d.approach([&] { return 31.5 - s.pos().x(); }, 1.0, 5.0);
  d.park_forks_down();
}

// The faulty drive: at twice walking pace through the door and the blind corner without the
// horn (the worker past the door does not hear it, and walks out once it has passed), up to the
// walkway as the worker there steps out, braking late, 2 m short of it; on again once he is
// across, into the crossing as the truck that goes first there comes.
void faulty_drive(Session& s) {
  Driver d{s};
  s.control_period_ticks = 50;
  d.lift_to = 0.2;
  d.settle_levers();
  drive(s, d, 2.6, 5.0, [&] { return d.heel_x() + s.shape.fork_length_m >= 24.0; });
  s.run(10, [&] { Controls c = d.levers(); c.brake = 0.6; c.steer_rad = s.c.steer_rad; return c; },
        [&] { return std::abs(s.v()) < 0.003; });
  hold(s, d, [&] { return walker(s).at_m.y() > 8.0; });
  d.approach([&] { return 31.5 - s.pos().x(); }, 1.0, 5.0);
  d.park_forks_down();
}

std::string write_script(const Session& s, const std::string& name, const std::string& what) {
  return evt::write_script(s, name, what, "tests/evaluation/pedestrian_test.cc");
}

std::vector<std::string> rules_of(const json& events) {
  std::vector<std::string> v;
  for (const json& e : events) v.push_back(e["rule"]);
  return v;
}

// Forks up, then ahead on lane y = 0 at 1 m/s into STANDER (tests/evaluation/scenes/pedestrians.json).
void strike_at_walking_pace(Session& s) {
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  drive(s, d, 1.0, 0.0, [&] { return s.count("pedestrian_struck") > 0; }, 20);
  hold(s, d, [&] { return std::abs(s.v()) < 0.005; }, 5);
  s.run(1.0, [&] { Controls c = d.levers(); c.brake = 0.5; return c; });  // still touching him: one event
}

TEST(Pedestrians, OneStruckAtOneMetrePerSecondFailsAnExam) {
  Session s(scene("pedestrians.json"), Mode::kExam);
  strike_at_walking_pace(s);
  // Driving on at him was marked before he was struck.
  ASSERT_EQ(s.events.size(), 2u) << s.summary();
  EXPECT_EQ(s.events[0].rule, "pedestrian_in_path");
  const EvaluationEvent& e = s.events[1];
  EXPECT_EQ(e.rule, "pedestrian_struck");
  EXPECT_EQ(e.worry_level, 5);
  EXPECT_TRUE(e.automatic_fail);
  const json d = json::parse(e.details);
  EXPECT_EQ(d["pedestrian"], "STANDER");
  EXPECT_NEAR(d["measured"]["impact_speed_m_s"].get<double>(), 1.0, 0.1);
  EXPECT_NEAR(e.x_m, 5.8, 0.1) << "at his chest";
  EXPECT_TRUE(s.state.pedestrians[0].struck);
  const Score score = s.finish("duration");
  EXPECT_FALSE(score.passed);
  EXPECT_NE(std::find(score.automatic_failures.begin(), score.automatic_failures.end(), "pedestrian_struck"),
            score.automatic_failures.end());
}

TEST(Pedestrians, OneStruckIsASeriousFaultInTraining) {
  Session s(scene("pedestrians.json"), Mode::kTraining);
  strike_at_walking_pace(s);
  ASSERT_EQ(s.count("pedestrian_struck"), 1) << s.summary();
  EXPECT_EQ(s.first("pedestrian_struck")->worry_level, 5);
  EXPECT_EQ(s.first("pedestrian_struck")->points, 5);
  EXPECT_EQ(s.count("violent_collision"), 0) << "a person is his own rule";
  EXPECT_EQ(s.count("collision_pedestrian"), 0) << "that is the standing figure's";
  EXPECT_EQ(s.count("pedestrian_in_path"), 1) << s.summary();
  EXPECT_EQ(s.points(), 5 + 5);
}

TEST(Pedestrians, ACopyOfTheStateIsARewindPointForThePeopleToo) {
  // Lane y = 20: CROSSER steps out as the truck comes; a kept copy, stepped twice from scratch,
  // walks him the same way both times.
  Session a(scene("pedestrians.json"), Mode::kTraining, Vector3d(0, 20, 0));
  Driver d{a};
  d.lift_to = 0.2;
  d.settle_levers();
  drive(a, d, 1.2, 20.0, [&] { return a.state.pedestrians[1].started; });
  a.run(0.5, [&] { return a.c; });
  const SessionState kept = a.state;
  const std::vector<SessionState> again = step_copies(a, kept, 2000);
  EXPECT_GT((again[0].pedestrians[1].at_m - kept.pedestrians[1].at_m).norm(), 2.0) << "he walked on";
  for (size_t i = 0; i < kept.pedestrians.size(); ++i)
    EXPECT_EQ(std::memcmp(again[0].pedestrians[i].at_m.data(), again[1].pedestrians[i].at_m.data(), 2 * sizeof(double)), 0) << i;
  EXPECT_EQ(std::memcmp(again[0].x.data(), again[1].x.data(), sizeof(double) * StateIndex::kSize), 0);
}

TEST(Pedestrians, TheCleanScriptKeepsToWalkingPaceAndTheFaultyOneDoesNot) {
  Session clean(load_scene(kAwareness, FORKLIFT_DATA_DIR), Mode::kExam);
  clean_drive(clean);
  const Score cs = clean.finish("duration");
  EXPECT_TRUE(clean.events.empty()) << clean.summary();
  EXPECT_TRUE(cs.passed);
  EXPECT_TRUE(clean.state.pedestrians[0].arrived) << "he crossed and walked on to his path's end";
  // The worker past the door heard the horn and stood on the walkway while the truck was near
  // (no event: he was never in its path); he crosses once it has gone on.
  EXPECT_TRUE(listener(clean).alerted) << "the horn at the door alerted the worker there";
  EXPECT_TRUE(traffic(clean).arrived) << "the truck went by first";

  Session faulty(load_scene(kAwareness, FORKLIFT_DATA_DIR), Mode::kTraining);
  faulty_drive(faulty);
  faulty.finish("duration");
  EXPECT_FALSE(listener(faulty).alerted) << "no horn: the worker past the door did not hear the truck";
  EXPECT_GT(listener(faulty).at_m.y(), 5.0) << "and he walked out across the aisle";
  EXPECT_EQ(faulty.count("give_way_at_crossing"), 1) << faulty.summary() << "on to the marker as the truck came";
  EXPECT_EQ(faulty.count("horn_at_marker"), 2) << faulty.summary() << "the door and the blind corner";
  EXPECT_GE(faulty.count("speed_at_marker"), 1) << faulty.summary();
  EXPECT_EQ(faulty.count("speed_near_pedestrian"), 1) << faulty.summary();
  EXPECT_EQ(faulty.count("pedestrian_struck"), 0) << faulty.summary();
  EXPECT_EQ(faulty.count("pedestrian_in_path"), 1) << faulty.summary();
  const EvaluationEvent* e = faulty.first("speed_near_pedestrian");
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->worry_level, 5);
  const json d = json::parse(e->details);
  EXPECT_EQ(d["pedestrian"], "W1");
  EXPECT_GT(d["measured"]["speed_m_s"].get<double>(), 1.4);
  EXPECT_LE(d["measured"]["distance_m"].get<double>(), 3.0);

  // The clean drive on into the crossing as the truck that goes first there comes: its driver
  // stands for the pupil's truck, and the pupil did not give way.
  Session cut_in(load_scene(kAwareness, FORKLIFT_DATA_DIR), Mode::kTraining);
  clean_drive(cut_in, false);
  cut_in.finish("duration");
  ASSERT_EQ(cut_in.count("give_way_at_crossing"), 1) << cut_in.summary();
  EXPECT_EQ(cut_in.events.size(), 1u) << cut_in.summary();
  const json g = json::parse(cut_in.first("give_way_at_crossing")->details);
  EXPECT_EQ(g["crossing"], "X_east");
  EXPECT_EQ(g["truck"], "T2");
  EXPECT_EQ(cut_in.count("collision_truck"), 0);

  // The same drives as cab scripts (rewritten into data/ with FORKLIFT_EVAL_SCRIPT_DIR).
  write_script(clean, kCleanScript, "pedestrian_awareness, exam: a clean drive that lets the workers and the truck cross");
  write_script(faulty, kFaultyScript, "pedestrian_awareness: off again too fast past the worker");
  write_script(cut_in, kCutInScript, "pedestrian_awareness: on into the crossing in front of the truck that goes first");
}

TEST(Pedestrians, TheShippedScriptsAreMarkedAlikeByForkliftSimAndTheLogReplaysTheWalkBitForBit) {
  const json clean = evaluate({"--scenario", kAwareness, "--script", data("evaluation/scripts/" + kCleanScript), "--mode", "exam"},
                              "ped_clean");
  EXPECT_TRUE(clean["events"].empty()) << clean["events"].dump(2)
                                       << "\nIf the truck model changed, regenerate the scripts (see this file's head).";
  EXPECT_EQ(clean["score"]["passed"], true);

  const std::string log = testing::TempDir() + "/pedestrian_faults.ctl";
  const std::string script = data("evaluation/scripts/" + kFaultyScript);
  const json faulty = evaluate({"--scenario", kAwareness, "--script", script, "--out-log", log}, "ped_faults");
  const std::vector<std::string> rules = rules_of(faulty["events"]);
  for (const char* rule : {"speed_near_pedestrian", "pedestrian_in_path", "horn_at_marker", "speed_at_marker"})
    EXPECT_NE(std::find(rules.begin(), rules.end(), rule), rules.end()) << rule << "\n" << faulty["events"].dump(1);

  // The walk as the script drives it, and as the log replays it: the same positions, bit for bit.
  const SessionModel model = load_session_model(SessionSpec{kAwareness}, FORKLIFT_DATA_DIR);
  std::vector<Eigen::Vector2d> first, again;
  const auto record = [](std::vector<Eigen::Vector2d>& into) {
    return [&into](const SessionState& st, const SessionWorkspace&) { into.push_back(st.pedestrians.at(0).at_m); };
  };
  const std::vector<InputChange> changes = script_changes(script, model);
  const int64_t end = changes.back().tick + 1;
  run_offline(model, initial_state(model), changes, end, EndReason::kDuration, nullptr, record(first));
  const ReplayResult r = replay_session(read_control_log(log), model, record(again));
  ASSERT_EQ(first.size(), again.size());
  ASSERT_GT(first.size(), 1000u);
  EXPECT_NE(first.front(), first.back()) << "he walked";
  EXPECT_EQ(std::memcmp(first.data(), again.data(), first.size() * sizeof(Eigen::Vector2d)), 0);
  ASSERT_FALSE(r.score_line.empty());
  EXPECT_EQ(faulty["score"]["points"], r.score.points);
}

}  // namespace
