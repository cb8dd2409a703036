// CPU time from /proc, for the benchmarks that say what a process (or one of its threads) spent.
#pragma once

#include <unistd.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

namespace forklift::bench {

// CPU seconds (user + system) in a /proc stat file, a process's or a thread's; NaN if unreadable.
inline double cpu_seconds_in(const std::string& stat_path) {
  std::ifstream in(stat_path);
  std::string stat;
  if (!std::getline(in, stat)) return NAN;
  // Fields after the command's closing parenthesis (the name may hold spaces): state is field 3,
  // utime 14, stime 15.
  const size_t close = stat.rfind(')');
  if (close == std::string::npos) return NAN;
  std::istringstream rest(stat.substr(close + 2));
  std::string field;
  double utime = 0, stime = 0;
  for (int i = 3; i <= 15 && rest >> field; ++i) {
    if (i == 14) utime = std::stod(field);
    if (i == 15) stime = std::stod(field);
  }
  return (utime + stime) / double(sysconf(_SC_CLK_TCK));
}

inline double cpu_seconds(pid_t pid) { return cpu_seconds_in("/proc/" + std::to_string(pid) + "/stat"); }

}  // namespace forklift::bench
