// A real forklift-worker for a test, and the summary it prints when it ends.
#pragma once

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "support/process.h"

namespace forklift_test {

// forklift-worker (from `bin`) for `cab` and `session` on DDS domain `domain`, its log at
// <prefix><session>.ctl and its output at <prefix><session>.worker.{out,err}; `extra` args after.
inline Process start_worker(const std::string& bin, const std::string& prefix, int domain, const std::string& cab,
                            const std::string& session, const std::vector<std::string>& extra = {}) {
  std::vector<std::string> args = {bin + "/forklift-worker", "--cab", cab, "--session", session,
                                   "--dds-domain", std::to_string(domain), "--log", prefix + session + ".ctl"};
  args.insert(args.end(), extra.begin(), extra.end());
  return Process(args, prefix + session + ".worker");
}

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

}  // namespace forklift_test
