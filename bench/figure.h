// A row of the table of figures (docs/figures.md): bench/figures.sh collects the lines a benchmark prints
// as "FIGURE<tab>figure<tab>goal<tab>measured<tab>met".
#pragma once

#include <cstdio>
#include <string>

namespace forklift::bench {

inline void figure(const std::string& what, const std::string& goal, const std::string& measured, bool met) {
  std::printf("FIGURE\t%s\t%s\t%s\t%s\n", what.c_str(), goal.c_str(), measured.c_str(), met ? "yes" : "NO");
  std::fflush(stdout);
}

// A row measured for comparison beside a goal's own (another setting of the same figure): no goal.
inline void comparison(const std::string& what, const std::string& measured) {
  std::printf("FIGURE\t%s\t(comparison)\t%s\t-\n", what.c_str(), measured.c_str());
  std::fflush(stdout);
}

template <class... A>
std::string fmt(const char* f, A... a) {
  char buf[256];
  std::snprintf(buf, sizeof buf, f, a...);
  return buf;
}

}  // namespace forklift::bench
