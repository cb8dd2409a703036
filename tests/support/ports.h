// One allocator for every test's loopback TCP port and DDS domain, so that `ctest -j2`, a
// repeated run and two checkouts tested on one machine never share one.
//
// Each number handed out is held by an flock on a file in $TMPDIR/forklift-test-locks (or
// /tmp/...) for the life of the test process: the kernel releases it when the process exits,
// however it exits, so a killed test leaks nothing. A port is also probed with bind() on
// 127.0.0.1, so a port some other program holds is skipped.
#pragma once

#include <fcntl.h>
#include <netinet/in.h>
#include <sys/file.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <mutex>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace forklift::test {
namespace ports_detail {

inline std::string lock_dir() {
  const char* tmp = std::getenv("TMPDIR");
  std::string d = std::string(tmp && *tmp ? tmp : "/tmp") + "/forklift-test-locks";
  mkdir(d.c_str(), 0777);
  return d;
}

// The descriptors of the locks this process holds.
inline std::vector<int>& held() {
  static std::vector<int> fds;
  return fds;
}

// Takes the lock for `name` if nobody holds it; the descriptor stays open (and the lock held)
// until the process exits.
inline bool try_hold(const std::string& name) {
  const int fd = open((lock_dir() + "/" + name).c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0666);
  if (fd < 0) return false;
  if (flock(fd, LOCK_EX | LOCK_NB) != 0) { close(fd); return false; }
  held().push_back(fd);
  return true;
}

inline bool bindable(int port) {
  const int s = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (s < 0) return false;
  int one = 1;
  setsockopt(s, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const bool ok = bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  close(s);
  return ok;
}

// Draws from [lo, hi] starting at a random place, so that parallel processes rarely race for
// the same lock; returns the first number whose lock (and `usable` check) it gets.
template <typename Usable>
int allocate(const char* kind, int lo, int hi, Usable usable) {
  static std::mutex mu;  // several threads of one test
  std::lock_guard<std::mutex> lock(mu);
  std::random_device rd;
  const int n = hi - lo + 1;
  const int start = static_cast<int>(rd() % static_cast<unsigned>(n));
  for (int i = 0; i < n; ++i) {
    const int v = lo + (start + i) % n;
    if (try_hold(std::string(kind) + "-" + std::to_string(v)) && usable(v)) return v;
  }
  throw std::runtime_error(std::string("no free test ") + kind + " left in " + std::to_string(lo) + "-" + std::to_string(hi));
}

}  // namespace ports_detail

// A TCP port on 127.0.0.1 nobody else uses, below Linux's ephemeral range.
inline int free_port() {
  return ports_detail::allocate("port", 20000, 32000, [](int p) { return ports_detail::bindable(p); });
}

// A DDS domain no other test uses (1-230: 0 is a school's default, and the school's DDS
// Security governance allows up to 230).
inline int free_domain() {
  return ports_detail::allocate("domain", 1, 230, [](int) { return true; });
}

// Hands the locks taken so far to the program this process exec()s next, and to that program's
// children, instead of dropping them at exec (forklift-test-alloc runs the web test so).
inline void keep_locks_across_exec() {
  for (const int fd : ports_detail::held()) fcntl(fd, F_SETFD, 0);
}

}  // namespace forklift::test
