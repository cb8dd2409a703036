// The server's view of the cabs and their sim workers: it spawns one forklift-worker per session,
// supervises it (exit, crash, hang), and writes what workers report over DDS into the store.
#pragma once

#include <sys/types.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <map>
#include <set>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "exam_evidence.h"
#include "outcome.h"
#include "forklift/host/worker_launch.h"
#include "forklift/protocol/protocol.h"
#include "forklift/store/store.h"

namespace forklift::server {

struct FleetConfig {
  std::string db_path;
  std::string worker_binary;
  std::string data_dir;
  std::string log_dir;        // worker logs and control logs
  int dds_domain = 0;
  std::string dds_config;     // empty: default resolution
  std::string security_dir;   // the school's DDS Security folder; empty: no security (training only)
  std::string identity = "server.main";  // the server's identity in it
  int max_workers = 8;
  double hang_timeout_s = 5;  // a running worker with no TruckState for this long is killed
  double start_timeout_s = 120;
  std::optional<host::WorkerFrames> frames;  // every worker's frames (nullopt: the worker's defaults)
  // Worker hosts (forklift-host) announce themselves over DDS; while one has room a session's
  // worker runs there. With none about, the server runs workers itself, unless local_workers is off.
  bool local_workers = true;
  bool realtime_workers = false;  // workers it runs itself tick at real-time priority (--realtime)
  // Worker hosts speak for themselves only under DDS Security (their identity host.<id>); in clear
  // DDS any machine on the network could claim to be one, so they are believed only when the
  // operator says the network is a closed lab (--trust-clear-hosts).
  bool trust_clear_hosts = false;
  double host_answer_timeout_s = 2;  // a host that has not named its running worker in this long is passed over
  double start_budget_s = 5;         // the whole placement of one start, hosts and then this machine
  double host_pass_over_s = 30;      // a host passed over for silence is not asked again for this long
  double path_interval_s = 0.5;  // sim time between two stored points of a session's truck path
  std::string chain_anchor;      // the exam chain's anchor file; empty: <log_dir>/exam-chain.anchor
};

struct WorkerInfo {
  std::string session, cab;
  std::string host;    // the worker host it runs on; empty: this machine
  pid_t pid = 0;       // the worker's process (0: not found after a server restart)
  bool child = false;  // ours to reap; otherwise adopted after a server restart, watched through /proc
  unsigned long long start_ticks = 0;  // an adopted process's start time (a reused pid is not it)
  std::string participant;  // the worker's DDS participant (GUID hex): its samples only are believed
  std::chrono::steady_clock::time_point started, last_state;
  bool seen_state = false;
  fk_TruckState last{};  // the newest TruckState, when seen_state
  std::optional<double> last_path_point_s;  // sim time of the last path point stored
  std::string hang_reason;  // a hosted worker asked to be killed, and why
  std::chrono::steady_clock::time_point hang_asked;  // when it was asked
};

// A worker host as its status says (fk_HostStatus).
struct HostInfo {
  std::string id, site, state;  // state: "ready", "stopping"
  int capacity = 0, running = 0, cores = 0;
  double load_1min = 0, memory_free_mib = 0;
  std::chrono::steady_clock::time_point last_seen;
  bool gone = false;  // its status writer lost its liveliness (the agent or its machine is down)
  int placed = 0;     // starts this server asked of it that it has not answered yet
  std::chrono::steady_clock::time_point passed_over_until{};  // it took a start and went silent
  bool alive(std::chrono::steady_clock::time_point now) const;
  bool has_room() const { return state == "ready" && running + placed < capacity; }
};

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

// What an examiner following a session sees: the newest truck state and rendered frame.
struct LiveView {
  fk_TruckState state{};
  bool have_state = false;
  std::vector<uint8_t> jpeg;  // the newest frame, JPEG-encoded; empty until one arrives
  uint32_t frame_seq = 0;
  double frame_sim_time_s = 0;
};

struct CabInfo {
  std::string id, mode, site;
  std::chrono::steady_clock::time_point last_seen;
};

// The store's audited state change, also a line in the session log when it changes something.
bool set_state(store::Store& db, const std::string& session, const std::string& state, const std::string& reason,
               const store::Actor& actor);

class Fleet {
 public:
  explicit Fleet(FleetConfig config);
  ~Fleet();  // stops the threads; running workers are told to stop (SIGTERM)

