// SessionRun: the one owner of a session's life around its tick. A run driven as the live worker
// drives it (the cab's samples, a dead-man stop and the cab's return, the instructor's abort, an
// integrator that fails) and its offline replay from the log write the same log, byte for byte,
// and give the same mark.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "forklift/session/controls.h"
#include "forklift/session/session.h"
#include "forklift/session/session_run.h"
#include "forklift/session/vocabulary.h"

namespace {

using namespace forklift;

const std::string kData = FORKLIFT_DATA_DIR;

std::string text_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

SessionModel yard_model() {
  SessionSpec spec;
  spec.scenario_file = kData + "/scenarios/first_drive_yard.json";
  return load_session_model(spec, kData);
}

DriverInputs drive(const SessionModel& m, double accelerator, double steer) {
  ControlSample c;
  c.accelerator = accelerator;
  c.steer_rad = steer;
  return driver_inputs(c, m.truck);
}

// What happens to the live run at a tick.
struct Act {
  int64_t tick;
  enum { kSample, kSilence, kResume, kAbort, kPause, kUnpause, kMessage, kRewind } what;
  double accelerator = 0, steer = 0;
  std::string text = "";  // kMessage's
  double seconds = 0;     // kRewind's
};

// Drives a run as the worker does and ends it; returns the log's path.
std::string live(const std::string& name, const std::vector<Act>& acts, bool nan_at_end = false) {
  const SessionModel model = yard_model();
  SessionState first = initial_state(model);
  const std::string path = testing::TempDir() + "/session_run_" + name + ".ctl";
  auto log = std::make_unique<ControlLogWriter>(path, log_header(model, first, name, "cab1"));
  SessionRun run(model, std::move(first), std::move(log), {0, false});
  run.keep_rewind_points(500, 4);  // every half second, the newest four
  uint32_t seq = 0;
  std::optional<EndReason> end;
  for (size_t next = 0; !end;) {
    for (; next < acts.size() && acts[next].tick <= run.state().tick; ++next) {
      const Act& a = acts[next];
      if (a.what == Act::kSample) run.apply(++seq, drive(model, a.accelerator, a.steer));
      if (a.what == Act::kSample) run.apply(seq, drive(model, a.accelerator, a.steer));  // a repeat: not logged again
      if (a.what == Act::kSilence) run.deadman();
      if (a.what == Act::kResume) run.resume();
      if (a.what == Act::kAbort) end = EndReason::kAborted;
      if (a.what == Act::kPause) run.instruct({InstructorAction::kPause, ""});
      if (a.what == Act::kUnpause) run.instruct({InstructorAction::kResume, ""});
      if (a.what == Act::kMessage) run.instruct({InstructorAction::kMessage, a.text});
      if (a.what == Act::kRewind) {
        const auto point = run.rewind_point(a.seconds);
        if (!point) {
          ADD_FAILURE() << "no rewind point " << a.seconds << " s back from tick " << run.state().tick;
          continue;
        }
        const SessionState kept = run.rewind_points().at(*point);
        run.instruct({InstructorAction::kRewind, "", *point, a.seconds});
        // The state after the rewind is the point's, bit for bit.
        EXPECT_EQ(run.state().tick, kept.tick);
        EXPECT_EQ(std::memcmp(run.state().x.data(), kept.x.data(), sizeof(double) * StateIndex::kSize), 0);
        EXPECT_EQ(run.state().handling.pallets().size(), kept.handling.pallets().size());
        EXPECT_EQ(run.state().evaluation.steps_done(), kept.evaluation.steps_done());
        EXPECT_TRUE(run.rewind_points().rbegin()->first == *point) << "the abandoned attempt's points are dropped";
      }
    }
    if (end) break;
    // Paused, the worker steps no tick until the resume, which comes in the same tick here.
    if (run.paused()) ADD_FAILURE() << "a tick stepped while paused at " << run.state().tick;
    if (next == acts.size() && nan_at_end) {
      DriverInputs broken = drive(model, 0.5, 0);
      broken.drive_torque_N_m = std::numeric_limits<double>::quiet_NaN();
      run.apply(++seq, broken);
    }
    end = run.tick().end;
  }
  run.end(*end);
  return path;
}

// The log's session again, offline, writing its own log; returns that log's path.
std::string offline(const std::string& live_path, const std::string& name) {
  const ControlLog log = read_control_log(live_path);
  const SessionModel model = load_session_model(log.header, kData);
  const SessionState first = initial_state(model, log.header);
  const std::string path = testing::TempDir() + "/session_run_" + name + ".offline.ctl";
  auto writer = std::make_unique<ControlLogWriter>(path, log_header(model, first, log.header.session_id, log.header.cab_id));
  run_offline(model, first, logged_changes(log), *log.ticks, logged_end_reason(log), std::move(writer));
  return path;
}

TEST(SessionRun, ADeadManStopAndAnAbortLogAndMarkTheSameLiveAndOffline) {
  const std::string a = live("abort", {{0, Act::kSample, 0.6, 0},
                                       {700, Act::kSample, 0.6, 0.2},
                                       {1500, Act::kSilence},        // the cab falls silent: stopped
                                       {2600, Act::kResume},         // and speaks again
                                       {2600, Act::kSample, 0.3, -0.1},
                                       {3100, Act::kSample, 0.3, -0.1},  // no change: not logged
                                       {3800, Act::kAbort}});
  const ControlLog log = read_control_log(a);
  ASSERT_EQ(log.deadman.size(), 2u);
  EXPECT_EQ(log.deadman[0], std::make_pair(int64_t(1500), true));
  EXPECT_EQ(log.deadman[1], std::make_pair(int64_t(2600), false));
  ASSERT_EQ(log.worker_events.size(), 1u);
  EXPECT_EQ(log.worker_events[0].second, kControlsResumedEvent);
  EXPECT_EQ(log.entries.size(), 4u) << "two samples, the dead man's stop, the resumed sample; never a repeat";
  EXPECT_EQ(log.end_reason(), "aborted");
  EXPECT_EQ(*log.ticks, 3800);
  bool deadman_event = false;
  for (const std::string& e : log.event_lines) deadman_event |= e.rfind("e 1501 deadman_stop ", 0) == 0;
  EXPECT_TRUE(deadman_event) << "the evaluation reports the stop on its tick";

  EXPECT_EQ(text_of(offline(a, "abort")), text_of(a)) << "the offline run's log, byte for byte";
  const ReplayResult r = replay_session(log, kData);
  EXPECT_EQ(r.score_line, *log.score_line);
  EXPECT_EQ(r.event_lines, log.event_lines);
  EXPECT_EQ(r.final_state, *log.final_state);
}

TEST(SessionRun, ANumericalFailureEndsTheSessionTheSameLiveAndOffline) {
  const std::string a = live("failure", {{0, Act::kSample, 0.5, 0}, {900, Act::kSilence}, {1200, Act::kResume}}, true);
  const ControlLog log = read_control_log(a);
  EXPECT_EQ(log.end_reason(), "numerical_failure");
  ASSERT_TRUE(log.final_state);
  EXPECT_TRUE(log.final_state->allFinite()) << "the last good state";
  EXPECT_EQ(text_of(offline(a, "failure")), text_of(a));
  const ReplayResult r = replay_session(log, kData);
  EXPECT_EQ(r.score_line, *log.score_line);
  EXPECT_EQ(r.ticks, *log.ticks);
}

TEST(SessionRun, TheLastInputAppliedInATickStandsForIt) {
  const SessionModel model = yard_model();
  const SessionState first = initial_state(model);
  const std::string path = testing::TempDir() + "/session_run_one_per_tick.ctl";
  SessionRun run(model, first, std::make_unique<ControlLogWriter>(path, log_header(model, first, "t", "c")));
  EXPECT_TRUE(run.apply(1, drive(model, 0.4, 0)));   // the first is always logged
  run.tick();
  EXPECT_TRUE(run.apply(2, drive(model, 0.8, 0)));
  EXPECT_TRUE(run.apply(3, drive(model, 0.2, 0)));   // supersedes 2 within the tick
  run.tick();
  EXPECT_TRUE(run.apply(4, drive(model, 0.9, 0)));
  EXPECT_FALSE(run.apply(5, drive(model, 0.2, 0)));  // back to the logged inputs: 4 is withdrawn
  EXPECT_EQ(run.applied_seq(), 5u);
  run.tick();
  run.end(EndReason::kSignal);
  const ControlLog log = read_control_log(path);
  ASSERT_EQ(log.entries.size(), 2u);
  EXPECT_EQ(log.entries[0].tick, 0);
  EXPECT_EQ(log.entries[1].tick, 1);
  EXPECT_EQ(log.entries[1].seq, 3u);
  EXPECT_EQ(log.end_reason(), "signal");
}

TEST(SessionRun, ItEndsWhenItsTimeIsUpOrItsTaskIsDone) {
  const SessionModel model = yard_model();
  SessionRun run(model, initial_state(model), nullptr, {0.05, true});
  std::optional<EndReason> end;
  while (!end) end = run.tick().end;
  EXPECT_EQ(end, EndReason::kDuration);
  EXPECT_NEAR(run.state().t_s, 0.05, 1e-9);
}

// The shipped cab scripts (data/evaluation/scripts/drives.json), each driven through a SessionRun
// as the worker drives it: its rows applied at their ticks, the session ended when its task is
// done and the truck let be ("task_complete"), else at the script's end. A clean drive does every
// step with no fault and is marked 100; a faulty one gives exactly the faults it names.
struct ShippedDrive {
  std::string script, scenario, mode;
  std::set<std::string> faults;
};

void PrintTo(const ShippedDrive& d, std::ostream* os) { *os << d.script; }  // its name in test lists

std::vector<ShippedDrive> shipped_drives() {
  const std::string dir = kData + "/evaluation/scripts";
  const nlohmann::json listed = nlohmann::json::parse(text_of(dir + "/drives.json"));
  std::vector<ShippedDrive> out;
  for (const auto& d : listed.at("drives"))
    out.push_back({d.at("script"), d.at("scenario"), d.at("mode"), d.at("faults").get<std::set<std::string>>()});
  return out;
}

TEST(ShippedDrives, EveryScriptIsListedWithWhatItGives) {
  std::set<std::string> listed;
  for (const ShippedDrive& d : shipped_drives()) listed.insert(d.script);
  for (const auto& f : std::filesystem::directory_iterator(kData + "/evaluation/scripts")) {
    if (f.path().extension() != ".csv") continue;
    EXPECT_EQ(listed.count(f.path().filename().string()), 1u) << f.path() << " is not in drives.json";
  }
}

class ShippedDriveTest : public testing::TestWithParam<ShippedDrive> {};

TEST_P(ShippedDriveTest, GivesTheFaultsItNamesAndNoOther) {
  const ShippedDrive& d = GetParam();
  SessionSpec spec;
  spec.scenario_file = kData + "/" + d.scenario;
  spec.mode = d.mode;
  const SessionModel model = load_session_model(spec, kData);
  const std::vector<InputChange> changes = script_changes(kData + "/evaluation/scripts/" + d.script, model);
  ASSERT_FALSE(changes.empty());
  // The script's last row acts for one tick, as forklift-sim evaluate runs it.
  const double script_end_s = double(changes.back().tick + 1) * model.tick_s;
  SessionRun run(model, initial_state(model), nullptr, {script_end_s, true});
  std::vector<SessionEvent> events;
  std::optional<EndReason> end;
  for (size_t next = 0; !end;) {
    for (; next < changes.size() && changes[next].tick <= run.state().tick; ++next) feed(run, changes[next]);
    const SessionRun::Tick t = run.tick();
    events.insert(events.end(), t.events.begin(), t.events.end());
    end = t.end;
  }
  const Score score = run.end(*end);
  events.insert(events.end(), run.end_events().begin(), run.end_events().end());
  std::set<std::string> faults;
  std::string said;
  for (const SessionEvent& e : events)
    if (event_origin(e.kind) == EventOrigin::kEvaluation) {
      faults.insert(e.kind);
      said += "  " + e.kind + " " + e.details.substr(0, 400) + "\n";
    }
  EXPECT_EQ(faults, d.faults) << d.script << " ended (" << name(*end) << ") at " << run.state().t_s << " s with:\n" << said;
  if (d.faults.empty()) {
    EXPECT_EQ(*end, EndReason::kTaskComplete) << "its task done and the truck let be, before its script ran out";
    EXPECT_EQ(score.mark, 100);
    EXPECT_TRUE(score.passed);
    EXPECT_TRUE(score.task_completed);
  } else {
    EXPECT_EQ(score.mark, 100 - score.points);
  }
}

INSTANTIATE_TEST_SUITE_P(Shipped, ShippedDriveTest, testing::ValuesIn(shipped_drives()),
                         [](const testing::TestParamInfo<ShippedDrive>& i) {
                           return i.param.script.substr(0, i.param.script.find('.'));
                         });

}  // namespace

