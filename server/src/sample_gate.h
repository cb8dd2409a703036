// The one door for what the fleet reads over DDS: a sample and its sample info in; out, either the
// domain value it carries, believed (its writer is the one that may speak for it) and valid, or a
// refusal counted by why. The gate reads no DDS reader: who a writer is, and whom a session's
// samples must come from, it asks of its world, so that a test forges both (sample_gate_test).
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "forklift/protocol/protocol.h"
#include "forklift/session/host_vocabulary.h"
#include "forklift/store/store.h"

namespace forklift::server {

// Samples the ingest refused, by why (GET /api/fleet shows them; the server's log names each).
struct RefusedSamples {
  uint64_t wrong_sender = 0;    // not from the worker that runs the session (or its cab's partition)
  uint64_t malformed = 0;       // not UTF-8, not finite, out of range, or unreadable
  uint64_t score_disagrees = 0; // a score that is not the one in the worker's session log
  uint64_t no_identity = 0;     // a worker host's sample in clear DDS, which no identity vouches for
  uint64_t unsigned_log = 0;    // a host's report whose session log its worker did not sign
  uint64_t recovered_events = 0;  // events taken from a worker's log because their samples never came
  uint64_t recovered_scores = 0;
};
using RefusalCounter = uint64_t RefusedSamples::*;

// The samples the gate let through, by topic, since the server started: what a load generator
// compares with what it published (nothing lost) and a school reads beside the refusals.
struct IngestedSamples {
  uint64_t states = 0, events = 0, statuses = 0, scores = 0, reports = 0, announces = 0;
};

// Whom a session's samples must come from: its worker's participant, in its cab's partitions.
struct Speaker {
  enum class Known {
    kNotOurs,  // another server's session, or long over: its samples are none of ours
    kNotYet,   // a hosted worker whose participant its host has not named yet
    kYes,
  };
  Known known = Known::kNotOurs;
  std::string cab, participant;  // when kYes (an empty participant: none vouched for)
};

// What the gate asks of the fleet.
class GateWorld {
 public:
  virtual ~GateWorld() = default;
  // Whether worker hosts' samples are believed (under DDS Security, or trusted by the operator).
  virtual bool hosts_believed() const = 0;
  virtual Speaker speaker(const std::string& session) = 0;
  // Who a writer is, as discovery says (nullopt: not matched any more, or not known).
  virtual std::optional<dds::Sender> discover(dds_entity_t reader, dds_instance_handle_t publication) = 0;
  // Counts a refusal and names it in the server's log.
  virtual void refuse(RefusalCounter counter, const std::string& what) = 0;
};

// A worker host's status: its room and load, or (gone) that its writer has gone.
struct HostStatusIn {
  std::string id, site;
  HostState state = HostState::kReady;
  int capacity = 0, running = 0, cores = 0;
  double load_1min = 0, memory_free_mib = 0;
  bool gone = false;
};
struct StatusIn {  // a worker's word on its session's state
  std::string session;
  SessionPhase state = SessionPhase::kWaiting;
  std::string reason;
};
struct CabIn {  // a cab's announcement
  std::string id, mode, site;
};

class SampleGate {
 public:
  using Clock = std::chrono::steady_clock;
  // A hosted worker's samples wait this long for its host to name its participant.
  static constexpr auto kWait = std::chrono::seconds(10);

  explicit SampleGate(GateWorld& world) : world_(world) {}

  // Who each writer is, learnt while it is matched: a sample taken after its writer has gone (a
  // worker exits 200 ms after its score) is still told apart.
  bool knows(dds_instance_handle_t publication) const { return senders_.count(publication) > 0; }
  void learn(dds_instance_handle_t publication, dds::Sender sender) { senders_.emplace(publication, std::move(sender)); }

  // Each topic's sample, from the reader `reader` (only handed back to the world's discover()).
  // nullopt: refused (counted), or none of ours, or (events and statuses) held back until its
  // sender can be told.
  std::optional<HostStatusIn> host_status(const fk_HostStatus& h, const dds_sample_info_t& info, dds_entity_t reader);
  bool report(const fk_WorkerReport& r, const dds_sample_info_t& info, dds_entity_t reader);  // false: refused
  std::optional<store::EventRecord> event(const fk_Event& e, const dds_sample_info_t& info, dds_entity_t reader,
                                          Clock::time_point now);
  std::optional<store::ScoreRecord> score(const fk_Score& s, const dds_sample_info_t& info, dds_entity_t reader);
  std::optional<StatusIn> status(const fk_SessionStatus& s, const dds_sample_info_t& info, dds_entity_t reader,
                                 Clock::time_point now);
  bool truck_state(const fk_TruckState& t, const dds_sample_info_t& info, dds_entity_t reader);  // false: not believed
  std::optional<CabIn> announce(const fk_CabAnnounce& a, const dds_sample_info_t& info, dds_entity_t reader);

  // The samples held back before this round, taken so that this round's own come first (as
  // they always have); offered again with again() after them.
  template <typename T>
  struct Held {
    T sample;
    dds_sample_info_t info;
    dds_entity_t reader;
    Clock::time_point at;  // when it first came
  };
  struct HeldBack {
    std::vector<Held<fk_Event>> events;
    std::vector<Held<fk_SessionStatus>> statuses;
  };
  HeldBack take_held();
  // Each held sample believed now, in order; those still unknown wait on (since they first
  // came), and those that waited kWait are refused.
  std::vector<store::EventRecord> events_again(std::vector<Held<fk_Event>>& held, Clock::time_point now);
  std::vector<StatusIn> statuses_again(std::vector<Held<fk_SessionStatus>>& held, Clock::time_point now);
  size_t held() const { return held_.events.size() + held_.statuses.size(); }

 private:
  enum class Verdict { kOurs, kNotOurs, kWrongSender, kNotYet };
  std::optional<dds::Sender> sender(dds_entity_t reader, dds_instance_handle_t publication);
  Verdict check_sender(const std::string& session, dds_entity_t reader, const dds_sample_info_t& info, bool state_topic);
  // Whether a sample for `session` is believed; refusals counted with the reason. kNotYet in `not_yet`.
  bool believed(const char* topic, const char* session, dds_entity_t reader, const dds_sample_info_t& info,
                bool state_topic, bool* not_yet = nullptr);
  // A host's status and reports count only from its own partition (under DDS Security, only the
  // identity host.<id> may write there).
  bool from_host(dds_entity_t reader, const dds_sample_info_t& info, const char* host);
  void malformed(const char* topic, const std::string& why);
  std::optional<store::EventRecord> valid_event(const fk_Event& e);
  std::optional<StatusIn> valid_status(const fk_SessionStatus& s);
  template <typename T, typename Out, typename Valid>
  std::vector<Out> again(std::vector<Held<T>>& held, std::vector<Held<T>>& waiting, Clock::time_point now,
                         const char* topic, Valid&& valid);

  GateWorld& world_;
  std::map<dds_instance_handle_t, dds::Sender> senders_;
  HeldBack held_;
};

}  // namespace forklift::server
