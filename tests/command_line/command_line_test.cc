// Every program speaks the same command line (docs/command-lines.md): --help lists its options
// with their defaults and exits 0, --version prints the version and exits 0, and bad usage (an
// unknown flag, a bad value) exits 2 with the reason on stderr and nothing on stdout. Built once
// per module with FORKLIFT_PROGRAMS naming that module's programs in build/bin, so each runs
// under its module's label.
#include <gtest/gtest.h>
#include <unistd.h>

#include <map>
#include <regex>
#include <set>
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
    {"forklift-bench-ingest", {{"--help"}, "--rate", "=60"}},
    {"forklift-bench-collision", {{"--help"}, "--benchmark_min_time", "=0.5"}},
    {"forklift-bench-evaluation", {{"--help"}, "--benchmark_format", "=console"}},
    {"forklift-bench-render", {{"--help"}, "--benchmark_repetitions", "=1"}}};

// Options that take a value and have no default, per program (and command): nothing to show,
// since without them the program names, writes or reads nothing of theirs. Every other option
// that takes a value shows its default, as CLI11 writes it ("=60") or in words ("default ...").
const std::multimap<std::string, std::string> kNoDefault = {
    {"forklift-bench-collision", "--benchmark_out"}, {"forklift-bench-evaluation", "--benchmark_out"},
    {"forklift-bench-render", "--benchmark_out"},
    {"forklift-cab", "--cab"}, {"forklift-cab", "--site"}, {"forklift-cab", "--save-frame"}, {"forklift-cab", "--save-frames"},
    {"forklift-cab", "--save-window"}, {"forklift-cab", "--scenario"}, {"forklift-cab", "--trace"}, {"forklift-cab", "--script"}, {"forklift-cab", "--joystick"},
    {"forklift-host", "--site"},
    {"forklift-menu", "login --password"}, {"forklift-menu", "pupil-add --email"}, {"forklift-menu", "pupil-add --user"},
    {"forklift-menu", "pupil-add --password"}, {"forklift-menu", "pupils --search"}, {"forklift-menu", "start --drive"},
    {"forklift-menu", "start --save-frame"}, {"forklift-menu", "follow --frame"},
    {"forklift-render", "--out"},
    {"forklift-server", "--dds-config"}, {"forklift-server", "--tls-cert"}, {"forklift-server", "--tls-key"},
    {"forklift-server", "--admin-password"},
    {"forklift-sim", "manoeuvre --csv"}, {"forklift-sim", "manoeuvre --plot"}, {"forklift-sim", "script --scenario-out"},
    {"forklift-sim", "evaluate --scenario"}, {"forklift-sim", "evaluate --script"}, {"forklift-sim", "evaluate --replay"},
    {"forklift-sim", "evaluate --out-log"}, {"forklift-sim", "trace --scenario"},
    {"forklift-worker", "--cab"}, {"forklift-worker", "--session"}, {"forklift-worker", "--scenario"}, {"forklift-worker", "--replay"}};

// Bad usage beyond an unknown flag, per program: a value the program must refuse.
const std::multimap<std::string, std::vector<std::string>> kBadValues = {
    {"forklift-worker", {"--rate", "0"}},
    // docs/command-lines.md: a port below 1024 is refused, as root too.
    {"forklift-server", {"--listen", "127.0.0.1:80"}},
    {"forklift-server", {"--public-url", "forklift.example.org"}},
    {"forklift-bench-server", {"--port", "80"}},
    {"forklift-bench-ingest", {"--port", "80"}},
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

// The commands a program's --help lists under "Subcommands:", for their own --help.
std::vector<std::string> commands(const std::string& help) {
  std::vector<std::string> out;
  const size_t at = help.find("\nSubcommands:\n");
  if (at == std::string::npos) return out;
  std::istringstream lines(help.substr(at + 14));
  for (std::string line; std::getline(lines, line) && line.rfind("  ", 0) == 0;) {
    std::istringstream words(line);
    std::string name;
    if (words >> name) out.push_back(name);
  }
  return out;
}

// Every option of the program and of each of its commands that takes a value (a TEXT, INT, FLOAT
// or UINT after its name) and is not REQUIRED shows its default, or is one of kNoDefault.
TEST_P(CommandLine, EveryOptionWithADefaultShowsIt) {
  const std::string program = GetParam();
  const Ran top = run(program, {"--help"});
  ASSERT_EQ(top.code, 0) << top.err;
  std::vector<std::pair<std::string, std::string>> helps = {{"", top.out}};  // command, its help
  for (const std::string& c : commands(top.out)) {
    const Ran r = run(program, {c, "--help"});
    ASSERT_EQ(r.code, 0) << c << ": " << r.err;
    helps.emplace_back(c + " ", r.out);
  }
  std::set<std::string> exempt;
  const auto [first, last] = kNoDefault.equal_range(program);
  for (auto it = first; it != last; ++it) exempt.insert(it->second);
  const std::regex option_line(R"(^\s+(?:-\w,)?(--[\w-]+) (TEXT|INT|FLOAT|UINT)\b(.*)$)");
  int checked = 0;
  for (const auto& [command, help] : helps) {
    std::vector<std::string> lines;
    std::istringstream in(help);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    for (size_t i = 0; i < lines.size(); ++i) {
      std::smatch m;
      if (!std::regex_match(lines[i], m, option_line)) continue;
      // The option's description: the rest of its line and the lines indented under it.
      std::string text = m[3];
      for (size_t j = i + 1; j < lines.size() && lines[j].find_first_not_of(' ') >= 20 &&
                             lines[j].find_first_not_of(' ') != std::string::npos && lines[j][lines[j].find_first_not_of(' ')] != '-';
           ++j)
        text += " " + lines[j];
      if (text.find("REQUIRED") != std::string::npos) continue;
      ++checked;
      const std::string name = command + m[1].str();
      const bool shown = text.find('=') != std::string::npos || text.find("default") != std::string::npos;
      if (exempt.count(name)) {
        EXPECT_FALSE(shown) << name << " shows a default: take it out of kNoDefault\n" << lines[i];
        continue;
      }
      EXPECT_TRUE(shown) << program << " " << name << " shows no default:\n" << lines[i] << text;
    }
  }
  EXPECT_GT(checked, 0) << program << ": no option with a value found in its help";
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
