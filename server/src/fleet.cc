#include "fleet.h"

#include "worker_log.h"

#include <spdlog/spdlog.h>

#include <pthread.h>

#include <algorithm>
#include <set>
#include <chrono>

namespace forklift::server {

void FleetState::refuse(RefusalCounter counter, const std::string& what) {
  uint64_t n;
  bool first;
  {
    std::lock_guard<std::mutex> lock(mu);
    n = ++(refused.*counter);
    first = refusals_named.size() < kRefusalsNamed && refusals_named.insert(what).second;
  }
  if (first || n <= 20 || (n & (n - 1)) == 0) spdlog::warn("refused {} ({} so far)", what, n);
}

Fleet::Fleet(FleetConfig config) : config_(std::move(config)) {
  if (!secure() && config_.trust_clear_hosts)
    spdlog::warn("worker hosts are believed in clear DDS (--trust-clear-hosts): any machine on this network can claim to be "
                 "one, take sessions, stop workers and set marks; keep this to a closed network the school alone can reach");
  else if (!secure())
    spdlog::info("worker hosts are not believed in clear DDS (no identity vouches for them): give --security, or "
                 "--trust-clear-hosts on a closed network");
  auto db = store::Store::open(config_.db_path);
  supervisor_.adopt(*db);
  supervisor_thread_ = std::thread([this] { supervise(); });
  ingest_thread_ = std::thread([this] { ingest(); });
}

Fleet::~Fleet() {
  stop_ = true;
  if (supervisor_thread_.joinable()) supervisor_thread_.join();
  if (ingest_thread_.joinable()) ingest_thread_.join();
  supervisor_.stop_local_workers();
}

bool Fleet::settling(const std::string& session) {
  std::lock_guard<std::mutex> lock(state_.mu);
  return state_.unsettled.count(session) > 0;
}

std::vector<WorkerInfo> Fleet::workers() {
  std::lock_guard<std::mutex> lock(state_.mu);
  std::vector<WorkerInfo> out;
  for (const auto& [id, w] : state_.workers) out.push_back(w);
  return out;
}

bool Fleet::cab_busy(const std::string& cab) {
  std::lock_guard<std::mutex> lock(state_.mu);
  return !state_.session_on(cab).empty();
}

std::optional<std::string> Fleet::instruct(const std::string& session, const Instruction& what, const std::string& by) {
  std::lock_guard<std::mutex> lock(state_.mu);
  const auto w = state_.workers.find(session);
  if (w == state_.workers.end()) return "session " + session + " has no running worker";
  if (w->second.seen_state && what.action == InstructorAction::kPause && w->second.last.paused)
    return "session " + session + " is paused already";
  if (w->second.seen_state && what.action == InstructorAction::kResume && !w->second.last.paused)
    return "session " + session + " is not paused";
  auto& writer = instructor_writers_[w->second.cab];
  try {
    if (!writer) writer = std::make_unique<dds::Writer<fk_InstructorAction>>(*participant_, dds::instructor_partition(w->second.cab));
  } catch (const std::runtime_error& e) {
    // An identity issued before the instructor's partition existed may not write there.
    spdlog::error("the instructor's action for session {} cannot be written: {}", session, e.what());
    return "this server's DDS identity may not write the instructor's actions: re-issue it with scripts/forklift-pki.sh";
  }
  // The wall clock's milliseconds, and never the same twice: a server restarted mid-session goes on
  // above the numbers it gave before, which its worker has taken.
  const auto now_ms = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
  instructor_seq_ = std::max(instructor_seq_ + 1, uint64_t(now_ms));
  fk_InstructorAction a{};
  dds::set_string(a.session_id, session);
  dds::set_string(a.cab_id, w->second.cab);
  a.seq = instructor_seq_;
  dds::set_string(a.action, name(what.action));
  dds::set_string(a.text, what.text);
  a.seconds = what.seconds;
  dds::set_string(a.by, by);
  if (!writer->write(a)) return "the action could not be sent to the worker of session " + session;
  return std::nullopt;
}

RefusedSamples Fleet::refused() {
  std::lock_guard<std::mutex> lock(state_.mu);
  return state_.refused;
}

IngestedSamples Fleet::ingested() {
  std::lock_guard<std::mutex> lock(state_.mu);
  return state_.ingested;
}

Speaker Fleet::speaker(const std::string& session) {
  std::lock_guard<std::mutex> lock(state_.mu);
  const auto it = state_.bindings.find(session);
  if (it == state_.bindings.end()) return {Speaker::Known::kNotOurs, "", ""};  // another server's, or long over
  if (it->second.participant.empty()) {
    // A hosted worker's participant comes in its host's report, which may follow its first samples.
    if (state_.hosted(session)) return {Speaker::Known::kNotYet, "", ""};
    it->second.participant = logged_participant(state_.log_path(session));
    // No log here: a hosted worker that a restart has not heard its host on yet (adopt()).
    if (it->second.participant.empty() && !std::ifstream(state_.log_path(session))) return {Speaker::Known::kNotYet, "", ""};
  }
  return {Speaker::Known::kYes, it->second.cab, it->second.participant};
}

std::optional<dds::Sender> Fleet::discover(dds_entity_t reader, dds_instance_handle_t publication) {
  return dds::sender_of(reader, publication);
}

void Fleet::supervise() {
  pthread_setname_np(pthread_self(), "supervise");
  auto db = store::Store::open(config_.db_path);
  ToChain to_chain = recorder_.check_chain(*db);  // ended exams, until when to wait
  // Signs of life five times a lease, so that a late one or two never lose this server its sessions.
  const auto alive_every = seconds(config_.server_lease_s / 5);
  auto said_alive = Clock::now();
  while (!stop_) {
    if (Clock::now() - said_alive >= alive_every) {
      said_alive = Clock::now();
      try {
        db->server_alive(config_.server_id, store::now_iso8601());
        take_over(*db, db->claim_sessions(config_.server_id, state_.lease_start(), false));
      } catch (const std::exception& e) {
        spdlog::error("saying this server is alive, or taking over a stopped server's sessions: {}", e.what());
      }
    }
    supervisor_.watch();
    for (const FleetState::Finishing& f : supervisor_.due()) {
      try {
        recorder_.settle(*db, f.worker, f.reason, to_chain);
      } catch (const std::exception& e) {
        spdlog::error("settling session {}: {}", f.worker.session, e.what());
      }
      supervisor_.settled(f.worker.session);
    }
    recorder_.chain_ended_exams(*db, to_chain);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

void Fleet::take_over(store::Store& db, const std::vector<std::string>& sessions) {
  // A hosted worker's host was heard from while the other server ran it; the rest ran on that
  // server's machine (adopted if that is this one) or are waited for as at start-up.
  std::vector<std::string> unheard;
  for (const std::string& s : sessions)
    if (!placement_.take_over(db, s)) unheard.push_back(s);
  if (!unheard.empty()) supervisor_.take_over(db, unheard);
}

namespace {

// Takes the reader's samples (every one, or the valid ones), each handed to `handle`: one
// sample's trouble costs that sample only (counted as malformed), the rest of its batch is taken.
template <typename Reader, typename Handle>
void take(Reader& reader, const char* topic, FleetState& state, bool all, Handle&& handle) {
  auto one = [&](const auto& sample, const dds_sample_info_t& info) {
    try {
      handle(sample, info);
    } catch (const std::exception& e) {
      state.refuse(&RefusedSamples::malformed, std::string("a ") + topic + " sample: " + e.what());
    }
  };
  try {
    if (all) reader.take_all_with_info(one);
    else reader.take_each_with_info(one);
  } catch (const std::exception& e) {
    spdlog::warn("ingest: {}", e.what());  // the count itself failed: logged, never fatal
  }
}

// Each value the gate let through, handed to `record`; a failure to record it costs that one only.
template <typename T, typename Record>
void record_each(const std::vector<T>& values, const char* topic, FleetState& state, Record&& record) {
  for (const T& v : values) {
    try {
      record(v);
    } catch (const std::exception& e) {
      state.refuse(&RefusedSamples::malformed, std::string("a ") + topic + " sample: " + e.what());
    }
  }
}

}  // namespace

void Fleet::ingest() {
  pthread_setname_np(pthread_self(), "ingest");  // its CPU time apart in /proc (forklift-bench-ingest)
  auto db = store::Store::open(config_.db_path);
  // Workers report in their own partitions; cabs announce in theirs.
  dds::Reader<fk_Event> events(*participant_, "worker.*");
  dds::Reader<fk_Score> scores(*participant_, "worker.*");
  dds::Reader<fk_SessionStatus> statuses(*participant_, "worker.*");
  dds::Reader<fk_CabAnnounce> announces(*participant_, "cab.*");
  // Worker hosts speak in their own partitions.
  dds::Reader<fk_HostStatus> host_statuses(*participant_, "host.*");
  dds::Reader<fk_WorkerReport> reports(*participant_, "host.*");
  const auto readers = {events.handle(), scores.handle(), statuses.handle(), announces.handle(), host_statuses.handle(),
                        reports.handle()};
  dds::WaitSet ws(*participant_);
  for (dds_entity_t r : readers) ws.attach_reader(r);
  // The truck states of the cabs whose sessions this server runs, a reader in each one's
  // partition: with several servers on one store, each is sent its own sessions' states alone
  // (60 a second each, the bulk of the ingest), not every cab's to read and drop. Every state,
  // not only each cab's newest: the truck path is taken from them, and a round of the ingest held
  // up (a store transaction, another server's commit on a shared SQLite file, a busy machine)
  // would otherwise lose the states that came meanwhile. 64 is a second of a worker's 60 Hz (held
  // only while a round is held up: a sample taken is freed).
  std::map<std::string, std::unique_ptr<dds::Reader<fk_TruckState>>> states;  // by cab
  auto read_states_of_bound_cabs = [&] {
    std::set<std::string> cabs;
    {
      std::lock_guard<std::mutex> lock(state_.mu);
      for (const auto& [session, b] : state_.bindings) cabs.insert(b.cab);
    }
    std::erase_if(states, [&](const auto& r) { return !cabs.count(r.first); });  // a deleted reader leaves the wait set
    for (const std::string& cab : cabs)
      if (!states.count(cab)) {
        auto r = std::make_unique<dds::Reader<fk_TruckState>>(*participant_, dds::cab_partition(cab), 64);
        ws.attach_reader(r->handle());
        states.emplace(cab, std::move(r));
      }
  };
  // Who each writer is, learnt while it is matched (the gate keeps it for after it has gone).
  auto learn_senders = [&](dds_entity_t reader) {
    dds_instance_handle_t handles[64];
    const dds_return_t n = dds_get_matched_publications(reader, handles, 64);
    for (dds_return_t i = 0; i < std::min<dds_return_t>(n, 64); ++i)
      if (!gate_.knows(handles[i]))
        if (auto found = dds::sender_of(reader, handles[i])) gate_.learn(handles[i], std::move(*found));
  };
  // Events, path points and cab sightings go to the store together, in one transaction at most
  // every kStoreEvery: one commit (a disk flush) for all the sessions' instead of one each, which
  // on PostgreSQL held a server to some 100 sessions. Before a score or a status is recorded, the
  // session's events are stored (an exam's details are worked out from them).
  constexpr auto kStoreEvery = std::chrono::milliseconds(100);
  std::vector<store::EventRecord> pending_events;
  std::map<std::string, std::vector<store::PathPoint>> path;  // by session, downsampled
  std::set<std::string> announced;
  auto stored_at = Clock::now();
  auto store_pending = [&] {
    stored_at = Clock::now();
    if (pending_events.empty() && path.empty() && announced.empty()) return;
    try {
      db->batch([&] {
        // One sample's trouble costs that one only: its savepoint is rolled back, the rest commit.
        record_each(pending_events, "fk_Event", state_, [&](const store::EventRecord& e) { recorder_.event(*db, e); });
        for (const std::string& cab : announced) db->cab_seen(cab, 1, store::now_iso8601());  // the default school
        for (const auto& [session, points] : path) {
          try {
            db->add_path_points(session, points);
          } catch (const std::exception& e) {
            spdlog::warn("ingest: {}", e.what());  // a session gone from the store: its points only
          }
        }
      });
    } catch (const std::exception& e) {
      // Logged, never fatal: these path points and sightings are lost (the events are in the
      // workers' logs, from which each session's settling takes what the store lacks).
      spdlog::warn("ingest: {}", e.what());
    }
    pending_events.clear();
    path.clear();
    announced.clear();
  };
  // A round at most every kRoundEvery: the samples that came meanwhile are taken together, a
  // reader at a time, rather than a round for each (the readers keep 64 states per cab). The
  // truck states' writers are learnt less often: a worker's lives for its session, and one not
  // learnt yet is asked for when its sample is taken.
  constexpr auto kRoundEvery = std::chrono::milliseconds(10);
  constexpr auto kLearnStatesEvery = std::chrono::milliseconds(250);
  auto learnt_states_at = Clock::now() - kLearnStatesEvery;
  while (!stop_) {
    const auto round_start = Clock::now();
    read_states_of_bound_cabs();
    ws.wait(0.1);
    IngestedSamples round;
    for (dds_entity_t r : readers) learn_senders(r);
    if (Clock::now() - learnt_states_at >= kLearnStatesEvery) {
      learnt_states_at = Clock::now();
      for (const auto& [cab, r] : states) learn_senders(r->handle());
    }
    // Invalid samples too: one says that a host's status writer has gone.
    take(host_statuses, "fk_HostStatus", state_, true, [&](const fk_HostStatus& h, const dds_sample_info_t& info) {
      if (auto in = gate_.host_status(h, info, host_statuses.handle())) placement_.host_status(*in);
    });
    take(reports, "fk_WorkerReport", state_, false, [&](const fk_WorkerReport& r, const dds_sample_info_t& info) {
      if (gate_.report(r, info, reports.handle())) {
        ++round.reports;
        placement_.on_report(*db, r);
      }
    });
    // A hosted worker's first events and statuses may come before its host's report names its
    // participant: the gate holds them back (a few seconds at most) and they are offered again
    // after this round's own.
    const auto now = Clock::now();
    SampleGate::HeldBack held = gate_.take_held();
    take(events, "fk_Event", state_, false, [&](const fk_Event& e, const dds_sample_info_t& info) {
      if (auto in = gate_.event(e, info, events.handle(), now)) {
        ++round.events;
        pending_events.push_back(std::move(*in));
      }
    });
    take(scores, "fk_Score", state_, false, [&](const fk_Score& s, const dds_sample_info_t& info) {
      if (auto in = gate_.score(s, info, scores.handle())) {
        ++round.scores;
        store_pending();
        recorder_.score(*db, std::move(*in));
      }
    });
    take(statuses, "fk_SessionStatus", state_, false, [&](const fk_SessionStatus& s, const dds_sample_info_t& info) {
      if (auto in = gate_.status(s, info, statuses.handle(), now)) {
        ++round.statuses;
        store_pending();
        recorder_.status(*db, *in);
      }
    });
    for (store::EventRecord& e : gate_.events_again(held.events, now)) {
      ++round.events;
      pending_events.push_back(std::move(e));
    }
    record_each(gate_.statuses_again(held.statuses, now), "fk_SessionStatus", state_, [&](const StatusIn& s) {
      ++round.statuses;
      store_pending();
      recorder_.status(*db, s);
    });
    for (const auto& [cab, r] : states)
      take(*r, "fk_TruckState", state_, false, [&](const fk_TruckState& t, const dds_sample_info_t& info) {
        if (gate_.truck_state(t, info, r->handle())) {
          ++round.states;
          recorder_.truck_state(t, path);
        }
      });
    take(announces, "fk_CabAnnounce", state_, false, [&](const fk_CabAnnounce& a, const dds_sample_info_t& info) {
      if (auto in = gate_.announce(a, info, announces.handle())) {
        ++round.announces;
        placement_.cab_seen(*in);
        announced.insert(in->id);
      }
    });
    try {
      recorder_.take_followed_frames();
    } catch (const std::exception& e) {
      spdlog::warn("ingest: {}", e.what());  // logged, never fatal: the sessions go on
    }
    if (Clock::now() - stored_at >= kStoreEvery) store_pending();
    {
      std::lock_guard<std::mutex> lock(state_.mu);
      IngestedSamples& n = state_.ingested;
      n.states += round.states, n.events += round.events, n.statuses += round.statuses;
      n.scores += round.scores, n.reports += round.reports, n.announces += round.announces;
    }
    std::this_thread::sleep_until(round_start + kRoundEvery);
  }
  store_pending();
}

}  // namespace forklift::server
