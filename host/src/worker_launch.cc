#include "forklift/host/worker_launch.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <dirent.h>

#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace forklift::host {

std::vector<std::string> worker_command(const WorkerLaunch& w) {
  std::vector<std::string> args = {w.binary, "--cab", w.cab, "--session", w.session, "--scenario", w.scenario_file,
                                   "--dds-domain", std::to_string(w.dds_domain), "--log", w.log_base + ".ctl",
                                   "--start-timeout", std::to_string(w.start_timeout_s), "--mode", name(w.mode)};
  if (w.duration_s) { args.push_back("--duration"); args.push_back(std::to_string(*w.duration_s)); }
  if (w.aids) { args.push_back("--aids"); args.push_back(*w.aids); }
  if (!w.language.empty()) { args.push_back("--language"); args.push_back(w.language); }
  if (!w.dds_config.empty()) { args.push_back("--dds-config"); args.push_back(w.dds_config); }
  if (!w.security_dir.empty()) { args.push_back("--security"); args.push_back(w.security_dir); }
  if (w.frames) {
    args.insert(args.end(), {"--fps", std::to_string(w.frames->fps), "--frame-size",
                             std::to_string(w.frames->width) + "x" + std::to_string(w.frames->height)});
    if (w.frames->jpeg) args.push_back("--jpeg");
  }
  if (w.realtime) args.push_back("--realtime");
  return args;
}

pid_t spawn_worker(const WorkerLaunch& w, bool die_with_parent) {
  std::vector<std::string> args = worker_command(w);
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const std::string out_file = w.log_base + ".out", err_file = w.log_base + ".err";
  std::remove((w.log_base + ".ctl.participant").c_str());  // a stale one must not vouch for anybody
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("cannot start a worker: ") + std::strerror(errno));
  if (pid == 0) {
    if (die_with_parent) {
      prctl(PR_SET_PDEATHSIG, SIGTERM);
      if (getppid() != parent) _exit(127);  // the parent died before the line above
    }
    const int out = open(out_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err = open(err_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (out >= 0) dup2(out, 1);
    if (err >= 0) dup2(err, 2);
    // Nothing else of the parent's: a worker holding a server's listening socket or database
    // would keep them after the server is gone.
    close_range(3, ~0U, 0);
    setpgid(0, 0);
    execv(argv[0], argv.data());
    _exit(127);
  }
  return pid;
}

std::string exit_words(int status) {
  if (WIFSIGNALED(status)) return "worker killed by signal " + std::to_string(WTERMSIG(status));
  if (WIFEXITED(status) && WEXITSTATUS(status) != 0) return "worker exited with code " + std::to_string(WEXITSTATUS(status));
  return "";
}

namespace {

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::optional<unsigned long long> start_ticks_of(pid_t pid) {
  const std::string stat = read_text("/proc/" + std::to_string(pid) + "/stat");
  const size_t paren = stat.rfind(')');  // the command name may hold spaces
  if (paren == std::string::npos) return std::nullopt;
  std::istringstream in(stat.substr(paren + 2));
  std::string field;
  // Fields 3.. follow the name; the start time is field 22.
  for (int i = 3; i < 22 && in >> field;) ++i;
  unsigned long long t = 0;
  if (!(in >> t)) return std::nullopt;
  return t;
}

std::optional<WorkerProcess> worker_of(pid_t pid, const std::string& log_dir) {
  const std::string raw = read_text("/proc/" + std::to_string(pid) + "/cmdline");
  std::vector<std::string> argv;
  for (size_t at = 0; at < raw.size();) {
    const size_t nul = raw.find('\0', at);
    argv.push_back(raw.substr(at, nul == std::string::npos ? std::string::npos : nul - at));
    at = nul == std::string::npos ? raw.size() : nul + 1;
  }
  if (argv.empty()) return std::nullopt;
  const std::string& exe = argv[0];
  if (exe.size() < 15 || exe.compare(exe.size() - 15, 15, "forklift-worker") != 0) return std::nullopt;
  WorkerProcess p;
  p.pid = pid;
  for (size_t i = 1; i + 1 < argv.size(); ++i) {
    if (argv[i] == "--session") p.session = argv[i + 1];
    else if (argv[i] == "--cab") p.cab = argv[i + 1];
    else if (argv[i] == "--log") p.log_path = argv[i + 1];
  }
  if (p.session.empty() || p.log_path != log_dir + "/" + p.session + ".ctl") return std::nullopt;
  const auto t = start_ticks_of(pid);
  if (!t) return std::nullopt;
  p.start_ticks = *t;
  return p;
}

}  // namespace

std::vector<WorkerProcess> find_workers(const std::string& log_dir) {
  std::vector<WorkerProcess> out;
  DIR* d = opendir("/proc");
  if (!d) return out;
  while (dirent* e = readdir(d)) {
    char* end = nullptr;
    const long pid = std::strtol(e->d_name, &end, 10);
    if (*end != '\0' || pid <= 0) continue;
    if (auto p = worker_of(static_cast<pid_t>(pid), log_dir)) out.push_back(*p);
  }
  closedir(d);
  return out;
}

bool still_running(const WorkerProcess& p) {
  if (p.pid <= 0 || kill(p.pid, 0) != 0) return false;
  const auto t = start_ticks_of(p.pid);
  if (!t || *t != p.start_ticks) return false;
  // A zombie (exited, not yet reaped by its parent) has ended.
  const std::string stat = read_text("/proc/" + std::to_string(p.pid) + "/stat");
  const size_t paren = stat.rfind(')');
  return paren == std::string::npos || paren + 2 >= stat.size() || stat[paren + 2] != 'Z';
}

}  // namespace forklift::host
