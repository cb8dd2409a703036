// What the server learns from a worker without DDS: its session log (the record of what it
// published, read when samples went missing or the server was down), its participant (whose
// samples to believe) and its process (found again after a server restart).
#pragma once

#include "forklift/host/worker_launch.h"

#include <sys/types.h>

#include <optional>
#include <string>
#include <vector>

#include "forklift/store/store.h"

namespace forklift::server {

// A session as its worker's log tells it.
struct LoggedSession {
  std::vector<store::EventRecord> events;  // in the order published: seq from 1, as on DDS
  std::optional<store::ScoreRecord> score; // mark and passed from the score line; counts from the events
  std::optional<std::string> end_reason;   // the score line's reason
  std::optional<int> points;               // the score line's penalty points
  bool finished = false;                   // the log has its "end" line
  bool gave_up = false;                    // the worker's cab never spoke
};

// Reads <log_dir>/<session>.ctl; nullopt if there is no readable log. Events recovered from a
// log carry no position or details (the log keeps kind, worry and tick): their details say so.
std::optional<LoggedSession> read_logged_session(const std::string& log_path, const std::string& session);

// The GUID the worker wrote beside its log (<log>.participant); empty if none yet.
std::string logged_participant(const std::string& log_path);

// The mark on a score line as written ("score <hex mark> <passed> <points> <reason>").
struct LoggedMark {
  double mark = 0;
  bool passed = false;
  int points = 0;
  std::string end_reason{};
};
std::optional<LoggedMark> parse_score_line(const std::string& line);

// The workers on this machine, found through /proc (shared with forklift-host).
using host::WorkerProcess;
using host::find_workers;
using host::still_running;

}  // namespace forklift::server
