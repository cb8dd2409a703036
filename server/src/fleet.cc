#include "fleet.h"

#include "exam_evidence.h"
#include "worker_log.h"

#include "forklift/image/image.h"
#include "forklift/security/evidence.h"
#include "forklift/server/logs.h"
#include "forklift/session/session_log.h"

#include <fcntl.h>
#include <signal.h>
#include <spdlog/spdlog.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <set>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

namespace forklift::server {

bool set_state(store::Store& db, const std::string& session, const std::string& state, const std::string& reason,
               const store::Actor& actor) {
  const bool changed = db.set_session_state_audited(session, state, reason, store::now_iso8601(), actor);
  if (changed) session_log(session, state, {{"reason", reason}, {"by", actor.name}});
  return changed;
}

namespace {

// The score likewise: audited, and a line in the session log when it is new.
bool set_score(store::Store& db, const store::ScoreRecord& score, const store::Actor& actor) {
  const bool changed = db.set_score_audited(score, store::now_iso8601(), actor);
  if (changed) session_log(score.session_public_id, "scored", {{"mark", score.mark}, {"passed", score.passed}, {"by", actor.name}});
  return changed;
}

using Clock = std::chrono::steady_clock;

// A span of seconds (from a setting) as the clock's duration.
Clock::duration seconds(double s) { return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s)); }

// Who the audit log names for what workers report over DDS.
const store::Actor kWorker{std::nullopt, "worker"};
const store::Actor kServer{std::nullopt, "server"};  // the supervisor's own findings
const store::Actor kWorkerLog{std::nullopt, "worker log"};  // what the server took from a worker's session log

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

Fleet::Fleet(FleetConfig config) : config_(std::move(config)) {
  participant_ = std::make_unique<dds::Participant>(
      dds::DomainSettings::resolve(config_.dds_domain, config_.dds_config, config_.security_dir, config_.identity));
  status_writer_ = std::make_unique<dds::Writer<fk_SessionStatus>>(*participant_);
  if (!secure() && config_.trust_clear_hosts)
    spdlog::warn("worker hosts are believed in clear DDS (--trust-clear-hosts): any machine on this network can claim to be "
                 "one, take sessions, stop workers and set marks; keep this to a closed network the school alone can reach");
  else if (!secure())
    spdlog::info("worker hosts are not believed in clear DDS (no identity vouches for them): give --security, or "
                 "--trust-clear-hosts on a closed network");
  auto db = store::Store::open(config_.db_path);
  adopt(*db);
  supervisor_ = std::thread([this] { supervise(); });
  ingest_ = std::thread([this] { ingest(); });
}

void Fleet::adopt(store::Store& db) {
  // A restarted server adopts the sessions still open whose workers still run (they keep
  // reporting over DDS; not our children, they are watched through /proc). A session whose
  // worker is gone is settled from its log: it may have ended, with its mark, while we were down.
  std::map<std::string, WorkerProcess> running;  // by session
  std::vector<WorkerProcess> strays;
  for (const WorkerProcess& p : find_workers(config_.log_dir)) {
    if (running.count(p.session)) strays.push_back(p);
    else running[p.session] = p;
  }
  const auto now = Clock::now();
  std::set<std::string> cabs_taken;
  std::vector<store::Session> open = db.open_sessions();
  // The newest session of a cab keeps it: an older one still open is settled.
  std::sort(open.begin(), open.end(), [](const store::Session& a, const store::Session& b) { return a.public_id > b.public_id; });
  for (const store::Session& s : open) {
    WorkerInfo w;
    w.session = s.public_id;
    w.cab = s.cab_id;
    w.started = w.last_state = now;
    w.participant = logged_participant(log_path(s.public_id));
    const auto p = running.find(s.public_id);
    if (p != running.end() && p->second.cab == s.cab_id && !cabs_taken.count(s.cab_id)) {
      w.pid = p->second.pid;
      w.start_ticks = p->second.start_ticks;
      running.erase(p);
      cabs_taken.insert(s.cab_id);
      spdlog::info("adopted the worker (pid {}) of session {} on cab {}", w.pid, s.public_id, s.cab_id);
      workers_[s.public_id] = w;
      unsettled_.insert(s.public_id);
      bindings_[s.public_id] = {w.cab, w.participant, std::nullopt};
    } else {
      // Not here: on a worker host, whose report adopts it within the hosts' lease (on_report);
      // else gone (or a second worker on a cab that has one), settled from its log after that.
      const auto grace = seconds(dds::kHostLeaseS + 1);
      bindings_[s.public_id] = {w.cab, w.participant, now + grace + std::chrono::seconds(2)};
      finishing_.push_back({w, s.state == "starting" && !std::ifstream(log_path(s.public_id))
                                   ? "the session never started (the server stopped while starting it)"
                                   : "",
                            now + grace});
    }
  }
  // Workers of this server with no open session, or a second one for a cab: no cab has two.
  for (const auto& [id, p] : running) strays.push_back(p);
  for (const WorkerProcess& p : strays) {
    spdlog::warn("stopping worker pid {} (session {}, cab {}): its session is not open here or its cab runs another", p.pid, p.session, p.cab);
    kill(p.pid, SIGTERM);
  }
}

Fleet::~Fleet() {
  stop_ = true;
  if (supervisor_.joinable()) supervisor_.join();
  if (ingest_.joinable()) ingest_.join();
  std::lock_guard<std::mutex> lock(mu_);
  // Adopted workers too: a server that stops ends the sessions it runs here (as "signal"), whoever
  // spawned them. A worker host's sessions go on: the school's other servers supervise them too,
  // and this one adopts them again when it starts.
  for (auto& [id, w] : workers_)
    if (w.host.empty()) signal_worker(w, SIGTERM);
}

void Fleet::signal_worker(const WorkerInfo& w, int sig) {
  if (!w.host.empty()) {  // under mu_
    request(w.host, w.session, sig == SIGUSR1 ? "abort" : "kill");
    return;
  }
  // An adopted worker's pid is checked first: after it exits, the number may be another's.
  if (w.pid > 0 && (w.child || still_running({w.pid, w.session, w.cab, log_path(w.session), w.start_ticks}))) kill(w.pid, sig);
}

bool HostInfo::alive(std::chrono::steady_clock::time_point now) const {
  return !gone && std::chrono::duration<double>(now - last_seen).count() < dds::kHostLeaseS;
}

