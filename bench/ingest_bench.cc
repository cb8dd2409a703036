// forklift-bench-ingest: how many cab sessions one forklift-server ingests over DDS.
//
// This program stands for a worker host (forklift-host) and every worker it runs: one DDS
// participant answers the server's start requests as a host does, then publishes each session's
// TruckState at the worker's rate (60 Hz) in the cab's partition and its events, status and score
// in the worker's, as a worker does, without simulating anything. At the end of each step each
// session ends as a worker's does: its session log written, its score and "ended" published, and
// the host's "exited" report carrying the log. So the server does all of its ingest work (the
// sample gate, the store's events, the truck paths, the settling from the log) and none of a
// worker's.
//
// Steps of --sessions concurrent sessions each (50 100 200 300 400 by default): the sessions are
// started through the HTTP API (the server places them on this host), published for a warm-up
// second and a measured --seconds while --clients keep-alive clients ask for pupils' histories,
// then ended. Each step's row: states published and ingested per second, any lost (the server's
// own count of the samples it believed, GET /api/fleet "ingested", against what was published),
// the history requests' rate and p99 meanwhile, the server's CPU and its ingest thread's.
// After each step the store is checked: every event stored once, and from DDS (none recovered
// from a log); the truck path the server kept is the one every state arriving gives; the mark.
// The goal (issue 39): one server ingests 300 or more concurrent sessions with nothing lost and
// the history p99 under 10 ms meanwhile.
//
// --servers 2: two servers on the one store, each session started through one of them in turn;
// each must believe its own sessions' samples and none of the other's (a session is run by the
// server that started it). --servers 1 2 measures both, one after the other on new stores, and
// how many sessions each configuration holds per core of its busiest server: two servers should
// hold 1.6 times one's. (On a 2-core machine this program and the servers share the cores, so it
// cannot publish enough sessions to find two servers' limit itself: CPU per session stands for it.)
//
// Clear DDS (the server runs with --trust-clear-hosts and no worker of its own): the figure is the
// server's ingest, not DDS Security's cost, which forklift-bench-dds measures.
// Eigen (the session's headers) before httplib, whose <resolv.h> defines a macro "_res" that
// Eigen uses as a parameter's name.
#include "forklift/session/session.h"
#include "forklift/session/session_log.h"

#include <CLI/CLI.hpp>
#include <dirent.h>
#include <httplib.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <sstream>
#include <thread>
#include <vector>

#include "figure.h"
#include "forklift/protocol/protocol.h"
#include "forklift/store/store.h"
#include "http_load.h"
#include "proc_stat.h"
#include "support/ports.h"
#include "support/postgres.h"
#include "support/process.h"

using namespace forklift;
using nlohmann::json;
using bench::Clock;
using bench::ms_since;

namespace {

const std::string kPassword = "bench-admin-pass";
const std::string kHost = "bench-host";
constexpr double kPathIntervalS = 0.5;  // the server's path_interval_s: one stored point per half second of sim time
constexpr const char* kEventKind = "speed_open_aisle";

// One session as this program's "worker" runs it.
struct FakeSession {
  std::string id, cab;
  int64_t pupil = 0;
  std::unique_ptr<dds::Writer<fk_TruckState>> states;
  std::unique_ptr<dds::Writer<fk_Event>> events;
  std::unique_ptr<dds::Writer<fk_SessionStatus>> statuses;
  std::unique_ptr<dds::Writer<fk_Score>> scores;
  int server = 0;                    // started through (and so run by) this server
  int64_t ticks = 0;                 // states published
  std::vector<double> event_times;   // sim time of each event published (seq = index + 1)
};

// Each thread of a process: its name and CPU seconds.
std::vector<std::pair<std::string, double>> thread_cpu(pid_t pid) {
  std::vector<std::pair<std::string, double>> out;
  const std::string base = "/proc/" + std::to_string(pid) + "/task";
  if (DIR* d = opendir(base.c_str())) {
    while (dirent* e = readdir(d)) {
      if (e->d_name[0] == '.') continue;
      std::ifstream comm(base + "/" + e->d_name + "/comm");
      std::string name;
      std::getline(comm, name);
      const double cpu = bench::cpu_seconds_in(base + "/" + e->d_name + "/stat");
      if (!std::isnan(cpu)) out.emplace_back(name + "#" + e->d_name, cpu);
    }
    closedir(d);
  }
  return out;
}

double thread_seconds(const std::vector<std::pair<std::string, double>>& threads, const std::string& name) {
  double total = 0;
  for (const auto& [id, cpu] : threads) total += id.substr(0, id.find('#')) == name ? cpu : 0;
  return total;
}

// The three threads that took most CPU between two looks, as "ingest 12 %, recvUC 8 %, ...".
std::string busiest(const std::vector<std::pair<std::string, double>>& before, const std::vector<std::pair<std::string, double>>& after,
                    double seconds) {
  std::map<std::string, double> was(before.begin(), before.end());
  std::map<std::string, double> by_name;  // httplib's pool threads share a name: summed
  for (const auto& [id, cpu] : after) by_name[id.substr(0, id.find('#'))] += cpu - was[id];
  std::vector<std::pair<double, std::string>> top;
  for (const auto& [name, cpu] : by_name) top.emplace_back(cpu, name);
  std::sort(top.rbegin(), top.rend());
  std::string out;
  for (size_t i = 0; i < std::min<size_t>(3, top.size()); ++i)
    out += (i ? ", " : "") + top[i].second + bench::fmt(" %.0f %%", 100 * top[i].first / seconds);
  return out;
}

// The host this program plays: its status twice a second, and an answer to each request.
class FakeHost {
 public:
  FakeHost(dds::Participant& p, int capacity)
      : status_(p, dds::host_partition(kHost)), reports_(p, dds::host_partition(kHost)),
        requests_(p, dds::host_partition(kHost)), guid_(dds::participant_guid(p.handle())), capacity_(capacity) {}

