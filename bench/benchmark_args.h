// The command line of a Google Benchmark program, as every program here has one: --help lists its
// flags with their defaults, --version, and bad usage (an unknown flag, a bad value) exits 2 with
// the reason on stderr. benchmark::Initialize alone exits 1 on a bad value and lets unknown flags
// through, so the flags are read here and only those given are handed on to it.
#pragma once

#include <benchmark/benchmark.h>

#include <CLI/CLI.hpp>
#include <optional>
#include <string>
#include <vector>

namespace forklift::bench {

// Adds Google Benchmark's common flags to `app` (which may hold the program's own), parses the
// command line and initialises Google Benchmark with the flags given. Returns the exit status
// when the program is to stop at once (0 after --help or --version, 2 on bad usage), else nullopt.
inline std::optional<int> parse_benchmark_command_line(CLI::App& app, int argc, char** argv) {
  app.set_version_flag("--version", FORKLIFT_VERSION);
  app.option_defaults()->always_capture_default();  // --help shows each option's default
  std::string filter = ".", format = "console", out, out_format = "json";
  double min_time = 0.5;
  int repetitions = 1;
  bool list = false, aggregates_only = false, counters_tabular = false;
  // Each value option under Google Benchmark's own name, passed on as --NAME=VALUE when given.
  const std::vector<CLI::Option*> values = {
      app.add_option("--benchmark_filter", filter, "run only the benchmarks whose name matches this regular expression"),
      app.add_option("--benchmark_min_time", min_time, "least time each benchmark runs, s")->check(CLI::Range(0.0, 3600.0)),
      app.add_option("--benchmark_repetitions", repetitions, "runs of each benchmark (their mean, median and spread are reported)")
          ->check(CLI::Range(1, 1000)),
      app.add_option("--benchmark_format", format, "the report on stdout")->check(CLI::IsMember({"console", "json", "csv"})),
      app.add_option("--benchmark_out", out, "also write the report to this file"),
      app.add_option("--benchmark_out_format", out_format, "the report in --benchmark_out")->check(CLI::IsMember({"console", "json", "csv"}))};
  const std::vector<std::pair<CLI::Option*, bool*>> flags = {
      {app.add_flag("--benchmark_list_tests", list, "list the benchmarks and run none"), &list},
      {app.add_flag("--benchmark_report_aggregates_only", aggregates_only, "with repetitions: report only mean, median and spread"),
       &aggregates_only},
      {app.add_flag("--benchmark_counters_tabular", counters_tabular, "counters as columns of a table"), &counters_tabular}};
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help and --version: 0; bad usage: 2, as every program
  }
  static std::vector<std::string> given;  // Google Benchmark keeps pointers into its argv
  given = {argv[0]};
  for (CLI::Option* o : values)
    if (o->count() > 0) given.push_back(o->get_name() + "=" + o->results().back());
  for (const auto& [o, on] : flags)
    if (o->count() > 0) given.push_back(o->get_name() + "=" + (*on ? "true" : "false"));
  static std::vector<char*> args;
  args.clear();
  for (std::string& a : given) args.push_back(a.data());
  int n = static_cast<int>(args.size());
  benchmark::Initialize(&n, args.data());
  if (benchmark::ReportUnrecognizedArguments(n, args.data())) return 2;
  return std::nullopt;
}

}  // namespace forklift::bench
