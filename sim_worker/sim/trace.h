// forklift-sim trace: a logged session re-simulated, sampled for the debrief's replay (see trace.cc).
#pragma once

#include <CLI/CLI.hpp>
#include <string>

namespace forklift {

struct TraceOptions {
  std::string log;       // the session's control log
  std::string scenario;  // instead of the file the log names (where the server keeps it now)
  double every_s = 0.1;  // one sample per this much sim time
};

CLI::App* add_trace_command(CLI::App& app, TraceOptions& options);

// Prints {session, tick_s, every_s, truck, samples, ...} as JSON on stdout. Exit status: 0, 2 for
// an unreadable log or scene (message on stderr), 3 when the replay failed numerically (the
// samples up to the failure are still printed).
int trace_main(const TraceOptions& options, const std::string& data_dir);

}  // namespace forklift