std::vector<std::string> Fleet::placement(const std::string& cab) {
  const auto now = Clock::now();
  const auto cab_it = cabs_.find(cab);
  const std::string site = cab_it == cabs_.end() ? "" : cab_it->second.site;
  std::vector<const HostInfo*> room;
  for (const auto& [id, h] : hosts_)
    if (h.alive(now) && h.has_room() && now >= h.passed_over_until) room.push_back(&h);
  // The cab's own site first; then the emptiest (by share of its capacity), then the least loaded.
  std::sort(room.begin(), room.end(), [&](const HostInfo* a, const HostInfo* b) {
    const bool a_near = !site.empty() && a->site == site, b_near = !site.empty() && b->site == site;
    if (a_near != b_near) return a_near;
    const double a_share = double(a->running + a->placed) / a->capacity, b_share = double(b->running + b->placed) / b->capacity;
    if (a_share != b_share) return a_share < b_share;
    const double a_load = a->load_1min / std::max(1, a->cores), b_load = b->load_1min / std::max(1, b->cores);
    if (a_load != b_load) return a_load < b_load;
    return a->id < b->id;
  });
  std::vector<std::string> ids;
  for (const HostInfo* h : room) ids.push_back(h->id);
  return ids;
}

void Fleet::request(const std::string& host, const std::string& session, const char* action) {
  auto& writer = request_writers_[host];
  if (!writer) writer = std::make_unique<dds::Writer<fk_WorkerRequest>>(*participant_, dds::host_partition(host));
  auto r = std::make_unique<fk_WorkerRequest>();  // 64 KiB of scenario: not on the stack
  dds::set_string(r->session_id, session);
  dds::set_string(r->host_id, host);
  dds::set_string(r->action, action);
  writer->write(*r);
}

void Fleet::start_worker(const store::Session& s, const std::string& scenario_file, std::optional<double> duration_s,
                         const std::optional<std::string>& aids) {
  std::vector<std::string> hosts;
  bool any_host = false;
  {
    std::lock_guard<std::mutex> lock(mu_);
    for (const auto& [id, w] : workers_)
      if (w.cab == s.cab_id) throw std::runtime_error("cab " + s.cab_id + " is running session " + id);
    for (const auto& [id, h] : hosts_) any_host = any_host || h.alive(Clock::now());
    hosts = placement(s.cab_id);
  }
  std::string refusals;
  if (!hosts.empty() && start_hosted_worker(s, scenario_file, duration_s, aids, hosts, refusals)) return;
  if (!config_.local_workers) {
    if (!refusals.empty()) throw std::runtime_error("no worker host took the session (" + refusals + ")");
    throw std::runtime_error(any_host ? "every worker host is full, stopping or passed over"
                                      : hosts_believed() ? "no worker host is about (and this server runs none itself)"
                                                         : "this server runs no worker itself, and believes no worker host without "
                                                           "DDS Security (--security, or --trust-clear-hosts on a closed network)");
  }
  // No host took it, or none is about: this machine runs the worker, as one without hosts does.
  if (!refusals.empty()) spdlog::warn("session {}: no worker host took it ({}); its worker runs here", s.public_id, refusals);
  if (secure()) {
    // The worker's identity must exist before it is spawned: a clear refusal now, not a failed
    // session later. The cab's identity is the cab's business (it lives on the cab).
    dds::SecurityFiles{config_.security_dir, "worker." + s.cab_id}.check();
  }
  host::WorkerLaunch l;
  l.binary = config_.worker_binary;
  l.session = s.public_id;
  l.cab = s.cab_id;
  l.mode = s.mode;
  l.scenario_file = scenario_file;
  l.log_base = config_.log_dir + "/" + s.public_id;
  l.dds_domain = config_.dds_domain;
  l.dds_config = config_.dds_config;
  l.security_dir = config_.security_dir;
  l.start_timeout_s = config_.start_timeout_s;
  l.duration_s = duration_s;
  l.aids = aids;
  l.frames = config_.frames;
  l.realtime = config_.realtime_workers;
  start_local_worker(s, l);
}

void Fleet::start_local_worker(const store::Session& s, const host::WorkerLaunch& launch) {
  std::lock_guard<std::mutex> lock(mu_);
  int here = 0;
  for (const auto& [id, w] : workers_) here += w.host.empty() ? 1 : 0;
  if (here >= config_.max_workers)
    throw std::runtime_error("this machine already runs " + std::to_string(here) + " workers (the limit)");
  for (const auto& [id, w] : workers_)
    if (w.cab == s.cab_id) throw std::runtime_error("cab " + s.cab_id + " is running session " + id);
  WorkerInfo w;
  w.session = s.public_id;
  w.cab = s.cab_id;
  w.pid = host::spawn_worker(launch, false);
  w.child = true;
  w.started = w.last_state = Clock::now();
  workers_[s.public_id] = w;
  unsettled_.insert(s.public_id);
  // The worker writes its participant beside its log before it publishes; read on first sample.
  bindings_[s.public_id] = {w.cab, "", std::nullopt};
}

bool Fleet::start_hosted_worker(const store::Session& s, const std::string& scenario_file, std::optional<double> duration_s,
                                const std::optional<std::string>& aids, std::vector<std::string> candidates,
                                std::string& refusals) {
  const auto deadline = Clock::now() + seconds(config_.start_budget_s);
  auto r = std::make_unique<fk_WorkerRequest>();  // 64 KiB of scenario: not on the stack
  const std::string scenario = slurp(scenario_file);
  if (scenario.empty()) throw std::runtime_error("the scenario " + scenario_file + " cannot be read");
  if (scenario.size() >= sizeof(r->scenario_json)) throw std::runtime_error("the scenario is over 64 KiB, more than a host takes");
  dds::set_string(r->session_id, s.public_id);
  dds::set_string(r->action, "start");
  dds::set_string(r->cab_id, s.cab_id);
  dds::set_string(r->mode, s.mode);
  r->duration_s = duration_s.value_or(0);
  dds::set_string(r->aids, aids.value_or(""));
  dds::set_string(r->scenario_json, scenario);
  if (config_.frames) {
    r->frame_fps = config_.frames->fps;
    r->frame_width = static_cast<uint16_t>(config_.frames->width);
    r->frame_height = static_cast<uint16_t>(config_.frames->height);
    r->frame_jpeg = config_.frames->jpeg;
  }
  for (const std::string& host : candidates) {
    if (Clock::now() >= deadline) {
      refusals += (refusals.empty() ? "" : "; ") + std::string("the start's ") + std::to_string(int(config_.start_budget_s)) +
                  " s ran out before host " + host + " was asked";
      break;
    }
    dds::Writer<fk_WorkerRequest>* writer;
    {
      std::unique_lock<std::mutex> lock(mu_);
      for (const auto& [id, w] : workers_)
        if (w.cab == s.cab_id) throw std::runtime_error("cab " + s.cab_id + " is running session " + id);
      // Known before the host answers: its report finds the session ours, not a stray.
      WorkerInfo w;
      w.session = s.public_id;
      w.cab = s.cab_id;
      w.host = host;
      w.started = w.last_state = Clock::now();
      workers_[s.public_id] = w;
      unsettled_.insert(s.public_id);
      bindings_[s.public_id] = {w.cab, "", std::nullopt};
      start_answers_.erase(s.public_id);
      ++hosts_[host].placed;
      auto& wr = request_writers_[host];
      if (!wr) wr = std::make_unique<dds::Writer<fk_WorkerRequest>>(*participant_, dds::host_partition(host));
      writer = wr.get();
    }
    // Each host has its share of what is left of the budget, so that a silent one leaves time
    // for the next and for this machine.
    const auto until = std::min(deadline, Clock::now() + seconds(config_.host_answer_timeout_s));
    // A writer made just now may not have found the host's reader yet.
    while (writer->matched() == 0 && Clock::now() < until) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    dds::set_string(r->host_id, host);
    writer->write(*r);  // in the host's own partition: under DDS Security only that host may read it
    std::unique_lock<std::mutex> lock(mu_);
    // Taken once the host names its running worker (or it has already exited, which settles the
    // session): a host that says "starting" and then nothing more is passed over like a silent one.
    const bool answered = answered_.wait_until(lock, until, [&] {
      const auto a = start_answers_.find(s.public_id);
      return a != start_answers_.end() && a->second.host == host && a->second.state != "starting";
    });
    --hosts_[host].placed;
    const StartAnswer a = answered ? start_answers_[s.public_id] : StartAnswer{host, "", "no running worker named in time"};
    start_answers_.erase(s.public_id);
    if (answered && a.state != "refused") {
      spdlog::info("session {} on cab {}: its worker runs on host {}", s.public_id, s.cab_id, host);
      return true;
    }
    // Refused, or silent: the next host. A late start is stopped (its session runs elsewhere).
    if (!answered) {
      request(host, s.public_id, "kill");
      hosts_[host].passed_over_until = Clock::now() + seconds(config_.host_pass_over_s);
      spdlog::warn("worker host {} took session {} and named no running worker in time: passed over for {} s", host,
                   s.public_id, int(config_.host_pass_over_s));
    }
    workers_.erase(s.public_id);
    unsettled_.erase(s.public_id);
    bindings_.erase(s.public_id);
    refusals += (refusals.empty() ? "" : "; ") + host + ": " + a.reason;
  }
  return false;
}

