// Hazard perception through the session's own pipeline (tests/evaluation/scenes/hazards.json):
// the horn and walking pace at marked blind corners and doors, driving towards a person
// standing in front of a fixed object, and a person under the raised forks; each rule on a drive
// that commits it and on one that does not, its words as a school reads them, and the horn
// carried through a cab script and a session log bit for bit; a spill the instructor starts.
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "evaluation/forklift_sim.h"
#include "evaluation/harness.h"
#include "forklift/evaluation/event_words.h"
#include "forklift/session/session_run.h"

namespace {

using namespace evt;
using nlohmann::json;

const std::string kHazards = scene_file("hazards.json");

// Ahead along the line y = `lane` at `v` until `done`; forks held; the horn as `horn()` says.
void drive(Session& s, Driver& d, double v, double lane, const std::function<bool()>& done,
           const std::function<bool()>& horn = [] { return false; }, double max_s = 60) {
  s.run(max_s,
        [&] {
          Controls c = d.levers();
          d.speed(c, v);
          c.steer_rad = d.steer_to_line(lane);
          c.horn = horn();
          return c;
        },
        done);
}

// Braked, forks held, until `done`.
void hold(Session& s, Driver& d, const std::function<bool()>& done, double max_s = 60) {
  s.run(max_s, [&] { Controls c = d.levers(); d.speed(c, 0); c.steer_rad = s.c.steer_rad; return c; }, done);
}

const PedestrianState& person(const Session& s, const std::string& id) {
  for (size_t i = 0; i < s.scene.pedestrians.size(); ++i)
    if (s.scene.pedestrians[i].id == id) return s.state.pedestrians[i];
  throw std::runtime_error("no pedestrian " + id);
}

// Lane y = -10 from x = 0 past both markers to x = 24, forks at travelling height, at `v`; the
// horn sounded while `horn(x)` of the CoG's x says.
void through_the_markers(Session& s, double v, const std::function<bool(double)>& horn) {
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  drive(s, d, v, -10.0, [&] { return s.pos().x() >= 24.0; }, [&] { return horn(s.pos().x()); });
  d.stop();
}

TEST(Hazards, NoHornAndTooFastAtABlindCornerAndADoorAreFaultsEachTime) {
  Session s(scene("hazards.json"), Mode::kTraining, Vector3d(0, -10, 0));
  through_the_markers(s, 2.0, [](double) { return false; });
  EXPECT_EQ(s.count("horn_at_marker"), 2) << s.summary();
  EXPECT_EQ(s.count("speed_at_marker"), 2) << s.summary();
  EXPECT_EQ(int(s.events.size()), 4) << s.summary();
  const EvaluationEvent* e = s.first("horn_at_marker");
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->worry_level, 3);
  const json d = json::parse(e->details);
  EXPECT_EQ(d["marker"], "M_corner");
  EXPECT_EQ(d["marker_kind"], "blind_corner");
  EXPECT_NEAR(e->x_m, 8.0 + 2.0 * 1.0, 0.2) << "judged horn_after_s (1 s) into the corner at 2 m/s";
  EXPECT_NE(std::string(d["source"]).find("1910.178(n)(4)"), std::string::npos);
  const json speed = json::parse(s.first("speed_at_marker")->details);
  EXPECT_GT(speed["measured"]["speed_m_s"].get<double>(), 1.4);

  // As the debrief and the HUD's words say it: the rules file's title and what was measured.
  const Rule* rule = rules().find("speed_at_marker");
  ASSERT_NE(rule, nullptr);
  const json words = event_words(rule->title, "speed_at_marker", s.first("speed_at_marker")->details);
  EXPECT_EQ(words["title"], "Too fast at a blind spot");
  EXPECT_NE(words.dump().find("m/s"), std::string::npos) << words.dump(1);
  // A threshold named as another rule's reads as this rule's (not a parked truck's top speed).
  const std::string near = event_words("", "speed_near_pedestrian",
                                       R"({"thresholds": {"speed_max_m_s": 1.4, "near_distance_m": 3.0}})")["summary"];
  EXPECT_NE(near.find("highest speed near a person 1.40 m/s"), std::string::npos) << near;
  EXPECT_EQ(near.find("parked"), std::string::npos) << near;
}

