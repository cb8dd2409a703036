// What the fleet's parts share (supervision, placement, the sample gate's world, the recorder):
// the configuration, what is known of each worker, host and cab, and the one mutex that guards it,
// which the HTTP threads, the supervisor thread and the ingest thread take in turn.
#pragma once

#include <sys/types.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <condition_variable>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "sample_gate.h"
#include "forklift/store/store.h"
#include "forklift/host/worker_launch.h"
#include "forklift/protocol/protocol.h"

namespace forklift::server {

struct FleetConfig {
  std::string db_path;
  std::string worker_binary;
  std::string data_dir;
  std::string log_dir;        // worker logs and control logs
  int dds_domain = 0;
  std::string dds_config;     // empty: default resolution
  std::string security_dir;   // the school's DDS Security folder; empty: no security (training only)
  std::string identity = "server.main";  // the server's identity in it
  int max_workers = 8;
  double hang_timeout_s = 5;  // a running worker with no TruckState for this long is killed
  double start_timeout_s = 120;
  std::optional<host::WorkerFrames> frames;  // every worker's frames (nullopt: the worker's defaults)
  // Worker hosts (forklift-host) announce themselves over DDS; while one has room a session's
  // worker runs there. With none about, the server runs workers itself, unless local_workers is off.
  bool local_workers = true;
  bool realtime_workers = false;  // workers it runs itself tick at real-time priority (--realtime)
  // Worker hosts speak for themselves only under DDS Security (their identity host.<id>); in clear
  // DDS any machine on the network could claim to be one, so they are believed only when the
  // operator says the network is a closed lab (--trust-clear-hosts).
  bool trust_clear_hosts = false;
  double host_answer_timeout_s = 2;  // a host that has not named its running worker in this long is passed over
  double start_budget_s = 5;         // the whole placement of one start, hosts and then this machine
  double host_pass_over_s = 30;      // a host passed over for silence is not asked again for this long
  double path_interval_s = 0.5;  // sim time between two stored points of a session's truck path
  std::string chain_anchor;      // the exam chain's anchor file; empty: <log_dir>/exam-chain.anchor
  // This server among those that share the store: it runs the sessions it starts, and takes over
  // those of a server that has said nothing for server_lease_s (store::claim_sessions).
  std::string server_id = "server";
  double server_lease_s = 10;
};

struct WorkerInfo {
  std::string session, cab;
  std::string host;    // the worker host it runs on; empty: this machine
  pid_t pid = 0;       // the worker's process (0: not found after a server restart)
  bool child = false;  // ours to reap; otherwise adopted after a server restart, watched through /proc
  unsigned long long start_ticks = 0;  // an adopted process's start time (a reused pid is not it)
  std::string participant;  // the worker's DDS participant (GUID hex): its samples only are believed
  std::chrono::steady_clock::time_point started, last_state;
  bool seen_state = false;
  fk_TruckState last{};  // the newest TruckState, when seen_state
  std::optional<double> last_path_point_s;  // sim time of the last path point stored
  std::string hang_reason;  // a hosted worker asked to be killed, and why
  std::chrono::steady_clock::time_point hang_asked;  // when it was asked
};

// A worker host as its status says (fk_HostStatus).
struct HostInfo {
  std::string id, site;
  HostState state = HostState::kReady;
  int capacity = 0, running = 0, cores = 0;
  double load_1min = 0, memory_free_mib = 0;
  std::chrono::steady_clock::time_point last_seen;
  bool gone = false;  // its status writer lost its liveliness (the agent or its machine is down)
  int placed = 0;     // starts this server asked of it that it has not answered yet
  std::chrono::steady_clock::time_point passed_over_until{};  // it took a start and went silent
  bool alive(std::chrono::steady_clock::time_point now) const;
  bool has_room() const { return state == HostState::kReady && running + placed < capacity; }
};

struct CabInfo {
  std::string id, mode, site;
  std::chrono::steady_clock::time_point last_seen;
};

using Clock = std::chrono::steady_clock;

// A span of seconds (from a setting) as the clock's duration.
inline Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

// The samples a worker sent just before it exited may still be on their way.
constexpr auto kLastSamples = std::chrono::milliseconds(1000);

inline std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Ended exams waiting for their score, each until when.
using ToChain = std::vector<std::pair<std::string, Clock::time_point>>;

struct FleetState {
  explicit FleetState(const FleetConfig& c) : config(c) {}
  std::string log_path(const std::string& session) const { return config.log_dir + "/" + session + ".ctl"; }
  bool secure() const { return !config.security_dir.empty(); }
  bool hosts_believed() const { return secure() || config.trust_clear_hosts; }
  // The wall-clock time before which a server's last sign of life means it has stopped.
  std::string lease_start() const {
    return store::iso8601_of(std::time(nullptr) - static_cast<std::time_t>(std::ceil(config.server_lease_s)));
  }
  // Counts a refused sample; each different refusal is named in the log once (a forged report
  // among a clear host's many statuses is seen), within a bounded memory; repeats only as the
  // count doubles. Takes mu.
  void refuse(RefusalCounter counter, const std::string& what);
  // The session's worker runs on a worker host (under mu).
  bool hosted(const std::string& session) const {
    const auto w = workers.find(session);
    return w != workers.end() && !w->second.host.empty();
  }
  // Any worker that runs the cab's session, or "" (under mu).
  std::string session_on(const std::string& cab) const {
    for (const auto& [id, w] : workers) if (w.cab == cab) return id;
    return "";
  }

  // Whose samples a session's are: the worker's participant and cab, kept a little while after
  // it exits for the samples still on their way.
  struct Binding {
    std::string cab, participant;
    std::optional<Clock::time_point> until;  // set when the worker is gone
  };
  struct Finishing {  // a worker gone; settled once its last samples had time to arrive
    WorkerInfo worker;
    std::string reason;
    Clock::time_point at;
  };
  struct StartAnswer {
    std::string host;
    std::optional<WorkerReportState> state;  // none: no answer in time
    std::string reason;
  };

  const FleetConfig& config;
  std::mutex mu;
  // Under mu:
  std::map<std::string, WorkerInfo> workers;  // by session
  std::map<std::string, Binding> bindings;     // by session, for the sample gate
  std::vector<Finishing> finishing;            // settled by the supervisor thread
  // The entry of `session` in finishing, else finishing.end() (under mu).
  std::vector<Finishing>::iterator finishing_of(const std::string& session) {
    return std::find_if(finishing.begin(), finishing.end(), [&](const Finishing& f) { return f.worker.session == session; });
  }
  std::set<std::string> unsettled;             // sessions with a worker here whose logs are not stored yet
  RefusedSamples refused;
  IngestedSamples ingested;                    // counted a round of the ingest at a time
  static constexpr size_t kRefusalsNamed = 4096;
  std::set<std::string> refusals_named;        // the refusals named in the log once each
  std::map<std::string, CabInfo> cabs;
  std::map<std::string, HostInfo> hosts;       // by id
  std::map<std::string, StartAnswer> start_answers;  // by session: a host's answer to a start
  std::condition_variable answered;
};

}  // namespace forklift::server