bool Fleet::abort(const std::string& session) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = workers_.find(session);
  if (it == workers_.end()) return false;
  signal_worker(it->second, SIGUSR1);  // an adopted worker too, and a hosted one (its host is asked)
  return true;
}

bool Fleet::settling(const std::string& session) {
  std::lock_guard<std::mutex> lock(mu_);
  return unsettled_.count(session) > 0;
}

std::vector<WorkerInfo> Fleet::workers() {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<WorkerInfo> out;
  for (const auto& [id, w] : workers_) out.push_back(w);
  return out;
}

std::vector<HostInfo> Fleet::hosts() {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<HostInfo> out;
  for (const auto& [id, h] : hosts_) out.push_back(h);
  return out;
}

std::vector<CabInfo> Fleet::cabs_online(double within_s) {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<CabInfo> out;
  const auto now = Clock::now();
  for (const auto& [id, c] : cabs_)
    if (std::chrono::duration<double>(now - c.last_seen).count() < within_s) out.push_back(c);
  return out;
}

bool Fleet::cab_busy(const std::string& cab) {
  std::lock_guard<std::mutex> lock(mu_);
  for (const auto& [id, w] : workers_) if (w.cab == cab) return true;
  return false;
}

void Fleet::publish_status(const std::string& session, const std::string& cab, const char* state, const std::string& reason) {
  fk_SessionStatus s{};
  dds::set_string(s.session_id, session);
  dds::set_string(s.cab_id, cab);
  dds::set_string(s.state, state);
  dds::set_string(s.reason, reason);
  status_writer_->write(s);
  // The cab reads its own partition only.
  std::lock_guard<std::mutex> lock(mu_);
  auto& w = cab_status_writers_[cab];
  if (!w) w = std::make_unique<dds::Writer<fk_SessionStatus>>(*participant_, dds::cab_partition(cab));
  w->write(s);
}

std::optional<LiveView> Fleet::follow(const std::string& session) {
  std::lock_guard<std::mutex> lock(mu_);
  const auto w = workers_.find(session);
  if (w == workers_.end()) return std::nullopt;
  Followed& f = followed_[w->second.cab];
  if (!f.frames) f.frames = std::make_unique<dds::Reader<fk_Frame>>(*participant_, dds::cab_partition(w->second.cab));
  f.last_asked = Clock::now();
  LiveView v = f.view;
  v.state = w->second.last;
  v.have_state = w->second.seen_state;
  return v;
}

void Fleet::take_followed_frames() {
  constexpr auto kFollowIdle = std::chrono::seconds(10);
  struct Newest {
    std::string cab;
    fk_Frame head{};  // the scalars only: its pixel buffer went back to DDS with the loan
    std::vector<uint8_t> pixels;
  };
  std::vector<Newest> taken;
  {
    std::lock_guard<std::mutex> lock(mu_);
    for (auto it = followed_.begin(); it != followed_.end();) {
      if (Clock::now() - it->second.last_asked > kFollowIdle) { it = followed_.erase(it); continue; }
      // Keep-last-1 readers: at most a few samples wait here; only the newest is kept.
      Newest n{it->first, {}, {}};
      if (it->second.frames->take_each([&](const fk_Frame& f) {
            n.head = f;
            n.pixels.assign(f.pixels._buffer, f.pixels._buffer + f.pixels._length);
          }) > 0)
        taken.push_back(std::move(n));
      ++it;
    }
  }
  // Encoding takes a millisecond or two: outside the lock that the HTTP threads share.
  for (Newest& n : taken) {
    std::vector<uint8_t> jpeg;
    try {
      if (std::string(n.head.encoding) == "jpeg") {
        jpeg = std::move(n.pixels);
      } else if (std::string(n.head.encoding) == "rgb8" && n.pixels.size() == size_t(n.head.width) * n.head.height * 3) {
        Image img;
        img.width = n.head.width;
        img.height = n.head.height;
        img.rgb = std::move(n.pixels);
        jpeg = encode_jpeg(img, 80);
      } else {
        continue;  // not a frame this server can show
      }
    } catch (const std::exception& e) {
      spdlog::warn("frame from cab {}: {}", n.cab, e.what());
      continue;
    }
    std::lock_guard<std::mutex> lock(mu_);
    const auto it = followed_.find(n.cab);
    if (it == followed_.end()) continue;
    it->second.view.jpeg = std::move(jpeg);
    it->second.view.frame_seq = n.head.seq;
    it->second.view.frame_sim_time_s = n.head.sim_time_s;
  }
}

void Fleet::fail(store::Store& db, const std::string& session, const std::string& cab, const std::string& reason) {
  // Never a pass: a session whose worker died is failed with the reason, and the cab is told.
  if (set_state(db, session, "failed", reason, kServer)) {
    spdlog::warn("session {} failed: {}", session, reason);
    publish_status(session, cab, "failed", reason);
  }
}

