// forklift-server as a library: the HTTP/JSON API (server/openapi.yaml) over the trainee store and
// the sim-worker fleet, mounted on an httplib::Server that the caller makes, binds and runs. The
// program (server/src/main.cc) and the in-process tests share it.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "forklift/host/worker_launch.h"

namespace httplib {
class Server;
}

namespace forklift::server {

// How much a password's hash costs (Argon2id's passes and memory): libsodium's three levels, and
// a fourth that costs next to nothing and so protects next to nothing, for tests and demonstrations.
enum class PasswordCost { kInteractive, kModerate, kSensitive, kTest };
// "interactive", "moderate", "sensitive", "test"; parse() of anything else: nullopt.
const char* name(PasswordCost cost);
std::optional<PasswordCost> parse_password_cost(const std::string& text);

// This machine's network name (gethostname), for the default server id; "localhost" if it has none.
std::string machine_name();

struct ServerConfig {
  // The store: an SQLite file, created if missing, or a PostgreSQL database's URI
  // ("postgresql://...", store::Store::open).
  std::string db_path = "forklift.db";
  std::string data_dir;                 // data/: scenarios, trucks, the theory bank
  // The school's rules for theory papers (time limits, retakes; data/theory/README.md). Empty:
  // <data_dir>/theory/policy.json.
  std::string theory_policy;
  // The school's rules for a licence (training, the theory pass's age; data/licence/README.md).
  // Empty: <data_dir>/licence/rules.json.
  std::string licence_rules;
  // The address the school's employers reach this server at ("https://forklift.example.org", no
  // path): certificates print it in their QR code and link. Empty: the pages use the address they
  // were opened at.
  std::string public_url;
  // Workers' logs and the stills cache; empty: <db_path>.logs, or forklift.logs in the working
  // directory for a PostgreSQL database.
  std::string log_dir;
  // The exam chain's anchor, appended as each exam is chained; keep it where the database's
  // writers cannot write (docs/exam-evidence.md). Empty: <log_dir>/exam-chain.anchor.
  std::string chain_anchor;
  std::string bin_dir;                  // where forklift-worker and forklift-render are
  // The 'admin' account a new database gets; empty: a random password (see Api::generated_admin_password).
  std::string admin_password;
  // The school's name as certificates print it. Empty: the school's name in the security folder
  // (scripts/forklift-pki.sh init --school NAME) when there is one, else the name the database
  // gives the school ("Default school" for a new one).
  std::string school_name;

  // Of the hashes made from now on (each hash keeps its own cost, so a change never locks anyone out).
  PasswordCost password_cost = PasswordCost::kInteractive;
  double token_ttl_s = 8 * 3600;  // how long a login lasts
  int login_attempts = 5;         // failed logins of one username within the window before a lockout
  std::optional<int> login_address_attempts;  // the same for one client address; default 4 x login_attempts
  double login_window_s = 60;

  std::optional<int> dds_domain;  // empty: FORKLIFT_DDS_DOMAIN, else 0
  std::string dds_config;         // Cyclone DDS configuration file; empty: the default
  std::string security_dir;       // the school's DDS Security folder; empty: no exams
  std::string identity = "server.main";
  // This server among those that share the store (each runs the sessions it starts, and takes
  // over a stopped one's after server_lease_s). Empty: this machine's name and the process id.
  std::string server_id;
  double server_lease_s = 10;
  int max_workers = 8;
  double hang_timeout_s = 5;
  std::optional<host::WorkerFrames> frames;  // every worker's frames' rate, size, encoding (nullopt: the worker's defaults)
  bool local_workers = true;  // run workers here when no worker host (forklift-host) is about
  bool realtime_workers = false;  // those workers tick at real-time priority (forklift-worker --realtime)
  // Believe worker hosts in clear DDS (no identities): for a closed lab only, said at start in the log.
  bool trust_clear_hosts = false;
};

struct Context;
class Contract;

// A route: what the server registered (path: httplib's pattern, /api/pupils/(\d+)) or what
// server/openapi.yaml documents (path: /api/pupils/{id}, with its operationId).
struct RouteInfo {
  std::string method;
  std::string path;
  std::string operation_id;
};
// Every operation of the API description built into the server.
std::vector<RouteInfo> documented_operations();

// The server's state (logins, store, fleet, question bank, caches) and its routes. Constructing
// it opens the store, gives a new database its school and admin, and starts the fleet (DDS).
class Api {
 public:
  explicit Api(ServerConfig config);
  ~Api();
  Api(const Api&) = delete;
  Api& operator=(const Api&) = delete;

  // Every /api route on `svr`, with the server's error answers, security headers and body limit.
  // `svr` must not outlive this Api.
  void mount(httplib::Server& svr);
  // What mount() registered, in its order.
  const std::vector<RouteInfo>& routes() const { return routes_; }

  // The admin password made up for a new database, to be shown once; empty if none was made.
  const std::string& generated_admin_password() const { return generated_admin_password_; }
  int dds_domain() const;  // the domain the fleet resolved
  const std::string& log_dir() const { return log_dir_; }  // ServerConfig::log_dir, or its default

 private:
  std::unique_ptr<Context> ctx_;
  const Contract* contract_;  // api_contract()
  std::vector<RouteInfo> routes_;
  std::string generated_admin_password_;
  std::string log_dir_;
};

}  // namespace forklift::server