  // Spawns the worker for a session created in the store; `aids` is its --aids list (nullopt:
  // the worker's default for the session's mode). Throws std::runtime_error when the machine
  // already runs max_workers, or the cab is busy.
  void start_worker(const store::Session& s, const std::string& scenario_file, std::optional<double> duration_s,
                    const std::optional<std::string>& aids = std::nullopt);
  // The instructor's abort: SIGUSR1 to the session's worker, which ends the session with reason
  // "aborted" (SIGTERM, the server stopping, ends it as "signal"); false if it has no worker here.
  bool abort(const std::string& session);

  std::vector<WorkerInfo> workers();
  std::vector<HostInfo> hosts();  // the worker hosts heard from, alive or not
  // Whether the session's worker runs here or has ended without its logs stored yet (they are
  // stored a moment after it exits, when its last samples have had time to arrive).
  bool settling(const std::string& session);
  std::vector<CabInfo> cabs_online(double within_s = 3.0);
  bool cab_busy(const std::string& cab);
  const FleetConfig& config() const { return config_; }
  bool secure() const { return !config_.security_dir.empty(); }
  // Whether worker hosts' samples are believed: under DDS Security, or when trusted by the operator.
  bool hosts_believed() const { return secure() || config_.trust_clear_hosts; }
  const MarkingRules& marking_rules() const { return rules_; }
  RefusedSamples refused();

  // The exam chain's anchor, and the keys and CA it is checked with (read from the security
  // folder at each call, so that a new CRL counts at once).
  const ChainAnchor& chain_anchor() const { return *anchor_; }
  ChainKeys chain_keys() const { return forklift::server::chain_keys(config_.security_dir, config_.identity); }
  // Whether exams can be chained: `problem` is why not (the database's chain is not the anchored
  // one); `refused` counts the exams refused since start (their record disagrees with their log).
  struct ChainStatus {
    std::string problem;
    int refused = 0;
  };
  ChainStatus chain_status() {
    std::lock_guard<std::mutex> lock(mu_);
    return chain_status_;
  }

  // Live follow: the session's newest state and frame. Asking subscribes to the cab's frames
  // (until nobody has asked for kFollowIdle); the first frame arrives a moment later.
  // nullopt if the session has no running worker here.
  std::optional<LiveView> follow(const std::string& session);

 private:
  void supervise();  // thread: reap exits, detect hangs
  void ingest();     // thread: DDS -> store
  void fail(store::Store& db, const std::string& session, const std::string& cab, const std::string& reason);
  void publish_status(const std::string& session, const std::string& cab, const char* state, const std::string& reason);
  void take_followed_frames();  // ingest thread
  // Appends the ended exams whose score has arrived to the hash chain; keeps the others until
  // their deadline (supervisor thread).
  void chain_ended_exams(store::Store& db, std::vector<std::pair<std::string, std::chrono::steady_clock::time_point>>& pending);
  // A worker is gone: its logs are stored, what its samples did not bring is taken from its
  // session log, and the session ends as the log says (supervisor thread).
  void settle(store::Store& db, const WorkerInfo& w, const std::string& reason,
              std::vector<std::pair<std::string, std::chrono::steady_clock::time_point>>& to_chain);
  // Start-up: the sessions left open, and the workers of this server still running.
  void adopt(store::Store& db);
  void signal_worker(const WorkerInfo& w, int sig);
  // Starting a session's worker on this machine, or on a worker host (which answers with a report).
  void start_local_worker(const store::Session& s, const host::WorkerLaunch& launch);
  // Tries the candidates in turn within the start's budget; false (with each host's refusal in
  // `refusals`) when none took it, so that the caller may run the worker here instead.
  bool start_hosted_worker(const store::Session& s, const std::string& scenario_file, std::optional<double> duration_s,
                           const std::optional<std::string>& aids, std::vector<std::string> candidates,
                           std::string& refusals);
  std::vector<std::string> placement(const std::string& cab);  // hosts with room, best first (under mu_)
  void request(const std::string& host, const std::string& session, const char* action);  // abort, kill (under mu_)
  // A worker host's report on a session's worker (ingest thread): a start answered, a participant
  // learnt, a worker exited with its files; another server's session adopted, a stray stopped.
  void on_report(store::Store& db, const fk_WorkerReport& r);
  void write_worker_files(const fk_WorkerReport& r);
  // Why a hosted worker's shipped log is not to be believed (its signature is not its cab's
  // worker's), or nullopt; in clear DDS with trusted hosts nothing is signed and nothing checked.
  std::optional<std::string> unsigned_log_problem(const fk_WorkerReport& r, const std::string& cab);
  std::string log_path(const std::string& session) const { return config_.log_dir + "/" + session + ".ctl"; }

