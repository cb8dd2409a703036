// forklift-host's agent: one per simulation machine. It announces the machine's capacity and
// health over DDS (fk_HostStatus), starts and supervises forklift-worker processes on the servers'
// requests (fk_WorkerRequest) and reports each worker's life, with its files when it exits
// (fk_WorkerReport), so that any server of the school can settle the session.
#pragma once

#include <sys/types.h>

#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "forklift/host/worker_launch.h"
#include "forklift/protocol/protocol.h"
#include "forklift/session/host_vocabulary.h"

namespace forklift::host {

struct HostConfig {
  std::string host_id;       // 1-32 letters, digits, - or _
  std::string site;          // where the machine stands; "" unknown
  int capacity = 8;          // workers it runs at once
  std::string worker_binary;
  std::string data_dir;
  std::string log_dir;       // the workers' session logs and output, and the scenarios they run
  int dds_domain = 0;
  std::string dds_config;
  std::string security_dir;  // empty: no DDS Security (then no exam can run here)
  std::string identity;      // in security_dir; default host.<host_id>
  double start_timeout_s = 120;
  bool realtime_workers = false;  // workers tick at real-time priority (forklift-worker --realtime)
  double report_kept_s = 600;  // an exited worker's report stays this long for servers that start later
  // Without DDS Security any machine on the network could ask this host to start or kill workers:
  // it runs in clear only when the operator says the network is a closed lab.
  bool trust_clear = false;
};

// A request is checked before anything is done with it: what is wrong with it, or nullopt.
std::optional<std::string> request_problem(const fk_WorkerRequest& r, const std::string& host_id);

class HostAgent {
 public:
  explicit HostAgent(HostConfig config);
  ~HostAgent();
  // Serves until `stop`; then takes no new worker, stops its workers (SIGTERM: they end their
  // sessions as stopped by the school's system) and reports their ends before returning. With
  // `leave_workers` (a restart of the agent, not of the machine) they go on running instead, for
  // the next agent to adopt.
  void run(const std::atomic<bool>& stop, const std::atomic<bool>& leave_workers);

 private:
  struct Worker {
    std::string session, cab;
    pid_t pid = 0;
    unsigned long long start_ticks = 0;  // of an adopted worker (not our child): a reused pid is not it
    bool adopted = false;                // started by an earlier agent: watched through /proc
    bool exited = false;
    std::string participant;
    std::chrono::steady_clock::time_point exited_at;
  };
  // Start-up: the workers an earlier agent left running are adopted, and the ends it never
  // reported (it stopped first) are reported now, so that no session is left open.
  void adopt();
  void take_requests(bool stopping);
  void start(const fk_WorkerRequest& r);
  void reap();
  void publish_status(bool stopping);
  void report(const Worker& w, WorkerReportState state, const std::string& reason, bool with_files = false);
  void refuse(const fk_WorkerRequest& r, const std::string& why);
  int running() const;
  std::string base(const std::string& session) const { return config_.log_dir + "/" + session; }

  HostConfig config_;
  std::unique_ptr<dds::Participant> participant_;
  std::unique_ptr<dds::Writer<fk_HostStatus>> status_;
  std::unique_ptr<dds::Writer<fk_WorkerReport>> reports_;
  std::unique_ptr<dds::Reader<fk_WorkerRequest>> requests_;
  std::map<std::string, Worker> workers_;  // by session, the exited ones until report_kept_s
  bool leave_workers_ = false;
};

}  // namespace forklift::host
