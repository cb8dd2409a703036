// forklift-bench-evaluation: what the driver evaluation adds to a 1 ms physics tick, beside the
// dynamics and the collision step measured in the same run.
//
// Design: a scripted session runs the worker's step() tick by tick; each of its stages (dynamics,
// collision and handling, the evaluator's inputs, the evaluation) is timed with the steady clock
// through a StageObserver, and the session restarts when its script ends. Two scenes:
//   yard       first_drive_yard with the shipped clean exam script (a 150 s drive over the
//              ramp; 2 zones, a route, 5 task steps, a few objects)
//   warehouse  practical_exam (the full warehouse: 13 zones, a 3 m route, about 70 objects)
//              with the first 60 s of the same script (the truck drives into the warehouse's
//              walls and racks, so contacts, collision events and their JSON are included)
//   yard_people_10  the yard with 10 pedestrians added (every other one looks; each walks 40 m
//              to and fro past the start, 6 m and more beside it): the walk, their bodies in
//              the collision world and the speed rule near people, against the yard's 0
//   yard_hazards_50  the yard with 50 hazards: 40 pedestrians as above, 5 markers (blind
//              corners on the drive's way: the horn and speed rules) and 5 spills (a tenth less
//              grip, under the drive: the tyres' grip looked up at every wheel every tick)
//   yard_people_10_trucks_2  the yard's 10 pedestrians and 2 other trucks looping 40 m beside
//              the start, and a crossing where they go first on the drive's way (the goal)
//   yard_moving_50  50 moving hazards: 40 pedestrians and 10 other trucks
// Rows:
//   pipeline/<scene>   manual time = the whole tick; counters: per-tick microseconds of each
//                      stage (dynamics_us, collision_us, outputs_us, evaluation_us) and the ratios
//                      evaluation/dynamics and evaluation/collision
//   evaluator/<scene>  Evaluator::tick alone, over 20 000 recorded ticks of that session (a
//                      fresh evaluator per pass, built outside the timing)
// Target: evaluation under 10 us per tick.
//
//   forklift-bench-evaluation [Google Benchmark flags, e.g. --benchmark_repetitions=5]
#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <map>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "benchmark_args.h"
#include "figure.h"
#include "forklift/session/session.h"

using namespace forklift;
using Clock = std::chrono::steady_clock;

namespace {

const std::string kData = FORKLIFT_DATA_DIR;

// One scripted session through the session's own step(), restartable.
struct Run {
  SessionModel model;
  std::vector<InputChange> changes;
  int64_t end = 0;
  SessionState first, state;
  std::unique_ptr<SessionWorkspace> ws;
  size_t next = 0;
  SessionInputs held;
  std::vector<SessionEvent> found;
  size_t events = 0;

  Run(const std::string& scenario, const std::string& script, double max_s, int people = 0, int fixed = 0, int trucks = 0) {
    SessionSpec spec;
    spec.scenario_file = scenario;
    spec.mode = "exam";
    model = load_session_model(spec, kData);
    add_people(people);
    add_fixed(fixed);
    add_trucks(trucks);
    changes = script_changes(script, model);
    end = std::min<int64_t>(changes.back().tick + 1, int64_t(max_s / model.tick_s));
    first = initial_state(model);
    restart();
  }

  // `n` people walking to and fro along lines across x, from 6 m beside the start outwards.
  void add_people(int n) {
    const Eigen::Vector2d at(model.scene.scenario.x_m, model.scene.scenario.y_m);
    for (int i = 0; i < n; ++i) {
      PedestrianSpec p;
      p.id = "bench_person_" + std::to_string(i);
      const Eigen::Vector2d a = at + Eigen::Vector2d(-20, 6 + 1.5 * i), b = at + Eigen::Vector2d(20, 6 + 1.5 * i);
      p.path = {a, b, a, b, a};
      p.speed_m_s = 1.2;
      p.looks = i % 2 == 0;
      p.stop_within_m = p.looks ? 3.0 : 0.0;
      model.scene.pedestrians.push_back(p);
    }
  }