// The instructor's pause, message and resume, and an abort while paused: each on the log at its
// tick, before that tick's input; the offline run from the log writes the same log byte for byte,
// and the same inputs without the instructor give the same truck and mark (a pause holds the
// session's clock, it does not change its physics).
TEST(SessionRun, TheInstructorsPauseAndMessageAreLoggedAndReplayedByteForByte) {
  const std::string said = "Slow down before the corner: brake gently, then steer \u00e9 \u2192 ok";
  const std::vector<Act> driving = {{0, Act::kSample, 0.6, 0}, {500, Act::kSample, 0.2, 0.1}, {900, Act::kSample, 0.4, -0.1}};
  std::vector<Act> acts = {driving[0],
                           {500, Act::kPause},
                           {500, Act::kMessage, 0, 0, said},
                           driving[1],  // the cab's sample while paused: applied when the clock runs again
                           {500, Act::kUnpause},
                           driving[2],
                           {1200, Act::kMessage, 0, 0, "Stop here"},
                           {1200, Act::kPause},
                           {1200, Act::kAbort}};
  const std::string a = live("instructor", acts);
  const ControlLog log = read_control_log(a);
  ASSERT_EQ(log.instructions.size(), 5u);
  EXPECT_EQ(log.instructions[0], (std::pair<int64_t, Instruction>{500, {InstructorAction::kPause, ""}}));
  EXPECT_EQ(log.instructions[1], (std::pair<int64_t, Instruction>{500, {InstructorAction::kMessage, said}}));
  EXPECT_EQ(log.instructions[2], (std::pair<int64_t, Instruction>{500, {InstructorAction::kResume, ""}}));
  EXPECT_EQ(log.instructions[3], (std::pair<int64_t, Instruction>{1200, {InstructorAction::kMessage, "Stop here"}}));
  EXPECT_EQ(log.instructions[4], (std::pair<int64_t, Instruction>{1200, {InstructorAction::kPause, ""}}));
  const std::string text = text_of(a);
  EXPECT_LT(text.find("instructor 500 resume\n"), text.find("i 500 ")) << "a tick's instructions before its input";
  EXPECT_LT(text.find("instructor 1200 pause\n"), text.find("score ")) << "ended paused: the pause on record";
  EXPECT_EQ(log.end_reason(), "aborted");

  EXPECT_EQ(text_of(offline(a, "instructor")), text) << "the offline run's log, byte for byte";
  const ReplayResult r = replay_session(log, kData);
  EXPECT_EQ(r.final_state, *log.final_state);
  EXPECT_EQ(r.score_line, *log.score_line);
  EXPECT_EQ(r.event_lines, log.event_lines);

  const ControlLog plain = read_control_log(live("no_instructor", {driving[0], driving[1], driving[2], {1200, Act::kAbort}}));
  EXPECT_EQ(*plain.final_state, *log.final_state);
  EXPECT_EQ(plain.score_line, log.score_line);
  EXPECT_EQ(plain.event_lines, log.event_lines);
}