  // Whose samples a session's are: the worker's participant and cab, kept a little while after
  // it exits for the samples still on their way.
  struct Binding {
    std::string cab, participant;
    std::optional<std::chrono::steady_clock::time_point> until;  // set when the worker is gone
  };
  enum class Verdict { kOurs, kNotOurs, kWrongSender, kNotYet };  // kNotYet: a hosted worker whose participant is not known yet
  // Whether a sample for `session` came from its worker, in `partition_of(cab)` (ingest thread).
  Verdict check_sender(const std::string& session, dds_entity_t reader, const dds_sample_info_t& info, bool state_topic);
  void refuse(uint64_t RefusedSamples::*counter, const std::string& what);

  struct Followed {  // a cab whose frames an examiner watches
    std::unique_ptr<dds::Reader<fk_Frame>> frames;
    std::chrono::steady_clock::time_point last_asked;
    LiveView view;
  };

  FleetConfig config_;
  std::mutex mu_;
  std::map<std::string, WorkerInfo> workers_;  // by session
  std::map<std::string, Binding> bindings_;     // by session, for the ingest
  struct Finishing {  // a worker gone; settled once its last samples had time to arrive
    WorkerInfo worker;
    std::string reason;
    std::chrono::steady_clock::time_point at;
  };
  std::vector<Finishing> finishing_;  // under mu_; settled by the supervisor thread
  std::set<std::string> unsettled_;    // sessions with a worker here whose logs are not stored yet
  RefusedSamples refused_;
  static constexpr size_t kRefusalsNamed = 4096;
  std::set<std::string> refusals_named_;  // under mu_: the refusals named in the log once each
  std::map<dds_instance_handle_t, dds::Sender> senders_;  // ingest thread: who each publication is
  std::map<std::string, CabInfo> cabs_;
  std::map<std::string, HostInfo> hosts_;  // by id
  std::map<std::string, std::unique_ptr<dds::Writer<fk_WorkerRequest>>> request_writers_;  // by host
  struct StartAnswer { std::string host, state, reason; };
  std::map<std::string, StartAnswer> start_answers_;  // by session: a host's answer to a start
  std::condition_variable answered_;
  std::map<std::string, Followed> followed_;            // by cab
  std::map<std::string, std::unique_ptr<dds::Writer<fk_SessionStatus>>> cab_status_writers_;  // by cab
  // Read before the threads start (config_ is initialised first).
  // The marking scheme, for the reasons a practical exam's record keeps (data/evaluation/rules.json).
  const MarkingRules rules_ = load_marking_rules(config_.data_dir + "/evaluation/rules.json");
  std::unique_ptr<ChainAnchor> anchor_ = std::make_unique<ChainAnchor>(
      config_.chain_anchor.empty() ? config_.log_dir + "/exam-chain.anchor" : config_.chain_anchor);
  ChainStatus chain_status_;  // under mu_
  std::unique_ptr<dds::Participant> participant_;
  std::unique_ptr<dds::Writer<fk_SessionStatus>> status_writer_;
  std::atomic<bool> stop_{false};
  std::thread supervisor_, ingest_;
};

}  // namespace forklift::server
