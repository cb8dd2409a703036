#include "fleet.h"

#include "exam_evidence.h"

#include "forklift/image/image.h"
#include "forklift/session/session_log.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>

namespace forklift::server {
namespace {

using Clock = std::chrono::steady_clock;

// Who the audit log names for what workers report over DDS.
const store::Actor kWorker{std::nullopt, "worker"};
const store::Actor kServer{std::nullopt, "server"};  // the supervisor's own findings

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
  // A restarted server adopts the sessions still open: their workers keep running on their own
  // and keep reporting over DDS; without a child pid they are supervised by their heartbeat.
  auto db = store::Store::open_sqlite(config_.db_path);
  for (const store::Session& s : db->open_sessions()) {
    if (s.state == "starting") continue;  // never got a worker
    WorkerInfo w;
    w.session = s.public_id;
    w.cab = s.cab_id;
    w.started = w.last_state = Clock::now();
    workers_[s.public_id] = w;
  }
  supervisor_ = std::thread([this] { supervise(); });
  ingest_ = std::thread([this] { ingest(); });
}

Fleet::~Fleet() {
  stop_ = true;
  if (supervisor_.joinable()) supervisor_.join();
  if (ingest_.joinable()) ingest_.join();
  std::lock_guard<std::mutex> lock(mu_);
  for (auto& [id, w] : workers_)
    if (w.pid > 0) kill(w.pid, SIGTERM);
}

void Fleet::start_worker(const store::Session& s, const std::string& scenario_file, std::optional<double> duration_s,
                         const std::optional<std::string>& aids) {
  std::lock_guard<std::mutex> lock(mu_);
  if (static_cast<int>(workers_.size()) >= config_.max_workers)
    throw std::runtime_error("this machine already runs " + std::to_string(workers_.size()) + " workers (the limit)");
  for (const auto& [id, w] : workers_)
    if (w.cab == s.cab_id) throw std::runtime_error("cab " + s.cab_id + " is running session " + id);
  if (secure()) {
    // The worker's identity must exist before it is spawned: a clear refusal now, not a failed
    // session later. The cab's identity is the cab's business (it lives on the cab).
    dds::SecurityFiles{config_.security_dir, "worker." + s.cab_id}.check();
  }
  const std::string base = config_.log_dir + "/" + s.public_id;
  std::vector<std::string> args = {config_.worker_binary, "--cab", s.cab_id, "--session", s.public_id,
                                   "--scenario", scenario_file, "--dds-domain", std::to_string(config_.dds_domain),
                                   "--log", base + ".ctl", "--start-timeout", std::to_string(config_.start_timeout_s),
                                   "--mode", s.mode};
  if (duration_s) { args.push_back("--duration"); args.push_back(std::to_string(*duration_s)); }
  if (aids) { args.push_back("--aids"); args.push_back(*aids); }
  if (!config_.dds_config.empty()) { args.push_back("--dds-config"); args.push_back(config_.dds_config); }
  if (secure()) { args.push_back("--security"); args.push_back(config_.security_dir); }
  args.insert(args.end(), config_.worker_args.begin(), config_.worker_args.end());
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
  if (pid == 0) {
    const int out = open((base + ".out").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err = open((base + ".err").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (out >= 0) dup2(out, 1);
    if (err >= 0) dup2(err, 2);
    setpgid(0, 0);  // a Ctrl-C to the server's terminal must not kill sessions mid-exam
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  WorkerInfo w;
  w.session = s.public_id;
  w.cab = s.cab_id;
  w.pid = pid;
  w.started = w.last_state = Clock::now();
  workers_[s.public_id] = w;
}

bool Fleet::abort(const std::string& session) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = workers_.find(session);
  if (it == workers_.end()) return false;
  if (it->second.pid > 0) kill(it->second.pid, SIGUSR1);
  return true;
}

std::vector<WorkerInfo> Fleet::workers() {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<WorkerInfo> out;
  for (const auto& [id, w] : workers_) out.push_back(w);
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
      std::cerr << "forklift-server: frame from cab " << n.cab << ": " << e.what() << std::endl;
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
  if (db.set_session_state_audited(session, "failed", reason, store::now_iso8601(), kServer)) {
    std::cerr << "forklift-server: session " << session << " failed: " << reason << std::endl;
    publish_status(session, cab, "failed", reason);
  }
}

void Fleet::supervise() {
  auto db = store::Store::open_sqlite(config_.db_path);
  std::vector<std::pair<std::string, Clock::time_point>> to_chain;  // ended exams, until when to wait
  // The database's chain must be the anchored one before anything is chained onto it.
  std::string chain_problem;
  try {
    chain_problem = check_chain_at_start(*db, *anchor_, chain_keys());
  } catch (const std::exception& e) {
    chain_problem = std::string("the exam chain cannot be checked: ") + e.what();
  }
  if (!chain_problem.empty()) {
    std::cerr << "forklift-server: " << chain_problem << ". No exam is chained, and no certificate counts a practical "
              << "exam, until the database's exam_chain is restored from a backup" << std::endl;
    std::lock_guard<std::mutex> lock(mu_);
    chain_status_.problem = chain_problem;
  }
  // Exams whose worker ended while this server was down, or just before it stopped: each is
  // checked against its signed log before it is chained (chain_exam).
  for (const std::string& s : db->unchained_signed_exams()) to_chain.push_back({s, Clock::now() + std::chrono::seconds(15)});
  while (!stop_) {
    std::vector<std::pair<WorkerInfo, std::string>> finished;  // worker, failure reason ("" if clean)
    {
      std::lock_guard<std::mutex> lock(mu_);
      const auto now = Clock::now();
      for (auto it = workers_.begin(); it != workers_.end();) {
        WorkerInfo& w = it->second;
        std::string reason;
        bool done = false;
        if (w.pid > 0) {
          int status = 0;
          if (waitpid(w.pid, &status, WNOHANG) == w.pid) {
            done = true;
            if (WIFSIGNALED(status)) reason = "worker killed by signal " + std::to_string(WTERMSIG(status));
            else if (WEXITSTATUS(status) != 0) reason = "worker exited with code " + std::to_string(WEXITSTATUS(status));
          }
        }
        const double silent = std::chrono::duration<double>(now - w.last_state).count();
        if (!done && w.seen_state && silent > config_.hang_timeout_s) {
          reason = "worker hung: no truck state for " + std::to_string(int(silent)) + " s";
          if (w.pid > 0) { kill(w.pid, SIGKILL); waitpid(w.pid, nullptr, 0); }
          done = true;
        }
        if (!done && w.pid == 0 && !w.seen_state && silent > config_.hang_timeout_s + config_.start_timeout_s) {
          reason = "worker lost across a server restart";
          done = true;
        }
        if (done) {
          finished.push_back({w, reason});
          it = workers_.erase(it);
        } else {
          ++it;
        }
      }
    }
    for (const auto& [w, reason] : finished) {
      const std::string base = config_.log_dir + "/" + w.session;
      db->put_session_log(w.session, "control", slurp(base + ".ctl"));
      db->put_session_log(w.session, "worker", slurp(base + ".err"));
      if (std::ifstream(base + ".ctl.sig")) {
        db->put_session_log(w.session, "signature", slurp(base + ".ctl.sig"));
        to_chain.push_back({w.session, Clock::now() + std::chrono::seconds(15)});
      }
      if (!reason.empty()) {
        fail(*db, w.session, w.cab, reason);
      } else {
        // A clean exit normally follows the worker's own "ended" status; if it was lost, the
        // session still ends, but as ended, which carries no mark and so is never a pass.
        const auto s = db->get_session(w.session);
        if (s && !store::is_terminal(s->state)) {
          // The session log says whether the worker gave up waiting for its cab.
          bool gave_up = false;
          try {
            for (const auto& [tick, kind] : read_control_log(base + ".ctl").worker_events) gave_up = gave_up || kind == kNoControlsEvent;
          } catch (const std::exception&) {
            // no log, or a torn one: the worker died early; it ended, unmarked
          }
          if (gave_up) fail(*db, w.session, w.cab, "the cab never spoke");
          else db->set_session_state_audited(w.session, "ended", "worker exited", store::now_iso8601(), kServer);
        }
      }
    }
    chain_ended_exams(*db, to_chain);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
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
      std::cerr << "forklift-server: cannot chain exam " << it->first << ": " << e.what() << std::endl;
    }
    if (r.result == ChainResult::kNotReady && !late) { ++it; continue; }
    if (r.result == ChainResult::kNotReady) std::cerr << "forklift-server: exam " << it->first << " never got its score: not chained" << std::endl;
    if (r.result == ChainResult::kChainBroken || r.result == ChainResult::kRefused) {
      const std::string why = r.result == ChainResult::kRefused ? r.why : "the exam chain is broken: " + r.why;
      std::cerr << "forklift-server: exam " << it->first << " is not chained: " << why << std::endl;
      {
        std::lock_guard<std::mutex> lock(mu_);
        if (r.result == ChainResult::kChainBroken && chain_status_.problem.empty()) chain_status_.problem = r.why;
        ++chain_status_.refused;
      }
      try {
        record_chain_refusal(db, it->first, why);
      } catch (const std::exception& e) {
        std::cerr << "forklift-server: cannot record the refusal of exam " << it->first << ": " << e.what() << std::endl;
      }
    }
    it = pending.erase(it);
  }
}

void Fleet::ingest() {
  auto db = store::Store::open_sqlite(config_.db_path);
  dds::Reader<fk_Event> events(*participant_);
  dds::Reader<fk_Score> scores(*participant_);
  dds::Reader<fk_SessionStatus> statuses(*participant_);
  dds::Reader<fk_TruckState> states(*participant_, "cab.*");
  dds::Reader<fk_CabAnnounce> announces(*participant_, "cab.*");
  dds::WaitSet ws(*participant_);
  for (dds_entity_t r : {events.handle(), scores.handle(), statuses.handle(), states.handle(), announces.handle()})
    ws.attach_reader(r);
  while (!stop_) {
    ws.wait(0.1);
    try {
      events.take_each([&](const fk_Event& e) {
        if (!db->get_session(e.session_id)) return;  // not one of ours (another server on this domain)
        db->add_event({e.session_id, e.seq, e.sim_time_s, e.kind, e.worry_level, e.x_m, e.y_m, e.details});
      });
      scores.take_each([&](const fk_Score& s) {
        if (!db->get_session(s.session_id)) return;
        store::ScoreRecord r{s.session_id, s.mark, s.passed, {}};
        for (uint32_t i = 0; i < s.counts._length; ++i) r.counts[s.counts._buffer[i].kind] = int(s.counts._buffer[i].count);
        db->set_score_audited(r, store::now_iso8601(), kWorker);
      });
      statuses.take_each([&](const fk_SessionStatus& s) {
        const std::string state = s.state;
        if (!db->get_session(s.session_id)) return;
        if (state == "waiting" || state == "running" || state == "ended" || state == "failed")
          db->set_session_state_audited(s.session_id, state, s.reason, store::now_iso8601(), kWorker);
      });
      std::vector<std::string> announced;
      std::map<std::string, std::vector<store::PathPoint>> path;  // by session, downsampled
      {
      std::lock_guard<std::mutex> lock(mu_);
      states.take_each([&](const fk_TruckState& t) {
        auto it = workers_.find(t.session_id);
        if (it != workers_.end()) {
          it->second.last = t;
          it->second.last_state = Clock::now();
          it->second.seen_state = true;
          // One point every path_interval_s of sim time.
          auto& last = it->second.last_path_point_s;
          if (!last || t.sim_time_s >= *last + config_.path_interval_s) {
            last = t.sim_time_s;
            path[t.session_id].push_back({t.sim_time_s, t.x_m, t.y_m, t.yaw_rad, t.speed_m_s, t.lift_m});
          }
        }
      });
      announces.take_each([&](const fk_CabAnnounce& a) {
        CabInfo& c = cabs_[a.cab_id];
        c.id = a.cab_id;
        c.mode = a.mode;
        c.last_seen = Clock::now();
        announced.push_back(c.id);
      });
      }
      take_followed_frames();
      for (const std::string& cab : announced) db->cab_seen(cab, 1, store::now_iso8601());  // the default school
      for (const auto& [session, points] : path) db->add_path_points(session, points);
    } catch (const std::exception& e) {
      std::cerr << "forklift-server: ingest: " << e.what() << std::endl;  // counted, never fatal
    }
  }
}

}  // namespace forklift::server