// A log's instructor lines are read as written, and a broken one is refused naming its line.
TEST(SessionRun, ABrokenInstructorLineIsRefused) {
  const std::string good = live("instructor_lines", {{0, Act::kSample, 0.3, 0}, {10, Act::kMessage, 0, 0, "two  spaces kept"}, {20, Act::kAbort}});
  EXPECT_EQ(read_control_log(good).instructions.at(0).second.text, "two  spaces kept");
  const std::string body = text_of(good);
  for (const char* bad : {"instructor 10 jump\n", "instructor 10 pause now\n", "instructor 10 message\n",
                                 "instructor 10 message \x01" "bell\n", "instructor 10 message \xc3\n"}) {
    const std::string path = testing::TempDir() + "/session_run_bad_instructor.ctl";
    std::ofstream(path, std::ios::binary) << body.substr(0, body.find("end ")) << bad << body.substr(body.find("end "));
    EXPECT_THROW(read_control_log(path), std::runtime_error) << bad;
  }
}

// "Try that again": the instructor takes the session back to a kept point (at least the seconds
// asked), its state exactly the point's; the log records where it went, its ticks count again from
// there, and the offline run from the log, which keeps the states its log goes back to, writes the
// same log byte for byte, twice rewound, paused and all; a rewind to where nothing is kept is
// refused with the tick named.
TEST(SessionRun, ARewindGoesBackToAKeptPointAndTheLogReplaysItByteForByte) {
  const std::vector<Act> acts = {{0, Act::kSample, 0.6, 0},
                                 {1300, Act::kSample, 0.5, 0.3},
                                 {2300, Act::kPause},
                                 {2300, Act::kRewind, 0, 0, "", 0.6},  // back to 1500: the newest point at least 600 ticks back
                                 {1500, Act::kSample, 0.2, -0.2},      // the pupil tries again, from the point's tick on
                                 {1500, Act::kUnpause},
                                 {2600, Act::kRewind, 0, 0, "", 0.2},  // back to 2000
                                 {2400, Act::kSample, 0.3, 0},
                                 {3000, Act::kAbort}};
  const std::string a = live("rewind", acts);
  const ControlLog log = read_control_log(a);
  std::vector<std::pair<int64_t, int64_t>> rewinds;
  for (const auto& [tick, what] : log.instructions)
    if (what.action == InstructorAction::kRewind) rewinds.emplace_back(tick, what.to_tick);
  EXPECT_EQ(rewinds, (std::vector<std::pair<int64_t, int64_t>>{{2300, 1500}, {2600, 2000}}));
  EXPECT_EQ(*log.ticks, 3000);
  ASSERT_GE(log.entries.size(), 4u);
  EXPECT_EQ(log.entries.back().segment, 2) << "two rewinds before the last input";
  const std::string text = text_of(a);
  EXPECT_LT(text.find("instructor 2300 pause\n"), text.find("instructor 2300 rewind 1500\n"));

  EXPECT_EQ(text_of(offline(a, "rewind")), text) << "the offline run's log, byte for byte";
  const ReplayResult r = replay_session(log, kData);
  EXPECT_EQ(r.final_state, *log.final_state);
  EXPECT_EQ(r.score_line, *log.score_line);
  EXPECT_EQ(r.event_lines, log.event_lines);

  const SessionModel model = yard_model();
  SessionRun run(model, initial_state(model));
  run.keep_rewind_points(500, 2);
  for (int i = 0; i < 1600; ++i) run.tick();
  EXPECT_EQ(run.rewind_point(0.5), 1000);
  EXPECT_EQ(run.rewind_point(1.0), std::nullopt) << "tick 0 has gone: the newest two are 1000 and 1500";
  EXPECT_THROW(run.instruct({InstructorAction::kRewind, "", 700, 0}), std::runtime_error);
}