void Fleet::supervise() {
  auto db = store::Store::open(config_.db_path);
  std::vector<std::pair<std::string, Clock::time_point>> to_chain;  // ended exams, until when to wait
  // The database's chain must be the anchored one before anything is chained onto it.
  std::string chain_problem;
  try {
    chain_problem = check_chain_at_start(*db, *anchor_, chain_keys());
  } catch (const std::exception& e) {
    chain_problem = std::string("the exam chain cannot be checked: ") + e.what();
  }
  if (!chain_problem.empty()) {
    spdlog::error("{}. No exam is chained, and no certificate counts a practical exam, until the database's exam_chain is "
                  "restored from a backup", chain_problem);
    std::lock_guard<std::mutex> lock(mu_);
    chain_status_.problem = chain_problem;
  }
  // Exams whose worker ended while this server was down, or just before it stopped: each is
  // checked against its signed log before it is chained (chain_exam).
  for (const std::string& s : db->unchained_signed_exams()) to_chain.push_back({s, Clock::now() + std::chrono::seconds(15)});
  // The samples a worker sent just before it exited may still be on their way.
  constexpr auto kLastSamples = std::chrono::milliseconds(1000);
  while (!stop_) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      const auto now = Clock::now();
      for (auto it = workers_.begin(); it != workers_.end();) {
        WorkerInfo& w = it->second;
        std::string reason;
        bool done = false;
        if (!w.host.empty()) {
          // A hosted worker's end comes in its host's report (on_report); its host's death here,
          // after a whole lease: an agent that restarts in place is back within it (its workers
          // run on), one whose machine is down is not.
          const auto h = hosts_.find(w.host);
          const bool unheard = h == hosts_.end() && std::chrono::duration<double>(now - w.started).count() > dds::kHostLeaseS;
          if (unheard || (h != hosts_.end() && std::chrono::duration<double>(now - h->second.last_seen).count() >= dds::kHostLeaseS)) {
            done = true;
            reason = "the worker host " + w.host + " stopped answering (its machine, its network or its agent is down)";
          }
        } else if (w.child) {
          int status = 0;
          if (waitpid(w.pid, &status, WNOHANG) == w.pid) {
            done = true;
            reason = host::exit_words(status);
          }
        } else if (w.pid == 0 || !still_running({w.pid, w.session, w.cab, log_path(w.session), w.start_ticks})) {
          done = true;  // an adopted worker: how it ended, its log says
        }
        const double silent = std::chrono::duration<double>(now - w.last_state).count();
        if (!done && !w.host.empty() && w.seen_state && silent > config_.hang_timeout_s && w.hang_reason.empty()) {
          // Its host kills it and reports the end, with its files.
          w.hang_reason = "worker hung: no truck state for " + std::to_string(int(silent)) + " s";
          w.hang_asked = now;
          signal_worker(w, SIGKILL);
        } else if (!done && !w.hang_reason.empty() && silent > config_.hang_timeout_s &&
                   std::chrono::duration<double>(now - w.hang_asked).count() > config_.hang_timeout_s + 2 * dds::kHostLeaseS) {
          // Asked to kill it, its host never brought back an end with a log its worker signed.
          done = true;
          reason = w.hang_reason + "; its worker host " + w.host + " never brought back a session log signed by its worker";
        } else if (!done && w.host.empty() && w.seen_state && silent > config_.hang_timeout_s) {
          reason = "worker hung: no truck state for " + std::to_string(int(silent)) + " s";
          signal_worker(w, SIGKILL);
          if (w.child) waitpid(w.pid, nullptr, 0);
          done = true;
        }
        if (done) {
          finishing_.push_back({w, reason, now + kLastSamples});
          bindings_[w.session].until = now + kLastSamples + std::chrono::seconds(30);
          it = workers_.erase(it);
        } else {
          ++it;
        }
      }
      for (auto it = bindings_.begin(); it != bindings_.end();)
        it = it->second.until && now > *it->second.until ? bindings_.erase(it) : std::next(it);
    }
    std::vector<Finishing> due;
    {
      std::lock_guard<std::mutex> lock(mu_);
      for (auto it = finishing_.begin(); it != finishing_.end();) {
        if (Clock::now() < it->at) { ++it; continue; }
        due.push_back(std::move(*it));
        it = finishing_.erase(it);
      }
    }
    for (const Finishing& f : due) {
      try {
        settle(*db, f.worker, f.reason, to_chain);
      } catch (const std::exception& e) {
        spdlog::error("settling session {}: {}", f.worker.session, e.what());
      }
      std::lock_guard<std::mutex> lock(mu_);
      if (!workers_.count(f.worker.session)) unsettled_.erase(f.worker.session);
    }
    chain_ended_exams(*db, to_chain);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

void Fleet::settle(store::Store& db, const WorkerInfo& w, const std::string& reason,
                   std::vector<std::pair<std::string, Clock::time_point>>& to_chain) {
  const std::string log = log_path(w.session);
  const std::string base = config_.log_dir + "/" + w.session;
  if (std::ifstream(log)) db.put_session_log(w.session, "control", slurp(log));
  if (std::ifstream(base + ".err")) db.put_session_log(w.session, "worker", slurp(base + ".err"));
  // What the samples did not bring: the log lists every event and the mark it published.
  const std::optional<LoggedSession> logged = read_logged_session(log, w.session);
  if (logged) {
    uint64_t events = 0;
    for (const store::EventRecord& e : logged->events) events += db.add_event(e) ? 1 : 0;
    bool scored = false;
    if (logged->score && !db.get_score(w.session)) {
      store::ScoreRecord score = *logged->score;
      score.exam_details = practical_exam_details(db, config_.data_dir, rules_, w.session, logged->end_reason.value_or(""),
                                                  logged->points, score.counts, score.passed);
      // A hosted worker's mark of record is its log's, which its host brings when it exits.
      scored = set_score(db, score, w.host.empty() ? kWorkerLog : kWorker) && w.host.empty();
    }
    if (events || scored) {
      std::lock_guard<std::mutex> lock(mu_);
      refused_.recovered_events += events;
      refused_.recovered_scores += scored ? 1 : 0;
    }
    if (events || scored)
      spdlog::warn("session {}: {} event(s){} taken from the worker's log (their samples never arrived)", w.session, events,
                   scored ? " and the score" : "");
  }
  if (std::ifstream(log + ".sig")) {
    db.put_session_log(w.session, "signature", slurp(log + ".sig"));
    to_chain.push_back({w.session, Clock::now() + std::chrono::seconds(15)});
  }
  const auto s = db.get_session(w.session);
  if (!s || store::is_terminal(s->state)) return;
  if (logged && logged->score && logged->end_reason) {
    // The log's end is the session's, whatever became of the worker's last status.
    if (set_state(db, w.session, "ended", *logged->end_reason, kWorkerLog))
      publish_status(w.session, w.cab, "ended", *logged->end_reason);
  } else if (logged && logged->gave_up) {
    fail(db, w.session, w.cab, "the cab never spoke");
  } else if (!reason.empty()) {
    fail(db, w.session, w.cab, reason);
  } else if (!w.child && w.host.empty()) {
    fail(db, w.session, w.cab, logged ? "the worker stopped before the session ended (the server was down)"
                                      : "the worker was gone after a server restart, with no session log");
  } else {
    // A clean exit with no mark in the log (a session that never ran): ended, which carries no
    // mark and so is never a pass.
    set_state(db, w.session, "ended", "worker exited", kServer);
  }
}

