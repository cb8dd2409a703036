#include "realtime.h"

#include <sched.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace forklift::worker {
namespace {

std::string read_first_line(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

// SCHED_FIFO for thread `tid`; reset on fork, so nothing the worker starts inherits it.
int make_fifo(pid_t tid) {
  sched_param p{};
  p.sched_priority = kRealtimePriority;
  return sched_setscheduler(tid, SCHED_FIFO | SCHED_RESET_ON_FORK, &p) == 0 ? 0 : errno;
}

}  // namespace

std::string enter_realtime() {
  const pid_t self = static_cast<pid_t>(syscall(SYS_gettid));
  if (const int err = make_fifo(self); err != 0)
    return err == EPERM ? "real-time priority not permitted (needs CAP_SYS_NICE or an rtprio limit of " +
                              std::to_string(kRealtimePriority) + ", e.g. systemd's LimitRTPRIO)"
                        : std::string("real-time priority refused: ") + std::strerror(err);
  // Cyclone DDS names its receive threads "recv" (and "recvUC", "recvMC"): the cab's controls
  // reach the tick through them.
  std::error_code ec;
  for (const auto& task : std::filesystem::directory_iterator("/proc/self/task", ec)) {
    if (read_first_line(task.path() / "comm").rfind("recv", 0) != 0) continue;
    const pid_t tid = static_cast<pid_t>(std::stol(task.path().filename().string()));
    if (const int err = make_fifo(tid); err != 0)
      return std::string("real-time priority for DDS's receive thread refused: ") + std::strerror(err);
  }
  return "";
}

void leave_realtime() {
  sched_param p{};
  sched_setscheduler(static_cast<pid_t>(syscall(SYS_gettid)), SCHED_OTHER, &p);
}

}  // namespace forklift::worker
