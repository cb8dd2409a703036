// Every program speaks the same command line (docs/command-lines.md): --help lists its options
// with their defaults and exits 0, --version prints the version and exits 0, and bad usage (an
// unknown flag, a bad value) exits 2 with the reason on stderr and nothing on stdout. Built once
// per module with FORKLIFT_PROGRAMS naming that module's programs in build/bin, so each runs
// under its module's label.
#include <gtest/gtest.h>
#include <unistd.h>

#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "support/process.h"

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;

struct Ran {
  int code;
  std::string out, err;
};

Ran run(const std::string& program, const std::vector<std::string>& args) {
  static int n = 0;
  std::vector<std::string> argv = {kBin + "/" + program};
  argv.insert(argv.end(), args.begin(), args.end());
  // The process id in the name: ctest runs each case of this binary as its own process, at once.
  Process p(argv, testing::TempDir() + "/command-line-" + program + "-" + std::to_string(getpid()) + "-" + std::to_string(++n));
  const int code = p.wait(60);
  return {code, p.out(), p.err()};
}

std::vector<std::string> programs() {
  std::vector<std::string> names;
  std::istringstream list(FORKLIFT_PROGRAMS);
  for (std::string name; std::getline(list, name, ',');) names.push_back(name);
  return names;
}

// Options whose default --help must show: the help to ask for (a command's own, for programs
// with commands), the option and its default as CLI11 writes it ("--rate FLOAT=60").
struct Shown {
  std::vector<std::string> help;
  std::string option, value;
};
const std::multimap<std::string, Shown> kDefaults = {
    {"forklift-worker", {{"--help"}, "--rate", "=60"}},
    {"forklift-worker", {{"--help"}, "--fps", "=30"}},
    {"forklift-server", {{"--help"}, "--listen", "=127.0.0.1:8080"}},
    {"forklift-server", {{"--help"}, "--frame-size", "=640x480"}},
    {"forklift-menu", {{"--help"}, "--server", "=http://127.0.0.1:8080"}},
    {"forklift-menu", {{"start", "--help"}, "--mode", "=training"}},
    {"forklift-sim", {{"manoeuvre", "--help"}, "--integrator", "=cvode"}},
    {"forklift-cab", {{"--help"}, "--window-size", "=960x720"}},
    {"forklift-render", {{"--help"}, "--size", "=640x480"}},
    {"forklift-host", {{"--help"}, "--start-timeout", "=120"}},
    {"forklift-bench-dynamics", {{"--help"}, "--repeat", "=5"}},
    {"forklift-bench-dds", {{"--help"}, "--samples", "=500"}},
    {"forklift-bench-server", {{"--help"}, "--pupils", "=10000"}},
    {"forklift-bench-collision", {{"--help"}, "--benchmark_min_time", "=0.5"}},
    {"forklift-bench-evaluation", {{"--help"}, "--benchmark_format", "=console"}},
    {"forklift-bench-render", {{"--help"}, "--benchmark_repetitions", "=1"}}};

// Bad usage beyond an unknown flag, per program: a value the program must refuse.
const std::multimap<std::string, std::vector<std::string>> kBadValues = {
    {"forklift-worker", {"--rate", "0"}},
    // docs/command-lines.md: a port below 1024 is refused, as root too.
    {"forklift-server", {"--listen", "127.0.0.1:80"}},
    {"forklift-bench-collision", {"--benchmark_format=xml"}},
    {"forklift-bench-evaluation", {"--benchmark_min_time=soon"}},
    {"forklift-bench-render", {"--benchmark_repetitions=0"}}};

class CommandLine : public testing::TestWithParam<std::string> {};

TEST_P(CommandLine, HelpListsTheOptionsWithTheirDefaults) {
  const std::string program = GetParam();
  const Ran help = run(program, {"--help"});
  EXPECT_EQ(help.code, 0) << help.err;
  EXPECT_NE(help.out.find("--version"), std::string::npos) << help.out;
  EXPECT_EQ(help.err, "");
  const auto [first, last] = kDefaults.equal_range(program);
  EXPECT_NE(first, last) << "no default checked for " << program;
  for (auto it = first; it != last; ++it) {
    const Shown& d = it->second;
    const Ran r = run(program, d.help);
    ASSERT_EQ(r.code, 0) << r.err;
    std::istringstream lines(r.out);
    bool seen = false;
    for (std::string line; std::getline(lines, line);)
      if (line.find("  " + d.option + " ") != std::string::npos || line.find(d.option + ",") != std::string::npos) {
        seen = true;
        EXPECT_NE(line.find(d.value), std::string::npos) << d.option << " shows no default " << d.value << ":\n" << line;
      }
    EXPECT_TRUE(seen) << d.option << " not in:\n" << r.out;
  }
}

TEST_P(CommandLine, VersionIsPrinted) {
  const Ran r = run(GetParam(), {"--version"});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find(FORKLIFT_VERSION), std::string::npos) << r.out;
}

TEST_P(CommandLine, BadUsageExits2WithTheReasonOnStderr) {
  const std::string program = GetParam();
  std::vector<std::vector<std::string>> cases = {{"--no-such-flag"}};
  const auto [first, last] = kBadValues.equal_range(program);
  for (auto it = first; it != last; ++it) cases.push_back(it->second);
  for (const auto& args : cases) {
    const Ran r = run(program, args);
    EXPECT_EQ(r.code, 2) << args[0] << ": " << r.out << r.err;
    EXPECT_NE(r.err, "") << args[0];
    EXPECT_EQ(r.out, "") << args[0];
  }
}

INSTANTIATE_TEST_SUITE_P(Programs, CommandLine, testing::ValuesIn(programs()), [](const auto& info) {
  std::string name = info.param;
  for (char& c : name)
    if (c == '-') c = '_';
  return name;
});

}  // namespace
