#include "forklift/host/worker_launch.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace forklift::host {

std::vector<std::string> worker_command(const WorkerLaunch& w) {
  std::vector<std::string> args = {w.binary, "--cab", w.cab, "--session", w.session, "--scenario", w.scenario_file,
                                   "--dds-domain", std::to_string(w.dds_domain), "--log", w.log_base + ".ctl",
                                   "--start-timeout", std::to_string(w.start_timeout_s), "--mode", w.mode};
  if (w.duration_s) { args.push_back("--duration"); args.push_back(std::to_string(*w.duration_s)); }
  if (w.aids) { args.push_back("--aids"); args.push_back(*w.aids); }
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

}  // namespace forklift::host
