#include "host_agent.h"

#include <signal.h>
#include <spdlog/spdlog.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <thread>

#include "forklift/i18n/catalogue.h"

namespace forklift::host {

namespace {

using Clock = std::chrono::steady_clock;

std::string slurp(const std::string& path, size_t keep_last = 0) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  std::string text = s.str();
  if (keep_last && text.size() > keep_last) text.erase(0, text.size() - keep_last);
  return text;
}

void set_octets(dds_sequence_octet& seq, std::string& bytes) {
  seq._buffer = reinterpret_cast<uint8_t*>(bytes.data());
  seq._length = seq._maximum = static_cast<uint32_t>(bytes.size());
  seq._release = false;
}

bool matches(const char* text, const char* pattern) { return std::regex_match(text, std::regex(pattern)); }

double load_1min() {
  double l = 0;
  std::ifstream("/proc/loadavg") >> l;
  return l;
}

double memory_free_mib() {
  std::ifstream in("/proc/meminfo");
  std::string key;
  double kib = 0;
  std::string unit;
  while (in >> key >> kib >> unit)
    if (key == "MemAvailable:") return kib / 1024;
  return 0;
}

}  // namespace

std::optional<std::string> request_problem(const fk_WorkerRequest& r, const std::string& host_id) {
  for (const char* text : {r.session_id, r.host_id, r.action, r.cab_id, r.mode, r.aids, r.language})
    if (!dds::valid_utf8(text)) return "a request whose text is not UTF-8";
  if (host_id != r.host_id) return "a request for host '" + std::string(r.host_id) + "'";
  if (!matches(r.session_id, "s-[0-9]{1,18}")) return "a request for session '" + std::string(r.session_id) + "', which is not a session id";
  const std::optional<WorkerAction> action = parse<WorkerAction>(r.action);
  if (!action) return "a request to '" + std::string(r.action) + "' (start, abort or kill)";
  if (*action != WorkerAction::kStart) return std::nullopt;
  if (!matches(r.cab_id, "[A-Za-z0-9_-]{1,32}")) return "a start for cab '" + std::string(r.cab_id) + "', which is not a cab id";
  if (!parse<Mode>(r.mode)) return "a start in mode '" + std::string(r.mode) + "'";
  if (!std::isfinite(r.duration_s) || r.duration_s > 7 * 86400) return "a start with a duration of " + std::to_string(r.duration_s) + " s";
  if (!matches(r.aids, "[a-z_,-]{0,63}")) return "a start with aids '" + std::string(r.aids) + "'";
  if (!std::isfinite(r.frame_fps) || r.frame_fps < 0 || r.frame_fps > 120) return "a start at " + std::to_string(r.frame_fps) + " frames per second";
  if (r.frame_fps > 0 && (r.frame_width < 16 || r.frame_height < 16 || r.frame_width > 4096 || r.frame_height > 4096))
    return "a start with frames of " + std::to_string(r.frame_width) + "x" + std::to_string(r.frame_height);
  if (!dds::valid_utf8(r.scenario_json)) return "a start whose scenario is not UTF-8";
  const auto scenario = nlohmann::json::parse(r.scenario_json, nullptr, false);
  if (scenario.is_discarded() || !scenario.is_object()) return "a start whose scenario is not a JSON object";
  return std::nullopt;
}

HostAgent::HostAgent(HostConfig config) : config_(std::move(config)) {
  if (config_.identity.empty()) config_.identity = "host." + config_.host_id;
  participant_ = std::make_unique<dds::Participant>(
      dds::DomainSettings::resolve(config_.dds_domain, config_.dds_config, config_.security_dir, config_.identity));
  const std::string own = dds::host_partition(config_.host_id);
  status_ = std::make_unique<dds::Writer<fk_HostStatus>>(*participant_, own);
  reports_ = std::make_unique<dds::Writer<fk_WorkerReport>>(*participant_, own);
  requests_ = std::make_unique<dds::Reader<fk_WorkerRequest>>(*participant_, own);
  adopt();
}

HostAgent::~HostAgent() {
  if (leave_workers_) return;
  for (auto& [id, w] : workers_)
    if (!w.exited) kill(w.pid, SIGTERM);
}

namespace {

// The cab a session log names in its header ("cab <id>"), or "".
std::string logged_cab(const std::string& log) {
  std::ifstream in(log);
  std::string line;
  for (int i = 0; i < 8 && std::getline(in, line);)
    if (line.rfind("cab ", 0) == 0) return line.substr(4);
    else ++i;
  return "";
}

}  // namespace

