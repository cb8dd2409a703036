// forklift-server: the paper's Menu Structure as an HTTP/JSON API (server/openapi.yaml) over the
// trainee store, and the supervisor of one sim worker per cab session. The API is the
// forklift_server_core library; this is its command line, its HTTP(S) listener and its web pages.
#include <httplib.h>
#include <netdb.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "forklift/server/listener.h"
#include "forklift/server/logs.h"
#include "forklift/server/server.h"
#include "forklift/store/store.h"

namespace {

// Fails with a message naming the option when `path` cannot be read (httplib would only say no).
void require_readable(const std::string& option, const std::string& path) {
  std::ifstream in(path);
  char c;
  if (!in || !in.get(c)) throw std::runtime_error(option + " " + path + ": cannot read it (" + std::strerror(errno) + ")");
}

// HTTPS with the certificate and key when both are given, else plain HTTP; either bounds every
// request it reads (forklift/server/listener.h).
std::unique_ptr<httplib::Server> make_http_server(const std::string& cert, const std::string& key) {
  if (cert.empty() != key.empty()) throw std::runtime_error("--tls-cert and --tls-key go together: give both or neither");
  if (cert.empty()) return std::make_unique<forklift::server::Listener>();
  require_readable("--tls-cert", cert);
  require_readable("--tls-key", key);
  auto svr = std::make_unique<forklift::server::TlsListener>(cert, key);
  if (!svr->is_valid())
    throw std::runtime_error("--tls-cert " + cert + " and --tls-key " + key + " are not a PEM certificate and its private key");
  return svr;
}

// A database file goes only in a folder that exists: making the folders of a mistyped path
// would start a new, empty school there.
void require_db_folder(const std::string& db) {
  if (forklift::store::is_postgresql_location(db)) return;
  const std::filesystem::path folder = std::filesystem::path(db).parent_path();
  if (folder.empty()) return;  // the working directory
  std::error_code ec;
  if (!std::filesystem::exists(folder, ec))
    throw std::runtime_error("--db " + db + ": the folder " + folder.string() + " does not exist. Create it first, or give the " +
                             "database a place in a folder that exists (the server makes no folders for its database)");
  if (!std::filesystem::is_directory(folder, ec)) throw std::runtime_error("--db " + db + ": " + folder.string() + " is not a folder");
}

// Why the listener could not bind `host` port `port`, in words: the same bind, tried again to
// read its errno (httplib says only no).
std::string why_not_listening(const std::string& host, int port) {
  const std::string where = "cannot listen on address " + host + ", port " + std::to_string(port) + ": ";
  addrinfo hints{};
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE;
  addrinfo* found = nullptr;
  if (getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &found) != 0 || !found)
    return where + "this machine does not know the address " + host + " (--listen ADDRESS:PORT)";
  int err = EADDRINUSE;
  for (addrinfo* a = found; a; a = a->ai_next) {
    const int sock = socket(a->ai_family, a->ai_socktype, a->ai_protocol);
    if (sock < 0) { err = errno; continue; }
    const int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    err = bind(sock, a->ai_addr, a->ai_addrlen) == 0 ? 0 : errno;
    close(sock);
    if (err != EADDRINUSE) break;
  }
  freeaddrinfo(found);
  switch (err) {
    case EADDRINUSE:
    case 0:  // free again: it was taken a moment ago
      return where + "another program is already using port " + std::to_string(port) +
             " (perhaps another forklift-server). Stop it, or start this one on another port with --listen " + host + ":PORT";
    case EACCES:
      return where + "ports below 1024 need administrator rights: choose one from 1024 up with --listen " + host + ":PORT";
    case EADDRNOTAVAIL:
      return where + "this machine has no address " + host + " (127.0.0.1: this machine only; 0.0.0.0: every network it is on)";
    default:
      return where + std::strerror(err);
  }
}

