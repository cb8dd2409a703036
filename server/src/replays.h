// The debrief's replay of a finished session: `forklift-sim trace` re-simulates
// the session's control log (as the store keeps it) through the worker's own step and samples the
// truck, forks and pallets ten times a second. It runs as a child process, one at a time (the
// cores belong to the sim workers), and each session's replay is kept in a cache folder, so it is
// computed once: a finished session never changes.
#pragma once

#include <mutex>
#include <string>

namespace forklift::server {

class Replays {
 public:
  Replays(std::string sim_binary, std::string cache_dir);
  bool available() const;  // whether forklift-sim has been built
  // The replay's JSON text for session `key` ([A-Za-z0-9_.-]) from its control log's text and the
  // scenario file it ran in. Throws std::runtime_error with forklift-sim's words if the log cannot
  // be replayed or it takes over `timeout_s`.
  std::string trace(const std::string& key, const std::string& control_log, const std::string& scenario_file,
                    double timeout_s = 600);

 private:
  std::string binary_, cache_dir_;
  std::mutex mu_;
};

}  // namespace forklift::server