void HostAgent::adopt() {
  for (const WorkerProcess& p : find_workers(config_.log_dir)) {
    if (workers_.count(p.session)) {  // never two workers for one session
      kill(p.pid, SIGTERM);
      continue;
    }
    Worker w;
    w.session = p.session;
    w.cab = p.cab;
    w.pid = p.pid;
    w.start_ticks = p.start_ticks;
    w.adopted = true;  // reap() reads its participant and reports it running
    spdlog::info("adopted the worker (pid {}) of session {} on cab {}, left running by the agent before this one", w.pid,
                 w.session, w.cab);
    workers_[w.session] = w;
  }
  // Workers that ended while no agent ran: their ends, with their files, are reported now (a
  // server settles a session still open from them, and ignores one already over).
  namespace fs = std::filesystem;
  std::error_code ec;
  const auto now = fs::file_time_type::clock::now();
  for (const fs::directory_entry& e : fs::directory_iterator(config_.log_dir, ec)) {
    const fs::path path = e.path();
    const std::string session = path.stem().string();
    if (path.extension() != ".ctl" || !matches(session.c_str(), "s-[0-9]{1,18}") || workers_.count(session) ||
        fs::exists(base(session) + ".reported"))
      continue;
    const auto age = std::chrono::duration<double>(now - fs::last_write_time(path, ec)).count();
    if (ec || age > config_.report_kept_s) continue;
    Worker w;
    w.session = session;
    w.cab = logged_cab(path.string());
    w.exited = true;
    w.exited_at = Clock::now();
    spdlog::info("the worker of session {} ended while no agent ran here: reporting its end", session);
    workers_[session] = w;
    report(w, WorkerReportState::kExited, "", true);
  }
}

int HostAgent::running() const {
  int n = 0;
  for (const auto& [id, w] : workers_) n += w.exited ? 0 : 1;
  return n;
}

void HostAgent::publish_status(bool stopping) {
  fk_HostStatus s{};
  dds::set_string(s.host_id, config_.host_id);
  dds::set_string(s.site, config_.site);
  dds::set_string(s.state, name(stopping ? HostState::kStopping : HostState::kReady));
  s.capacity = static_cast<uint16_t>(config_.capacity);
  s.running = static_cast<uint16_t>(running());
  s.cores = static_cast<uint16_t>(std::thread::hardware_concurrency());
  s.load_1min = load_1min();
  s.memory_free_mib = memory_free_mib();
  status_->write(s);
}

void HostAgent::report(const Worker& w, WorkerReportState state, const std::string& reason, bool with_files) {
  fk_WorkerReport r{};
  dds::set_string(r.session_id, w.session);
  dds::set_string(r.host_id, config_.host_id);
  dds::set_string(r.cab_id, w.cab);
  dds::set_string(r.state, name(state));
  dds::set_string(r.reason, reason);
  dds::set_string(r.participant, w.participant);
  r.pid = static_cast<uint32_t>(w.pid);
  std::string log, sig, err;
  if (with_files) {
    log = slurp(base(w.session) + ".ctl");
    sig = slurp(base(w.session) + ".ctl.sig");
    err = slurp(base(w.session) + ".err", 64 * 1024);
    set_octets(r.control_log, log);
    set_octets(r.signature, sig);
    set_octets(r.worker_err, err);
  }
  reports_->write(r);
  // An end reported is not reported again by a later agent (adopt()).
  if (with_files && state == WorkerReportState::kExited) std::ofstream(base(w.session) + ".reported");
}

void HostAgent::refuse(const fk_WorkerRequest& r, const std::string& why) {
  spdlog::warn("refused to start session {} for cab {}: {}", r.session_id, r.cab_id, why);
  Worker w;
  w.session = r.session_id;
  w.cab = r.cab_id;
  report(w, WorkerReportState::kRefused, why);
}

void HostAgent::start(const fk_WorkerRequest& r) {
  const auto known = workers_.find(r.session_id);
  if (known != workers_.end()) {  // asked twice (a second server, a resent request): the answer again
    const Worker& w = known->second;
    report(w, w.exited ? WorkerReportState::kExited : w.participant.empty() ? WorkerReportState::kStarting : WorkerReportState::kRunning,
           "", w.exited);
    return;
  }
  if (running() >= config_.capacity) return refuse(r, "host " + config_.host_id + " is full (" + std::to_string(config_.capacity) + " workers)");
  for (const auto& [id, w] : workers_)
    if (!w.exited && w.cab == r.cab_id) return refuse(r, "cab " + std::string(r.cab_id) + " already has a worker here (session " + id + ")");
  WorkerLaunch l;
  l.binary = config_.worker_binary;
  l.session = r.session_id;
  l.cab = r.cab_id;
  l.mode = parse<Mode>(r.mode).value();  // request_problem() refused any other
  l.log_base = base(l.session);
  l.scenario_file = l.log_base + ".scenario.json";
  l.dds_domain = config_.dds_domain;
  l.dds_config = config_.dds_config;
  l.security_dir = config_.security_dir;
  l.start_timeout_s = config_.start_timeout_s;
  l.realtime = config_.realtime_workers;
  if (r.duration_s > 0) l.duration_s = r.duration_s;
  if (r.aids[0]) l.aids = std::string(r.aids);
  // The pupil's language goes on to the cab; one this host's worker does not know is left out (the
  // cab speaks its own), not refused: the session runs all the same.
  if (i18n::shipped().has_language(r.language)) l.language = r.language;
  l.frames = WorkerFrames{r.frame_fps, r.frame_width, r.frame_height, bool(r.frame_jpeg)};
  if (r.frame_fps <= 0) l.frames = WorkerFrames{0, 640, 480, false};
  if (l.mode == Mode::kExam && config_.security_dir.empty()) return refuse(r, "host " + config_.host_id + " runs without DDS Security, which exams need");
  if (!(std::ofstream(l.scenario_file) << r.scenario_json)) return refuse(r, "host " + config_.host_id + " cannot write to " + config_.log_dir);
  Worker w;
  w.session = l.session;
  w.cab = l.cab;
  try {
    // Not tied to this agent's life: a restarted agent adopts its workers (adopt()); a stopped
    // one ends them (run()).
    w.pid = spawn_worker(l, false);
  } catch (const std::exception& e) {
    return refuse(r, e.what());
  }
  spdlog::info("started the worker (pid {}) of session {} on cab {}", w.pid, w.session, w.cab);
  workers_[w.session] = w;
  report(w, WorkerReportState::kStarting, "");
  publish_status(false);
}