TEST(Hazards, TheHornSoundedJustBeforeEachMarkerAtWalkingPaceIsClean) {
  Session s(scene("hazards.json"), Mode::kTraining, Vector3d(0, -10, 0));
  through_the_markers(s, 1.0, [](double x) { return (x > 6.0 && x < 7.0) || (x > 16.0 && x < 17.0); });
  EXPECT_TRUE(s.events.empty()) << s.summary();
}

TEST(Hazards, AHornLongBeforeTheCornerIsNotAHornAtIt) {
  // Sounded only in the first metre: some 8 s before the corner at 1 m/s, more than horn_before_s
  // (5 s); just before the door it is sounded again.
  Session s(scene("hazards.json"), Mode::kTraining, Vector3d(0, -10, 0));
  through_the_markers(s, 1.0, [](double x) { return x < 1.0 || (x > 16.0 && x < 17.0); });
  ASSERT_EQ(s.count("horn_at_marker"), 1) << s.summary();
  EXPECT_EQ(json::parse(s.first("horn_at_marker")->details)["marker"], "M_corner");
  EXPECT_EQ(s.count("speed_at_marker"), 0) << s.summary();
}

// Forks at travelling height, towards the person standing 8 m ahead on lane y = `lane`, stopping
// with the fork tips `short_m` from him.
void towards(Session& s, double lane, const std::string& who, double short_m) {
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  d.approach([&] { return person(s, who).at_m.x() - (d.heel_x() + s.shape.fork_length_m) - short_m; }, 0.6, lane);
  hold(s, d, [] { return false; }, 1.0);
}

TEST(Hazards, DrivingUpToAPersonInFrontOfAWallIsAFaultAndStoppingShortOrInTheOpenIsNot) {
  Session pinned(scene("hazards.json"), Mode::kTraining, Vector3d(0, 0, 0));
  towards(pinned, 0.0, "PINNED", 2.2);
  ASSERT_EQ(pinned.count("pedestrian_at_fixed_object"), 1) << pinned.summary();
  EXPECT_EQ(pinned.events.size(), 1u) << pinned.summary();
  const EvaluationEvent* e = pinned.first("pedestrian_at_fixed_object");
  EXPECT_EQ(e->worry_level, 5);
  const json d = json::parse(e->details);
  EXPECT_EQ(d["pedestrian"], "PINNED");
  EXPECT_EQ(d["object"], "WALL");
  EXPECT_NEAR(d["measured"]["object_distance_m"].get<double>(), 0.4, 1e-6);
  EXPECT_LE(d["measured"]["distance_m"].get<double>(), 3.0);
  EXPECT_NE(std::string(d["source"]).find("(m)(1)"), std::string::npos);

  // Stopped with 3.5 m to spare: never near him.
  Session short_of_him(scene("hazards.json"), Mode::kTraining, Vector3d(0, 0, 0));
  towards(short_of_him, 0.0, "PINNED", 3.5);
  EXPECT_TRUE(short_of_him.events.empty()) << short_of_him.summary();

  // The same approach to a person with nothing behind him: he can step aside.
  Session open(scene("hazards.json"), Mode::kTraining, Vector3d(0, 10, 0));
  towards(open, 10.0, "OPEN", 2.2);
  EXPECT_TRUE(open.events.empty()) << open.summary();
}

// Forks raised to 2.1 m at the start of lane y = `lane`; held, braked, until `who` has crossed.
void forks_up_while_crossing(Session& s, const std::string& who) {
  Driver d{s};
  d.lift_to = 2.1;
  hold(s, d, [&] { return person(s, who).arrived; }, 40);
}

