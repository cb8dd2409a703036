// The session as a value: a SessionState copy is a rewind point, and one pipeline gives the same
// marks live, through `forklift-sim evaluate --replay` and through `forklift-worker --replay`.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "evaluation/harness.h"
#include "support/process.h"

namespace {

using namespace evt;
using nlohmann::json;

bool same_bits(const StateVector& a, const StateVector& b) { return std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0; }

// The yard's clean exam, through the session's own loader and step().
struct Yard {
  SessionModel model;
  std::vector<InputChange> changes;
  explicit Yard(IntegratorKind kind = IntegratorKind::kCvodeBdf) {
    SessionSpec spec;
    spec.scenario_file = data("scenarios/first_drive_yard.json");
    spec.mode = "exam";
    spec.integrator.kind = kind;
    model = load_session_model(spec, FORKLIFT_DATA_DIR);
    changes = script_changes(data("evaluation/scripts/first_drive_yard_exam.csv"), model);
  }
  // Steps `state` to `end_tick` with the script's inputs in `ws`; returns the events' count.
  size_t run(SessionState& state, SessionWorkspace& ws, int64_t end_tick) const {
    std::vector<SessionEvent> events;
    SessionInputs in;
    size_t next = 0;
    while (state.tick < end_tick) {
      for (; next < changes.size() && changes[next].tick <= state.tick; ++next) in = changes[next].inputs;
      step(model, state, ws, in, events);
    }
    return events.size();
  }
};

void expect_same(const SessionState& a, const SessionState& b) {
  EXPECT_EQ(a.tick, b.tick);
  EXPECT_TRUE(same_bits(a.x, b.x));
  EXPECT_EQ(a.t_s, b.t_s);
  EXPECT_EQ(a.load.has_value(), b.load.has_value());
  ASSERT_EQ(a.handling.pallets().size(), b.handling.pallets().size());
  for (size_t i = 0; i < a.handling.pallets().size(); ++i)
    EXPECT_TRUE(a.handling.pallets()[i].pose.isApprox(b.handling.pallets()[i].pose, 0.0)) << a.handling.pallets()[i].id;
  EXPECT_EQ(a.evaluation.events().size(), b.evaluation.events().size());
  EXPECT_EQ(a.evaluation.points(), b.evaluation.points());
  EXPECT_EQ(a.evaluation.steps_done(), b.evaluation.steps_done());
}

TEST(SessionState, ACopyIsARewindPointBitForBit) {
  const Yard yard;
  SessionState live = initial_state(yard.model);
  SessionWorkspace ws(yard.model);
  yard.run(live, ws, 20000);  // 20 s in: moving, a task step or two done
  ASSERT_GT(live.evaluation.steps_done(), 0) << "the copy should carry the task's progress";
  const SessionState rewind = live;

  yard.run(live, ws, 26000);  // the live session goes on

  // The copy, stepped in a fresh workspace and again in the live one (a rewind), gives the same
  // state to the bit: nothing the future needs was left in a workspace.
  SessionState a = rewind, b = rewind;
  SessionWorkspace fresh(yard.model);
  yard.run(a, fresh, 26000);
  yard.run(b, ws, 26000);
  expect_same(a, b);
  // And the rewound session is the live one, to within the integrator's tolerance: the rewind
  // restarts CVODE's step history, nothing else.
  EXPECT_LT((a.x.head<2>() - live.x.head<2>()).norm(), 1e-3);
  EXPECT_EQ(a.evaluation.points(), live.evaluation.points());
  EXPECT_EQ(a.evaluation.steps_done(), live.evaluation.steps_done());
}

TEST(SessionState, WithAMemorylessIntegratorACopyContinuesTheLiveSessionExactly) {
  const Yard yard(IntegratorKind::kRk4);
  SessionState live = initial_state(yard.model);
  SessionWorkspace ws(yard.model);
  yard.run(live, ws, 3000);
  SessionState copy = live;
  yard.run(live, ws, 5000);
  SessionWorkspace other(yard.model);
  yard.run(copy, other, 5000);
  expect_same(copy, live);
}

// Every shipped script: the live session (forklift-sim evaluate, logging it), its replay through
// forklift-sim evaluate --replay and through forklift-worker --replay give the same marks.
struct Shipped {
  std::string name, scenario, script;
};
std::vector<Shipped> shipped() {
  std::vector<Shipped> out;
  const std::string d = FORKLIFT_DATA_DIR;
  for (const char* s : {"first_drive_yard_exam", "first_drive_yard_faults"})
    out.push_back({s, d + "/scenarios/first_drive_yard.json", d + "/evaluation/scripts/" + s + ".csv"});
  for (const auto& f : std::filesystem::directory_iterator(d + "/manoeuvres"))
    if (f.path().extension() == ".csv") {
      const std::string stem = f.path().stem().string();
      out.push_back({stem, d + "/manoeuvres/" + stem + ".json", f.path().string()});
    }
  return out;
}

class ShippedScript : public testing::TestWithParam<Shipped> {};

json run_json(const std::vector<std::string>& argv, const std::string& tag, int want = 0) {
  Process p(argv, testing::TempDir() + "/session_" + tag);
  EXPECT_EQ(p.wait(300), want) << p.err();
  return json::parse(p.out());
}

TEST_P(ShippedScript, ReplaysGiveTheLiveMarks) {
  const Shipped& s = GetParam();
  const std::string bin = FORKLIFT_BIN_DIR, log = testing::TempDir() + "/session_" + s.name + ".ctl";
  const json live = run_json({bin + "/forklift-sim", "evaluate", "--json", "--scenario", s.scenario, "--script", s.script, "--mode",
                              "exam", "--out-log", log}, s.name + "_live");
  const json again = run_json({bin + "/forklift-sim", "evaluate", "--json", "--replay", log}, s.name + "_replay");
  EXPECT_EQ(again["mode"], "exam");  // marked as the log says
  EXPECT_EQ(again["score"], live["score"]);
  EXPECT_EQ(again["events"], live["events"]);
  EXPECT_EQ(again["ticks"], live["ticks"]);
  const json worker = run_json({bin + "/forklift-worker", "--replay", log, "--json"}, s.name + "_worker");
  EXPECT_EQ(worker["matches_log"], true) << "final state bit for bit";
  EXPECT_EQ(worker["events_match_log"], true) << "the same events and the same mark";
  EXPECT_EQ(worker["score"]["mark"], live["score"]["mark"]) << "a number, never the log's hex float";
}

// The debrief's replay: `forklift-sim trace` re-simulates a log and samples it
// every 0.1 s of sim time, ending where the log's session ended; a broken log is refused.
TEST(Trace, SamplesTheReplayedSessionEveryTenthOfASecond) {
  const std::string bin = FORKLIFT_BIN_DIR, d = FORKLIFT_DATA_DIR, log = testing::TempDir() + "/session_trace.ctl";
  const json live = run_json({bin + "/forklift-sim", "evaluate", "--json", "--scenario", d + "/scenarios/first_drive_yard.json", "--script",
                              d + "/evaluation/scripts/first_drive_yard_faults.csv", "--out-log", log}, "trace_live");
  const json trace = run_json({bin + "/forklift-sim", "trace", log}, "trace");
  const int64_t ticks = live["ticks"];
  EXPECT_EQ(trace["ticks"], ticks);
  const json& samples = trace["samples"];
  ASSERT_EQ(samples.size(), static_cast<size_t>(ticks / 100));
  double travelled = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    EXPECT_NEAR(samples[i]["t"].get<double>(), 0.1 * double(i + 1), 1e-9);
    EXPECT_EQ(samples[i]["pallets"].size(), trace["pallet_ids"].size());
    if (i) travelled += std::hypot(samples[i]["x_m"].get<double>() - samples[i - 1]["x_m"].get<double>(),
                                   samples[i]["y_m"].get<double>() - samples[i - 1]["y_m"].get<double>());
    // The forks' tips lie a fork's length ahead of their heels.
    const json &heel = samples[i]["fork_heel_m"], &tip = samples[i]["fork_tip_m"];
    EXPECT_NEAR(std::hypot(tip[0].get<double>() - heel[0].get<double>(), tip[1].get<double>() - heel[1].get<double>()),
                trace["truck"]["fork_length_m"].get<double>(), 0.05);
  }
  EXPECT_GT(travelled, 5.0);  // the faults drive covers the yard's first stretch
  // Every tick: the last sample is the session's final state, at its last tick.
  const json every = run_json({bin + "/forklift-sim", "trace", log, "--every", "0.001"}, "trace_every");
  EXPECT_NEAR(every["samples"].back()["t"].get<double>(), 0.001 * double(ticks), 1e-9);
  EXPECT_EQ(every["samples"][99], samples[0]);  // the same replay, sampled finer

  {
    std::ofstream broken(log + ".broken");
    broken << "not a control log\n";
  }
  Process p({bin + "/forklift-sim", "trace", log + ".broken"}, testing::TempDir() + "/session_trace_broken");
  EXPECT_EQ(p.wait(60), 2);
  EXPECT_NE(p.err().find("forklift-sim trace:"), std::string::npos) << p.err();
}

INSTANTIATE_TEST_SUITE_P(All, ShippedScript, testing::ValuesIn(shipped()),
                         [](const testing::TestParamInfo<Shipped>& i) { return i.param.name; });

}  // namespace
