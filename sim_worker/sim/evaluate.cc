// forklift-sim evaluate --scenario FILE --script FILE [--mode training|exam] [--out-log FILE]
// forklift-sim evaluate --replay LOG [--scenario FILE] [--mode ...]
//
// A scripted session offline, with no cab: each 1 ms tick applies the script's row due at that
// tick (or the control log's input), then runs the pipeline the worker runs (dynamics, collision
// and pallet handling, evaluation) and at the end prints the events and the score as JSON. This
// is how instructors and tests check a rule; `--out-log` writes the session's control log, and
// `--replay` re-derives the events and the mark from such a log.
#include "evaluate.h"

#include <cmath>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>

#include "forklift/collision/collision.h"
#include "forklift/evaluation/evaluation.h"
#include "forklift/scene/scene.h"
#include "forklift/session/controls.h"
#include "forklift/session/session_log.h"
#include "forklift/script/script.h"

namespace forklift {
namespace {

using json = nlohmann::ordered_json;

constexpr double kTick = 1e-3;  // the worker's physics tick

// One input change at a tick, as the control log records it.
struct Change {
  int64_t tick;
  uint32_t seq;
  DriverInputs inputs;
};

json event_json(const EvaluationEvent& e) {
  return {{"seq", e.seq},         {"t_s", e.t_s},           {"rule", e.rule},
          {"worry_level", e.worry_level}, {"points", e.points}, {"automatic_fail", e.automatic_fail},
          {"x_m", e.x_m},         {"y_m", e.y_m},           {"details", json::parse(e.details)}};
}

json score_json(const Score& s) {
  return {{"mark", s.mark},
          {"passed", s.passed},
          {"points", s.points},
          {"counts", s.counts},
          {"automatic_failures", s.automatic_failures},
          {"task_completed", s.task_completed},
          {"steps_done", s.steps_done},
          {"steps_total", s.steps_total},
          {"end_reason", s.end_reason},
          {"mode", s.mode},
          {"min_stability_fraction", s.min_stability_fraction}};
}

// The script's rows as input changes at tick boundaries: a row at time t is applied at the first
// tick boundary at or after t. Rows a cab would have refused are refused here, with their line.
std::vector<Change> script_changes(const std::string& path, const TruckParams& truck) {
  std::vector<Change> out;
  const std::vector<ScriptRow> rows = read_script(path);
  for (size_t i = 0; i < rows.size(); ++i) {
    const ScriptRow& r = rows[i];
    if (!std::isfinite(r.t) || r.t < 0) throw std::runtime_error(path + ": row " + std::to_string(i + 1) + ": bad time");
    const ControlSample c{uint32_t(i + 1), r.steer, r.accelerator, r.brake, r.lift, r.tilt, r.shift, false, r.parking_brake};
    if (const auto problem = control_problem(c))
      throw std::runtime_error(path + ": row " + std::to_string(i + 1) + " (t = " + std::to_string(r.t) + " s): " + *problem);
    out.push_back({int64_t(std::ceil(r.t / kTick - 1e-6)), c.seq, driver_inputs(c, truck)});
  }
  return out;
}

Environment environment(const Scene& scene) {
  Environment env;
  env.ground = scene.ground;
  return env;
}

}  // namespace

CLI::App* add_evaluate_command(CLI::App& app, EvaluateOptions& o) {
  auto* sub = app.add_subcommand("evaluate", "run a scripted session offline (no cab) and print its events and mark as JSON");
  sub->add_option("--scenario", o.scenario, "scenario file (data/scenarios/*.json); with --replay, overrides the log's")
      ->check(CLI::ExistingFile);
  auto* script = sub->add_option("--script", o.script, "cab control script, CSV t,steer,accelerator,brake,lift,tilt,shift")
                     ->check(CLI::ExistingFile);
  auto* replay = sub->add_option("--replay", o.replay, "control log to re-evaluate instead of a script")->check(CLI::ExistingFile);
  script->excludes(replay);
  sub->add_option("--mode", o.mode, "training (default) or exam")->check(CLI::IsMember({"training", "exam"}));
  sub->add_option("--out-log", o.out_log, "write the session's control log here (for --replay and forklift-worker --replay)");
  sub->add_option("--rules", o.rules, "rules file (default: data/evaluation/rules.json)")->check(CLI::ExistingFile);
  sub->add_option("--duration", o.duration_s, "end the session at this sim time, s (default: the script's last row)")
      ->check(CLI::Range(0.0, 86400.0));
  sub->add_option("--integrator", o.integrator, "cvode (default), dopri5 or rk4")->check(CLI::IsMember({"cvode", "dopri5", "rk4"}));
  return sub;
}

int evaluate_main(const EvaluateOptions& o, const std::string& data_dir) {
  std::optional<Scene> scene;
  std::optional<TruckParams> truck;
  std::optional<TruckShape> shape;
  std::optional<Rules> rules;
  std::optional<ControlLog> log;
  std::vector<Change> changes;
  StateVector x0;
  std::optional<Load> load;
  IntegratorOptions integrator;
  std::string scenario_file = o.scenario;
  try {
    if (o.script.empty() == o.replay.empty()) throw std::runtime_error("evaluate needs --script or --replay");
    if (!o.replay.empty()) {
      log = read_control_log(o.replay);
      if (scenario_file.empty()) scenario_file = log->header.scenario_file;
    }
    if (scenario_file.empty()) throw std::runtime_error("evaluate needs --scenario (the log names none)");
    scene = load_scene(scenario_file, data_dir);
    if (log && !o.truck.empty()) throw std::runtime_error("--truck cannot change a replay: the log names the truck it ran");
    if (log) scene->scenario.truck_file = log->header.truck_file;
    if (!o.truck.empty()) scene->scenario.truck_file = o.truck;
    truck = load_truck(scene->scenario.truck_file);
    shape = load_truck_shape(scene->scenario.truck_file, data_dir);
    rules = load_rules(o.rules.empty() ? data_dir + "/evaluation/rules.json" : o.rules);
    if (log) {
      x0 = log->header.initial;
      load = log->header.load;
      integrator = log->header.integrator;
      if (std::abs(log->header.tick_s - kTick) > 1e-12) throw std::runtime_error(o.replay + ": tick is not 1 ms");
      for (const ControlLog::Entry& e : log->entries) changes.push_back({e.tick, e.seq, e.inputs});
    } else {
      integrator.kind = parse_integrator(o.integrator);
      TruckDynamics dyn(*truck, environment(*scene));
      load = scene->scenario.load;
      if (load) dyn.attach_load(*load);
      const Scenario& sc = scene->scenario;
      x0 = dyn.rest_state(sc.x_m, sc.y_m, sc.yaw_rad, 0, 0, sc.lift_m, 0);
      if (!dyn.settle_static(x0)) throw std::runtime_error(scenario_file + ": the truck does not stand at the start pose");
      changes = script_changes(o.script, *truck);
    }
  } catch (const std::exception& e) {
    std::cerr << "forklift-sim evaluate: " << e.what() << '\n';
    return 2;
  }

  int64_t end = 0;
  if (log) end = log->ticks ? *log->ticks : (changes.empty() ? 0 : changes.back().tick + 1);
  else end = changes.empty() ? 0 : changes.back().tick + 1;  // the last row acts for one tick
  if (o.duration_s >= 0) end = int64_t(std::ceil(o.duration_s / kTick - 1e-6));

  // The session: the same stages, in the same order, as the worker's tick.
  TruckDynamics dynamics(*truck, environment(*scene));
  if (load) dynamics.attach_load(*load);
  Simulation sim(dynamics, x0, integrator);
  Warehouse warehouse(*scene, *shape, *truck);
  Evaluator evaluator(*rules, *scene, *truck, *shape, parse_mode(o.mode));
  std::optional<ControlLogWriter> writer;
  if (!o.out_log.empty()) {
    LogHeader h;
    h.session_id = "evaluate";
    h.cab_id = "offline";
    h.truck_file = scene->scenario.truck_file;
    h.scenario_file = std::filesystem::absolute(scenario_file).string();
    h.tick_s = kTick;
    h.integrator = integrator;
    h.initial = x0;
    h.load = load;
    try {
      writer.emplace(o.out_log, h);
    } catch (const std::exception& e) {
      std::cerr << "forklift-sim evaluate: " << e.what() << '\n';
      return 2;
    }
  }

  std::vector<EvaluationEvent> events;
  std::string reason = "duration";
  int status = 0;
  int64_t tick = 0;
  size_t next = 0;
  DriverInputs u;
  try {
    for (; tick < end; ++tick) {
      // inputs
      bool changed = false;
      while (next < changes.size() && changes[next].tick <= tick) {
        u = changes[next].inputs;
        if (writer) writer->input(tick, changes[next].seq, u);
        ++next;
        changed = true;
      }
      if (changed) sim.set_inputs(u);
      // dynamics
      sim.advance_to((tick + 1) * kTick);
      // collision and pallet handling
      const StepReport& report = warehouse.step(sim);
      // evaluation
      const Outputs out = sim.outputs();
      const BodyPoses poses = body_poses(*truck, out.q);
      const TickInput in{sim.time(), out, poses, u, report, warehouse.pallets(), sim.dynamics().load()};
      const size_t before = events.size();
      evaluator.tick(in, events);
      bool over_time = false;
      for (size_t i = before; i < events.size(); ++i) over_time = over_time || events[i].rule == "time_limit";
      if (over_time) {
        reason = "time_limit";
        ++tick;
        break;
      }
    }
  } catch (const IntegratorError& e) {
    std::cerr << "forklift-sim evaluate: numerical failure at t = " << sim.time() << " s: " << e.what() << '\n';
    reason = "numerical_failure";
    status = 3;
  }
  if (writer) writer->finish(tick, sim.state());
  const Score score = evaluator.finish(reason, events);

  json ev = json::array();
  for (const EvaluationEvent& e : events) ev.push_back(event_json(e));
  const json result = {{"scenario", scene->name},
                       {"scenario_file", scenario_file},
                       {"mode", o.mode},
                       {"rules", {{"file", rules->file}, {"scheme", rules->scheme.name}}},
                       {"end_reason", reason},
                       {"ticks", tick},
                       {"sim_time_s", sim.time()},
                       {"events", ev},
                       {"score", score_json(score)}};
  std::cout << result.dump(2) << std::endl;
  return status;
}

}  // namespace forklift
