// How a sim worker is started: the one command line and the one way of spawning it, shared by the
// server (its own workers, when no worker host is about) and forklift-host (a simulation machine's).
#pragma once

#include <sys/types.h>

#include <optional>
#include <string>
#include <vector>

#include "forklift/session/vocabulary.h"

namespace forklift::host {

// The frames a worker renders while its cab asks for them.
struct WorkerFrames {
  double fps = 30;
  int width = 640, height = 480;
  bool jpeg = false;
};

struct WorkerLaunch {
  std::string binary;         // forklift-worker
  std::string session, cab;
  Mode mode = Mode::kTraining;
  std::string scenario_file;
  std::string log_base;       // <dir>/<session>: the session log is <log_base>.ctl, stdout and stderr .out and .err
  int dds_domain = 0;
  std::string dds_config;     // empty: the default
  std::string security_dir;   // empty: no DDS Security
  double start_timeout_s = 120;
  std::optional<double> duration_s;
  std::optional<std::string> aids;
  std::string language;                // the pupil's, for the cab (--language; one the catalogue has); "" none
  std::optional<WorkerFrames> frames;  // nullopt: the worker's defaults
  bool realtime = false;               // its tick at real-time priority where permitted (--realtime)
};

std::vector<std::string> worker_command(const WorkerLaunch& w);

// Forks and runs the worker in its own process group (a Ctrl-C to the terminal of whoever spawned
// it must not end sessions mid-exam), its output into <log_base>.out and .err. With
// die_with_parent the worker gets SIGTERM when the spawning process dies: a host agent's workers
// never outlive it unsupervised. Throws std::runtime_error when it cannot fork.
pid_t spawn_worker(const WorkerLaunch& w, bool die_with_parent);

// A forklift-worker process on this machine, from /proc.
struct WorkerProcess {
  pid_t pid = 0;
  std::string session, cab, log_path;
  unsigned long long start_ticks = 0;  // /proc/<pid>/stat's start time: tells a reused pid apart
};
// Every forklift-worker whose --log lies in `log_dir` (this server's or host's workers, not another's).
std::vector<WorkerProcess> find_workers(const std::string& log_dir);
// Whether the process is still that worker (alive, same start time, not a zombie).
bool still_running(const WorkerProcess& p);

// How a reaped child ended, in words ("" for a clean exit).
std::string exit_words(int wait_status);

}  // namespace forklift::host