void Fleet::chain_ended_exams(store::Store& db, std::vector<std::pair<std::string, Clock::time_point>>& pending) {
  if (pending.empty()) return;
  ChainKeys keys;
  std::string broken;
  try {
    keys = chain_keys();
  } catch (const std::exception& e) {
    broken = std::string("the school's CA cannot be read: ") + e.what();
  }
  for (auto it = pending.begin(); it != pending.end();) {
    const bool late = Clock::now() > it->second;
    ChainOutcome r;
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (broken.empty()) broken = chain_status_.problem;
    }
    try {
      // Its score and events come over DDS and may still be on their way.
      r = broken.empty() ? chain_exam(db, it->first, *anchor_, keys, late) : ChainOutcome{ChainResult::kChainBroken, broken};
    } catch (const std::exception& e) {
      spdlog::error("cannot chain exam {}: {}", it->first, e.what());
    }
    if (r.result == ChainResult::kNotReady && !late) { ++it; continue; }
    if (r.result == ChainResult::kNotReady) spdlog::error("exam {} never got its score: not chained", it->first);
    if (r.result == ChainResult::kChainBroken || r.result == ChainResult::kRefused) {
      const std::string why = r.result == ChainResult::kRefused ? r.why : "the exam chain is broken: " + r.why;
      spdlog::error("exam {} is not chained: {}", it->first, why);
      {
        std::lock_guard<std::mutex> lock(mu_);
        if (r.result == ChainResult::kChainBroken && chain_status_.problem.empty()) chain_status_.problem = r.why;
        ++chain_status_.refused;
      }
      try {
        record_chain_refusal(db, it->first, why);
      } catch (const std::exception& e) {
        spdlog::error("cannot record the refusal of exam {}: {}", it->first, e.what());
      }
    }
    it = pending.erase(it);
  }
}

RefusedSamples Fleet::refused() {
  std::lock_guard<std::mutex> lock(mu_);
  return refused_;
}

void Fleet::refuse(uint64_t RefusedSamples::*counter, const std::string& what) {
  uint64_t n;
  bool first;
  {
    std::lock_guard<std::mutex> lock(mu_);
    n = ++(refused_.*counter);
    // Each different refusal is named once (a forged report among a clear host's many statuses is
    // seen), within a bounded memory; repeats only as the count doubles.
    first = refusals_named_.size() < kRefusalsNamed && refusals_named_.insert(what).second;
  }
  if (first || n <= 20 || (n & (n - 1)) == 0) spdlog::warn("refused {} ({} so far)", what, n);
}

Fleet::Verdict Fleet::check_sender(const std::string& session, dds_entity_t reader, const dds_sample_info_t& info,
                                   bool state_topic) {
  Binding b;
  {
    std::lock_guard<std::mutex> lock(mu_);
    const auto it = bindings_.find(session);
    if (it == bindings_.end()) return Verdict::kNotOurs;  // another server's, or long over
    if (it->second.participant.empty()) {
      const auto w = workers_.find(session);
      // A hosted worker's participant comes in its host's report, which may follow its first samples.
      if (w != workers_.end() && !w->second.host.empty()) return Verdict::kNotYet;
      it->second.participant = logged_participant(log_path(session));
      // No log here: a hosted worker that a restart has not heard its host on yet (adopt()).
      if (it->second.participant.empty() && !std::ifstream(log_path(session))) return Verdict::kNotYet;
    }
    b = it->second;
  }
  auto sender = senders_.find(info.publication_handle);
  if (sender == senders_.end()) {
    auto found = dds::sender_of(reader, info.publication_handle);
    if (!found) return Verdict::kWrongSender;  // a writer discovery does not vouch for
    sender = senders_.emplace(info.publication_handle, std::move(*found)).first;
  }
  const std::string partition = state_topic ? dds::cab_partition(b.cab) : dds::worker_partition(b.cab);
  if (b.participant.empty() || sender->second.participant != b.participant || !sender->second.in(partition))
    return Verdict::kWrongSender;
  return Verdict::kOurs;
}

namespace {

// A sample whose sender cannot be told yet, kept until it can (ingest thread).
template <typename T>
struct Deferred {
  T sample;
  dds_sample_info_t info;
  std::chrono::steady_clock::time_point at;
};

bool valid_session_id(const char* id) { return std::regex_match(id, std::regex("s-[0-9]{1,18}")); }

void write_octets(const std::string& path, const dds_sequence_octet& bytes) {
  if (bytes._length == 0) { std::remove(path.c_str()); return; }
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes._buffer), bytes._length);
  if (!out) throw std::runtime_error("cannot write " + path);
}

bool finite(std::initializer_list<double> xs) {
  for (double x : xs) if (!std::isfinite(x)) return false;
  return true;
}

// What is wrong with a sample's strings (UTF-8 and not empty where a name is), or nullopt.
std::optional<std::string> bad_text(std::initializer_list<std::pair<const char*, const char*>> fields) {
  for (const auto& [name, text] : fields)
    if (!dds::valid_utf8(text)) return std::string(name) + " is not UTF-8";
  return std::nullopt;
}

}  // namespace

void Fleet::write_worker_files(const fk_WorkerReport& r) {
  // The session id is checked (s-<digits>): it names the files.
  const std::string log = log_path(r.session_id);
  write_octets(log, r.control_log);
  write_octets(log + ".sig", r.signature);
  write_octets(config_.log_dir + "/" + r.session_id + ".err", r.worker_err);
  std::ofstream(log + ".participant") << r.participant << '\n';
}

