// The server's view of the cabs and their sim workers, the one object the routes see. Its parts:
// the worker supervisor (this machine's workers: spawned, reaped, killed when they hang, adopted
// at start), host placement (worker hosts: chosen, asked, passed over, their reports), the sample
// gate (each sample of the seven topics it reads authenticated and validated, or refused and
// counted) and the session recorder (what a session leaves in the store, its exam chained, live follow). The fleet owns
// the DDS participant and its two threads: the supervisor's and the ingest's (DDS -> gate -> parts).
#pragma once

#include <atomic>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "exam_evidence.h"
#include "fleet_state.h"
#include "host_placement.h"
#include "outcome.h"
#include "sample_gate.h"
#include "session_recorder.h"
#include "worker_supervisor.h"
#include "forklift/protocol/protocol.h"
#include "forklift/session/session_log.h"
#include "forklift/store/store.h"

namespace forklift::server {

class Fleet : private GateWorld {
 public:
  explicit Fleet(FleetConfig config);
  ~Fleet() override;  // stops the threads; running workers are told to stop (SIGTERM)

  // Spawns the worker for a session created in the store, on a worker host with room or else on
  // this machine; `aids` is its --aids list (nullopt: the worker's default for the session's mode);
  // `language` the pupil's (one the catalogue has; "" none), which the worker tells the cab.
  // Throws std::runtime_error when no host takes it and this machine may not (it already runs
  // max_workers, or runs no workers itself), or the cab is busy.
  void start_worker(const store::Session& s, const std::string& scenario_file, std::optional<double> duration_s,
                    const std::optional<std::string>& aids = std::nullopt, const std::string& language = "") {
    placement_.start_worker(s, scenario_file, duration_s, aids, language);
  }
  // The instructor's abort: SIGUSR1 to the session's worker, which ends the session with reason
  // "aborted" (SIGTERM, the server stopping, ends it as "signal"); false if it has no worker here.
  // Another server's session whose worker runs on a host heard from: that host is asked.
  bool abort(const std::string& session) { return supervisor_.abort(session) || placement_.abort_heard(session); }
  // The instructor's pause, resume, message or rewind, written to the session's worker (here or on a host)
  // in its cab's instructor partition, `by` the instructor's username; the worker acts on it at
  // its next tick. Why it cannot go (no running worker here; paused already, or not paused, as the
  // worker's newest state says), or nullopt once it is written.
  std::optional<std::string> instruct(const std::string& session, const Instruction& what, const std::string& by);

  std::vector<WorkerInfo> workers();
  std::vector<HostInfo> hosts() { return placement_.hosts(); }  // the worker hosts heard from, alive or not
  // Whether the session's worker runs here or has ended without its logs stored yet (they are
  // stored a moment after it exits, when its last samples have had time to arrive).
  bool settling(const std::string& session);
  std::vector<CabInfo> cabs_online(double within_s = 3.0) { return placement_.cabs_online(within_s); }
  bool cab_busy(const std::string& cab);
  const FleetConfig& config() const { return config_; }
  bool secure() const { return state_.secure(); }
  // Whether worker hosts' samples are believed: under DDS Security, or when trusted by the operator.
  bool hosts_believed() const override { return state_.hosts_believed(); }
  const MarkingRules& marking_rules() const { return recorder_.marking_rules(); }
  RefusedSamples refused();
  IngestedSamples ingested();

  // The exam chain's anchor, and the keys and CA it is checked with (read from the security
  // folder at each call, so that a new CRL counts at once).
  const ChainAnchor& chain_anchor() const { return recorder_.chain_anchor(); }
  ChainKeys chain_keys() const { return recorder_.chain_keys(); }
  // Whether exams can be chained (see ChainStatus).
  using ChainStatus = forklift::server::ChainStatus;
  ChainStatus chain_status() { return recorder_.chain_status(); }

  // Live follow: the session's newest state and frame. Asking subscribes to the cab's frames
  // (until nobody has asked for a while); the first frame arrives a moment later.
  // nullopt if the session has no running worker here.
  std::optional<LiveView> follow(const std::string& session) { return recorder_.follow(session); }

 private:
  void supervise();  // thread: reap exits, detect hangs, settle, chain
  void ingest();     // thread: DDS -> sample gate -> parts
  // Sessions of a server that has stopped, claimed in the store: run from here from now on.
  void take_over(store::Store& db, const std::vector<std::string>& sessions);

  // The gate's world: whom a session's samples must come from, who a writer is, the count.
  Speaker speaker(const std::string& session) override;
  std::optional<dds::Sender> discover(dds_entity_t reader, dds_instance_handle_t publication) override;
  void refuse(RefusalCounter counter, const std::string& what) override { state_.refuse(counter, what); }

  FleetConfig config_;
  FleetState state_{config_};
  std::unique_ptr<dds::Participant> participant_ = std::make_unique<dds::Participant>(
      dds::DomainSettings::resolve(config_.dds_domain, config_.dds_config, config_.security_dir, config_.identity));
  SessionRecorder recorder_{state_, *participant_};
  WorkerSupervisor supervisor_{state_, [this](const std::string& host, const std::string& session, WorkerAction action) {
                                 placement_.request(host, session, action);
                               }};
  HostPlacement placement_{state_, *participant_, supervisor_};
  SampleGate gate_{*this};  // ingest thread
  // The instructor's writers, one per cab (made on the first action; the topic keeps a few
  // samples for a worker that matches late), and the last sequence number given, under state_.mu.
  std::map<std::string, std::unique_ptr<dds::Writer<fk_InstructorAction>>> instructor_writers_;
  uint64_t instructor_seq_ = 0;
  std::atomic<bool> stop_{false};
  std::thread supervisor_thread_, ingest_thread_;
};

}  // namespace forklift::server