  void run(const std::atomic<bool>& stop) {
    auto last_status = Clock::now() - std::chrono::seconds(1);
    while (!stop) {
      if (ms_since(last_status) >= 500) {
        fk_HostStatus s{};
        dds::set_string(s.host_id, kHost);
        dds::set_string(s.state, "ready");
        s.capacity = static_cast<uint16_t>(capacity_);
        s.running = static_cast<uint16_t>(running_.load());
        s.cores = static_cast<uint16_t>(std::thread::hardware_concurrency());
        s.memory_free_mib = 1024;
        status_.write(s);
        last_status = Clock::now();
      }
      requests_.take_each([&](const fk_WorkerRequest& r) {
        if (std::string(r.host_id) != kHost) return;
        const std::string action = r.action;
        if (action == "start") {
          report(r.session_id, r.cab_id, "running", "");
          ++running_;
        } else {
          // A kill after the worker's end is the server tidying up; before it, the server gave up.
          std::lock_guard<std::mutex> lock(mu_);
          if (!exited_.count(r.session_id)) killed_.insert(r.session_id);
        }
      });
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  }

  // What became of a session: "running" at its start; "exited" with its session log at its end.
  void report(const std::string& session, const std::string& cab, const char* state, const std::string& log) {
    auto r = std::make_unique<fk_WorkerReport>();
    dds::set_string(r->session_id, session);
    dds::set_string(r->host_id, kHost);
    dds::set_string(r->cab_id, cab);
    dds::set_string(r->state, state);
    dds::set_string(r->participant, guid_);
    r->pid = static_cast<uint32_t>(getpid());
    std::vector<uint8_t> bytes(log.begin(), log.end());
    r->control_log._buffer = bytes.data();
    r->control_log._length = r->control_log._maximum = static_cast<uint32_t>(bytes.size());
    r->control_log._release = false;
    if (std::string(state) == "exited") {
      std::lock_guard<std::mutex> lock(mu_);
      exited_.insert(session);
      --running_;
    }
    std::lock_guard<std::mutex> lock(write_mu_);
    reports_.write(*r);
  }

  std::set<std::string> killed() {
    std::lock_guard<std::mutex> lock(mu_);
    return killed_;
  }

 private:
  dds::Writer<fk_HostStatus> status_;
  dds::Writer<fk_WorkerReport> reports_;
  dds::Reader<fk_WorkerRequest> requests_;
  std::string guid_;
  int capacity_;
  std::atomic<int> running_{0};
  std::mutex mu_, write_mu_;
  std::set<std::string> killed_, exited_;
};

// A thread stopped and joined however its scope is left (a refused start ends the program).
struct Stopped {
  std::atomic<bool>& stop;
  std::thread& thread;
  ~Stopped() {
    stop = true;
    if (thread.joinable()) thread.join();
  }
};

// One step's figures.
struct Step {
  int sessions = 0;
  double start_ms_median = 0, start_ms_max = 0;
  double states_published_per_s = 0, states_ingested_per_s = 0;
  long states_lost = 0, events_lost = 0;  // published but never believed by the server
  bench::Load history;
  double server_cpu = 0, ingest_cpu = 0;  // share of one core over the window (the servers' together)
  double server_cpu_max = 0;               // the busiest server's share
  long publisher_late = 0;                // rounds this program could not publish in time
  std::string busiest;                    // the server's threads that took most CPU, with their share
  std::vector<std::string> problems;      // what the store's check found
  bool ok() const { return states_lost == 0 && events_lost == 0 && problems.empty() && history.errors == 0; }
};

json get_json(httplib::Client& c, const std::string& token, const std::string& path) {
  auto r = c.Get(path, {{"Authorization", "Bearer " + token}});
  if (!r || r->status != 200) throw std::runtime_error("GET " + path + ": " + (r ? std::to_string(r->status) + " " + r->body : "no answer"));
  return json::parse(r->body);
}

// The truck path the server keeps when every state arrives: its first, then one each path
// interval of sim time (SessionRecorder::truck_state).
std::vector<double> expected_path(int64_t ticks, double rate) {
  std::vector<double> out;
  for (int64_t k = 1; k <= ticks; ++k) {
    const double t = double(k) / rate;
    if (out.empty() || t >= out.back() + kPathIntervalS) out.push_back(t);
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"forklift-bench-ingest: how many cab sessions one forklift-server ingests over DDS (states, events, scores), "
               "with nothing lost and its pages answering"};
  app.set_version_flag("--version", FORKLIFT_VERSION);
  app.option_defaults()->always_capture_default();  // --help shows each option's default
  std::vector<int> steps = {50, 100, 200, 300, 400};
  double seconds = 10, rate = 60, event_every = 2;
  int clients = 2, port = 18190, domain = 78;
  std::vector<int> server_counts = {1};
  double history_rate = 200;
  std::string out_dir = "out/bench-ingest", db = "sqlite", from, from_postgresql;
  bool check = false;
  app.add_option("--sessions", steps, "concurrent sessions of each step, one step after another")->check(CLI::Range(1, 1000));
  app.add_option("--seconds", seconds, "length of each step's measured window, s")->check(CLI::Range(0.5, 600.0));
  app.add_option("--rate", rate, "TruckState samples per session per second (a worker's rate)")->check(CLI::Range(1.0, 1000.0));
  app.add_option("--event-every", event_every, "one event per session every this many seconds of sim time")->check(CLI::Range(0.05, 600.0));
  app.add_option("--clients", clients, "keep-alive HTTP clients asking for pupils' histories meanwhile")->check(CLI::Range(1, 64));
  app.add_option("--history-rate", history_rate, "history requests per second, all clients together, as staff's pages ask (0: back to back)")
      ->check(CLI::Range(0.0, 100000.0));
  app.add_option("--from", from, "an SQLite store to copy and measure on, whose pupils' histories are asked (e.g. forklift-bench-server's "
                 "out/bench/server-10000x50.db); default: a new store, where the histories asked are this program's pupils'")
      ->check(CLI::ExistingFile);
  app.add_option("--from-postgresql", from_postgresql, "with --db postgresql: a database of a kept PostgreSQL server to copy and "
                 "measure on, as the server's folder and the database's name (forklift-bench-store's "
                 "build/bench-data/postgresql/store_1000000); the copy is dropped at the end; default: a new store");
  app.add_option("--servers", server_counts, "servers sharing the store, each with its own id, port (the first --port, the others free ones) and log folder; "
                 "each step's sessions are started through each in turn, and each must ingest its own alone. Several counts: one run "
                 "each, on a new store, and how many sessions the servers hold per core each, against one server's (1 2)")
      ->check(CLI::Range(1, 4));
  app.add_option("--port", port, "loopback port for the (first) server (1024 to 65535)")->check(CLI::Range(1024, 65535));
  app.add_option("--dds-domain", domain, "DDS domain")->check(CLI::Range(0, 232));
  app.add_option("--dir", out_dir, "where the store, the server's logs and this program's session logs go");
  app.add_option("--db", db, "the store: sqlite (a new file in --dir), postgresql (a server this program starts in --dir/postgresql) or a "
                 "postgresql://... URI")
      ->check([](const std::string& v) {
        return v == "sqlite" || v == "postgresql" || store::is_postgresql_location(v) ? std::string()
                                                                                      : "'" + v + "' is neither sqlite, postgresql nor a postgresql:// URI";
      });
  app.add_flag("--check", check, "exit 1 unless every step lost nothing and the store holds every sample once (a test)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help and --version: 0; bad usage: 2, as every program
  }
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  std::sort(steps.begin(), steps.end());
  const int most = steps.back();

  // One run of every step with `server_count` servers, in `dir`: its steps' figures in `results`.
  auto run = [&](const int server_count, const std::string& dir, std::vector<Step>& results) -> int {
    // A new store each run, so logs of the same sessions' names from a run before must not be about.
    for (const char* sub : {"/logs", "/worker-logs"}) std::filesystem::remove_all(dir + sub);
    std::filesystem::create_directories(dir + "/logs");
    std::filesystem::create_directories(dir + "/worker-logs");
    std::unique_ptr<forklift::test::PostgresServer> postgres;
    std::string location = db;
    if (!from.empty() && db != "sqlite") {
      std::fprintf(stderr, "--from copies an SQLite store: it goes with --db sqlite\n");
      return 2;
    }
    if (!from_postgresql.empty() && db != "postgresql") {
      std::fprintf(stderr, "--from-postgresql copies a database of a PostgreSQL server: it goes with --db postgresql\n");
      return 2;
    }
    if (db == "sqlite") {
      location = dir + "/ingest.db";
      for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(location + suffix);
      if (!from.empty()) std::filesystem::copy_file(from, location);
    } else if (db == "postgresql") {
      try {
        const std::filesystem::path copied(from_postgresql);
        postgres = std::make_unique<forklift::test::PostgresServer>(from_postgresql.empty() ? dir + "/postgresql" : copied.parent_path().string(), true);
        postgres->drop_database("ingest");
        if (from_postgresql.empty()) {
          location = postgres->create_database("ingest");
        } else {
          const std::string why = postgres->exec("postgres", "CREATE DATABASE ingest TEMPLATE \"" + copied.filename().string() + "\" STRATEGY FILE_COPY");
          if (!why.empty()) throw std::runtime_error("cannot copy " + from_postgresql + ": " + why);
          location = postgres->uri("ingest");
        }
      } catch (const std::exception& e) {
        std::fprintf(stderr, "cannot start PostgreSQL: %s\n", e.what());
        return 1;
      }
    }
    const std::string bin = FORKLIFT_BIN_DIR;
    // The first server makes the store's tables; the others start once it answers.
    std::vector<std::unique_ptr<Process>> servers;
    std::vector<std::unique_ptr<httplib::Client>> clients_of;  // one per server
    // The first on --port; the others wherever is free (tests/support/ports.h, as the tests' ports).
    std::vector<int> ports = {port};
    while (int(ports.size()) < server_count) ports.push_back(forklift::test::free_port());
    for (int k = 0; k < server_count; ++k) {
      const std::string suffix = k ? std::to_string(k + 1) : "";
      std::filesystem::create_directories(dir + "/logs" + suffix);
      servers.push_back(std::make_unique<Process>(
          std::vector<std::string>{bin + "/forklift-server", "--db", location, "--listen", "127.0.0.1:" + std::to_string(ports[k]),
                                   "--dds-domain", std::to_string(domain), "--admin-password", kPassword, "--password-cost", "test",
                                   "--log-dir", dir + "/logs" + suffix, "--no-local-workers", "--trust-clear-hosts", "--server-id",
                                   "bench-" + std::to_string(k + 1)},
          dir + "/server" + suffix));
      clients_of.push_back(std::make_unique<httplib::Client>("127.0.0.1", ports[k]));
      if (!bench::answers_health(*clients_of.back())) {
        std::fprintf(stderr, "forklift-server %d did not come up on %s:\n%s\n", k + 1, store::printable_location(location).c_str(),
                     servers.back()->err().c_str());
        return 1;
      }
    }
    httplib::Client& c = *clients_of[0];
    auto login = c.Post("/api/login", json{{"username", "admin"}, {"password", kPassword}}.dump(), "application/json");
    if (!login || login->status != 200) {
      std::fprintf(stderr, "cannot sign in to the server as admin\n");
      return 1;
    }
    const std::string token = json::parse(login->body)["token"];
    const httplib::Headers auth = {{"Authorization", "Bearer " + token}};

    // A pupil for each cab of the largest step; their histories grow a session a step.
    std::vector<int64_t> pupils;
    for (int i = 0; i < most; ++i) {
      auto r = c.Post("/api/pupils", auth, json{{"name", "Ingest Pupil " + std::to_string(i + 1)}}.dump(), "application/json");
      if (!r || r->status != 201) {
        std::fprintf(stderr, "cannot add a pupil: %s\n", r ? r->body.c_str() : "no answer");
        return 1;
      }
      pupils.push_back(json::parse(r->body)["id"]);
    }

    // The pupils whose histories are asked: the store's own (--from), else this program's.
    auto store = store::Store::open(location);
    std::vector<int64_t> asked;
    for (const store::Pupil& p : store->list_pupils(store->find_user("admin")->school_id, "", 10000, 0))
      if (p.name.rfind("Ingest Pupil ", 0) != 0) asked.push_back(p.id);
    if (asked.empty()) asked = pupils;

    dds::Participant part(dds::DomainSettings::resolve(domain, ""));
    FakeHost host(part, std::max(most, 1));
    std::atomic<bool> stop_host{false};
    std::thread host_thread([&] { host.run(stop_host); });
    const Stopped host_stopped{stop_host, host_thread};
    // The host is believed once a server has its status: wait for it in each one's fleet.
    for (const auto& sc : clients_of)
      for (int i = 0; i < 100; ++i) {
        const json f = get_json(*sc, token, "/api/fleet");
        if (!f["hosts"].empty() && f["hosts"][0].value("alive", false)) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
      }
    // The servers' counts together, or one's (GET /api/fleet "ingested").
    auto ingested = [&](const char* topic, int only = -1) {
      long n = 0;
      for (int k = 0; k < server_count; ++k)
        if (only < 0 || only == k) n += get_json(*clients_of[k], token, "/api/fleet")["ingested"][topic].get<long>();
      return n;
    };
    auto servers_cpu = [&] {
      double cpu = 0;
      for (const auto& p : servers) cpu += bench::cpu_seconds(p->pid());
      return cpu;
    };
    auto servers_threads = [&] {
      std::vector<std::vector<std::pair<std::string, double>>> t;
      for (const auto& p : servers) t.push_back(thread_cpu(p->pid()));
      return t;
    };

    std::printf("forklift-bench-ingest: %d server%s on one %s store, states at %.0f Hz, an event every %.1f s, %d history clients "
                "(of the first server), %.0f s windows\n\n",
                server_count, server_count > 1 ? "s" : "", db == "sqlite" || db == "postgresql" ? db.c_str() : store::printable_location(location).c_str(),
                rate, event_every, clients, seconds);
    std::printf("%8s %9s %11s %11s %6s %6s %10s %8s %8s %8s %8s %6s\n", "sessions", "start ms", "states/s", "ingested/s", "lost", "events",
                "history/s", "p50 ms", "p99 ms", "server%", "ingest%", "late");
    long published_states = 0, published_events = 0;
    std::vector<long> published_through(server_count, 0);  // states of the sessions started through each server

    for (const int n : steps) {
      Step step;
      step.sessions = n;
      std::vector<std::unique_ptr<FakeSession>> sessions;
      std::mutex live_mu;
      std::vector<FakeSession*> live;  // publishing now
      std::atomic<bool> stop_publishing{false};
      std::atomic<long> late{0};
      // The workers' loop: every session's state each period, an event each event_every.
      std::thread publisher([&] {
        const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate));
        auto next = Clock::now();
        const int64_t event_ticks = std::max<int64_t>(1, std::llround(event_every * rate));
        while (!stop_publishing) {
          {
            std::lock_guard<std::mutex> lock(live_mu);
            for (FakeSession* s : live) {
              fk_TruckState t{};
              dds::set_string(t.cab_id, s->cab);
              dds::set_string(t.session_id, s->id);
              ++s->ticks;
              t.sim_time_s = double(s->ticks) / rate;
              t.x_m = 10 + std::sin(t.sim_time_s), t.y_m = 5, t.yaw_rad = 0.1, t.speed_m_s = 1.2, t.lift_m = 0.1;
              t.fz_front_left_N = t.fz_front_right_N = t.fz_rear_N = 10000;
              t.stability_margin = 0.8;
              s->states->write(t);
              if (s->ticks % event_ticks == 0) {
                fk_Event e{};
                dds::set_string(e.session_id, s->id);
                s->event_times.push_back(t.sim_time_s);
                e.seq = static_cast<uint32_t>(s->event_times.size());
                e.sim_time_s = t.sim_time_s;
                dds::set_string(e.kind, kEventKind);
                e.worry_level = 1;
                e.x_m = t.x_m, e.y_m = t.y_m;
                dds::set_string(e.details, R"({"speed_m_s":1.2})");
                s->events->write(e);
              }
            }
          }
          next += period;
          if (Clock::now() > next) {
            ++late;
            next = Clock::now();
          }
          std::this_thread::sleep_until(next);
        }
      });
      const Stopped publisher_stopped{stop_publishing, publisher};

      // Started through the API, one after another, as a school's staff would; each publishes
      // once its start has been answered (its participant is then known to the server).
      std::vector<double> start_ms;
      for (int i = 0; i < n; ++i) {
        auto s = std::make_unique<FakeSession>();
        // Named for the run too: a server of the run before may still be going away.
        s->cab = "ing" + std::to_string(server_count) + "s" + std::to_string(n) + "-" + std::to_string(i + 1);
        s->pupil = pupils[i];
        s->states = std::make_unique<dds::Writer<fk_TruckState>>(part, dds::cab_partition(s->cab));
        s->events = std::make_unique<dds::Writer<fk_Event>>(part, dds::worker_partition(s->cab));
        s->statuses = std::make_unique<dds::Writer<fk_SessionStatus>>(part, dds::worker_partition(s->cab));
        s->scores = std::make_unique<dds::Writer<fk_Score>>(part, dds::worker_partition(s->cab));
        const auto t0 = Clock::now();
        s->server = i % server_count;
        auto r = clients_of[s->server]->Post("/api/sessions", auth, json{{"pupil_id", s->pupil}, {"cab_id", s->cab}, {"scenario", "first_drive"}}.dump(),
                        "application/json");
        if (!r || r->status != 201) {
          std::fprintf(stderr, "the server refused to start session %d of %d: %s\n", i + 1, n, r ? r->body.c_str() : "no answer");
          return 1;
        }
        start_ms.push_back(ms_since(t0));
        s->id = json::parse(r->body)["id"];
        // Best-effort states published before the server's reader is matched are lost on the way:
        // a worker's are too, but they are not the server's to count.
        // The server makes its reader of the cab's states when it binds the session (a round of
        // its ingest later); a busy machine may take seconds to match it.
        for (int k = 0; k < 5000 && (s->states->matched() == 0 || s->events->matched() == 0); ++k)
          std::this_thread::sleep_for(std::chrono::milliseconds(2));
        fk_SessionStatus st{};
        dds::set_string(st.session_id, s->id);
        dds::set_string(st.cab_id, s->cab);
        dds::set_string(st.state, "running");
        s->statuses->write(st);
        std::lock_guard<std::mutex> lock(live_mu);
        live.push_back(s.get());
        sessions.push_back(std::move(s));
      }
      std::sort(start_ms.begin(), start_ms.end());
      step.start_ms_median = start_ms[start_ms.size() / 2];
      step.start_ms_max = start_ms.back();
      std::this_thread::sleep_for(std::chrono::seconds(1));  // every session publishing

      // The window: what was published and believed over it, the histories meanwhile.
      auto published = [&] {
        std::lock_guard<std::mutex> lock(live_mu);
        long states = 0;
        for (const auto& s : sessions) states += s->ticks;
        return states;
      };
      const long p0 = published();
      const long ingested0 = ingested("states");
      const double cpu0 = servers_cpu();
      std::vector<double> cpu0_of;
      for (const auto& p : servers) cpu0_of.push_back(bench::cpu_seconds(p->pid()));
      const long late0 = late;
      const auto threads0 = servers_threads();
      const auto w0 = Clock::now();
      std::uniform_int_distribution<size_t> pick(0, asked.size() - 1);
      step.history = bench::hammer(
          port, token, clients, seconds, [&](std::mt19937& rng) { return "/api/pupils/" + std::to_string(asked[pick(rng)]) + "/history"; },
          history_rate / clients);
      const auto threads1 = servers_threads();
      const double window_s = ms_since(w0) / 1e3;
      const long p1 = published();
      const long ingested1 = ingested("states");
      step.server_cpu = 100 * (servers_cpu() - cpu0) / window_s;
      for (int k = 0; k < server_count; ++k)
        step.server_cpu_max = std::max(step.server_cpu_max, 100 * (bench::cpu_seconds(servers[k]->pid()) - cpu0_of[k]) / window_s);
      for (int k = 0; k < server_count; ++k) {
        step.busiest += (k ? "; server " + std::to_string(k + 1) + "'s: " : "") + busiest(threads0[k], threads1[k], window_s);
        step.ingest_cpu += 100 * (thread_seconds(threads1[k], "ingest") - thread_seconds(threads0[k], "ingest")) / window_s;
      }
      step.publisher_late = late - late0;
      step.states_published_per_s = (p1 - p0) / window_s;
      step.states_ingested_per_s = (ingested1 - ingested0) / window_s;

      // Publishing stops and each session ends at once, as a worker's does (the server would stop
      // a worker silent for its hang timeout).
      stop_publishing = true;
      publisher.join();
      // Each session ends as a worker's does: its log, its score and status, its host's report.
      for (const auto& s : sessions) {
        const std::string log_path = dir + "/worker-logs/" + s->id + ".ctl";
        Score score;
        score.mark = std::max(0.0, 100.0 - double(s->event_times.size()));
        score.passed = true;
        score.points = int(s->event_times.size());
        score.end_reason = "time_limit";
        score.mode = "training";
        if (!s->event_times.empty()) score.counts[kEventKind] = int(s->event_times.size());
        {
          LogHeader h;
          h.session_id = s->id;
          h.cab_id = s->cab;
          h.truck_file = "data/trucks/training.json";
          ControlLogWriter log(log_path, h);
          for (double t : s->event_times) log.event(std::llround(t * 1000), kEventKind, 1);
          log.score(score_line(score));
          log.finish(std::llround(double(s->ticks) / rate * 1000), StateVector::Zero());
        }
        fk_Score sc{};
        dds::set_string(sc.session_id, s->id);
        sc.mark = score.mark;
        sc.passed = score.passed;
        std::vector<fk_FaultCount> counts;
        for (const auto& [kind, count] : score.counts) {
          fk_FaultCount fc{};
          dds::set_string(fc.kind, kind);
          fc.count = static_cast<uint32_t>(count);
          counts.push_back(fc);
        }
        sc.counts._buffer = counts.data();
        sc.counts._length = sc.counts._maximum = static_cast<uint32_t>(counts.size());
        sc.counts._release = false;
        s->scores->write(sc);
        fk_SessionStatus st{};
        dds::set_string(st.session_id, s->id);
        dds::set_string(st.cab_id, s->cab);
        dds::set_string(st.state, "ended");
        dds::set_string(st.reason, "time_limit");
        st.sim_time_s = double(s->ticks) / rate;
        s->statuses->write(st);
        std::ifstream in(log_path);
        host.report(s->id, s->cab, "exited", std::string((std::istreambuf_iterator<char>(in)), {}));
      }
      // What was published and what the server believed, since it started.
      long states = 0, events = 0;
      for (const auto& s : sessions) states += s->ticks, events += long(s->event_times.size()), published_through[s->server] += s->ticks;
      published_states += states;
      published_events += events;
      for (int i = 0; i < 50; ++i) {  // the last samples in flight: up to 5 s for the count to settle
        if (ingested("states") >= published_states && ingested("events") >= published_events) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
      }
      step.states_lost = published_states - ingested("states");
      step.events_lost = published_events - ingested("events");
      // Each server believed its own sessions' states, and none of another's.
      for (int k = 0; k < server_count && server_count > 1; ++k)
        if (const long own = ingested("states", k); own != published_through[k])
          step.problems.push_back("server " + std::to_string(k + 1) + " believed " + std::to_string(own) + " states, not the " +
                                  std::to_string(published_through[k]) + " of the sessions started through it");
      // Settled: every session ended in the store with its mark (the server waits a few seconds
      // for a worker's last samples before it settles from the log).
      const auto settle0 = Clock::now();
      for (const auto& s : sessions) {
        while (ms_since(settle0) < 60e3) {
          const auto got = store->get_session(s->id);
          if (got && is_terminal(got->state) && store->get_score(s->id)) break;
          std::this_thread::sleep_for(std::chrono::milliseconds(100));
        }
      }
      for (const auto& s : sessions) {
        const auto got = store->get_session(s->id);
        const auto score = store->get_score(s->id);
        if (!got || got->state != SessionPhase::kEnded || !score) {
          step.problems.push_back("session " + s->id + " was not ended with a mark");
          continue;
        }
        if (std::abs(score->mark - std::max(0.0, 100.0 - double(s->event_times.size()))) > 1e-9)
          step.problems.push_back("session " + s->id + "'s mark is not the one published");
        const auto stored = store->list_events(s->id);
        size_t from_dds = 0;
        for (const auto& e : stored) from_dds += e.details.find("recovered_from") == std::string::npos ? 1 : 0;
        if (stored.size() != s->event_times.size() || from_dds != stored.size())
          step.problems.push_back("session " + s->id + ": " + std::to_string(stored.size()) + " events stored (" + std::to_string(from_dds) +
                                  " from DDS) of " + std::to_string(s->event_times.size()) + " published");
        // The last states' point is stored with the ingest's next batch: up to 5 s for it.
        const std::vector<double> expected = expected_path(s->ticks, rate);
        std::vector<double> path;
        for (int i = 0; i < 50 && (i == 0 || path != expected); ++i) {
          if (i > 0) std::this_thread::sleep_for(std::chrono::milliseconds(100));
          path.clear();
          for (const auto& p : store->list_path(s->id)) path.push_back(p.sim_time_s);
        }
        if (path != expected)
          step.problems.push_back("session " + s->id + ": a truck path of " + std::to_string(path.size()) + " points, not the " +
                                  std::to_string(expected.size()) + " every state gives");
      }
      for (const std::string& k : host.killed())
        for (const auto& s : sessions)
          if (s->id == k) step.problems.push_back("the server stopped session " + k + "'s worker");
      for (const auto& sc : clients_of)
        for (const auto& [why, count] : get_json(*sc, token, "/api/fleet")["refused_samples"].items())
          if (count.get<long>() != 0) step.problems.push_back(std::to_string(count.get<long>()) + " samples refused (" + why + ")");

      std::printf("%8d %9.0f %11.0f %11.0f %6ld %6ld %10.0f %8.2f %8.2f %8.0f %8.0f %6ld\n", n, step.start_ms_median,
                  step.states_published_per_s, step.states_ingested_per_s, step.states_lost, step.events_lost, step.history.rps(),
                  step.history.pct(0.5), step.history.pct(0.99), step.server_cpu, step.ingest_cpu, step.publisher_late);
      for (size_t i = 0; i < std::min<size_t>(step.problems.size(), 3); ++i) std::printf("         %s\n", step.problems[i].c_str());
      if (step.problems.size() > 3) std::printf("         and %zu more such\n", step.problems.size() - 3);
      std::printf("         the server%s busiest threads: %s\n", server_count > 1 ? "s' (each's)" : "'s", step.busiest.c_str());
      results.push_back(std::move(step));
    }
    stop_host = true;
    host_thread.join();
    for (const auto& p : servers) p->signal(SIGTERM);
    for (const auto& p : servers) p->wait(10);
    // A copy of a generated store is as large as it (some 11 GB at 10 million sessions).
    if (!from_postgresql.empty()) {
      store.reset();
      postgres->drop_database("ingest");
    }