// "Hazard now": the instructor sets a scenario's pedestrian walking before his trigger would
// (the truck stands 10 m from him, beyond his 8 m); he walks at his speed from then on, the log
// says when and who, and the offline run from the log writes the same log byte for byte.
TEST(SessionRun, AHazardSetsAScenariosPedestrianWalkingNowAndReplaysByteForByte) {
  SessionSpec spec;
  spec.scenario_file = kData + "/scenarios/pedestrian_awareness.json";
  const SessionModel model = load_session_model(spec, kData);
  const SessionState first = initial_state(model);
  const std::string path = testing::TempDir() + "/session_run_hazard.ctl";
  SessionRun run(model, first, std::make_unique<ControlLogWriter>(path, log_header(model, first, "hazard", "cab1")), {0, false});
  EXPECT_NE(run.hazard_problem("W9"), std::nullopt) << "no such pedestrian";
  for (int i = 0; i < 100; ++i) run.tick();
  ASSERT_EQ(run.state().pedestrians.size(), 2u);  // W1, and W2 past the door
  const Eigen::Vector2d at_start = run.state().pedestrians[0].at_m;
  EXPECT_FALSE(run.state().pedestrians[0].started) << "beyond his trigger";
  EXPECT_EQ(run.hazard_problem("W1"), std::nullopt);
  run.instruct({InstructorAction::kHazard, "W1"});
  EXPECT_NE(run.hazard_problem("W1"), std::nullopt) << "walking already";
  for (int i = 0; i < 1000; ++i) run.tick();
  EXPECT_NEAR((run.state().pedestrians[0].at_m - at_start).norm(), 1.2, 0.01) << "a second at his 1.2 m/s";
  run.end(EndReason::kAborted);
  const ControlLog log = read_control_log(path);
  ASSERT_EQ(log.instructions.size(), 1u);
  EXPECT_EQ(log.instructions[0], (std::pair<int64_t, Instruction>{100, {InstructorAction::kHazard, "W1"}}));
  EXPECT_EQ(text_of(offline(path, "hazard")), text_of(path)) << "the offline run's log, byte for byte";
}
