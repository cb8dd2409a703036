// The workers' lives as this server sees them: spawning a session's worker on this machine,
// adopting at start the workers of this server still running, reaping each one's exit, killing
// one that hangs (a hosted one through its host), and handing each one gone over to be settled
// once its last samples have had time to arrive.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "fleet_state.h"
#include "worker_log.h"
#include "forklift/store/store.h"

namespace forklift::server {

class WorkerSupervisor {
 public:
  // How a hosted worker is signalled: its host is asked (abort, kill), under mu.
  using AskHost = std::function<void(const std::string& host, const std::string& session, WorkerAction action)>;
  WorkerSupervisor(FleetState& fleet, AskHost ask_host) : fleet_(fleet), ask_host_(std::move(ask_host)) {}

  // Start-up: the sessions left open that are this server's (or nobody's, or a stopped server's),
  // and the workers of this server still running; the rest stopped.
  void adopt(store::Store& db);
  // Sessions taken over from a server that has stopped (store::claim_sessions): each worker found
  // running here adopted, the others waited for their host's word as at start-up.
  void take_over(store::Store& db, const std::vector<std::string>& sessions);
  // Spawns the session's worker on this machine. Throws std::runtime_error when the machine
  // already runs max_workers, the cab is busy, or (under DDS Security) the worker has no identity.
  void start_local(const store::Session& s, const std::string& scenario_file, std::optional<double> duration_s,
                   const std::optional<std::string>& aids, const std::string& language);
  // The instructor's abort (SIGUSR1); false if the session has no worker here.
  bool abort(const std::string& session);
  // SIGTERM to every worker that runs on this machine (the server is stopping).
  void stop_local_workers();

  // One look at every worker (supervisor thread): exits reaped, hangs killed, each one gone
  // queued to be settled; expired bindings dropped.
  void watch();
  // The workers gone whose last samples have had time to arrive, taken to be settled.
  std::vector<FleetState::Finishing> due();
  // Its logs are stored: the session is settled unless a new worker runs it.
  void settled(const std::string& session);

 private:
  // The sessions' workers adopted or waited for; the workers to stop (every worker here that is
  // not adopted, with `all_workers`).
  std::vector<WorkerProcess> take_over(store::Store& db, const std::vector<std::string>& sessions, bool all_workers);
  void signal_worker(const WorkerInfo& w, int sig);  // under mu
  // Why the worker is done (its exit, its host's silence, a hang), with `done` set; or it hangs.
  bool check(WorkerInfo& w, Clock::time_point now, std::string& reason);

  FleetState& fleet_;
  AskHost ask_host_;
};

}  // namespace forklift::server