std::optional<std::string> Fleet::unsigned_log_problem(const fk_WorkerReport& r, const std::string& cab) {
  if (!secure()) return std::nullopt;  // trusted clear hosts (a closed lab): no identities to check
  if (r.control_log._length == 0) return std::nullopt;  // no log: the session ends without a mark
  const std::string log(reinterpret_cast<const char*>(r.control_log._buffer), r.control_log._length);
  if (r.signature._length == 0) return "its session log is not signed (every worker signs its log under DDS Security)";
  const auto signature = nlohmann::json::parse(r.signature._buffer, r.signature._buffer + r.signature._length, nullptr, false);
  if (signature.is_discarded()) return "its log signature is not JSON";
  ChainKeys keys;
  try {
    keys = forklift::server::chain_keys(config_.security_dir, config_.identity);
  } catch (const std::exception& e) {
    return std::string("the school's CA cannot be read to check it: ") + e.what();
  }
  const security::VerifyReport v = security::verify_log_signature(r.session_id, cab, log, signature, keys.ca_pem, keys.crl_pem);
  if (v.ok) return std::nullopt;
  std::string why = "its session log is not signed by cab " + cab + "'s worker: ";
  for (size_t i = 0; i < v.problems.size(); ++i) why += (i ? "; " : "") + v.problems[i];
  return why;
}

void Fleet::on_report(store::Store& db, const fk_WorkerReport& r) {
  if (!valid_session_id(r.session_id)) throw std::runtime_error(std::string("a report on session '") + r.session_id + "'");
  const std::string state = r.state, session = r.session_id;
  if (state != "starting" && state != "running" && state != "exited" && state != "refused")
    throw std::runtime_error("a report of a worker " + state);
  if (r.participant[0] && !std::regex_match(r.participant, std::regex("[0-9a-f]{32}")))
    throw std::runtime_error(std::string("a report naming participant '") + r.participant + "'");
  const auto now = Clock::now();
  constexpr auto kLastSamples = std::chrono::milliseconds(1000);
  // An exited worker's files settle the mark: they count only as the session's worker signed them
  // (checked once, for the cab the session was started on); refused, the report is not an answer.
  std::optional<std::optional<std::string>> log_problem;
  auto refused_log = [&](const std::string& cab) {
    if (state != "exited") return false;
    if (!log_problem) log_problem = unsigned_log_problem(r, cab);
    if (!*log_problem) return false;
    const uint64_t n = ++refused_.unsigned_log;
    spdlog::warn("refused host {}'s report that session {}'s worker exited: {} ({} such so far)", r.host_id, session, **log_problem, n);
    return true;
  };
  // Its files are not believed, and its states tell whether it really ended: if none come, the
  // supervisor fails the session with this reason (a worker that crashed before signing).
  auto distrust = [&](WorkerInfo& w) {
    if (!w.hang_reason.empty()) return;
    w.hang_reason = "its worker host reported that it ended, with a session log its worker did not sign";
    w.hang_asked = now;
  };
  // What becomes of the worker once it is ours: its participant believed, its end settled.
  auto follow = [&](WorkerInfo& w) {
    if (refused_log(w.cab)) return distrust(w);
    if (r.participant[0]) {
      w.participant = r.participant;
      bindings_[session].participant = r.participant;
    }
    if (state != "exited") return;
    write_worker_files(r);
    const std::string reason = !w.hang_reason.empty() ? w.hang_reason : r.reason;
    finishing_.push_back({w, reason, now + kLastSamples});
    bindings_[session].until = now + kLastSamples + std::chrono::seconds(30);
    workers_.erase(session);
  };
  {
    std::lock_guard<std::mutex> lock(mu_);
    const auto w = workers_.find(session);
    const auto ending = std::find_if(finishing_.begin(), finishing_.end(), [&](const Finishing& x) { return x.worker.session == session; });
    // Never a report on a session whose worker this server runs itself: its own files are the truth.
    if ((w != workers_.end() && w->second.host.empty()) || (ending != finishing_.end() && ending->worker.child)) {
      const uint64_t n = ++refused_.wrong_sender;
      spdlog::warn("refused host {}'s report on session {}, whose worker runs on this server ({} refused samples so far)",
                   r.host_id, session, n);
      return;
    }
    if (w != workers_.end() && w->second.host == r.host_id && refused_log(w->second.cab)) return distrust(w->second);
    start_answers_[session] = {r.host_id, state, r.reason};
    answered_.notify_all();
    if (state == "refused") return;
    if (w != workers_.end()) {
      if (w->second.host != r.host_id) {
        spdlog::warn("host {} reports a worker for session {}, which runs {}: stopping it", r.host_id, session,
                     w->second.host.empty() ? "here" : "on host " + w->second.host);
        if (state != "exited") request(r.host_id, session, "kill");  // a start that answered too late
        return;
      }
      follow(w->second);
      return;
    }
    // One a restart left waiting for its host's word (adopt()) is adopted now; any other being
    // settled stays so.
    const bool waiting = ending != finishing_.end() && ending->worker.host.empty() && !ending->worker.child && ending->worker.pid == 0;
    if (waiting) finishing_.erase(ending);
    else if (ending != finishing_.end() || unsettled_.count(session)) return;
  }
  // A session this server did not start: adopted if it is open for that cab (another server's,
  // or this one's before a restart); its worker stopped if the session is over or unknown.
  const auto s = db.get_session(session);
  if (!s || store::is_terminal(s->state) || s->cab_id != r.cab_id) {
    if (state == "exited") return;
    spdlog::warn("host {} runs a worker for session {}, which is {}: stopping it", r.host_id, session,
                 !s ? "unknown here" : store::is_terminal(s->state) ? "over" : "on another cab");
    std::lock_guard<std::mutex> lock(mu_);
    request(r.host_id, session, "kill");
    return;
  }
  std::lock_guard<std::mutex> lock(mu_);
  for (const auto& [id, other] : workers_)
    if (other.cab == s->cab_id && id != session) {
      spdlog::warn("host {} runs a worker for session {} on cab {}, which runs session {}: stopping it", r.host_id, session, s->cab_id, id);
      request(r.host_id, session, "kill");
      return;
    }
  WorkerInfo w;
  w.session = session;
  w.cab = s->cab_id;
  w.host = r.host_id;
  w.pid = static_cast<pid_t>(r.pid);
  w.started = w.last_state = now;
  spdlog::info("adopted session {} on cab {}, whose worker runs on host {}", session, w.cab, w.host);
  workers_[session] = w;
  unsettled_.insert(session);
  bindings_[session] = {w.cab, "", std::nullopt};
  follow(workers_[session]);
}