  // `n` other trucks driving round 40 m loops beside the start (from 8 m on the other side from
  // the people, 3 m apart), their drivers looking ahead, and one crossing where the traffic goes
  // first on the drive's first leg (the give-way rule's test every tick).
  void add_trucks(int n) {
    if (n == 0) return;
    const Eigen::Vector2d at(model.scene.scenario.x_m, model.scene.scenario.y_m);
    for (int i = 0; i < n; ++i) {
      OtherTruckSpec t;
      t.id = "bench_truck_" + std::to_string(i);
      const double y = -8 - 3.0 * i;
      t.route = {at + Eigen::Vector2d(-20, y), at + Eigen::Vector2d(20, y)};
      t.loop = true;
      t.speed_m_s = 2.0;
      t.stop_within_m = 2.0;
      model.scene.trucks.push_back(t);
    }
    Crossing c;
    c.id = "bench_crossing";
    c.priority = "traffic";
    for (const Eigen::Vector2d& d : {Eigen::Vector2d(18, -2), Eigen::Vector2d(22, -2), Eigen::Vector2d(22, 2), Eigen::Vector2d(18, 2)})
      c.polygon.push_back(at + d);
    c.middle_m = at + Eigen::Vector2d(20, 0);
    model.scene.crossings.push_back(c);
  }

  // `n` blind-corner markers and `n` spills, 3 m squares every 8 m ahead of the start (the yard
  // drive's first leg runs through them).
  void add_fixed(int n) {
    const Eigen::Vector2d at(model.scene.scenario.x_m, model.scene.scenario.y_m);
    std::vector<GripPatch> grip = model.scene.ground.grip_patches();
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector2d c = at + Eigen::Vector2d(4 + 8 * i, 0);
      const Eigen::AlignedBox2d box(c - Eigen::Vector2d(1.5, 1.5), c + Eigen::Vector2d(1.5, 1.5));
      Marker m;
      m.id = "bench_marker_" + std::to_string(i);
      m.kind = "blind_corner";
      for (int k : {0, 1, 3, 2}) m.polygon.push_back(box.corner(Eigen::AlignedBox2d::CornerType(k)));
      model.scene.markers.push_back(m);
      Spill spill;  // on the floor from the start
      spill.id = "bench_spill_" + std::to_string(i);
      spill.rect = box.translated(Eigen::Vector2d(4, 0));
      spill.friction_scale = 0.9;
      model.scene.spills.push_back(spill);
      grip.push_back({model.scene.spills.back().rect, 0.9});
    }
    if (n > 0) model.scene.ground = Ground(model.scene.ground.ramps(), model.scene.ground.steps(), grip);
  }

  void restart() {
    state = first;
    ws = std::make_unique<SessionWorkspace>(model);
    next = 0;
    held = {};
    events = 0;
  }
  void apply_inputs() {
    while (next < changes.size() && changes[next].tick <= state.tick) held = changes[next++].inputs;
  }
};

struct Scenes {
  const char* name;
  std::string scenario;
  double max_s;
  int people = 0;
  int fixed = 0;  // markers, and as many spills
  int trucks = 0;  // other trucks
};
const Scenes kYard{"yard", kData + "/scenarios/first_drive_yard.json", 1e9};
const Scenes kWarehouse{"warehouse", kData + "/scenarios/practical_exam.json", 60};
const Scenes kYardPeople{"yard_people_10", kYard.scenario, 1e9, 10};
const Scenes kYardHazards{"yard_hazards_50", kYard.scenario, 1e9, 40, 5};
const Scenes kYardTraffic{"yard_people_10_trucks_2", kYard.scenario, 1e9, 10, 0, 2};
const Scenes kYardMoving{"yard_moving_50", kYard.scenario, 1e9, 40, 0, 10};
const std::string kScript = kData + "/evaluation/scripts/first_drive_yard_exam.csv";

double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Times each stage of step() with the steady clock.
struct StageTimes : StageObserver {
  Clock::time_point t0;
  double last = 0, total = 0;
  std::array<double, 4> sum{};
  void begin(Stage) override { t0 = Clock::now(); }
  void end(Stage s) override {
    const double d = since(t0);
    sum[size_t(s)] += d;
    last += d;
  }
};

// Each scene's tick times, for the table of figures (main()).
std::map<std::string, std::vector<double>> g_tick_s;

