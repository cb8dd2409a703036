// forklift-host: a simulation machine's agent. It tells the school's servers over DDS what it can
// take and starts and supervises the sim workers they place on it (see host_agent.h).
#include <csignal>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <iostream>
#include <vector>
#include <filesystem>
#include <memory>
#include <regex>
#include <thread>

#include "host_agent.h"

namespace {

std::atomic<bool> g_stop{false}, g_restart{false};
void on_signal(int) { g_stop = true; }
void on_restart(int) {
  g_restart = true;
  g_stop = true;
}

std::string default_log_dir(const std::string& host_id) {
  if (const char* env = std::getenv("FORKLIFT_LOG_DIR")) return env;
  const char* home = std::getenv("HOME");
  return std::string(home ? home : ".") + "/.local/state/forklift/host-" + host_id;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"forklift-host: runs the sim workers the school's servers place on this machine, and tells them what it "
               "can take (DDS: fk_HostStatus, fk_WorkerRequest, fk_WorkerReport in partition host.<id>)"};
  app.set_version_flag("--version", FORKLIFT_VERSION);
  app.option_defaults()->always_capture_default();  // --help shows each option's default
  forklift::host::HostConfig c;
  c.capacity = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()) * 4);
  std::optional<int> domain;
  app.add_option("--host-id", c.host_id, "this machine's name among the school's worker hosts (letters, digits, - or _)")
      ->required()
      ->check([](const std::string& v) {
        return std::regex_match(v, std::regex("[A-Za-z0-9_-]{1,32}")) ? std::string() : std::string("1-32 letters, digits, - or _");
      });
  app.add_option("--site", c.site, "where this machine stands (a room, a test centre): cabs at the same site get their workers here first")
      ->check([](const std::string& v) { return v.size() <= 63 ? std::string() : std::string("at most 63 bytes"); });
  app.add_option("--capacity", c.capacity, "sim workers this machine runs at once (default 4 per core; with 30 fps frames about 2.5 per core)")
      ->check(CLI::Range(1, 256));
  app.add_option("--log-dir", c.log_dir, "where the workers' session logs, output and scenarios go "
                 "(default: FORKLIFT_LOG_DIR, or ~/.local/state/forklift/host-<id>)");
  app.add_option("--worker", c.worker_binary, "the forklift-worker program (default: the one beside this program)")->check(CLI::ExistingFile);
  app.add_option("--start-timeout", c.start_timeout_s, "a worker whose cab never speaks gives up after this long, s")->check(CLI::Range(1.0, 3600.0));
  app.add_option("--dds-domain", domain, "DDS domain id (default FORKLIFT_DDS_DOMAIN or 0)")->check(CLI::Range(0, 232));
  app.add_option("--dds-config", c.dds_config, "Cyclone DDS configuration file (default: loopback; protocol/config/lan.xml on a school network)")
      ->check(CLI::ExistingFile);
  app.add_option("--security", c.security_dir, "the school's DDS Security folder (scripts/forklift-pki.sh; default FORKLIFT_SECURITY_DIR), "
                 "with this host's identity and the workers' identities of the cabs it serves");
  app.add_option("--identity", c.identity, "this host's identity in it (default host.<id>)");
  app.add_flag("--trust-clear-hosts", c.trust_clear, "run without DDS Security: then any machine on the network can start and "
               "stop this host's workers and speak for it, so only on a closed network the school alone can reach");
  app.add_flag("--realtime-workers", c.realtime_workers, "workers run their tick at real-time priority (forklift-worker --realtime; "
               "needs CAP_SYS_NICE or an rtprio limit, e.g. systemd's LimitRTPRIO=10): each cab keeps real time on a full machine");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help and --version: 0; bad usage: 2, as every program
  }
  if (c.security_dir.empty())
    if (const char* env = std::getenv("FORKLIFT_SECURITY_DIR")) c.security_dir = env;
  if (c.security_dir.empty() && !c.trust_clear) {
    std::cerr << "forklift-host: a worker host runs with the school's DDS Security (--security DIR, or FORKLIFT_SECURITY_DIR), "
                 "so that only the school's servers can start and stop its workers and only its reports are believed. On a "
                 "closed network the school alone can reach, --trust-clear-hosts runs it without.\n";
    return 2;
  }
  if (c.log_dir.empty()) c.log_dir = default_log_dir(c.host_id);
  const std::filesystem::path self = std::filesystem::canonical("/proc/self/exe");
  if (c.worker_binary.empty()) c.worker_binary = (self.parent_path() / "forklift-worker").string();
  c.data_dir = FORKLIFT_DATA_DIR;
  try {
    if (!std::filesystem::exists(c.worker_binary)) throw std::runtime_error("there is no worker program at " + c.worker_binary + " (give --worker)");
    std::filesystem::create_directories(c.log_dir);
    c.dds_domain = static_cast<int>(forklift::dds::DomainSettings::resolve(domain, c.dds_config).domain_id);
    auto agent = std::make_unique<forklift::host::HostAgent>(c);
    std::signal(SIGTERM, on_signal);
    std::signal(SIGINT, on_signal);
    std::signal(SIGHUP, on_restart);
    if (c.security_dir.empty())
      spdlog::warn("host {} runs without DDS Security (--trust-clear-hosts): any machine on this network can start and stop "
                   "its workers; training only", c.host_id);
    spdlog::info("host {} ready: up to {} workers, logs in {}, DDS domain {}", c.host_id, c.capacity, c.log_dir, c.dds_domain);
    agent->run(g_stop, g_restart);
    if (g_restart) {
      // SIGHUP: the agent starts again in place (a new program file, say) and adopts the workers,
      // which keep running meanwhile; the pid stays, so they stay its children.
      spdlog::info("host {} restarting in place", c.host_id);
      std::vector<char*> args(argv, argv + argc);
      args.push_back(nullptr);
      agent.reset();  // the DDS participant goes before the new one comes
      execv(self.c_str(), args.data());
      spdlog::error("could not restart: {}", std::strerror(errno));
      return 1;
    }
    spdlog::info("host {} stopped", c.host_id);
    return 0;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