void HostAgent::take_requests(bool stopping) {
  requests_->take_each([&](const fk_WorkerRequest& r) {
    if (const auto problem = request_problem(r, config_.host_id)) {
      spdlog::warn("refused {}", *problem);
      return;
    }
    const WorkerAction action = parse<WorkerAction>(r.action).value();  // request_problem() refused any other
    if (action == WorkerAction::kStart) {
      if (stopping) refuse(r, "host " + config_.host_id + " is stopping");
      else start(r);
      return;
    }
    const auto it = workers_.find(r.session_id);
    if (it == workers_.end() || it->second.exited) return;
    spdlog::info("{} the worker of session {} as a server asks", action == WorkerAction::kAbort ? "aborting" : "killing", r.session_id);
    const Worker& w = it->second;
    if (!w.adopted || still_running({w.pid, w.session, w.cab, base(w.session) + ".ctl", w.start_ticks}))
      kill(w.pid, action == WorkerAction::kAbort ? SIGUSR1 : SIGKILL);
  });
}

void HostAgent::reap() {
  const auto now = Clock::now();
  for (auto it = workers_.begin(); it != workers_.end();) {
    Worker& w = it->second;
    if (!w.exited) {
      if (w.participant.empty()) {  // written by the worker beside its log before it publishes
        std::ifstream in(base(w.session) + ".ctl.participant");
        std::string guid;
        if (in >> guid && guid.size() == 32) {
          w.participant = guid;
          report(w, WorkerReportState::kRunning, "");
        }
      }
      int status = 0;
      // An adopted worker is still our child after a restart in place (exec keeps the pid), else
      // it is watched through /proc, and how it ended its log says.
      const pid_t reaped = waitpid(w.pid, &status, WNOHANG);
      const bool ours = reaped == w.pid;
      const bool ended = ours || (w.adopted && reaped < 0 && !still_running({w.pid, w.session, w.cab, base(w.session) + ".ctl", w.start_ticks}));
      if (ended) {
        w.exited = true;
        w.exited_at = now;
        const std::string how = ours ? exit_words(status) : "";
        spdlog::info("the worker of session {} ended{}", w.session, how.empty() ? "" : ": " + how);
        report(w, WorkerReportState::kExited, how, true);
      }
    } else if (std::chrono::duration<double>(now - w.exited_at).count() > config_.report_kept_s) {
      fk_WorkerReport key{};
      dds::set_string(key.session_id, w.session);
      dds_unregister_instance(reports_->handle(), &key);  // no longer kept for servers that start later
      it = workers_.erase(it);
      continue;
    }
    ++it;
  }
}

void HostAgent::run(const std::atomic<bool>& stop, const std::atomic<bool>& leave_workers) {
  dds::WaitSet ws(*participant_);
  ws.attach_reader(requests_->handle());
  auto last_status = Clock::now() - std::chrono::seconds(1);
  while (!stop) {
    ws.wait(0.05);
    take_requests(false);
    reap();
    if (Clock::now() - last_status > std::chrono::milliseconds(500)) {
      publish_status(false);
      last_status = Clock::now();
    }
  }
  if (leave_workers) {  // a restart: the workers go on, and the next agent adopts them
    leave_workers_ = true;
    spdlog::info("restarting: {} worker(s) left running for the next agent", running());
    return;
  }
  // Stopping: no new worker; the running ones end their sessions, and their ends are reported.
  publish_status(true);
  for (auto& [id, w] : workers_)
    if (!w.exited) kill(w.pid, SIGTERM);
  const auto until = Clock::now() + std::chrono::seconds(15);
  while (running() > 0 && Clock::now() < until) {
    ws.wait(0.05);
    take_requests(true);
    reap();
  }
  for (auto& [id, w] : workers_)
    if (!w.exited) {
      kill(w.pid, SIGKILL);
      if (!w.adopted) waitpid(w.pid, nullptr, 0);
    }
  // A moment for the last reports to reach the servers before the participant goes.
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
}

}  // namespace forklift::host
