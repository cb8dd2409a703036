#include "host_placement.h"

#include "exam_evidence.h"
#include "worker_supervisor.h"

#include "forklift/security/evidence.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

namespace forklift::server {

namespace {

void write_octets(const std::string& path, const dds_sequence_octet& bytes) {
  if (bytes._length == 0) { std::remove(path.c_str()); return; }
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes._buffer), bytes._length);
  if (!out) throw std::runtime_error("cannot write " + path);
}

void also(std::string& list, const std::string& item) { list += (list.empty() ? "" : "; ") + item; }

}  // namespace

bool HostInfo::alive(std::chrono::steady_clock::time_point now) const {
  return !gone && std::chrono::duration<double>(now - last_seen).count() < dds::kHostLeaseS;
}

std::vector<std::string> HostPlacement::placement(const std::string& cab) {
  const auto now = Clock::now();
  const auto cab_it = fleet_.cabs.find(cab);
  const std::string site = cab_it == fleet_.cabs.end() ? "" : cab_it->second.site;
  std::vector<const HostInfo*> room;
  for (const auto& [id, h] : fleet_.hosts)
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

dds::Writer<fk_WorkerRequest>& HostPlacement::request_writer(const std::string& host) {
  auto& writer = request_writers_[host];
  // In the host's own partition: under DDS Security only that host may read it.
  if (!writer) writer = std::make_unique<dds::Writer<fk_WorkerRequest>>(participant_, dds::host_partition(host));
  return *writer;
}

void HostPlacement::request(const std::string& host, const std::string& session, WorkerAction action) {
  auto r = std::make_unique<fk_WorkerRequest>();  // 64 KiB of scenario: not on the stack
  dds::set_string(r->session_id, session);
  dds::set_string(r->host_id, host);
  dds::set_string(r->action, name(action));
  request_writer(host).write(*r);
}

void HostPlacement::start_worker(const store::Session& s, const std::string& scenario_file, std::optional<double> duration_s,
                                 const std::optional<std::string>& aids, const std::string& language) {
  std::vector<std::string> hosts;
  bool any_host = false;
  {
    std::lock_guard<std::mutex> lock(fleet_.mu);
    if (const std::string busy = fleet_.session_on(s.cab_id); !busy.empty())
      throw std::runtime_error("cab " + s.cab_id + " is running session " + busy);
    for (const auto& [id, h] : fleet_.hosts) any_host = any_host || h.alive(Clock::now());
    hosts = placement(s.cab_id);
  }
  std::string refusals;
  if (!hosts.empty() && start_hosted_worker(s, scenario_file, duration_s, aids, language, hosts, refusals)) return;
  if (!fleet_.config.local_workers) {
    if (!refusals.empty()) throw std::runtime_error("no worker host took the session (" + refusals + ")");
    throw std::runtime_error(any_host ? "every worker host is full, stopping or passed over"
                                      : fleet_.hosts_believed() ? "no worker host is about (and this server runs none itself)"
                                                                : "this server runs no worker itself, and believes no worker host without "
                                                                  "DDS Security (--security, or --trust-clear-hosts on a closed network)");
  }
  // No host took it, or none is about: this machine runs the worker, as one without hosts does.
  if (!refusals.empty()) spdlog::warn("session {}: no worker host took it ({}); its worker runs here", s.public_id, refusals);
  local_.start_local(s, scenario_file, duration_s, aids, language);
}

bool HostPlacement::start_hosted_worker(const store::Session& s, const std::string& scenario_file, std::optional<double> duration_s,
                                        const std::optional<std::string>& aids, const std::string& language,
                                        std::vector<std::string> candidates,
                                        std::string& refusals) {
  const FleetConfig& config = fleet_.config;
  const auto deadline = Clock::now() + seconds(config.start_budget_s);
  auto r = std::make_unique<fk_WorkerRequest>();  // 64 KiB of scenario: not on the stack
  const std::string scenario = slurp(scenario_file);
  if (scenario.empty()) throw std::runtime_error("the scenario " + scenario_file + " cannot be read");
  if (scenario.size() >= sizeof(r->scenario_json)) throw std::runtime_error("the scenario is over 64 KiB, more than a host takes");
  dds::set_string(r->session_id, s.public_id);
  dds::set_string(r->action, name(WorkerAction::kStart));
  dds::set_string(r->cab_id, s.cab_id);
  dds::set_string(r->mode, name(s.mode));
  r->duration_s = duration_s.value_or(0);
  dds::set_string(r->aids, aids.value_or(""));
  dds::set_string(r->language, language);
  dds::set_string(r->scenario_json, scenario);
  if (config.frames) {
    r->frame_fps = config.frames->fps;
    r->frame_width = static_cast<uint16_t>(config.frames->width);
    r->frame_height = static_cast<uint16_t>(config.frames->height);
    r->frame_jpeg = config.frames->jpeg;
  }
  for (const std::string& host : candidates) {
    if (Clock::now() >= deadline) {
      also(refusals, "the start's " + std::to_string(int(config.start_budget_s)) + " s ran out before host " + host + " was asked");
      break;
    }
    dds::Writer<fk_WorkerRequest>* writer;
    {
      std::unique_lock<std::mutex> lock(fleet_.mu);
      if (const std::string busy = fleet_.session_on(s.cab_id); !busy.empty())
        throw std::runtime_error("cab " + s.cab_id + " is running session " + busy);
      // Known before the host answers: its report finds the session ours, not a stray.
      WorkerInfo w;
      w.session = s.public_id;
      w.cab = s.cab_id;
      w.host = host;
      w.started = w.last_state = Clock::now();
      fleet_.workers[s.public_id] = w;
      fleet_.unsettled.insert(s.public_id);
      fleet_.bindings[s.public_id] = {w.cab, "", std::nullopt};
      fleet_.start_answers.erase(s.public_id);
      ++fleet_.hosts[host].placed;
      writer = &request_writer(host);
    }
    // Each host has its share of what is left of the budget, so that a silent one leaves time
    // for the next and for this machine.
    const auto until = std::min(deadline, Clock::now() + seconds(config.host_answer_timeout_s));
    // A writer made just now may not have found the host's reader yet.
    while (writer->matched() == 0 && Clock::now() < until) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    dds::set_string(r->host_id, host);
    writer->write(*r);
    std::unique_lock<std::mutex> lock(fleet_.mu);
    // Taken once the host names its running worker (or it has already exited, which settles the
    // session): a host that says "starting" and then nothing more is passed over like a silent one.
    const bool answered = fleet_.answered.wait_until(lock, until, [&] {
      const auto a = fleet_.start_answers.find(s.public_id);
      return a != fleet_.start_answers.end() && a->second.host == host && a->second.state != WorkerReportState::kStarting;
    });
    --fleet_.hosts[host].placed;
    const FleetState::StartAnswer a =
        answered ? fleet_.start_answers[s.public_id] : FleetState::StartAnswer{host, std::nullopt, "no running worker named in time"};
    fleet_.start_answers.erase(s.public_id);
    if (answered && a.state != WorkerReportState::kRefused) {
      spdlog::info("session {} on cab {}: its worker runs on host {}", s.public_id, s.cab_id, host);
      return true;
    }
    // Refused, or silent: the next host. A late start is stopped (its session runs elsewhere).
    if (!answered) {
      request(host, s.public_id, WorkerAction::kKill);
      fleet_.hosts[host].passed_over_until = Clock::now() + seconds(config.host_pass_over_s);
      spdlog::warn("worker host {} took session {} and named no running worker in time: passed over for {} s", host,
                   s.public_id, int(config.host_pass_over_s));
    }
    fleet_.workers.erase(s.public_id);
    fleet_.unsettled.erase(s.public_id);
    fleet_.bindings.erase(s.public_id);
    also(refusals, host + ": " + a.reason);
  }
  return false;
}

void HostPlacement::host_status(const HostStatusIn& h) {
  std::lock_guard<std::mutex> lock(fleet_.mu);
  if (h.gone) {
    const auto known = fleet_.hosts.find(h.id);
    if (known == fleet_.hosts.end()) return;
    if (!known->second.gone) spdlog::warn("worker host {} is gone", h.id);
    known->second.gone = true;
    return;
  }
  HostInfo& info_of = fleet_.hosts[h.id];
  if (!info_of.alive(Clock::now())) spdlog::info("worker host {} is here: {} of {} workers running", h.id, h.running, h.capacity);
  info_of.id = h.id;
  info_of.site = h.site;
  info_of.state = h.state;
  info_of.capacity = h.capacity;
  info_of.running = h.running;
  info_of.cores = h.cores;
  info_of.load_1min = h.load_1min;
  info_of.memory_free_mib = h.memory_free_mib;
  info_of.last_seen = Clock::now();
  info_of.gone = false;
}

void HostPlacement::cab_seen(const CabIn& a) {
  std::lock_guard<std::mutex> lock(fleet_.mu);
  CabInfo& c = fleet_.cabs[a.id];
  c.id = a.id;
  c.mode = a.mode;
  c.site = a.site;
  c.last_seen = Clock::now();
}

std::vector<HostInfo> HostPlacement::hosts() {
  std::lock_guard<std::mutex> lock(fleet_.mu);
  std::vector<HostInfo> out;
  for (const auto& [id, h] : fleet_.hosts) out.push_back(h);
  return out;
}

std::vector<CabInfo> HostPlacement::cabs_online(double within_s) {
  std::lock_guard<std::mutex> lock(fleet_.mu);
  std::vector<CabInfo> out;
  const auto now = Clock::now();
  for (const auto& [id, c] : fleet_.cabs)
    if (std::chrono::duration<double>(now - c.last_seen).count() < within_s) out.push_back(c);
  return out;
}

void HostPlacement::write_worker_files(const fk_WorkerReport& r) {
  // The session id is checked (s-<digits>, by the sample gate): it names the files.
  const std::string log = fleet_.log_path(r.session_id);
  write_octets(log, r.control_log);
  write_octets(log + ".sig", r.signature);
  write_octets(fleet_.config.log_dir + "/" + r.session_id + ".err", r.worker_err);
  std::ofstream(log + ".participant") << r.participant << '\n';
}

std::optional<std::string> HostPlacement::unsigned_log_problem(const fk_WorkerReport& r, const std::string& cab) {
  if (!fleet_.secure()) return std::nullopt;  // trusted clear hosts (a closed lab): no identities to check
  if (r.control_log._length == 0) return std::nullopt;  // no log: the session ends without a mark
  const std::string log(reinterpret_cast<const char*>(r.control_log._buffer), r.control_log._length);
  if (r.signature._length == 0) return "its session log is not signed (every worker signs its log under DDS Security)";
  const auto signature = nlohmann::json::parse(r.signature._buffer, r.signature._buffer + r.signature._length, nullptr, false);
  if (signature.is_discarded()) return "its log signature is not JSON";
  ChainKeys keys;
  try {
    keys = chain_keys(fleet_.config.security_dir, fleet_.config.identity);
  } catch (const std::exception& e) {
    return std::string("the school's CA cannot be read to check it: ") + e.what();
  }
  const security::VerifyReport v = security::verify_log_signature(r.session_id, cab, log, signature, keys.ca_pem, keys.crl_pem);
  if (v.ok) return std::nullopt;
  std::string why = "its session log is not signed by cab " + cab + "'s worker: ";
  for (size_t i = 0; i < v.problems.size(); ++i) why += (i ? "; " : "") + v.problems[i];
  return why;
}

bool HostPlacement::refused_log(Report& rep, const std::string& cab) {
  // An exited worker's files settle the mark: they count only as the session's worker signed them
  // (checked once, for the cab the session was started on); refused, the report is not an answer.
  if (rep.state != WorkerReportState::kExited) return false;
  if (!rep.log_problem) rep.log_problem = unsigned_log_problem(rep.r, cab);
  if (!*rep.log_problem) return false;
  const uint64_t n = ++fleet_.refused.unsigned_log;
  spdlog::warn("refused host {}'s report that session {}'s worker exited: {} ({} such so far)", rep.r.host_id, rep.session,
               **rep.log_problem, n);
  return true;
}

void HostPlacement::distrust(WorkerInfo& w, Clock::time_point now) {
  if (!w.hang_reason.empty()) return;
  w.hang_reason = "its worker host reported that it ended, with a session log its worker did not sign";
  w.hang_asked = now;
}

void HostPlacement::follow(WorkerInfo& w, Report& rep) {
  if (refused_log(rep, w.cab)) return distrust(w, rep.now);
  if (rep.r.participant[0]) {
    w.participant = rep.r.participant;
    fleet_.bindings[rep.session].participant = rep.r.participant;
  }
  if (rep.state != WorkerReportState::kExited) return;
  write_worker_files(rep.r);
  const std::string reason = !w.hang_reason.empty() ? w.hang_reason : rep.r.reason;
  fleet_.finishing.push_back({w, reason, rep.now + kLastSamples});
  fleet_.bindings[rep.session].until = rep.now + kLastSamples + std::chrono::seconds(30);
  fleet_.workers.erase(rep.session);
}

void HostPlacement::on_report(store::Store& db, const fk_WorkerReport& r) {
  Report rep{r, parse<WorkerReportState>(r.state).value(), r.session_id, Clock::now(), std::nullopt};
  const std::string& session = rep.session;
  {
    std::lock_guard<std::mutex> lock(fleet_.mu);
    const auto w = fleet_.workers.find(session);
    const auto ending = fleet_.finishing_of(session);
    // Never a report on a session whose worker this server runs itself: its own files are the truth.
    if ((w != fleet_.workers.end() && w->second.host.empty()) || (ending != fleet_.finishing.end() && ending->worker.child)) {
      const uint64_t n = ++fleet_.refused.wrong_sender;
      spdlog::warn("refused host {}'s report on session {}, whose worker runs on this server ({} refused samples so far)",
                   r.host_id, session, n);
      return;
    }
    if (w != fleet_.workers.end() && w->second.host == r.host_id && refused_log(rep, w->second.cab))
      return distrust(w->second, rep.now);
    fleet_.start_answers[session] = {r.host_id, rep.state, r.reason};
    fleet_.answered.notify_all();
    if (rep.state == WorkerReportState::kRefused) return;
    if (w != fleet_.workers.end()) {
      if (w->second.host != r.host_id) {
        spdlog::warn("host {} reports a worker for session {}, which runs {}: stopping it", r.host_id, session,
                     w->second.host.empty() ? "here" : "on host " + w->second.host);
        if (rep.state != WorkerReportState::kExited) request(r.host_id, session, WorkerAction::kKill);  // a start that answered too late
        return;
      }
      follow(w->second, rep);
      return;
    }
    // One a restart left waiting for its host's word (adopt()) is adopted now; any other being
    // settled stays so.
    const bool waiting = ending != fleet_.finishing.end() && ending->worker.host.empty() && !ending->worker.child && ending->worker.pid == 0;
    if (waiting) fleet_.finishing.erase(ending);
    else if (ending != fleet_.finishing.end() || fleet_.unsettled.count(session)) return;
  }
  // Another server's, alive: its samples and its end are its own (kept for a take-over).
  if (const auto owner = db.session_server(session);
      owner && *owner != fleet_.config.server_id &&
      db.claim_sessions(fleet_.config.server_id, fleet_.lease_start(), false, session).empty()) {
    std::lock_guard<std::mutex> lock(fleet_.mu);
    keep_heard(r, rep.now);
    return;
  }
  adopt_hosted(db, rep);
}

void HostPlacement::keep_heard(const fk_WorkerReport& r, Clock::time_point now) {
  // Forgotten a while after its worker's end (its server has settled it, or it is taken over
  // with this copy), or with a newer report.
  std::erase_if(heard_, [&](const auto& h) {
    return h.second->exited() && now - h.second->at > std::chrono::minutes(2);
  });
  auto h = std::make_unique<Heard>();
  h->r = r;
  h->at = now;
  auto keep = [](dds_sequence_octet& seq, std::vector<uint8_t>& bytes) {
    bytes.assign(seq._buffer, seq._buffer + seq._length);
    seq._buffer = bytes.data();
    seq._maximum = seq._length;
    seq._release = false;
  };
  keep(h->r.control_log, h->log);
  keep(h->r.signature, h->sig);
  keep(h->r.worker_err, h->err);
  heard_[r.session_id] = std::move(h);
}

bool HostPlacement::abort_heard(const std::string& session) {
  std::lock_guard<std::mutex> lock(fleet_.mu);
  const auto it = heard_.find(session);
  if (it == heard_.end() || it->second->exited()) return false;
  request(it->second->r.host_id, session, WorkerAction::kAbort);
  return true;
}

bool HostPlacement::take_over(store::Store& db, const std::string& session) {
  std::unique_ptr<Heard> h;
  {
    std::lock_guard<std::mutex> lock(fleet_.mu);
    const auto it = heard_.find(session);
    if (it == heard_.end()) return false;
    h = std::move(it->second);
    heard_.erase(it);
  }
  spdlog::info("took over session {} from a server that has stopped: its worker runs on host {}", session, h->r.host_id);
  const auto state = parse<WorkerReportState>(h->r.state);
  if (!state) return false;
  Report rep{h->r, *state, session, Clock::now(), std::nullopt};
  adopt_hosted(db, rep);
  return true;
}

void HostPlacement::adopt_hosted(store::Store& db, Report& rep) {
  // A session this server did not start: adopted if it is open for that cab (another server's,
  // or this one's before a restart); its worker stopped if the session is over or unknown.
  const fk_WorkerReport& r = rep.r;
  const std::string& session = rep.session;
  const auto s = db.get_session(session);
  if (!s || is_terminal(s->state) || s->cab_id != r.cab_id) {
    if (rep.state == WorkerReportState::kExited) return;
    spdlog::warn("host {} runs a worker for session {}, which is {}: stopping it", r.host_id, session,
                 !s ? "unknown here" : is_terminal(s->state) ? "over" : "on another cab");
    std::lock_guard<std::mutex> lock(fleet_.mu);
    request(r.host_id, session, WorkerAction::kKill);
    return;
  }
  std::lock_guard<std::mutex> lock(fleet_.mu);
  for (const auto& [id, other] : fleet_.workers)
    if (other.cab == s->cab_id && id != session) {
      spdlog::warn("host {} runs a worker for session {} on cab {}, which runs session {}: stopping it", r.host_id, session, s->cab_id, id);
      request(r.host_id, session, WorkerAction::kKill);
      return;
    }
  WorkerInfo w;
  w.session = session;
  w.cab = s->cab_id;
  w.host = r.host_id;
  w.pid = static_cast<pid_t>(r.pid);
  w.started = w.last_state = rep.now;
  spdlog::info("adopted session {} on cab {}, whose worker runs on host {}", session, w.cab, w.host);
  fleet_.workers[session] = w;
  fleet_.unsettled.insert(session);
  fleet_.bindings[session] = {w.cab, "", std::nullopt};
  follow(fleet_.workers[session], rep);
}

}  // namespace forklift::server
