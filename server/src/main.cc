// forklift-server: the paper's Menu Structure as an HTTP/JSON API (server/openapi.yaml) over the
// trainee store, and the supervisor of one sim worker per cab session. The API is the
// forklift_server_core library; this is its command line, its HTTP(S) listener and its web pages.
#include <httplib.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "forklift/server/listener.h"
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

std::atomic<httplib::Server*> g_server{nullptr};
void on_signal(int) {
  if (auto* s = g_server.load()) s->stop();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"forklift-server: pupils, sessions, exams and the sim-worker fleet, over HTTP/JSON"};
  app.set_version_flag("--version", FORKLIFT_VERSION);
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
  app.add_option("--frame-size", frame_size, "size of those frames, WxH");
  app.add_flag("--frame-jpeg", frame_jpeg, "send frames as JPEG (cabs on a real network) instead of raw RGB");
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
  app.add_option("--admin-password", cfg.admin_password, "password of the 'admin' account created with a new database (else FORKLIFT_ADMIN_PASSWORD, else random)");
  app.add_option("--school-name", cfg.school_name, "the school's name as certificates print it (default: the school of the "
                 "--security folder's CA, else the database's)")->envname("FORKLIFT_SCHOOL_NAME");
  app.add_option("--theory-policy", cfg.theory_policy, "the school's rules for theory papers: time limits, the wait between "
                 "exam attempts and their limit (default: data/theory/policy.json)")->check(CLI::ExistingFile);
  app.add_option("--web-dir", web_dir, "the built web pages (default: web/ beside bin/ in the build tree)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help and --version: 0; bad usage: 2, as every program
  }

  try {
    const std::unique_ptr<httplib::Server> svr = make_http_server(tls_cert, tls_key);  // first: a bad flag changes nothing
    const auto colon = listen.rfind(':');
    if (colon == std::string::npos) throw std::runtime_error("--listen must be address:port");
    const std::string host = listen.substr(0, colon);
    const int port = std::stoi(listen.substr(colon + 1));
    if (cfg.admin_password.empty())
      if (const char* env = std::getenv("FORKLIFT_ADMIN_PASSWORD")) cfg.admin_password = env;
    const std::filesystem::path self = std::filesystem::canonical("/proc/self/exe");
    cfg.data_dir = FORKLIFT_DATA_DIR;
    cfg.bin_dir = self.parent_path().string();
    cfg.worker_args = {"--fps", std::to_string(frame_fps), "--frame-size", frame_size};
    if (frame_jpeg) cfg.worker_args.push_back("--jpeg");
    if (web_dir.empty()) web_dir = (self.parent_path().parent_path() / "web").string();

    forklift::server::Api api(cfg);
    if (!api.generated_admin_password().empty())
      std::cerr << "forklift-server: created user 'admin' with password " << api.generated_admin_password() << std::endl;
    api.mount(*svr);
    // The web pages (menu/web/, copied with the chart library into the build's web/), at /.
    if (!std::filesystem::is_directory(web_dir) || !svr->set_mount_point("/", web_dir))
      std::cerr << "forklift-server: no web pages at " << web_dir << ": serving the API only" << std::endl;
    g_server = svr.get();
    std::signal(SIGTERM, on_signal);
    std::signal(SIGINT, on_signal);
    if (!svr->bind_to_port(host, port)) throw std::runtime_error("cannot listen on " + listen);
    std::cerr << "forklift-server: listening on " << (tls_cert.empty() ? "http://" : "https://") << listen << " (db " << forklift::store::printable_location(cfg.db_path)
              << ", DDS domain " << api.dds_domain() << ")" << std::endl;
    svr->listen_after_bind();
    g_server = nullptr;
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "forklift-server: " << e.what() << '\n';
    return 2;
  }
}