    // The goal: the most sessions ingested with nothing lost and the history's p99 under 10 ms.
    int held = 0;
    for (const Step& s : results)
      if (s.ok() && s.history.pct(0.99) < 10) held = std::max(held, s.sessions);
    const Step* at = nullptr;
    for (const Step& s : results)
      if (s.sessions == held) at = &s;
    const std::string who = server_count == 1 ? "one server" : std::to_string(server_count) + " servers";
    std::printf("\n%s held %d concurrent sessions at %.0f Hz with nothing lost and the history p99 under 10 ms%s\n", who.c_str(), held, rate,
                held == most ? " (every step: try more with --sessions)" : "");
    bench::figure("server: concurrent sessions " + who + " ingest" + (server_count == 1 ? "s" : "") + " (" +
                      std::string(db == "sqlite" || db == "postgresql" ? db : "postgresql") + ", states at " + bench::fmt("%.0f", rate) +
                      " Hz), nothing lost, history p99 < 10 ms meanwhile",
                  server_count == 1 ? ">= 300" : ">= 1.6 x one server's",
                  at ? bench::fmt("%d (%.0f states/s; history p99 %.1f ms; %s %.0f %% of a core, ingest thread%s %.0f %%)", held,
                                  at->states_ingested_per_s, at->history.pct(0.99), server_count == 1 ? "server" : "servers", at->server_cpu,
                                  server_count == 1 ? "" : "s", at->ingest_cpu)
                     : std::string("none"),
                  server_count > 1 || held >= 300);
    return 0;
  };