TEST(Hazards, APersonWalkingUnderTheRaisedForksIsAFaultAndOneBeyondTheirTipsIsNot) {
  Session under(scene("hazards.json"), Mode::kTraining, Vector3d(0, 20, 0));
  forks_up_while_crossing(under, "UNDER");
  ASSERT_EQ(under.count("person_under_forks"), 1) << under.summary();
  EXPECT_EQ(under.events.size(), 1u) << under.summary() << "he walked under them, not into them";
  const json d = json::parse(under.first("person_under_forks")->details);
  EXPECT_EQ(d["pedestrian"], "UNDER");
  EXPECT_GT(d["measured"]["fork_height_m"].get<double>(), 1.9);
  EXPECT_NE(std::string(d["source"]).find("(m)(2)"), std::string::npos);

  Session beyond(scene("hazards.json"), Mode::kTraining, Vector3d(0, 30, 0));
  forks_up_while_crossing(beyond, "BEYOND");
  EXPECT_TRUE(beyond.events.empty()) << beyond.summary();
  EXPECT_TRUE(person(beyond, "BEYOND").arrived);
}

// At 2 m/s along lane y = `lane`, forks at travelling height; the brake full on once the CoG is
// at x = 9 (the whole truck over the spill on lane -20) until it stands. Returns the distance the
// CoG ran from the brake's touch.
double full_stop(Session& s, double lane) {
  Driver d{s};
  d.lift_to = 0.2;
  d.settle_levers();
  drive(s, d, 2.0, lane, [&] { return s.pos().x() >= 9.0; });
  const double from = s.pos().x();
  s.run(20, [&] { Controls c = d.levers(); c.brake = 1.0; c.steer_rad = s.c.steer_rad; return c; },
        [&] { return std::abs(s.v()) < 0.01; });
  return s.pos().x() - from;
}

TEST(Hazards, ASpillLengthensTheStopAsItsGripSays) {
  Session dry(scene("hazards.json"), Mode::kTraining, Vector3d(0, -30, 0));
  Session oily(scene("hazards.json"), Mode::kTraining, Vector3d(0, -20, 0));
  const double dry_m = full_stop(dry, -30), oily_m = full_stop(oily, -20);
  std::cout << "full brake from 2 m/s: " << dry_m << " m dry, " << oily_m << " m on the spill\n";
  // The dry stop is the brakes' (their torque locks no wheel on this floor); on a fifth of the
  // grip the tyres slide, and from 2 m/s at under 0.2 x 0.75 g on the front wheels' share the
  // stop is longer than 2^2 / (2 * 0.15 * 9.81) = 1.36 m.
  EXPECT_GT(oily_m, 1.36);
  EXPECT_GT(oily_m, 1.5 * dry_m);
  EXPECT_LT(oily.pos().x(), 16.0) << "it stood on the spill";
}

// The spill OIL_LATE (lane y = -25) that waits for the instructor: a SessionRun from the lane's
// start at half throttle to x = 9 (the whole truck over the patch), where the instructor starts
// the spill (or not), then the brake full on until the truck stands. Returns the distance the CoG
// ran from the brake's touch; `log` (when given) records the session.
double stop_on_the_late_spill(const SessionModel& model, bool start_it, const std::string& log = "") {
  const SessionState first = initial_state(model);
  SessionRun run(model, first, log.empty() ? nullptr : std::make_unique<ControlLogWriter>(log, log_header(model, first, "spill", "cab1")),
                 {0, false});
  ControlSample c;
  c.accelerator = 0.5;
  run.apply(1, driver_inputs(c, model.truck));
  while (run.state().x[kX] < 9.0 && run.state().t_s < 30) run.tick();
  const double from = run.state().x[kX];
  EXPECT_EQ(run.hazard_problem("OIL_LATE"), std::nullopt);
  if (start_it) {
    run.instruct({InstructorAction::kHazard, "OIL_LATE"});
    EXPECT_NE(run.hazard_problem("OIL_LATE"), std::nullopt) << "on the floor already";
  }
  c.accelerator = 0;
  c.brake = 1.0;
  run.apply(2, driver_inputs(c, model.truck));
  const auto v = [&] { return std::hypot(run.state().x[StateIndex::kQdot + kX], run.state().x[StateIndex::kQdot + kY]); };
  for (int i = 0; i < 100 || (v() > 0.01 && run.state().t_s < 40); ++i) run.tick();
  run.end(EndReason::kAborted);
  return run.state().x[kX] - from;
}

