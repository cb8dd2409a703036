#include "session_recorder.h"

#include "worker_log.h"

#include "forklift/image/image.h"
#include "forklift/server/logs.h"
#include "forklift/session/session_log.h"

#include <spdlog/spdlog.h>

#include <fstream>

namespace forklift::server {

bool set_state(store::Store& db, const std::string& session, SessionPhase state, const std::string& reason,
               const store::Actor& actor) {
  const bool changed = db.set_session_state_audited(session, state, reason, store::now_iso8601(), actor);
  if (changed) session_log(session, name(state), {{"reason", reason}, {"by", actor.name}});
  return changed;
}

namespace {

// The score likewise: audited, and a line in the session log when it is new.
bool set_score(store::Store& db, const store::ScoreRecord& score, const store::Actor& actor) {
  const bool changed = db.set_score_audited(score, store::now_iso8601(), actor);
  if (changed) session_log(score.session_public_id, "scored", {{"mark", score.mark}, {"passed", score.passed}, {"by", actor.name}});
  return changed;
}

// Who the audit log names for what workers report over DDS.
const store::Actor kWorker{std::nullopt, "worker"};
const store::Actor kServer{std::nullopt, "server"};  // the supervisor's own findings
const store::Actor kWorkerLog{std::nullopt, "worker log"};  // what the server took from a worker's session log

}  // namespace

SessionRecorder::SessionRecorder(FleetState& fleet, dds::Participant& participant)
    : fleet_(fleet),
      participant_(participant),
      rules_(load_marking_rules(fleet.config.data_dir + "/evaluation/rules.json")),
      anchor_(std::make_unique<ChainAnchor>(fleet.config.chain_anchor.empty() ? fleet.config.log_dir + "/exam-chain.anchor"
                                                                              : fleet.config.chain_anchor)),
      status_writer_(std::make_unique<dds::Writer<fk_SessionStatus>>(participant)) {}

void SessionRecorder::event(store::Store& db, const store::EventRecord& e) { db.add_event(e); }

void SessionRecorder::score(store::Store& db, store::ScoreRecord r) {
  const std::string log_path = fleet_.log_path(r.session_public_id);
  {
    // A hosted worker's log comes with its host's report when it exits, and its mark with it.
    std::lock_guard<std::mutex> lock(fleet_.mu);
    if (fleet_.hosted(r.session_public_id) && !std::ifstream(log_path)) return;
  }
  std::optional<LoggedMark> logged;
  try {
    const auto log = read_control_log(log_path);
    if (log.score_line) logged = parse_score_line(*log.score_line);
  } catch (const std::exception&) {
    // no log: nothing vouches for the mark
  }
  if (!logged || logged->mark != r.mark || logged->passed != r.passed) {
    fleet_.refuse(&RefusedSamples::score_disagrees, "a score for session " + r.session_public_id + " that its session log does not hold");
    return;
  }
  r.exam_details = practical_exam_details(db, fleet_.config.data_dir, rules_, r.session_public_id, logged->end_reason, logged->points,
                                          r.counts, r.passed);
  set_score(db, r, kWorker);
}

void SessionRecorder::status(store::Store& db, const StatusIn& s) { set_state(db, s.session, s.state, s.reason, kWorker); }

void SessionRecorder::truck_state(const fk_TruckState& t, std::map<std::string, std::vector<store::PathPoint>>& path) {
  std::lock_guard<std::mutex> lock(fleet_.mu);
  // A running worker's, or a finished one's whose last states are still coming (its host's report
  // of its end may come first): they are the session's until it is settled, its path's last
  // point among them.
  WorkerInfo* w = nullptr;
  if (auto it = fleet_.workers.find(t.session_id); it != fleet_.workers.end()) w = &it->second;
  else if (auto f = fleet_.finishing_of(t.session_id); f != fleet_.finishing.end()) w = &f->worker;
  if (!w) return;
  w->last = t;
  w->last_state = Clock::now();
  w->seen_state = true;
  // One point every path_interval_s of sim time.
  auto& last = w->last_path_point_s;
  if (!last || t.sim_time_s >= *last + fleet_.config.path_interval_s) {
    last = t.sim_time_s;
    path[t.session_id].push_back({t.sim_time_s, t.x_m, t.y_m, t.yaw_rad, t.speed_m_s, t.lift_m});
  }
}

void SessionRecorder::publish_status(const std::string& session, const std::string& cab, SessionPhase state, const std::string& reason) {
  fk_SessionStatus s{};
  dds::set_string(s.session_id, session);
  dds::set_string(s.cab_id, cab);
  dds::set_string(s.state, name(state));
  dds::set_string(s.reason, reason);
  status_writer_->write(s);
  // The cab reads its own partition only.
  std::lock_guard<std::mutex> lock(fleet_.mu);
  auto& w = cab_status_writers_[cab];
  if (!w) w = std::make_unique<dds::Writer<fk_SessionStatus>>(participant_, dds::cab_partition(cab));
  w->write(s);
}

std::optional<LiveView> SessionRecorder::follow(const std::string& session) {
  std::lock_guard<std::mutex> lock(fleet_.mu);
  const auto w = fleet_.workers.find(session);
  if (w == fleet_.workers.end()) return std::nullopt;
  Followed& f = followed_[w->second.cab];
  if (!f.frames) f.frames = std::make_unique<dds::Reader<fk_Frame>>(participant_, dds::cab_partition(w->second.cab));
  f.last_asked = Clock::now();
  LiveView v = f.view;
  v.state = w->second.last;
  v.have_state = w->second.seen_state;
  return v;
}

void SessionRecorder::take_followed_frames() {
  constexpr auto kFollowIdle = std::chrono::seconds(10);
  struct Newest {
    std::string cab;
    fk_Frame head{};  // the scalars only: its pixel buffer went back to DDS with the loan
    std::vector<uint8_t> pixels;
  };
  std::vector<Newest> taken;
  {
    std::lock_guard<std::mutex> lock(fleet_.mu);
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
    std::lock_guard<std::mutex> lock(fleet_.mu);
    const auto it = followed_.find(n.cab);
    if (it == followed_.end()) continue;
    it->second.view.jpeg = std::move(jpeg);
    it->second.view.frame_seq = n.head.seq;
    it->second.view.frame_sim_time_s = n.head.sim_time_s;
  }
}

void SessionRecorder::fail(store::Store& db, const std::string& session, const std::string& cab, const std::string& reason) {
  if (set_state(db, session, SessionPhase::kFailed, reason, kServer)) {
    spdlog::warn("session {} failed: {}", session, reason);
    publish_status(session, cab, SessionPhase::kFailed, reason);
  }
}

void SessionRecorder::settle(store::Store& db, const WorkerInfo& w, const std::string& reason, ToChain& to_chain) {
  const std::string log = fleet_.log_path(w.session);
  const std::string base = fleet_.config.log_dir + "/" + w.session;
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
      score.exam_details = practical_exam_details(db, fleet_.config.data_dir, rules_, w.session, logged->end_reason.value_or(""),
                                                  logged->points, score.counts, score.passed);
      // A hosted worker's mark of record is its log's, which its host brings when it exits.
      scored = set_score(db, score, w.host.empty() ? kWorkerLog : kWorker) && w.host.empty();
    }
    if (events || scored) {
      std::lock_guard<std::mutex> lock(fleet_.mu);
      fleet_.refused.recovered_events += events;
      fleet_.refused.recovered_scores += scored ? 1 : 0;
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
  if (!s || is_terminal(s->state)) return;
  if (logged && logged->score && logged->end_reason) {
    // The log's end is the session's, whatever became of the worker's last status.
    if (set_state(db, w.session, SessionPhase::kEnded, *logged->end_reason, kWorkerLog))
      publish_status(w.session, w.cab, SessionPhase::kEnded, *logged->end_reason);
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
    set_state(db, w.session, SessionPhase::kEnded, "worker exited", kServer);
  }
}

ToChain SessionRecorder::check_chain(store::Store& db) {
  // The database's chain must be the anchored one before anything is chained onto it.
  std::string chain_problem;
  try {
    chain_problem = check_chain_at_start(db, *anchor_, chain_keys());
  } catch (const std::exception& e) {
    chain_problem = std::string("the exam chain cannot be checked: ") + e.what();
  }
  if (!chain_problem.empty()) {
    spdlog::error("{}. No exam is chained, and no certificate counts a practical exam, until the database's exam_chain is "
                  "restored from a backup", chain_problem);
    std::lock_guard<std::mutex> lock(fleet_.mu);
    chain_status_.problem = chain_problem;
  }
  // Exams whose worker ended while this server was down, or just before it stopped: each is
  // checked against its signed log before it is chained (chain_exam).
  ToChain to_chain;
  for (const std::string& s : db.unchained_signed_exams()) to_chain.push_back({s, Clock::now() + std::chrono::seconds(15)});
  return to_chain;
}

void SessionRecorder::chain_ended_exams(store::Store& db, ToChain& pending) {
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
      std::lock_guard<std::mutex> lock(fleet_.mu);
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
        std::lock_guard<std::mutex> lock(fleet_.mu);
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

}  // namespace forklift::server
