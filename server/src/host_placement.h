// Where a session's worker runs: on a worker host with room (the cab's own site first, then the
// emptiest), each asked in turn within the start's budget, a silent one passed over for a while,
// and this machine when no host takes it; the hosts' statuses and reports (their answers to a
// start, the participant of a worker, its end with its files, and another server's session
// adopted within the hosts' lease), and the cabs about.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fleet_state.h"
#include "sample_gate.h"
#include "forklift/protocol/protocol.h"
#include "forklift/store/store.h"

namespace forklift::server {

class WorkerSupervisor;

class HostPlacement {
 public:
  HostPlacement(FleetState& fleet, dds::Participant& participant, WorkerSupervisor& local)
      : fleet_(fleet), participant_(participant), local_(local) {}

  // See Fleet::start_worker.
  void start_worker(const store::Session& s, const std::string& scenario_file, std::optional<double> duration_s,
                    const std::optional<std::string>& aids, const std::string& language);
  void request(const std::string& host, const std::string& session, WorkerAction action);  // abort, kill (under mu)

  // What the gate let in (ingest thread).
  void host_status(const HostStatusIn& h);
  void cab_seen(const CabIn& c);
  // A worker host's report on a session's worker: a start answered, a participant learnt, a
  // worker exited with its files; another server's session adopted, a stray stopped.
  void on_report(store::Store& db, const fk_WorkerReport& r);

  // A session taken over from a server that has stopped, adopted from what its host last
  // reported (the report was heard, and left, while the other server ran it); false if nothing was heard.
  bool take_over(store::Store& db, const std::string& session);
  // The abort of another server's session, asked of its worker's host when heard of; false if not.
  bool abort_heard(const std::string& session);

  std::vector<HostInfo> hosts();
  std::vector<CabInfo> cabs_online(double within_s);

 private:
  std::vector<std::string> placement(const std::string& cab);  // hosts with room, best first (under mu)
  // Tries the candidates in turn within the start's budget; false (with each host's refusal in
  // `refusals`) when none took it, so that the caller may run the worker here instead.
  bool start_hosted_worker(const store::Session& s, const std::string& scenario_file, std::optional<double> duration_s,
                           const std::optional<std::string>& aids, const std::string& language, std::vector<std::string> candidates,
                           std::string& refusals);
  dds::Writer<fk_WorkerRequest>& request_writer(const std::string& host);  // under mu
  void write_worker_files(const fk_WorkerReport& r);
  // Why a hosted worker's shipped log is not to be believed (its signature is not its cab's
  // worker's), or nullopt; in clear DDS with trusted hosts nothing is signed and nothing checked.
  std::optional<std::string> unsigned_log_problem(const fk_WorkerReport& r, const std::string& cab);
  struct Report {  // one report being handled
    const fk_WorkerReport& r;
    WorkerReportState state;  // the gate let in no other word
    std::string session;
    Clock::time_point now;
    std::optional<std::optional<std::string>> log_problem;  // unsigned_log_problem(), checked once
  };
  // A session this server did not start: adopted if it is open for that cab, else its worker stopped.
  void adopt_hosted(store::Store& db, Report& rep);
  // What becomes of a worker once it is ours: its participant believed, its end settled (under mu).
  void follow(WorkerInfo& w, Report& rep);
  // An exited worker's files refused (counted as unsigned_log; under mu): true.
  bool refused_log(Report& rep, const std::string& cab);
  // Its files are not believed, and its states tell whether it really ended: if none come, the
  // supervisor fails the session with this reason (a worker that crashed before signing).
  static void distrust(WorkerInfo& w, Clock::time_point now);

  // A report on another server's session, kept (a deep copy) for a take-over.
  struct Heard {
    fk_WorkerReport r{};
    std::vector<uint8_t> log, sig, err;  // r's sequences point here
    Clock::time_point at;
    bool exited() const { return std::string(r.state) == name(WorkerReportState::kExited); }
  };
  void keep_heard(const fk_WorkerReport& r, Clock::time_point now);  // under mu

  FleetState& fleet_;
  dds::Participant& participant_;
  std::map<std::string, std::unique_ptr<Heard>> heard_;  // by session, under mu
  WorkerSupervisor& local_;
  std::map<std::string, std::unique_ptr<dds::Writer<fk_WorkerRequest>>> request_writers_;  // by host, under mu
};

}  // namespace forklift::server
