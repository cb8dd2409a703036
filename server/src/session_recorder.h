// What a session leaves in the store, and what an examiner following it sees: its states, events
// and score as its worker reports them (the score only as the worker's session log holds it), its
// truck's path, its end once its worker is gone (settled from the log, which brings what the
// samples did not), and its exam appended to the hash chain.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "exam_evidence.h"
#include "fleet_state.h"
#include "outcome.h"
#include "sample_gate.h"
#include "forklift/protocol/protocol.h"
#include "forklift/store/store.h"

namespace forklift::server {

// What an examiner following a session sees: the newest truck state and rendered frame.
struct LiveView {
  fk_TruckState state{};
  bool have_state = false;
  std::vector<uint8_t> jpeg;  // the newest frame, JPEG-encoded; empty until one arrives
  uint32_t frame_seq = 0;
  double frame_sim_time_s = 0;
};

// Whether exams can be chained: `problem` is why not (the database's chain is not the anchored
// one); `refused` counts the exams refused since start (their record disagrees with their log).
struct ChainStatus {
  std::string problem;
  int refused = 0;
};

class SessionRecorder {
 public:
  SessionRecorder(FleetState& fleet, dds::Participant& participant);

  // What the gate let in (ingest thread).
  void event(store::Store& db, const store::EventRecord& e);
  // The mark of record is the one the worker wrote in its session log before sending it: a score
  // that the log does not hold is refused (counted as score_disagrees).
  void score(store::Store& db, store::ScoreRecord r);
  void status(store::Store& db, const StatusIn& s);
  // A running worker's newest state; one point every path_interval_s of sim time joins `path`
  // (by session), stored once per round.
  void truck_state(const fk_TruckState& t, std::map<std::string, std::vector<store::PathPoint>>& path);
  void take_followed_frames();

  // A worker is gone: its logs are stored, what its samples did not bring is taken from its
  // session log, and the session ends as the log says (supervisor thread). An exam with a signed
  // log joins `to_chain`.
  void settle(store::Store& db, const WorkerInfo& w, const std::string& reason, ToChain& to_chain);
  // The database's chain checked against the anchor; the exams left unchained (supervisor thread).
  ToChain check_chain(store::Store& db);
  // Appends the ended exams whose score has arrived to the hash chain; keeps the others until
  // their deadline (supervisor thread).
  void chain_ended_exams(store::Store& db, ToChain& pending);

  // Never a pass: a session whose worker died is failed with the reason, and the cab is told.
  void fail(store::Store& db, const std::string& session, const std::string& cab, const std::string& reason);
  void publish_status(const std::string& session, const std::string& cab, SessionPhase state, const std::string& reason);
  // Live follow (see Fleet::follow).
  std::optional<LiveView> follow(const std::string& session);

  const MarkingRules& marking_rules() const { return rules_; }
  const ChainAnchor& chain_anchor() const { return *anchor_; }
  ChainKeys chain_keys() const { return forklift::server::chain_keys(fleet_.config.security_dir, fleet_.config.identity); }
  ChainStatus chain_status() {
    std::lock_guard<std::mutex> lock(fleet_.mu);
    return chain_status_;
  }

 private:
  struct Followed {  // a cab whose frames an examiner watches
    std::unique_ptr<dds::Reader<fk_Frame>> frames;
    std::chrono::steady_clock::time_point last_asked;
    LiveView view;
  };

  FleetState& fleet_;
  dds::Participant& participant_;
  // The marking scheme, for the reasons a practical exam's record keeps (data/evaluation/rules.json).
  const MarkingRules rules_;
  std::unique_ptr<ChainAnchor> anchor_;
  std::unique_ptr<dds::Writer<fk_SessionStatus>> status_writer_;
  // Under fleet_.mu:
  ChainStatus chain_status_;
  std::map<std::string, Followed> followed_;  // by cab
  std::map<std::string, std::unique_ptr<dds::Writer<fk_SessionStatus>>> cab_status_writers_;  // by cab
};

// The store's audited state change, also a line in the session log when it changes something.
bool set_state(store::Store& db, const std::string& session, SessionPhase state, const std::string& reason,
               const store::Actor& actor);

}  // namespace forklift::server