  std::map<int, double> per_core;  // by server count: sessions held per core of the busiest server
  std::vector<Step> all;
  for (const int count : server_counts) {
    std::vector<Step> results;
    if (const int rc = run(count, server_counts.size() == 1 ? out_dir : out_dir + "/" + std::to_string(count) + "-servers", results))
      return rc;
    for (const Step& s : results)
      if (s.ok() && s.server_cpu_max > 0) per_core[count] = s.sessions * 100 / s.server_cpu_max;  // the largest step's
    all.insert(all.end(), results.begin(), results.end());
    std::printf("\n");
  }
  // Several servers against one, measured in this run: how many sessions each configuration
  // would hold if each server had a core of its own, at the CPU per session measured (this
  // machine's 2 cores cannot hold enough sessions to find two servers' limit itself).
  for (const auto& [count, sessions] : per_core)
    if (count > 1 && per_core.count(1))
      bench::figure(bench::fmt("server: sessions %d servers on one %s store hold, per core each, against one server's", count,
                               db == "sqlite" ? "sqlite" : "postgresql"),
                    ">= 1.6", bench::fmt("%.2f (%.0f against %.0f sessions per core)", sessions / per_core[1], sessions, per_core[1]),
                    sessions / per_core[1] >= 1.6);
  if (check) {
    bool ok = true;
    for (const Step& s : all) ok = ok && s.ok();
    if (!ok) {
      std::fprintf(stderr, "forklift-bench-ingest: a step lost samples or the store does not hold them all (above)\n");
      return 1;
    }
  }
  return 0;
}