// The admin password made up for a new database goes to a file only its owner reads, never to
// the log; to the terminal alone if that file cannot be written, so that it is not lost.
void keep_admin_password(const std::string& log_dir, const std::string& password) {
  const std::string path = log_dir + "/admin-password";
  const mode_t old = umask(077);
  std::ofstream out(path);
  out << password << '\n';
  out.close();
  umask(old);
  if (out) {
    spdlog::warn("created user 'admin'; its password is in {} (readable by this user only): note it, then delete the file", path);
  } else {
    spdlog::warn("created user 'admin'; cannot write its password to {}: it follows on stderr, outside the log", path);
    std::fprintf(stderr, "admin password: %s\n", password.c_str());
  }
}

std::atomic<httplib::Server*> g_server{nullptr};
void on_signal(int) {
  if (auto* s = g_server.load()) s->stop();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"forklift-server: pupils, sessions, exams and the sim-worker fleet, over HTTP/JSON"};
  app.set_version_flag("--version", FORKLIFT_VERSION);
  app.option_defaults()->always_capture_default();  // --help shows each option's default
  forklift::server::ServerConfig cfg;
  std::string listen = "127.0.0.1:8080", web_dir;
  std::string tls_cert, tls_key;
  double frame_fps = 30;
  std::string frame_size = "640x480";
  bool frame_jpeg = false;
  app.add_option("--db", cfg.db_path, "the store: an SQLite database file (created if missing), or a PostgreSQL "
                 "database as postgresql://user@host:port/dbname (password from ~/.pgpass or PGPASSWORD)");
  app.add_option("--listen", listen, "address:port to serve on");
  app.add_option("--dds-domain", cfg.dds_domain, "DDS domain id (default FORKLIFT_DDS_DOMAIN or 0)")->check(CLI::Range(0, 232));
  app.add_option("--dds-config", cfg.dds_config, "Cyclone DDS configuration file")->check(CLI::ExistingFile);
  app.add_option("--log-dir", cfg.log_dir, "where workers' logs go (default: <db>.logs/, or forklift.logs/ with PostgreSQL)");
  app.add_option("--chain-anchor", cfg.chain_anchor, "the exam chain's anchor file, appended as each exam is chained: keep it "
                 "where the database's writers cannot write (default: <log-dir>/exam-chain.anchor)");
  app.add_option("--max-workers", cfg.max_workers, "sim workers this machine may run at once")->check(CLI::Range(1, 256));
  app.add_option("--hang-timeout", cfg.hang_timeout_s, "kill a worker that sends no state for this long, s")->check(CLI::Range(0.5, 600.0));
  app.add_option("--frame-fps", frame_fps, "frames each worker renders per second while its cab asks for them (0: none)")->check(CLI::Range(0.0, 120.0));
  app.add_option("--frame-size", frame_size, "size of those frames, WxH")->check([](const std::string& v) {
    int w = 0, h = 0;
    char x = 0;
    std::istringstream size(v);
    return size >> w >> x >> h && x == 'x' && w >= 16 && h >= 16 && w <= 4096 && h <= 4096 && size.peek() == EOF
               ? std::string()
               : std::string("give a width and a height from 16 to 4096, as 640x480");
  });
  app.add_flag("--frame-jpeg", frame_jpeg, "send frames as JPEG (cabs on a real network) instead of raw RGB");
  bool no_local_workers = false;
  app.add_flag("--no-local-workers", no_local_workers, "run no sim worker on this machine: only on worker hosts (forklift-host); "
               "by default the server runs them itself while no worker host is about");
  app.add_flag("--trust-clear-hosts", cfg.trust_clear_hosts, "believe worker hosts (forklift-host) without DDS Security: in clear "
               "DDS any machine on the network can claim to be one, place itself, kill workers and set marks, so only on a "
               "closed network the school alone can reach; with --security hosts are believed by their identity");
  app.add_flag("--realtime-workers", cfg.realtime_workers, "the workers this server runs tick at real-time priority (forklift-worker "
               "--realtime; needs CAP_SYS_NICE or an rtprio limit, e.g. systemd's LimitRTPRIO=10)");
  std::string password_cost = forklift::server::name(cfg.password_cost);
  if (const char* env = std::getenv("FORKLIFT_PASSWORD_COST")) password_cost = env;
  app.add_option("--password-cost", password_cost, "how costly each new password hash is (Argon2id): interactive (about "
                 "0.1 s and 64 MiB), moderate, sensitive (seconds and 1 GiB), or test (next to nothing: for tests and "
                 "demonstrations only, never for real passwords); hashes made before keep their cost (default "
                 "FORKLIFT_PASSWORD_COST, else interactive)")
      ->check(CLI::IsMember({"interactive", "moderate", "sensitive", "test"}));
  app.add_option("--token-ttl", cfg.token_ttl_s, "how long a login lasts, s")->check(CLI::Range(1.0, 30.0 * 86400));
  app.add_option("--tls-cert", tls_cert, "serve HTTPS with this PEM certificate (chain); needs --tls-key");
  app.add_option("--tls-key", tls_key, "the PEM private key of --tls-cert");
  app.add_option("--login-attempts", cfg.login_attempts, "failed logins of one username within --login-window before it is locked out for the window")
      ->check(CLI::Range(1, 1000));
  app.add_option("--login-address-attempts", cfg.login_address_attempts,
                 "failed logins from one client address within --login-window before it is locked out (default 4 x --login-attempts)")
      ->check(CLI::Range(1, 100000));
  app.add_option("--login-window", cfg.login_window_s, "the window of --login-attempts, and the lockout, s")->check(CLI::Range(1.0, 86400.0));
  app.add_option("--security", cfg.security_dir, "the school's DDS Security folder (scripts/forklift-pki.sh; default FORKLIFT_SECURITY_DIR): "
                 "needed for exams")->envname("FORKLIFT_SECURITY_DIR");
  app.add_option("--identity", cfg.identity, "the server's identity in it");
  app.add_option("--server-id", cfg.server_id, "this server's name among the servers that share one database: each runs the "
                 "sessions it starts (default: this machine's name and the port, as school1:8080)");
  app.add_option("--server-lease", cfg.server_lease_s, "how long a server sharing the database may say nothing before another "
                 "takes over its sessions, s")->check(CLI::Range(2.0, 3600.0));
  app.add_option("--admin-password", cfg.admin_password, "password of the 'admin' account created with a new database (else FORKLIFT_ADMIN_PASSWORD, else random)");
  app.add_option("--school-name", cfg.school_name, "the school's name as certificates print it (default: the school of the "
                 "--security folder's CA, else the database's)")->envname("FORKLIFT_SCHOOL_NAME");
  app.add_option("--theory-policy", cfg.theory_policy, "the school's rules for theory papers: time limits, the wait between "
                 "exam attempts and their limit (default: data/theory/policy.json)")->check(CLI::ExistingFile);
  app.add_option("--licence-rules", cfg.licence_rules, "the school's rules for a licence: the marked training sessions and how "
                 "recent a theory pass it needs (default: data/licence/rules.json)")->check(CLI::ExistingFile);
  app.add_option("--public-url", cfg.public_url, "the address employers reach this server at, printed in certificates' QR codes "
                 "and links, as https://forklift.example.org (default: the address the examiner's browser used)")
      ->check([](const std::string& v) {
        const size_t scheme = v.rfind("https://", 0) == 0 ? 8 : v.rfind("http://", 0) == 0 ? 7 : 0;
        return scheme && v.size() > scheme && v[scheme] != '/' && v.find_first_of("?# ") == std::string::npos
                   ? std::string()
                   : std::string("give the school's address with http:// or https://, as https://forklift.example.org");
      });
  app.add_option("--web-dir", web_dir, "the built web pages (default: web/ beside bin/ in the build tree)");
  std::string log_format = "text", access_log, session_log;
  app.add_option("--log-format", log_format, "the server's log (stderr), access log and session log: text, or json (one object per line)")
      ->check(CLI::IsMember({"text", "json"}));
  app.add_option("--access-log", access_log, "one line per HTTP request, appended to this file (- for stdout; default: "
                 "<log-dir>/access.log)");
  app.add_option("--session-log", session_log, "one line per thing that happens to a session (started, its states, its mark), "
                 "appended to this file (- for stdout; default: <log-dir>/sessions.log)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help and --version: 0; bad usage: 2, as every program
  }

  const auto format = log_format == "json" ? forklift::server::LogFormat::kJson : forklift::server::LogFormat::kText;
  forklift::server::start_server_log(format);
  try {
    const std::unique_ptr<httplib::Server> svr = make_http_server(tls_cert, tls_key);  // first: a bad flag changes nothing
    const auto colon = listen.rfind(':');
    const std::string host = colon == std::string::npos ? "" : listen.substr(0, colon);
    const std::string port_text = colon == std::string::npos ? "" : listen.substr(colon + 1);
    if (host.empty() || port_text.empty() || port_text.size() > 5 || port_text.find_first_not_of("0123456789") != std::string::npos ||
        std::stoi(port_text) < 1024 || std::stoi(port_text) > 65535)  // as root too: the school's server needs no system port
      throw std::runtime_error("--listen " + listen + ": give an address and a port from 1024 to 65535, as 127.0.0.1:8080 "
                               "(ports below 1024 are kept for the system's own services, even when run as root)");
    const int port = std::stoi(port_text);
    if (cfg.server_id.empty()) cfg.server_id = forklift::server::machine_name() + ":" + std::to_string(port);
    require_db_folder(cfg.db_path);
    // The port before anything else: a second server started by mistake changes nothing (its
    // fleet would adopt and stop the first one's workers).
    if (!svr->bind_to_port(host, port)) throw std::runtime_error(why_not_listening(host, port));
    if (cfg.admin_password.empty())
      if (const char* env = std::getenv("FORKLIFT_ADMIN_PASSWORD")) cfg.admin_password = env;
    const std::filesystem::path self = std::filesystem::canonical("/proc/self/exe");
    cfg.data_dir = FORKLIFT_DATA_DIR;
    cfg.bin_dir = self.parent_path().string();
    int frame_w = 640, frame_h = 480;
    char x = 0;
    std::istringstream(frame_size) >> frame_w >> x >> frame_h;  // checked with the flags
    cfg.local_workers = !no_local_workers;
    // The flag is checked with the others; FORKLIFT_PASSWORD_COST, its default, only here.
    const auto cost = forklift::server::parse_password_cost(password_cost);
    if (!cost) throw std::runtime_error("FORKLIFT_PASSWORD_COST=" + password_cost + ": give interactive, moderate, sensitive or test");
    cfg.password_cost = *cost;
    cfg.frames = forklift::host::WorkerFrames{frame_fps, frame_w, frame_h, frame_jpeg};
    if (web_dir.empty()) web_dir = (self.parent_path().parent_path() / "web").string();

    forklift::server::Api api(cfg);
    forklift::server::start_session_log(session_log.empty() ? api.log_dir() + "/sessions.log" : session_log, format);
    if (!api.generated_admin_password().empty()) keep_admin_password(api.log_dir(), api.generated_admin_password());
    api.mount(*svr);
    forklift::server::start_access_log(*svr, access_log.empty() ? api.log_dir() + "/access.log" : access_log, format);
    // The web pages (menu/web/, copied with the chart library into the build's web/), at /.
    if (!std::filesystem::is_directory(web_dir) || !svr->set_mount_point("/", web_dir))
      spdlog::warn("no web pages at {}: serving the API only", web_dir);
    g_server = svr.get();
    std::signal(SIGTERM, on_signal);
    std::signal(SIGINT, on_signal);
    spdlog::info("listening on {}{} (db {}, DDS domain {})", tls_cert.empty() ? "http://" : "https://", listen,
                 forklift::store::printable_location(cfg.db_path), api.dds_domain());
    svr->listen_after_bind();
    g_server = nullptr;
    spdlog::info("stopped");
    return 0;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 2;  // bad arguments or data, as every program: a flag, a file, a port that cannot be used
  }
}
