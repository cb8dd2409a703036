// forklift-sim evaluate: a scripted session offline, with no cab (see evaluate.cc).
#pragma once

#include <CLI/CLI.hpp>
#include <string>

namespace forklift {

struct EvaluateOptions {
  std::string scenario, script, replay, mode = "training", out_log, rules, integrator = "cvode";
  std::string truck;  // instead of the scenario's (not with --replay: the log names its own)
  double duration_s = -1;  // negative: the script's (or the log's) own end
  bool json = false;       // the result as JSON, for scripts, instead of words
};

// Adds the "evaluate" subcommand and its options to the tool.
CLI::App* add_evaluate_command(CLI::App& app, EvaluateOptions& options);

// Runs it: prints the events and the mark in words on stdout ({events, score, ...} as JSON with
// --json). Returns the exit status: 0, 2 for bad arguments or data (message on stderr), 3 for a
// numerical failure (the result is still printed).
int evaluate_main(const EvaluateOptions& options, const std::string& data_dir);

}  // namespace forklift