TEST(Hazards, ASpillTheInstructorStartsGripsLessFromThenOnAndReplaysBitForBit) {
  // A scene starting on lane y = -25 (the session's start is the scenario's).
  json j = json::parse(std::ifstream(kHazards));
  j["start"]["y_m"] = -25.0;
  const std::string dir = testing::TempDir();
  const std::string scenario = dir + "/hazards_lane_late_spill.json";
  std::ofstream(scenario) << j.dump(1);
  const SessionModel model = load_session_model(SessionSpec{scenario}, FORKLIFT_DATA_DIR);
  {
    const SessionRun probe(model, initial_state(model));
    ASSERT_TRUE(probe.hazard_problem("OIL"));
    EXPECT_NE(probe.hazard_problem("OIL")->find("on the floor from the start"), std::string::npos) << *probe.hazard_problem("OIL");
  }
  const std::string log = dir + "/hazards_late_spill.ctl";
  const double dry_m = stop_on_the_late_spill(model, false), oily_m = stop_on_the_late_spill(model, true, log);
  std::cout << "full brake from half throttle at x = 9: " << dry_m << " m with the spill waiting, " << oily_m
            << " m once the instructor started it\n";
  // Not yet started, the patch grips as the dry floor: the brakes' stop (ASpillLengthens...: under
  // a metre from 2 m/s). Started, the tyres slide on a fifth of their grip.
  EXPECT_GT(oily_m, 1.5 * dry_m);
  EXPECT_GT(dry_m, 0.05) << "it was moving";

  // The log names the spill at its tick, and its replay slides the same way, bit for bit.
  const ControlLog parsed = read_control_log(log);
  ASSERT_EQ(parsed.instructions.size(), 1u);
  EXPECT_EQ(parsed.instructions[0].second, (Instruction{InstructorAction::kHazard, "OIL_LATE"}));
  std::vector<StateVector> states;
  const ReplayResult r = replay_session(parsed, model, [&](const SessionState& st, const SessionWorkspace&) { states.push_back(st.x); });
  ASSERT_TRUE(parsed.final_state.has_value());
  EXPECT_EQ(std::memcmp(r.final_state.data(), parsed.final_state->data(), sizeof(double) * StateIndex::kSize), 0);
  EXPECT_EQ(r.event_lines, parsed.event_lines);
  // Without the instructor's line the replay stops short, as the spill waited.
  ControlLog without = parsed;
  without.instructions.clear();
  without.instruction_segments.clear();
  const ReplayResult dry = replay_session(without, model);
  EXPECT_NE(std::memcmp(dry.final_state.data(), parsed.final_state->data(), sizeof(double) * StateIndex::kSize), 0);
  EXPECT_LT(dry.final_state[kX], r.final_state[kX]);
}