void Fleet::ingest() {
  auto db = store::Store::open(config_.db_path);
  std::vector<Deferred<fk_Event>> deferred_events;
  std::vector<Deferred<fk_SessionStatus>> deferred_statuses;
  auto hosted = [&](const std::string& session) {
    std::lock_guard<std::mutex> lock(mu_);
    const auto w = workers_.find(session);
    return w != workers_.end() && !w->second.host.empty();
  };
  // Workers report in their own partitions; cabs announce in theirs.
  dds::Reader<fk_Event> events(*participant_, "worker.*");
  dds::Reader<fk_Score> scores(*participant_, "worker.*");
  dds::Reader<fk_SessionStatus> statuses(*participant_, "worker.*");
  dds::Reader<fk_TruckState> states(*participant_, "cab.*");
  dds::Reader<fk_CabAnnounce> announces(*participant_, "cab.*");
  // Worker hosts speak in their own partitions.
  dds::Reader<fk_HostStatus> host_statuses(*participant_, "host.*");
  dds::Reader<fk_WorkerReport> reports(*participant_, "host.*");
  const auto readers = {events.handle(), scores.handle(), statuses.handle(), states.handle(), announces.handle(),
                        host_statuses.handle(), reports.handle()};
  dds::WaitSet ws(*participant_);
  for (dds_entity_t r : readers) ws.attach_reader(r);
  // One sample's trouble costs that sample only: the rest of its batch is taken as usual.
  auto each = [&](auto& reader, const char* topic, auto&& handle) {
    try {
      reader.take_each_with_info([&](const auto& sample, const dds_sample_info_t& info) {
        try {
          handle(sample, info);
        } catch (const std::exception& e) {
          refuse(&RefusedSamples::malformed, std::string("a ") + topic + " sample: " + e.what());
        }
      });
    } catch (const std::exception& e) {
      spdlog::warn("ingest: {}", e.what());  // counted, never fatal
    }
  };
  // Whether a report for `session` is to be stored; refusals counted with the reason.
  bool not_yet = false;  // the last sample's sender could not be told yet (believed() said false)
  auto believed = [&](const char* topic, const char* session, dds_entity_t reader, const dds_sample_info_t& info,
                      bool state_topic = false) {
    not_yet = false;
    if (!dds::valid_utf8(session)) { refuse(&RefusedSamples::malformed, std::string("a ") + topic + " whose session is not UTF-8"); return false; }
    switch (check_sender(session, reader, info, state_topic)) {
      case Verdict::kOurs: return true;
      case Verdict::kNotOurs: return false;
      case Verdict::kNotYet: not_yet = true; return false;
      case Verdict::kWrongSender:
        refuse(&RefusedSamples::wrong_sender, std::string("a ") + topic + " for session " + session + " not from its worker");
        return false;
    }
    return false;
  };
  // Who each writer is, learnt while it is matched: a sample taken after its writer has gone
  // (a worker exits 200 ms after its score) is still told apart.
  auto learn_senders = [&](dds_entity_t reader) {
    dds_instance_handle_t handles[64];
    const dds_return_t n = dds_get_matched_publications(reader, handles, 64);
    for (dds_return_t i = 0; i < std::min<dds_return_t>(n, 64); ++i)
      if (!senders_.count(handles[i]))
        if (auto found = dds::sender_of(reader, handles[i])) senders_.emplace(handles[i], std::move(*found));
  };
  while (!stop_) {
    ws.wait(0.1);
    for (dds_entity_t r : readers) learn_senders(r);
    // A host's status and reports count only from its own partition (under DDS Security, only
    // the identity host.<id> may write there).
    auto from_host = [&](dds_entity_t reader, const dds_sample_info_t& info, const char* host) {
      auto sender = senders_.find(info.publication_handle);
      if (sender == senders_.end()) {
        auto found = dds::sender_of(reader, info.publication_handle);
        if (!found) return false;
        sender = senders_.emplace(info.publication_handle, std::move(*found)).first;
      }
      return sender->second.in(dds::host_partition(host));
    };
    try {
      host_statuses.take_all_with_info([&](const fk_HostStatus& h, const dds_sample_info_t& info) {
        if (!dds::valid_utf8(h.host_id) || !h.host_id[0]) return;
        if (!info.valid_data) {  // its writer is gone or lost its liveliness
          std::lock_guard<std::mutex> lock(mu_);
          if (info.instance_state != DDS_IST_ALIVE && hosts_.count(h.host_id)) {
            if (!hosts_[h.host_id].gone) spdlog::warn("worker host {} is gone", h.host_id);
            hosts_[h.host_id].gone = true;
          }
          return;
        }
        // Checked before mu_ is taken: refuse() takes it.
        if (!hosts_believed()) {
          refuse(&RefusedSamples::no_identity, std::string("a status of worker host ") + h.host_id +
                                                   " in clear DDS (no identity vouches for it; --trust-clear-hosts on a closed network)");
          return;
        }
        if (!from_host(host_statuses.handle(), info, h.host_id)) {
          refuse(&RefusedSamples::wrong_sender, std::string("a status of worker host ") + h.host_id + " from outside its partition");
          return;
        }
        const std::string state = dds::valid_utf8(h.state) ? h.state : "";
        if (!dds::valid_utf8(h.site) || (state != "ready" && state != "stopping") || h.capacity == 0 ||
            !std::isfinite(h.load_1min) || !std::isfinite(h.memory_free_mib)) {
          refuse(&RefusedSamples::malformed, std::string("a status of worker host ") + h.host_id + " out of range");
          return;
        }
        std::lock_guard<std::mutex> lock(mu_);
        HostInfo& info_of = hosts_[h.host_id];
        if (!info_of.alive(Clock::now())) spdlog::info("worker host {} is here: {} of {} workers running", h.host_id, h.running, h.capacity);
        info_of.id = h.host_id;
        info_of.site = h.site;
        info_of.state = h.state;
        info_of.capacity = h.capacity;
        info_of.running = h.running;
        info_of.cores = h.cores;
        info_of.load_1min = h.load_1min;
        info_of.memory_free_mib = h.memory_free_mib;
        info_of.last_seen = Clock::now();
        info_of.gone = false;
      });
    } catch (const std::exception& e) {
      spdlog::warn("ingest: {}", e.what());
    }
    each(reports, "fk_WorkerReport", [&](const fk_WorkerReport& r, const dds_sample_info_t& info) {
      if (auto bad = bad_text({{"its host", r.host_id}, {"its session", r.session_id}, {"its cab", r.cab_id}, {"its state", r.state},
                               {"its reason", r.reason}, {"its participant", r.participant}}))
        throw std::runtime_error(*bad);
      if (!hosts_believed()) {
        refuse(&RefusedSamples::no_identity, std::string("a report ") + (r.host_id[0] ? "of worker host " + std::string(r.host_id) : "naming no worker host") +
                                                 " on session " + r.session_id + " in clear DDS (no identity vouches for it)");
        return;
      }
      if (!r.host_id[0]) {
        refuse(&RefusedSamples::wrong_sender, std::string("a report on session ") + r.session_id + " that names no worker host");
        return;
      }
      if (!from_host(reports.handle(), info, r.host_id)) {
        refuse(&RefusedSamples::wrong_sender, std::string("a report of worker host ") + r.host_id + " from outside its partition");
        return;
      }
      on_report(*db, r);
    });
    // A hosted worker's first events and statuses may come before its host's report names its
    // participant: they wait here (a few seconds at most) until it does.
    const auto now = Clock::now();
    std::vector<Deferred<fk_Event>> events_again;
    std::vector<Deferred<fk_SessionStatus>> statuses_again;
    events_again.swap(deferred_events);
    statuses_again.swap(deferred_statuses);
    auto on_event = [&](const fk_Event& e, const dds_sample_info_t& info) {
      if (!believed("fk_Event", e.session_id, events.handle(), info)) {
        if (not_yet) deferred_events.push_back({e, info, now});
        return;
      }
      if (auto bad = bad_text({{"its kind", e.kind}, {"its details", e.details}})) throw std::runtime_error(*bad);
      if (!finite({e.sim_time_s, e.x_m, e.y_m}) || e.sim_time_s < 0 || e.seq == 0 || e.worry_level > 5 || !e.kind[0])
        throw std::runtime_error("event " + std::to_string(e.seq) + " of session " + std::string(e.session_id) + " is out of range");
      db->add_event({e.session_id, e.seq, e.sim_time_s, e.kind, e.worry_level, e.x_m, e.y_m, e.details});
    };
    each(events, "fk_Event", on_event);
    each(scores, "fk_Score", [&](const fk_Score& s, const dds_sample_info_t& info) {
      if (!believed("fk_Score", s.session_id, scores.handle(), info)) return;
      if (!finite({s.mark}) || s.mark < 0 || s.mark > 100) throw std::runtime_error("a mark of " + std::to_string(s.mark));
      store::ScoreRecord r{s.session_id, s.mark, s.passed, {}};
      for (uint32_t i = 0; i < s.counts._length; ++i) {
        if (!dds::valid_utf8(s.counts._buffer[i].kind)) throw std::runtime_error("a fault kind that is not UTF-8");
        r.counts[s.counts._buffer[i].kind] = int(s.counts._buffer[i].count);
      }
      // The mark of record is the one the worker wrote in its session log before sending it. A
      // hosted worker's log comes with its host's report when it exits, and its mark with it.
      if (hosted(s.session_id) && !std::ifstream(log_path(s.session_id))) return;
      std::optional<LoggedMark> logged;
      try {
        const auto log = read_control_log(log_path(s.session_id));
        if (log.score_line) logged = parse_score_line(*log.score_line);
      } catch (const std::exception&) {
        // no log: nothing vouches for the mark
      }
      if (!logged || logged->mark != s.mark || logged->passed != bool(s.passed)) {
        refuse(&RefusedSamples::score_disagrees, "a score for session " + std::string(s.session_id) + " that its session log does not hold");
        return;
      }
      r.exam_details = practical_exam_details(*db, config_.data_dir, rules_, r.session_public_id, logged->end_reason,
                                              logged->points, r.counts, r.passed);
      set_score(*db, r, kWorker);
    });
    auto on_status = [&](const fk_SessionStatus& s, const dds_sample_info_t& info) {
      if (!believed("fk_SessionStatus", s.session_id, statuses.handle(), info)) {
        if (not_yet) deferred_statuses.push_back({s, info, now});
        return;
      }
      if (auto bad = bad_text({{"its state", s.state}, {"its reason", s.reason}})) throw std::runtime_error(*bad);
      const std::string state = s.state;
      if (state == "waiting" || state == "running" || state == "ended" || state == "failed")
        set_state(*db, s.session_id, state, s.reason, kWorker);
    };
    each(statuses, "fk_SessionStatus", on_status);
    auto again = [&](auto& list, auto& deferred, auto& handle, const char* topic) {
      for (auto& d : list) {
        if (now - d.at > std::chrono::seconds(10)) {
          refuse(&RefusedSamples::wrong_sender, std::string("a ") + topic + " for session " + d.sample.session_id +
                                                    " whose worker host never named its worker");
          continue;
        }
        const size_t before = deferred.size();
        try {
          handle(d.sample, d.info);
        } catch (const std::exception& e) {
          refuse(&RefusedSamples::malformed, std::string("a ") + topic + " sample: " + e.what());
        }
        if (deferred.size() > before) deferred.back().at = d.at;  // still waiting, since it first came
      }
    };
    again(events_again, deferred_events, on_event, "fk_Event");
    again(statuses_again, deferred_statuses, on_status, "fk_SessionStatus");
    std::vector<std::string> announced;
    std::map<std::string, std::vector<store::PathPoint>> path;  // by session, downsampled
    each(states, "fk_TruckState", [&](const fk_TruckState& t, const dds_sample_info_t& info) {
      if (!believed("fk_TruckState", t.session_id, states.handle(), info, true)) return;
      if (!finite({t.sim_time_s, t.x_m, t.y_m, t.yaw_rad, t.speed_m_s, t.lift_m}))
        throw std::runtime_error("a truck state that is not finite");
      std::lock_guard<std::mutex> lock(mu_);
      auto it = workers_.find(t.session_id);
      if (it == workers_.end()) return;
      it->second.last = t;
      it->second.last_state = Clock::now();
      it->second.seen_state = true;
      // One point every path_interval_s of sim time.
      auto& last = it->second.last_path_point_s;
      if (!last || t.sim_time_s >= *last + config_.path_interval_s) {
        last = t.sim_time_s;
        path[t.session_id].push_back({t.sim_time_s, t.x_m, t.y_m, t.yaw_rad, t.speed_m_s, t.lift_m});
      }
    });
    each(announces, "fk_CabAnnounce", [&](const fk_CabAnnounce& a, const dds_sample_info_t& info) {
      if (auto bad = bad_text({{"its cab id", a.cab_id}, {"its mode", a.mode}, {"its school", a.school}})) throw std::runtime_error(*bad);
      if (!a.cab_id[0]) throw std::runtime_error("a cab announcement with no cab id");
      // A cab speaks in its own partition only (under DDS Security nobody else may).
      auto sender = senders_.find(info.publication_handle);
      if (sender == senders_.end()) {
        auto found = dds::sender_of(announces.handle(), info.publication_handle);
        if (!found) return;
        sender = senders_.emplace(info.publication_handle, std::move(*found)).first;
      }
      if (!sender->second.in(dds::cab_partition(a.cab_id))) {
        refuse(&RefusedSamples::wrong_sender, "an announcement for cab " + std::string(a.cab_id) + " from another cab's partition");
        return;
      }
      std::lock_guard<std::mutex> lock(mu_);
      CabInfo& c = cabs_[a.cab_id];
      c.id = a.cab_id;
      c.mode = a.mode;
      c.site = dds::valid_utf8(a.site) ? a.site : "";
      c.last_seen = Clock::now();
      announced.push_back(c.id);
    });
    try {
      take_followed_frames();
      for (const std::string& cab : announced) db->cab_seen(cab, 1, store::now_iso8601());  // the default school
      for (const auto& [session, points] : path) db->add_path_points(session, points);
    } catch (const std::exception& e) {
      spdlog::warn("ingest: {}", e.what());  // counted, never fatal
    }
  }
}

}  // namespace forklift::server
