// forklift-sim evaluate --scenario FILE --script FILE [--mode training|exam] [--out-log FILE]
// forklift-sim evaluate --replay LOG [--scenario FILE] [--mode ...]
//
// A scripted session offline, with no cab: each tick applies the script's row due at that tick
// (or the log's input), then runs the session's step, the one the worker runs (dynamics,
// collision and pallet handling, evaluation), and at the end prints the events and the mark in
// words (the debrief's: each event's title, what was measured against its limit, in units), or as
// JSON with --json. This is how instructors and tests check a rule; `--out-log` writes the session's log, and
// `--replay` re-derives the events and the mark from such a log, marked as the log says.
#include "evaluate.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>

#include "forklift/evaluation/event_words.h"
#include "forklift/session/controls.h"
#include "forklift/session/session.h"
#include "forklift/session/session_run.h"

namespace forklift {
namespace {

using json = nlohmann::ordered_json;

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

// The result as the debrief words it: each event's title and what was measured against its limit,
// then the mark with each fault in the rules' words.
void print_words(const SessionModel& model, const OfflineRun& run) {
  std::printf("scenario %s (%s), marked as %s under %s\n", model.scene.name.c_str(), model.scenario_file.c_str(),
              mode_name(model.mode), model.rules.scheme.name.c_str());
  std::printf("ran %.1f s of sim time (%lld ticks); ended: %s\n", run.final_state.t_s, static_cast<long long>(run.ticks),
              words(*run.end_reason));
  std::printf(run.evaluation_events.empty() ? "no events\n" : "events:\n");
  for (const EvaluationEvent& e : run.evaluation_events) {
    const Rule* rule = model.rules.find(e.rule);
    const nlohmann::json w = event_words(rule ? rule->title : "", e.rule, e.details);
    std::string line = worry_words(e.worry_level) + ": " + w["title"].get<std::string>();
    if (!w["summary"].get<std::string>().empty()) line += ". " + w["summary"].get<std::string>();
    std::printf("  at %6.1f s  %s%s\n", e.t_s, line.c_str(), e.automatic_fail ? " (fails by itself)" : "");
  }
  const Score& s = *run.score;
  std::printf("%s", score_words(s, model.rules).c_str());
  std::printf("task steps done: %d of %d; lowest stability margin: %.0f %% of the unladen truck's\n", s.steps_done, s.steps_total,
              100 * s.min_stability_fraction);
}

}  // namespace

CLI::App* add_evaluate_command(CLI::App& app, EvaluateOptions& o) {
  auto* sub = app.add_subcommand("evaluate", "run a scripted session offline (no cab) and print its events and mark (as JSON with --json)");
  sub->add_option("--scenario", o.scenario, "scenario file (data/scenarios/*.json); not with --replay (the log names its own)")
      ->check(CLI::ExistingFile);
  auto* script = sub->add_option("--script", o.script, "cab control script, CSV t,steer,accelerator,brake,lift,tilt,shift[,parking[,horn]]")
                     ->check(CLI::ExistingFile);
  auto* replay = sub->add_option("--replay", o.replay, "session log to re-evaluate instead of a script (marked as it ran)")
                     ->check(CLI::ExistingFile);
  script->excludes(replay);
  auto* mode = sub->add_option("--mode", o.mode, "training (default) or exam")->check(CLI::IsMember({"training", "exam"}));
  mode->excludes(replay);
  sub->add_option("--out-log", o.out_log, "write the session's log here (for --replay and forklift-worker --replay)");
  sub->add_option("--rules", o.rules, "rules file (default: data/evaluation/rules.json)")->check(CLI::ExistingFile);
  sub->add_option("--duration", o.duration_s, "end the session at this sim time, s (default: the script's last row)")
      ->check(CLI::Range(0.0, 86400.0));
  sub->add_option("--integrator", o.integrator, "cvode (default), dopri5 or rk4")->check(CLI::IsMember({"cvode", "dopri5", "rk4"}));
  sub->add_flag("--json", o.json, "print the events and the score as JSON (for scripts) instead of words");
  return sub;
}

int evaluate_main(const EvaluateOptions& o, const std::string& data_dir) {
  std::optional<SessionModel> model;
  std::optional<SessionState> first;
  std::vector<InputChange> changes;
  int64_t end = 0;
  EndReason reason = EndReason::kDuration;
  try {
    if (o.script.empty() == o.replay.empty()) throw std::runtime_error("evaluate needs --script or --replay");
    if (!o.replay.empty()) {
      if (!o.truck.empty()) throw std::runtime_error("--truck cannot change a replay: the log names the truck it ran");
      if (!o.scenario.empty()) throw std::runtime_error("--scenario cannot change a replay: the log names the scene it ran in");
      const ControlLog log = read_control_log(o.replay);
      if (log.header.scenario_file.empty()) throw std::runtime_error(o.replay + ": the log names no scenario");
      model = load_session_model(log.header, data_dir);
      if (!o.rules.empty()) model->rules = load_rules(o.rules);
      first = initial_state(*model, log.header);
      // Its inputs and dead-man switches, as the worker applied them, to its end, marked as it
      // ended (a log whose worker died before its end: as if its time had run out).
      changes = logged_changes(log);
      end = log.ticks ? *log.ticks : (log.entries.empty() ? 0 : log.entries.back().tick + 1);
      reason = logged_end_reason(log).value_or(EndReason::kDuration);
    } else {
      if (o.scenario.empty()) throw std::runtime_error("evaluate needs --scenario");
      SessionSpec spec;
      spec.scenario_file = o.scenario;
      spec.truck_file = o.truck;
      spec.rules_file = o.rules;
      spec.mode = o.mode;
      spec.integrator.kind = parse_integrator(o.integrator);
      model = load_session_model(spec, data_dir);
      first = initial_state(*model);
      changes = script_changes(o.script, *model);
      end = changes.empty() ? 0 : changes.back().tick + 1;  // the last row acts for one tick
    }
  } catch (const std::exception& e) {
    std::cerr << "forklift-sim evaluate: " << e.what() << '\n';
    return 2;
  }
  if (o.duration_s >= 0) {
    end = first_tick_at(o.duration_s, model->tick_s);
    reason = EndReason::kDuration;
  }

  std::unique_ptr<ControlLogWriter> writer;
  if (!o.out_log.empty()) {
    try {
      writer = std::make_unique<ControlLogWriter>(o.out_log, log_header(*model, *first, "evaluate", "offline"));
    } catch (const std::exception& e) {
      std::cerr << "forklift-sim evaluate: " << e.what() << '\n';
      return 2;
    }
  }
  const OfflineRun run = run_offline(*model, *first, changes, end, reason, std::move(writer));
  if (!run.failure.empty())
    std::cerr << "forklift-sim evaluate: numerical failure at t = " << run.final_state.t_s << " s: " << run.failure << '\n';

  if (!o.json) {
    print_words(*model, run);
    return run.failure.empty() ? 0 : 3;
  }
  json ev = json::array();
  for (const EvaluationEvent& e : run.evaluation_events) ev.push_back(event_json(e));
  const json result = {{"scenario", model->scene.name},
                       {"scenario_file", o.replay.empty() ? o.scenario : model->scenario_file},
                       {"mode", mode_name(model->mode)},
                       {"rules", {{"file", model->rules.file}, {"scheme", model->rules.scheme.name}}},
                       {"end_reason", name(*run.end_reason)},
                       {"ticks", run.ticks},
                       {"sim_time_s", run.final_state.t_s},
                       {"events", ev},
                       {"score", score_json(*run.score)}};
  std::cout << result.dump(2) << std::endl;
  return run.failure.empty() ? 0 : 3;
}

}  // namespace forklift