// A rewind point kept before the instructor started the spill takes it away again: the state
// rewound to has it waiting, the dynamics grip as on the dry floor there, and the instructor
// may start it again.
TEST(Hazards, ARewindToBeforeTheSpillTakesItAway) {
  json j = json::parse(std::ifstream(kHazards));
  j["start"]["y_m"] = -25.0;
  const std::string scenario = testing::TempDir() + "/hazards_lane_late_spill_rewind.json";
  std::ofstream(scenario) << j.dump(1);
  const SessionModel model = load_session_model(SessionSpec{scenario}, FORKLIFT_DATA_DIR);
  SessionRun run(model, initial_state(model));
  run.keep_rewind_points(500, 4);
  ControlSample c;
  c.accelerator = 0.5;
  run.apply(1, driver_inputs(c, model.truck));
  for (int i = 0; i < 1000; ++i) run.tick();
  run.instruct({InstructorAction::kHazard, "OIL_LATE"});
  EXPECT_EQ(absent_spills(model.scene.spills, run.state().spills), 0u) << "on the floor";
  for (int i = 0; i < 700; ++i) run.tick();
  const auto point = run.rewind_point(0.7);
  ASSERT_TRUE(point);
  EXPECT_EQ(*point, 1000) << "kept as the instructor started it, before the tick that did";
  run.instruct({InstructorAction::kRewind, "", *point, 0.7});
  EXPECT_EQ(absent_spills(model.scene.spills, run.state().spills), 0b10u) << "OIL_LATE (the second) waiting again";
  EXPECT_EQ(run.hazard_problem("OIL_LATE"), std::nullopt) << "and the instructor may start it again";
}

TEST(Hazards, TheHornGoesThroughACabScriptAndASessionLogBitForBit) {
  // The clean drive past the markers as a cab script: forklift-sim marks it clean, and the same
  // script without its horn column is marked for the horn at both markers.
  Session s(scene("hazards.json"), Mode::kTraining, Vector3d(0, -10, 0));
  through_the_markers(s, 1.0, [](double x) { return (x > 6.0 && x < 7.0) || (x > 16.0 && x < 17.0); });
  ASSERT_TRUE(s.events.empty()) << s.summary();
  const std::string dir = testing::TempDir();
  const std::string script = dir + "/hazards_horn.csv";
  s.write_script(script, (s.ticks - 1) * Session::kTick, "hazards: past the markers at walking pace, the horn before each");

  // A scene starting on lane y = -10 (the session's start is the scenario's).
  json j = json::parse(std::ifstream(kHazards));
  j["start"]["y_m"] = -10.0;
  const std::string scenario = dir + "/hazards_lane_markers.json";
  std::ofstream(scenario) << j.dump(1);

  const std::string log = dir + "/hazards_horn.ctl";
  // The scene has no task, so its end judges the parking (the forks were left at travelling height).
  const auto marker_faults = [](const json& events) {
    int n = 0;
    for (const json& e : events) n += e["rule"] == "horn_at_marker" || e["rule"] == "speed_at_marker";
    return n;
  };
  const json clean = evaluate({"--scenario", scenario, "--script", script, "--out-log", log}, "hazards_horn");
  EXPECT_EQ(marker_faults(clean["events"]), 0) << clean["events"].dump(1);
  std::ifstream logged(log);
  std::string text((std::istreambuf_iterator<char>(logged)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find(" 0 1\n"), std::string::npos) << "an input line with the horn sounding";

  const SessionModel model = load_session_model(SessionSpec{scenario}, FORKLIFT_DATA_DIR);
  const ControlLog parsed = read_control_log(log);
  const ReplayResult r = replay_session(parsed, model);
  EXPECT_EQ(r.event_lines, parsed.event_lines);
  ASSERT_TRUE(parsed.score_line.has_value());
  EXPECT_EQ(r.score_line, *parsed.score_line);
  EXPECT_EQ(r.score.points, clean["score"]["points"].get<int>());
  ASSERT_TRUE(parsed.final_state.has_value());
  EXPECT_EQ(std::memcmp(r.final_state.data(), parsed.final_state->data(), sizeof(double) * StateIndex::kSize), 0);

  // The same rows with the horn column cut off.
  std::ifstream in(script);
  std::ofstream silent(dir + "/hazards_silent.csv");
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line[0] != '#' && std::count(line.begin(), line.end(), ',') == 8) line.erase(line.rfind(','));
    silent << line << "\n";
  }
  silent.close();
  const json quiet = evaluate({"--scenario", scenario, "--script", dir + "/hazards_silent.csv"}, "hazards_silent");
  int horns = 0;
  for (const json& e : quiet["events"]) horns += e["rule"] == "horn_at_marker";
  EXPECT_EQ(horns, 2) << quiet["events"].dump(1);
  EXPECT_EQ(marker_faults(quiet["events"]), 2) << "at walking pace all the same";
}

