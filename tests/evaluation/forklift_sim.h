// Whole drives through forklift-sim, for the exam tests: a session's controls written as a cab
// script, and `forklift-sim evaluate` run on one.
#pragma once

#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "evaluation/harness.h"
#include "support/process.h"

namespace evt {

// Writes the session's controls as the cab script `name` in the test's temporary folder, and into
// FORKLIFT_EVAL_SCRIPT_DIR when it is set (data/evaluation/scripts: how the shipped scripts are
// rewritten); `what` and the test file `by` go in its comment line. Returns the temporary path.
inline std::string write_script(const Session& s, const std::string& name, const std::string& what, const std::string& by) {
  const std::string path = testing::TempDir() + "/" + name;
  // The last row at the last tick: forklift-sim then runs exactly as many ticks as this session.
  const double end_s = (s.ticks - 1) * Session::kTick;
  const std::string comment = what + " (written by " + by + "; see data/evaluation/README.md)";
  s.write_script(path, end_s, comment);
  if (const char* dir = std::getenv("FORKLIFT_EVAL_SCRIPT_DIR")) s.write_script(std::string(dir) + "/" + name, end_s, comment);
  return path;
}

// forklift-sim evaluate --json with `args`; its JSON (and its raw output in `raw`).
inline nlohmann::json evaluate(const std::vector<std::string>& args, const std::string& tag, std::string* raw = nullptr) {
  std::vector<std::string> argv = {std::string(FORKLIFT_BIN_DIR) + "/forklift-sim", "evaluate", "--json"};
  argv.insert(argv.end(), args.begin(), args.end());
  Process p(argv, testing::TempDir() + "/evaluate_" + tag);
  const int code = p.wait(300);
  EXPECT_EQ(code, 0) << p.err();
  if (raw) *raw = p.out();
  return nlohmann::json::parse(p.out());
}

}  // namespace evt
