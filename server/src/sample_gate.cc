#include "sample_gate.h"

#include <cmath>
#include <iterator>
#include <regex>

#include "forklift/session/vocabulary.h"

namespace forklift::server {

namespace {

bool finite(std::initializer_list<double> xs) {
  for (double x : xs) if (!std::isfinite(x)) return false;
  return true;
}

// What is wrong with a sample's strings (UTF-8), or nullopt.
std::optional<std::string> bad_text(std::initializer_list<std::pair<const char*, const char*>> fields) {
  for (const auto& [name, text] : fields)
    if (!dds::valid_utf8(text)) return std::string(name) + " is not UTF-8";
  return std::nullopt;
}

bool valid_session_id(const char* id) { return std::regex_match(id, std::regex("s-[0-9]{1,18}")); }

}  // namespace

void SampleGate::malformed(const char* topic, const std::string& why) {
  world_.refuse(&RefusedSamples::malformed, std::string("a ") + topic + " sample: " + why);
}

std::optional<dds::Sender> SampleGate::sender(dds_entity_t reader, dds_instance_handle_t publication) {
  auto it = senders_.find(publication);
  if (it == senders_.end()) {
    auto found = world_.discover(reader, publication);
    if (!found) return std::nullopt;
    it = senders_.emplace(publication, std::move(*found)).first;
  }
  return it->second;
}

SampleGate::Verdict SampleGate::check_sender(const std::string& session, dds_entity_t reader, const dds_sample_info_t& info,
                                             bool state_topic) {
  const Speaker b = world_.speaker(session);
  if (b.known == Speaker::Known::kNotOurs) return Verdict::kNotOurs;
  if (b.known == Speaker::Known::kNotYet) return Verdict::kNotYet;
  const auto s = sender(reader, info.publication_handle);
  if (!s) return Verdict::kWrongSender;  // a writer discovery does not vouch for
  // The worker's states go to its cab; all else it says in its own partition.
  const std::string partition = state_topic ? dds::cab_partition(b.cab) : dds::worker_partition(b.cab);
  if (b.participant.empty() || s->participant != b.participant || !s->in(partition)) return Verdict::kWrongSender;
  return Verdict::kOurs;
}

bool SampleGate::believed(const char* topic, const char* session, dds_entity_t reader, const dds_sample_info_t& info,
                          bool state_topic, bool* not_yet) {
  if (!dds::valid_utf8(session)) {
    world_.refuse(&RefusedSamples::malformed, std::string("a ") + topic + " whose session is not UTF-8");
    return false;
  }
  switch (check_sender(session, reader, info, state_topic)) {
    case Verdict::kOurs: return true;
    case Verdict::kNotOurs: return false;
    case Verdict::kNotYet:
      if (not_yet) *not_yet = true;
      return false;
    case Verdict::kWrongSender:
      world_.refuse(&RefusedSamples::wrong_sender, std::string("a ") + topic + " for session " + session + " not from its worker");
      return false;
  }
  return false;
}

bool SampleGate::from_host(dds_entity_t reader, const dds_sample_info_t& info, const char* host) {
  const auto s = sender(reader, info.publication_handle);
  return s && s->in(dds::host_partition(host));
}

std::optional<HostStatusIn> SampleGate::host_status(const fk_HostStatus& h, const dds_sample_info_t& info, dds_entity_t reader) {
  if (!dds::valid_utf8(h.host_id) || !h.host_id[0]) return std::nullopt;
  if (!info.valid_data) {  // its writer is gone or lost its liveliness
    if (info.instance_state == DDS_IST_ALIVE) return std::nullopt;
    HostStatusIn gone;
    gone.id = h.host_id;
    gone.gone = true;
    return gone;
  }
  if (!world_.hosts_believed()) {
    world_.refuse(&RefusedSamples::no_identity, std::string("a status of worker host ") + h.host_id +
                                                    " in clear DDS (no identity vouches for it; --trust-clear-hosts on a closed network)");
    return std::nullopt;
  }
  if (!from_host(reader, info, h.host_id)) {
    world_.refuse(&RefusedSamples::wrong_sender, std::string("a status of worker host ") + h.host_id + " from outside its partition");
    return std::nullopt;
  }
  const std::optional<HostState> state = parse<HostState>(h.state);
  if (!dds::valid_utf8(h.site) || !state || h.capacity == 0 || !std::isfinite(h.load_1min) || !std::isfinite(h.memory_free_mib)) {
    world_.refuse(&RefusedSamples::malformed, std::string("a status of worker host ") + h.host_id + " out of range");
    return std::nullopt;
  }
  return HostStatusIn{h.host_id, h.site, *state, int(h.capacity), int(h.running), int(h.cores), h.load_1min, h.memory_free_mib, false};
}

bool SampleGate::report(const fk_WorkerReport& r, const dds_sample_info_t& info, dds_entity_t reader) {
  constexpr const char* kTopic = "fk_WorkerReport";
  if (auto bad = bad_text({{"its host", r.host_id}, {"its session", r.session_id}, {"its cab", r.cab_id}, {"its state", r.state},
                           {"its reason", r.reason}, {"its participant", r.participant}})) {
    malformed(kTopic, *bad);
    return false;
  }
  if (!world_.hosts_believed()) {
    world_.refuse(&RefusedSamples::no_identity, std::string("a report ") +
                                                    (r.host_id[0] ? "of worker host " + std::string(r.host_id) : "naming no worker host") +
                                                    " on session " + r.session_id + " in clear DDS (no identity vouches for it)");
    return false;
  }
  if (!r.host_id[0]) {
    world_.refuse(&RefusedSamples::wrong_sender, std::string("a report on session ") + r.session_id + " that names no worker host");
    return false;
  }
  if (!from_host(reader, info, r.host_id)) {
    world_.refuse(&RefusedSamples::wrong_sender, std::string("a report of worker host ") + r.host_id + " from outside its partition");
    return false;
  }
  // The session id names the files a report brings (s-<digits>).
  if (!valid_session_id(r.session_id)) {
    malformed(kTopic, std::string("a report on session '") + r.session_id + "'");
    return false;
  }
  if (!parse<WorkerReportState>(r.state)) {
    malformed(kTopic, std::string("a report of a worker ") + r.state);
    return false;
  }
  if (r.participant[0] && !std::regex_match(r.participant, std::regex("[0-9a-f]{32}"))) {
    malformed(kTopic, std::string("a report naming participant '") + r.participant + "'");
    return false;
  }
  return true;
}

std::optional<store::EventRecord> SampleGate::valid_event(const fk_Event& e) {
  if (auto bad = bad_text({{"its kind", e.kind}, {"its details", e.details}})) {
    malformed("fk_Event", *bad);
    return std::nullopt;
  }
  if (!finite({e.sim_time_s, e.x_m, e.y_m}) || e.sim_time_s < 0 || e.seq == 0 || e.worry_level > 5 || !e.kind[0]) {
    malformed("fk_Event", "event " + std::to_string(e.seq) + " of session " + std::string(e.session_id) + " is out of range");
    return std::nullopt;
  }
  return store::EventRecord{e.session_id, e.seq, e.sim_time_s, e.kind, e.worry_level, e.x_m, e.y_m, e.details};
}

std::optional<store::EventRecord> SampleGate::event(const fk_Event& e, const dds_sample_info_t& info, dds_entity_t reader,
                                                    Clock::time_point now) {
  bool not_yet = false;
  if (believed("fk_Event", e.session_id, reader, info, false, &not_yet)) return valid_event(e);
  if (not_yet) held_.events.push_back({e, info, reader, now});
  return std::nullopt;
}

std::optional<store::ScoreRecord> SampleGate::score(const fk_Score& s, const dds_sample_info_t& info, dds_entity_t reader) {
  if (!believed("fk_Score", s.session_id, reader, info, false)) return std::nullopt;
  if (!finite({s.mark}) || s.mark < 0 || s.mark > 100) {
    malformed("fk_Score", "a mark of " + std::to_string(s.mark));
    return std::nullopt;
  }
  store::ScoreRecord r{s.session_id, s.mark, s.passed, {}};
  for (uint32_t i = 0; i < s.counts._length; ++i) {
    if (!dds::valid_utf8(s.counts._buffer[i].kind)) {
      malformed("fk_Score", "a fault kind that is not UTF-8");
      return std::nullopt;
    }
    r.counts[s.counts._buffer[i].kind] = int(s.counts._buffer[i].count);
  }
  return r;
}

std::optional<StatusIn> SampleGate::valid_status(const fk_SessionStatus& s) {
  // Its language is the cab's alone (the server reads none), checked as text all the same.
  if (auto bad = bad_text({{"its state", s.state}, {"its reason", s.reason}, {"its language", s.language}})) {
    malformed("fk_SessionStatus", *bad);
    return std::nullopt;
  }
  // The states a worker may set; the others are the server's own.
  const std::optional<SessionPhase> state = parse<SessionPhase>(s.state);
  if (!state) return std::nullopt;
  switch (*state) {
    case SessionPhase::kWaiting:
    case SessionPhase::kRunning:
    case SessionPhase::kEnded:
    case SessionPhase::kFailed: return StatusIn{s.session_id, *state, s.reason};
    case SessionPhase::kStarting:
    case SessionPhase::kAborted: break;
  }
  return std::nullopt;
}

std::optional<StatusIn> SampleGate::status(const fk_SessionStatus& s, const dds_sample_info_t& info, dds_entity_t reader,
                                           Clock::time_point now) {
  bool not_yet = false;
  if (believed("fk_SessionStatus", s.session_id, reader, info, false, &not_yet)) return valid_status(s);
  if (not_yet) held_.statuses.push_back({s, info, reader, now});
  return std::nullopt;
}

bool SampleGate::truck_state(const fk_TruckState& t, const dds_sample_info_t& info, dds_entity_t reader) {
  if (!believed("fk_TruckState", t.session_id, reader, info, true)) return false;
  if (!finite({t.sim_time_s, t.x_m, t.y_m, t.yaw_rad, t.speed_m_s, t.lift_m})) {
    malformed("fk_TruckState", "a truck state that is not finite");
    return false;
  }
  // The pedestrians' list is shown on the live page as it comes: each one's every field checked.
  if (t.pedestrian_count > std::size(t.pedestrians)) {
    malformed("fk_TruckState", "a truck state with more pedestrians than it holds");
    return false;
  }
  for (uint8_t i = 0; i < t.pedestrian_count; ++i) {
    const fk_PedestrianSeen& p = t.pedestrians[i];
    if (!finite({p.x_m, p.y_m, p.heading_rad}) || p.activity > static_cast<uint8_t>(PedestrianActivity::kStruck) ||
        bad_text({{"a pedestrian's id", p.id}})) {
      malformed("fk_TruckState", "a truck state with a pedestrian not finite, of no known activity or whose id is not UTF-8");
      return false;
    }
  }
  // And the other trucks' list, as the pedestrians'.
  if (t.truck_count > std::size(t.trucks)) {
    malformed("fk_TruckState", "a truck state with more other trucks than it holds");
    return false;
  }
  for (uint8_t i = 0; i < t.truck_count; ++i) {
    const fk_OtherTruckSeen& o = t.trucks[i];
    if (!finite({o.x_m, o.y_m, o.heading_rad}) || o.activity > static_cast<uint8_t>(TruckActivity::kStruck) ||
        bad_text({{"another truck's id", o.id}})) {
      malformed("fk_TruckState", "a truck state with another truck not finite, of no known activity or whose id is not UTF-8");
      return false;
    }
  }
  // A pallet lies on the floor only after it left its beams.
  if ((t.falls_landed & ~t.falls_started) != 0) {
    malformed("fk_TruckState", "a truck state with a pallet on the floor that never left its beams");
    return false;
  }
  return true;
}

std::optional<CabIn> SampleGate::announce(const fk_CabAnnounce& a, const dds_sample_info_t& info, dds_entity_t reader) {
  if (auto bad = bad_text({{"its cab id", a.cab_id}, {"its mode", a.mode}, {"its school", a.school}})) {
    malformed("fk_CabAnnounce", *bad);
    return std::nullopt;
  }
  if (!a.cab_id[0]) {
    malformed("fk_CabAnnounce", "a cab announcement with no cab id");
    return std::nullopt;
  }
  // A cab speaks in its own partition only (under DDS Security nobody else may).
  const auto s = sender(reader, info.publication_handle);
  if (!s) return std::nullopt;
  if (!s->in(dds::cab_partition(a.cab_id))) {
    world_.refuse(&RefusedSamples::wrong_sender, "an announcement for cab " + std::string(a.cab_id) + " from another cab's partition");
    return std::nullopt;
  }
  return CabIn{a.cab_id, a.mode, dds::valid_utf8(a.site) ? a.site : ""};
}

SampleGate::HeldBack SampleGate::take_held() {
  HeldBack taken;
  std::swap(taken, held_);
  return taken;
}

template <typename T, typename Out, typename Valid>
std::vector<Out> SampleGate::again(std::vector<Held<T>>& held, std::vector<Held<T>>& waiting, Clock::time_point now,
                                   const char* topic, Valid&& valid) {
  std::vector<Out> out;
  for (Held<T>& h : held) {
    if (now - h.at > kWait) {
      world_.refuse(&RefusedSamples::wrong_sender, std::string("a ") + topic + " for session " + h.sample.session_id +
                                                       " whose worker host never named its worker");
      continue;
    }
    bool not_yet = false;
    if (believed(topic, h.sample.session_id, h.reader, h.info, false, &not_yet)) {
      if (auto v = valid(h.sample)) out.push_back(std::move(*v));
    } else if (not_yet) {
      waiting.push_back(h);  // still waiting, since it first came
    }
  }
  return out;
}

std::vector<store::EventRecord> SampleGate::events_again(std::vector<Held<fk_Event>>& held, Clock::time_point now) {
  return again<fk_Event, store::EventRecord>(held, held_.events, now, "fk_Event", [&](const fk_Event& e) { return valid_event(e); });
}

std::vector<StatusIn> SampleGate::statuses_again(std::vector<Held<fk_SessionStatus>>& held, Clock::time_point now) {
  return again<fk_SessionStatus, StatusIn>(held, held_.statuses, now, "fk_SessionStatus",
                                           [&](const fk_SessionStatus& s) { return valid_status(s); });
}

}  // namespace forklift::server