// --- a pallet falling from its rack ---

const PalletState& pf(const Session& s) { return *s.pallet("PF"); }

// Lane y = 40 at 1 m/s, forks at travelling height, until `done`.
void along_the_rack(Session& s, Driver& d, const std::function<bool()>& done) {
  d.lift_to = 0.2;
  d.settle_levers();
  drive(s, d, 1.0, 40.0, done);
}

TEST(Hazards, APalletFallsFromItsRackAsTheTruckComesAndLiesWhereItLanded) {
  Session s(scene("hazards.json"), Mode::kTraining, Vector3d(0, 40, 0));
  Driver d{s};
  const Eigen::Vector3d stood = s.scene.find("PF")->pose.translation();  // no step yet: as the scenario stands it
  EXPECT_NEAR(stood.z(), 2.7, 1e-9) << "on the top beams";
  along_the_rack(s, d, [&] { return s.state.falls.at(0).started; });
  // Triggered with the truck's outline 4 m from the pallet's middle.
  EXPECT_NEAR(distance_to_truck(truck_outline(s.shape), s.poses(), stood.head<2>()), 4.0, 0.01);
  const double t0 = s.state.falls[0].started_t_s;
  hold(s, d, [&] { return s.state.falls[0].landed; }, 5);  // braking
  // Free fall from 2.7 m: sqrt(2 h / g) = 0.742 s, to the tick.
  EXPECT_NEAR(s.t() - t0, std::sqrt(2 * 2.7 / kGravity_m_s2), 1.5e-3);
  const PalletState& p = pf(s);
  EXPECT_TRUE(p.dropped);
  EXPECT_TRUE(p.resting_on.empty());
  EXPECT_NEAR(p.pose.translation().z(), 0.0, 1e-12);
  EXPECT_NEAR(p.pose.translation().x(), 10.0, 1e-9);
  EXPECT_NEAR(p.pose.translation().y(), 42.0 - 1.2, 1e-9) << "thrown 1.2 m off the beams towards the lane";
  const Eigen::Vector3d landed_at = p.pose.translation();
  d.stop();
  hold(s, d, [] { return false; }, 2);
  EXPECT_EQ(pf(s).pose.translation(), landed_at) << "it lies there";
  EXPECT_TRUE(s.events.empty()) << s.summary() << "stopped short of it";
}

TEST(Hazards, ATruckDrivingOnIntoTheFallenPalletStrikesIt) {
  Session s(scene("hazards.json"), Mode::kTraining, Vector3d(0, 40, 0));
  Driver d{s};
  along_the_rack(s, d, [&] { return s.count("collision_pallet") + s.count("fork_strike_pallet") > 0 || s.pos().x() > 12; });
  ASSERT_GE(s.count("collision_pallet") + s.count("fork_strike_pallet"), 1) << s.summary();
  const EvaluationEvent& e = s.events.front();
  EXPECT_EQ(json::parse(e.details)["object"], "PF") << s.summary();
}

