// A real forklift-worker for a test, and the summary it prints when it ends.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "support/process.h"

namespace forklift_test {

// forklift-worker (from `bin`) for `cab` and `session` on DDS domain `domain`, its log at
// <prefix><session>.ctl and its output at <prefix><session>.worker.{out,err} (its summary as JSON,
// for output_json); `extra` args after.
inline Process start_worker(const std::string& bin, const std::string& prefix, int domain, const std::string& cab,
                            const std::string& session, const std::vector<std::string>& extra = {}) {
  std::vector<std::string> args = {bin + "/forklift-worker", "--cab", cab, "--session", session,
                                   "--dds-domain", std::to_string(domain), "--log", prefix + session + ".ctl", "--json"};
  args.insert(args.end(), extra.begin(), extra.end());
  return Process(args, prefix + session + ".worker");
}

// A file in the test's temporary folder (the build tree's tests/tmp under ctest).
inline std::string temp_file(const std::string& name) { return testing::TempDir() + "/" + name; }

// The JSON summary a worker printed at its end; a test failure (and {}) when it printed none.
inline nlohmann::json output_json(const Process& p) {
  const std::string out = p.out();
  try {
    return nlohmann::json::parse(out);
  } catch (const std::exception&) {
    ADD_FAILURE() << "not JSON: " << out << "\nstderr: " << p.err();
    return nlohmann::json::object();
  }
}

// Waits until `folder` holds at least `n` files, at most `timeout_s`; the count it saw. For a cab
// saving every frame (--save-frames DIR --save-every 1): a worker renders at nice 10, so on a busy
// machine frames come when the rest of its work leaves room, and a test waits for them rather than
// for a set time.
inline size_t wait_for_files(const std::string& folder, size_t n, double timeout_s) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  size_t seen = 0;
  while (true) {
    std::error_code ec;
    seen = 0;
    for (auto it = std::filesystem::directory_iterator(folder, ec); !ec && it != std::filesystem::directory_iterator(); it.increment(ec))
      ++seen;
    if (seen >= n || std::chrono::steady_clock::now() >= until) return seen;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

}  // namespace forklift_test