void BM_Pipeline(benchmark::State& state, Scenes sc) {
  Run run(sc.scenario, kScript, sc.max_s, sc.people, sc.fixed, sc.trucks);
  std::vector<double>& ticks = g_tick_s[sc.name];
  StageTimes times;
  for (auto _ : state) {
    if (run.state.tick >= run.end) run.restart();  // a few milliseconds, once per session; not timed
    run.apply_inputs();
    times.last = 0;
    step(run.model, run.state, *run.ws, run.held, run.found, &times);
    run.events += run.ws->evaluation_events().size();
    run.found.clear();
    state.SetIterationTime(times.last);
    ticks.push_back(times.last);
  }
  const auto per_tick = [&](double total) { return benchmark::Counter(total * 1e6, benchmark::Counter::kAvgIterations); };
  const double dyn = times.sum[size_t(Stage::kDynamics)], col = times.sum[size_t(Stage::kCollision)];
  const double eval = times.sum[size_t(Stage::kEvaluation)];
  state.counters["dynamics_us"] = per_tick(dyn);
  state.counters["collision_us"] = per_tick(col);
  state.counters["outputs_us"] = per_tick(times.sum[size_t(Stage::kOutputs)]);
  state.counters["evaluation_us"] = per_tick(eval);
  state.counters["eval/dyn"] = eval / dyn;
  state.counters["eval/coll"] = eval / col;
  state.counters["events"] = double(run.events);
}

// What a tick hands the evaluator, kept by value.
struct Recorded {
  double t;
  Outputs out;
  BodyPoses poses;
  DriverInputs u;
  StepReport report;
  std::vector<PalletState> pallets;
  std::optional<Load> load;
};

void BM_EvaluatorTick(benchmark::State& state, Scenes sc) {
  Run run(sc.scenario, kScript, sc.max_s);
  std::vector<Recorded> rec;
  const int64_t n = std::min<int64_t>(20000, run.end);
  rec.reserve(n);
  while (run.state.tick < n) {
    run.apply_inputs();
    step(run.model, run.state, *run.ws, run.held, run.found);
    run.found.clear();
    rec.push_back({run.state.t_s, run.ws->outputs(), run.ws->poses(), run.held.driver, run.ws->report(),
                   run.state.handling.pallets(), run.state.load});
  }
  size_t i = rec.size();
  const SessionModel& m = run.model;
  Evaluator ev(m.rules, m.scene, m.truck, m.shape, Mode::kExam);
  EvaluationMemory memory;
  std::vector<EvaluationEvent> events;
  for (auto _ : state) {
    if (i == rec.size()) {
      state.PauseTiming();
      memory = EvaluationMemory();
      events.clear();
      i = 0;
      state.ResumeTiming();
    }
    const Recorded& r = rec[i++];
    const TickInput in{r.t, r.out, r.poses, r.u, r.report, r.pallets, r.load};
    ev.tick(memory, in, events);
    benchmark::DoNotOptimize(events.data());
  }
  state.counters["ticks_recorded"] = double(rec.size());
}

BENCHMARK_CAPTURE(BM_Pipeline, yard, kYard)->Name("pipeline/yard")->UseManualTime()->Iterations(150000)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Pipeline, warehouse, kWarehouse)->Name("pipeline/warehouse")->UseManualTime()->Iterations(60000)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Pipeline, yard_people_10, kYardPeople)->Name("pipeline/yard_people_10")->UseManualTime()->Iterations(150000)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Pipeline, yard_hazards_50, kYardHazards)->Name("pipeline/yard_hazards_50")->UseManualTime()->Iterations(150000)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Pipeline, yard_people_10_trucks_2, kYardTraffic)->Name("pipeline/yard_people_10_trucks_2")->UseManualTime()->Iterations(150000)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Pipeline, yard_moving_50, kYardMoving)->Name("pipeline/yard_moving_50")->UseManualTime()->Iterations(150000)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_EvaluatorTick, yard, kYard)->Name("evaluator/yard")->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_EvaluatorTick, warehouse, kWarehouse)->Name("evaluator/warehouse")->Unit(benchmark::kMicrosecond);

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"forklift-bench-evaluation: the evaluator's and the worker's whole tick, in the yard and the warehouse"};
  if (const auto stop = forklift::bench::parse_benchmark_command_line(app, argc, argv)) return *stop;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  // Goal: the worker's tick under 15 us without frames and events, p99 under 0.15 ms.
  for (auto& [scene, ticks] : g_tick_s) {
    if (ticks.empty()) continue;
    std::sort(ticks.begin(), ticks.end());
    const double median_us = ticks[ticks.size() / 2] * 1e6, p99_us = ticks[size_t(0.99 * (ticks.size() - 1))] * 1e6;
    bench::figure("the worker's whole tick, step() (dynamics, collision, outputs, evaluation), " + scene + ": median; p99",
                  "< 15 us; < 150 us", bench::fmt("%.1f us; %.1f us", median_us, p99_us), median_us < 15 && p99_us < 150);
  }
  return 0;
}