TEST(Hazards, TheFallIsPartOfTheStateAndReplaysBitForBit) {
  // A kept copy from just before the fall, stepped twice from scratch, drops it the same way.
  Session a(scene("hazards.json"), Mode::kTraining, Vector3d(0, 40, 0));
  Driver d{a};
  along_the_rack(a, d, [&] { return distance_to_truck(truck_outline(a.shape), a.poses(), Vector2d(10, 42)) < 4.3; });
  const SessionState kept = a.state;
  ASSERT_FALSE(kept.falls.at(0).started);
  const std::vector<SessionState> again = step_copies(a, kept, 700);
  ASSERT_TRUE(again[0].falls[0].started);
  const auto pose_of = [](const SessionState& st) { return st.handling.pallet("PF")->pose.matrix(); };
  EXPECT_LT(pose_of(again[0])(2, 3), 2.6) << "it was falling";
  EXPECT_EQ(std::memcmp(pose_of(again[0]).data(), pose_of(again[1]).data(), 16 * sizeof(double)), 0);
  EXPECT_EQ(std::memcmp(again[0].x.data(), again[1].x.data(), sizeof(double) * StateIndex::kSize), 0);

  // The drive as a cab script, its log replayed: the pallet where it was at every tick.
  const std::string dir = testing::TempDir();
  json j = json::parse(std::ifstream(kHazards));
  j["start"]["y_m"] = 40.0;
  const std::string scenario = dir + "/hazards_lane_rack.json";
  std::ofstream(scenario) << j.dump(1);
  Session s(scene("hazards.json"), Mode::kTraining, Vector3d(0, 40, 0));
  Driver ds{s};
  along_the_rack(s, ds, [&] { return s.state.falls.at(0).started; });
  ds.stop();
  hold(s, ds, [] { return false; }, 2);
  const std::string script = dir + "/hazards_fall.csv";
  s.write_script(script, (s.ticks - 1) * Session::kTick, "hazards: along the rack as PF falls, stopped short");
  const std::string log = dir + "/hazards_fall.ctl";
  const json run = evaluate({"--scenario", scenario, "--script", script, "--out-log", log}, "hazards_fall");
  const SessionModel model = load_session_model(SessionSpec{scenario}, FORKLIFT_DATA_DIR);
  std::vector<Eigen::Matrix4d> first, replayed;
  const auto record = [](std::vector<Eigen::Matrix4d>& into) {
    return [&into](const SessionState& st, const SessionWorkspace&) { into.push_back(st.handling.pallet("PF")->pose.matrix()); };
  };
  const std::vector<InputChange> changes = script_changes(script, model);
  run_offline(model, initial_state(model), changes, changes.back().tick + 1, EndReason::kDuration, nullptr, record(first));
  const ControlLog parsed = read_control_log(log);
  const ReplayResult r = replay_session(parsed, model, record(replayed));
  ASSERT_EQ(first.size(), replayed.size());
  ASSERT_GT(first.size(), 1000u);
  EXPECT_NE(first.front()(2, 3), first.back()(2, 3)) << "it fell";
  EXPECT_EQ(std::memcmp(first.data(), replayed.data(), first.size() * sizeof(Eigen::Matrix4d)), 0);
  ASSERT_TRUE(parsed.score_line.has_value());
  EXPECT_EQ(r.score_line, *parsed.score_line);
  EXPECT_EQ(r.score.points, run["score"]["points"].get<int>());
}

TEST(Hazards, TheInstructorDropsThePalletNowAndNotTwice) {
  const SessionModel model = load_session_model(SessionSpec{kHazards}, FORKLIFT_DATA_DIR);
  SessionRun run(model, initial_state(model));
  EXPECT_EQ(run.hazard_problem("PF"), std::nullopt);
  ASSERT_TRUE(run.hazard_problem("P9"));
  EXPECT_NE(run.hazard_problem("P9")->find("no pedestrian, falling pallet or spill 'P9'"), std::string::npos) << *run.hazard_problem("P9");
  for (int i = 0; i < 100; ++i) run.tick();
  run.instruct({InstructorAction::kHazard, "PF"});
  for (int i = 0; i < 1000; ++i) run.tick();
  EXPECT_TRUE(run.state().falls.at(0).landed) << "the truck at the start, 10 m off: the instructor's hand";
  EXPECT_NEAR(run.state().handling.pallet("PF")->pose.translation().z(), 0.0, 1e-12);
  ASSERT_TRUE(run.hazard_problem("PF"));
  EXPECT_NE(run.hazard_problem("PF")->find("fallen already"), std::string::npos);
}

}  // namespace
