#include "worker_supervisor.h"

#include "worker_log.h"

#include <signal.h>
#include <spdlog/spdlog.h>
#include <sys/wait.h>

#include <algorithm>

namespace forklift::server {

void WorkerSupervisor::adopt(store::Store& db) {
  // A restarted server adopts the sessions still open whose workers still run (they keep
  // reporting over DDS; not our children, they are watched through /proc). A session whose
  // worker is gone is settled from its log: it may have ended, with its mark, while we were down.
  // Another server's sessions are its own, while it lives.
  db.server_alive(fleet_.config.server_id, store::now_iso8601());
  const std::vector<std::string> ours = db.claim_sessions(fleet_.config.server_id, fleet_.lease_start(), true);
  const std::vector<WorkerProcess> strays = take_over(db, ours, true);
  for (const WorkerProcess& p : strays) {
    spdlog::warn("stopping worker pid {} (session {}, cab {}): its session is not open here or its cab runs another", p.pid, p.session, p.cab);
    kill(p.pid, SIGTERM);
  }
}

void WorkerSupervisor::take_over(store::Store& db, const std::vector<std::string>& sessions) {
  for (const std::string& s : sessions) spdlog::info("took over session {} from a server that has stopped", s);
  take_over(db, sessions, false);
}

std::vector<WorkerProcess> WorkerSupervisor::take_over(store::Store& db, const std::vector<std::string>& sessions, bool all_workers) {
  std::map<std::string, WorkerProcess> running;  // by session
  std::vector<WorkerProcess> strays;
  for (const WorkerProcess& p : find_workers(fleet_.config.log_dir)) {
    if (running.count(p.session)) strays.push_back(p);
    else running[p.session] = p;
  }
  const std::set<std::string> taken(sessions.begin(), sessions.end());
  std::vector<store::Session> open = db.open_sessions();
  std::erase_if(open, [&](const store::Session& s) { return !taken.count(s.public_id); });
  // The newest session of a cab keeps it: an older one still open is settled.
  std::sort(open.begin(), open.end(), [](const store::Session& a, const store::Session& b) { return a.public_id > b.public_id; });
  std::lock_guard<std::mutex> lock(fleet_.mu);
  const auto now = Clock::now();
  std::set<std::string> cabs_taken;
  for (const auto& [id, w] : fleet_.workers) cabs_taken.insert(w.cab);
  for (const store::Session& s : open) {
    if (fleet_.workers.count(s.public_id) || fleet_.unsettled.count(s.public_id)) continue;  // adopted from its host's report meanwhile
    WorkerInfo w;
    w.session = s.public_id;
    w.cab = s.cab_id;
    w.started = w.last_state = now;
    w.participant = logged_participant(fleet_.log_path(s.public_id));
    const auto p = running.find(s.public_id);
    if (p != running.end() && p->second.cab == s.cab_id && !cabs_taken.count(s.cab_id)) {
      w.pid = p->second.pid;
      w.start_ticks = p->second.start_ticks;
      running.erase(p);
      cabs_taken.insert(s.cab_id);
      spdlog::info("adopted the worker (pid {}) of session {} on cab {}", w.pid, s.public_id, s.cab_id);
      fleet_.workers[s.public_id] = w;
      fleet_.unsettled.insert(s.public_id);
      fleet_.bindings[s.public_id] = {w.cab, w.participant, std::nullopt};
    } else {
      // Not here: on a worker host, whose report adopts it within the hosts' lease (on_report);
      // else gone (or a second worker on a cab that has one), settled from its log after that.
      const auto grace = seconds(dds::kHostLeaseS + 1);
      const bool logged = static_cast<bool>(std::ifstream(fleet_.log_path(s.public_id)));
      fleet_.bindings[s.public_id] = {w.cab, w.participant, now + grace + std::chrono::seconds(2)};
      // Taken over from another server, a worker not on a worker host ran on that server's own
      // machine: its log is there, out of this one's reach.
      fleet_.finishing.push_back({w, s.state == SessionPhase::kStarting && !logged ? "the session never started (the server stopped while starting it)"
                                     : !all_workers && !logged
                                         ? "the school's server that ran it stopped, and its worker ran on that server's own machine"
                                         : "",
                                  now + grace});
    }
  }
  // At start-up, workers of this server with no open session here, or a second one for a cab:
  // no cab has two. (Later, a worker of a session another server runs is left alone.)
  if (all_workers)
    for (const auto& [id, p] : running)
      if (!fleet_.workers.count(id)) strays.push_back(p);
  return strays;
}

void WorkerSupervisor::stop_local_workers() {
  std::lock_guard<std::mutex> lock(fleet_.mu);
  // Adopted workers too: a server that stops ends the sessions it runs here (as "signal"), whoever
  // spawned them. A worker host's sessions go on: the school's other servers supervise them too,
  // and this one adopts them again when it starts.
  for (auto& [id, w] : fleet_.workers)
    if (w.host.empty()) signal_worker(w, SIGTERM);
}

void WorkerSupervisor::signal_worker(const WorkerInfo& w, int sig) {
  if (!w.host.empty()) {
    ask_host_(w.host, w.session, sig == SIGUSR1 ? WorkerAction::kAbort : WorkerAction::kKill);
    return;
  }
  // An adopted worker's pid is checked first: after it exits, the number may be another's.
  if (w.pid > 0 && (w.child || still_running({w.pid, w.session, w.cab, fleet_.log_path(w.session), w.start_ticks}))) kill(w.pid, sig);
}

void WorkerSupervisor::start_local(const store::Session& s, const std::string& scenario_file, std::optional<double> duration_s,
                                   const std::optional<std::string>& aids, const std::string& language) {
  const FleetConfig& config = fleet_.config;
  if (fleet_.secure()) {
    // The worker's identity must exist before it is spawned: a clear refusal now, not a failed
    // session later. The cab's identity is the cab's business (it lives on the cab).
    dds::SecurityFiles{config.security_dir, "worker." + s.cab_id}.check();
  }
  host::WorkerLaunch l;
  l.binary = config.worker_binary;
  l.session = s.public_id;
  l.cab = s.cab_id;
  l.mode = s.mode;
  l.scenario_file = scenario_file;
  l.log_base = config.log_dir + "/" + s.public_id;
  l.dds_domain = config.dds_domain;
  l.dds_config = config.dds_config;
  l.security_dir = config.security_dir;
  l.start_timeout_s = config.start_timeout_s;
  l.duration_s = duration_s;
  l.aids = aids;
  l.language = language;
  l.frames = config.frames;
  l.realtime = config.realtime_workers;

  std::lock_guard<std::mutex> lock(fleet_.mu);
  int here = 0;
  for (const auto& [id, w] : fleet_.workers) here += w.host.empty() ? 1 : 0;
  if (here >= config.max_workers)
    throw std::runtime_error("this machine already runs " + std::to_string(here) + " workers (the limit)");
  if (const std::string busy = fleet_.session_on(s.cab_id); !busy.empty())
    throw std::runtime_error("cab " + s.cab_id + " is running session " + busy);
  WorkerInfo w;
  w.session = s.public_id;
  w.cab = s.cab_id;
  w.pid = host::spawn_worker(l, false);
  w.child = true;
  w.started = w.last_state = Clock::now();
  fleet_.workers[s.public_id] = w;
  fleet_.unsettled.insert(s.public_id);
  // The worker writes its participant beside its log before it publishes; read on first sample.
  fleet_.bindings[s.public_id] = {w.cab, "", std::nullopt};
}

bool WorkerSupervisor::abort(const std::string& session) {
  std::lock_guard<std::mutex> lock(fleet_.mu);
  auto it = fleet_.workers.find(session);
  if (it == fleet_.workers.end()) return false;
  signal_worker(it->second, SIGUSR1);  // an adopted worker too, and a hosted one (its host is asked)
  return true;
}

bool WorkerSupervisor::check(WorkerInfo& w, Clock::time_point now, std::string& reason) {
  const double hang_s = fleet_.config.hang_timeout_s;
  bool done = false;
  if (!w.host.empty()) {
    // A hosted worker's end comes in its host's report (on_report); its host's death here,
    // after a whole lease: an agent that restarts in place is back within it (its workers
    // run on), one whose machine is down is not.
    const auto h = fleet_.hosts.find(w.host);
    const bool unheard = h == fleet_.hosts.end() && std::chrono::duration<double>(now - w.started).count() > dds::kHostLeaseS;
    if (unheard || (h != fleet_.hosts.end() && std::chrono::duration<double>(now - h->second.last_seen).count() >= dds::kHostLeaseS)) {
      done = true;
      reason = "the worker host " + w.host + " stopped answering (its machine, its network or its agent is down)";
    }
  } else if (w.child) {
    int status = 0;
    if (waitpid(w.pid, &status, WNOHANG) == w.pid) {
      done = true;
      reason = host::exit_words(status);
    }
  } else if (w.pid == 0 || !still_running({w.pid, w.session, w.cab, fleet_.log_path(w.session), w.start_ticks})) {
    done = true;  // an adopted worker: how it ended, its log says
  }
  if (done) return true;
  const double silent = std::chrono::duration<double>(now - w.last_state).count();
  if (!w.host.empty() && w.seen_state && silent > hang_s && w.hang_reason.empty()) {
    // Its host kills it and reports the end, with its files.
    w.hang_reason = "worker hung: no truck state for " + std::to_string(int(silent)) + " s";
    w.hang_asked = now;
    signal_worker(w, SIGKILL);
  } else if (!w.hang_reason.empty() && silent > hang_s &&
             std::chrono::duration<double>(now - w.hang_asked).count() > hang_s + 2 * dds::kHostLeaseS) {
    // Asked to kill it, its host never brought back an end with a log its worker signed.
    reason = w.hang_reason + "; its worker host " + w.host + " never brought back a session log signed by its worker";
    return true;
  } else if (w.host.empty() && w.seen_state && silent > hang_s) {
    reason = "worker hung: no truck state for " + std::to_string(int(silent)) + " s";
    signal_worker(w, SIGKILL);
    if (w.child) waitpid(w.pid, nullptr, 0);
    return true;
  }
  return false;
}

void WorkerSupervisor::watch() {
  std::lock_guard<std::mutex> lock(fleet_.mu);
  const auto now = Clock::now();
  for (auto it = fleet_.workers.begin(); it != fleet_.workers.end();) {
    WorkerInfo& w = it->second;
    std::string reason;
    if (check(w, now, reason)) {
      fleet_.finishing.push_back({w, reason, now + kLastSamples});
      fleet_.bindings[w.session].until = now + kLastSamples + std::chrono::seconds(30);
      it = fleet_.workers.erase(it);
    } else {
      ++it;
    }
  }
  for (auto it = fleet_.bindings.begin(); it != fleet_.bindings.end();)
    it = it->second.until && now > *it->second.until ? fleet_.bindings.erase(it) : std::next(it);
}

std::vector<FleetState::Finishing> WorkerSupervisor::due() {
  std::vector<FleetState::Finishing> due;
  std::lock_guard<std::mutex> lock(fleet_.mu);
  for (auto it = fleet_.finishing.begin(); it != fleet_.finishing.end();) {
    if (Clock::now() < it->at) { ++it; continue; }
    due.push_back(std::move(*it));
    it = fleet_.finishing.erase(it);
  }
  return due;
}

void WorkerSupervisor::settled(const std::string& session) {
  std::lock_guard<std::mutex> lock(fleet_.mu);
  if (!fleet_.workers.count(session)) fleet_.unsettled.erase(session);
}

}  // namespace forklift::server
