// forklift-bench-evaluation: what the driver evaluation adds to a 1 ms physics tick, beside the
// dynamics and the collision step measured in the same run.
//
// Design: a scripted session runs the worker's pipeline tick by tick (inputs, Simulation::
// advance_to, Warehouse::step, the evaluator's inputs (Simulation::outputs and body_poses),
// Evaluator::tick); each stage is timed with the steady clock, and the session restarts when
// its script ends. Two scenes:
//   yard       first_drive_yard with the shipped clean exam script (a 150 s drive over the
//              ramp; 2 zones, a route, 5 task steps, a few objects)
//   warehouse  practical_exam (the full warehouse: 13 zones, a 3 m route, about 70 objects)
//              with the first 60 s of the same script (the truck drives into the warehouse's
//              walls and racks, so contacts, collision events and their JSON are included)
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

#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "forklift/collision/collision.h"
#include "forklift/evaluation/evaluation.h"
#include "forklift/scene/scene.h"
#include "forklift/session/controls.h"
#include "forklift/session/session_log.h"
#include "forklift/script/script.h"

using namespace forklift;
using Clock = std::chrono::steady_clock;

namespace {

constexpr double kTick = 1e-3;
const std::string kData = FORKLIFT_DATA_DIR;

struct Change {
  int64_t tick;
  DriverInputs u;
};

// One scripted session, restartable.
struct Run {
  Scene scene;
  TruckParams truck;
  TruckShape shape;
  const Rules* rules;
  std::vector<Change> changes;
  int64_t end = 0;
  StateVector x0;
  std::unique_ptr<TruckDynamics> dynamics;
  std::unique_ptr<Simulation> sim;
  std::unique_ptr<Warehouse> warehouse;
  std::unique_ptr<Evaluator> evaluator;
  int64_t tick = 0;
  size_t next = 0;
  DriverInputs u;
  std::vector<EvaluationEvent> events;

  Run(const std::string& scenario, const std::string& script, double max_s, const Rules& r) : rules(&r) {
    scene = load_scene(scenario, kData);
    truck = load_truck(scene.scenario.truck_file);
    shape = load_truck_shape(scene.scenario.truck_file, kData);
    for (const ScriptRow& row : read_script(script)) {
      const ControlSample c{0, row.steer, row.accelerator, row.brake, row.lift, row.tilt, row.shift, false, row.parking_brake};
      changes.push_back({int64_t(std::ceil(row.t / kTick - 1e-6)), driver_inputs(c, truck)});
    }
    end = std::min<int64_t>(changes.back().tick + 1, int64_t(max_s / kTick));
    Environment env;
    env.ground = scene.ground;
    TruckDynamics d(truck, env);
    x0 = d.rest_state(scene.scenario.x_m, scene.scenario.y_m, scene.scenario.yaw_rad);
    d.settle_static(x0);
    restart();
  }

  void restart() {
    Environment env;
    env.ground = scene.ground;
    dynamics = std::make_unique<TruckDynamics>(truck, env);
    sim = std::make_unique<Simulation>(*dynamics, x0, IntegratorOptions{});
    warehouse = std::make_unique<Warehouse>(scene, shape, truck);
    evaluator = std::make_unique<Evaluator>(*rules, scene, truck, shape, Mode::kExam);
    tick = 0;
    next = 0;
    events.clear();
  }
};

const Rules& rules() {
  static const Rules r = load_rules(kData + "/evaluation/rules.json");
  return r;
}

struct Scenes {
  const char* name;
  std::string scenario;
  double max_s;
};
const Scenes kYard{"yard", kData + "/scenarios/first_drive_yard.json", 1e9};
const Scenes kWarehouse{"warehouse", kData + "/scenarios/practical_exam.json", 60};
const std::string kScript = kData + "/evaluation/scripts/first_drive_yard_exam.csv";

double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

void BM_Pipeline(benchmark::State& state, Scenes sc) {
  Run run(sc.scenario, kScript, sc.max_s, rules());
  double dyn = 0, col = 0, outs = 0, eval = 0;
  for (auto _ : state) {
    if (run.tick >= run.end) run.restart();  // a few milliseconds, once per session; not timed
    while (run.next < run.changes.size() && run.changes[run.next].tick <= run.tick) {
      run.u = run.changes[run.next++].u;
      run.sim->set_inputs(run.u);
    }
    auto t0 = Clock::now();
    run.sim->advance_to((run.tick + 1) * kTick);
    const double t_dyn = since(t0);
    t0 = Clock::now();
    const StepReport& report = run.warehouse->step(*run.sim);
    const double t_col = since(t0);
    t0 = Clock::now();
    const Outputs out = run.sim->outputs();
    const BodyPoses poses = body_poses(run.truck, out.q);
    const double t_out = since(t0);
    const TickInput in{run.sim->time(), out, poses, run.u, report, run.warehouse->pallets(), run.sim->dynamics().load()};
    t0 = Clock::now();
    run.evaluator->tick(in, run.events);
    const double t_eval = since(t0);
    ++run.tick;
    dyn += t_dyn;
    col += t_col;
    outs += t_out;
    eval += t_eval;
    state.SetIterationTime(t_dyn + t_col + t_out + t_eval);
  }
  const auto per_tick = [&](double total) { return benchmark::Counter(total * 1e6, benchmark::Counter::kAvgIterations); };
  state.counters["dynamics_us"] = per_tick(dyn);
  state.counters["collision_us"] = per_tick(col);
  state.counters["outputs_us"] = per_tick(outs);
  state.counters["evaluation_us"] = per_tick(eval);
  state.counters["eval/dyn"] = eval / dyn;
  state.counters["eval/coll"] = eval / col;
  state.counters["events"] = double(run.events.size());
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
  Run run(sc.scenario, kScript, sc.max_s, rules());
  std::vector<Recorded> rec;
  const int64_t n = std::min<int64_t>(20000, run.end);
  rec.reserve(n);
  for (; run.tick < n; ++run.tick) {
    while (run.next < run.changes.size() && run.changes[run.next].tick <= run.tick) run.sim->set_inputs(run.u = run.changes[run.next++].u);
    run.sim->advance_to((run.tick + 1) * kTick);
    const StepReport& report = run.warehouse->step(*run.sim);
    const Outputs out = run.sim->outputs();
    rec.push_back({run.sim->time(), out, body_poses(run.truck, out.q), run.u, report, run.warehouse->pallets(), run.sim->dynamics().load()});
  }
  size_t i = rec.size();
  std::unique_ptr<Evaluator> ev;
  std::vector<EvaluationEvent> events;
  for (auto _ : state) {
    if (i == rec.size()) {
      state.PauseTiming();
      ev = std::make_unique<Evaluator>(rules(), run.scene, run.truck, run.shape, Mode::kExam);
      events.clear();
      i = 0;
      state.ResumeTiming();
    }
    const Recorded& r = rec[i++];
    const TickInput in{r.t, r.out, r.poses, r.u, r.report, r.pallets, r.load};
    ev->tick(in, events);
    benchmark::DoNotOptimize(events.data());
  }
  state.counters["ticks_recorded"] = double(rec.size());
}

BENCHMARK_CAPTURE(BM_Pipeline, yard, kYard)->Name("pipeline/yard")->UseManualTime()->Iterations(150000)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Pipeline, warehouse, kWarehouse)->Name("pipeline/warehouse")->UseManualTime()->Iterations(60000)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_EvaluatorTick, yard, kYard)->Name("evaluator/yard")->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_EvaluatorTick, warehouse, kWarehouse)->Name("evaluator/warehouse")->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
