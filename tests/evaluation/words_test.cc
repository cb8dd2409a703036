// forklift-sim evaluate and forklift-worker --replay speak to a person: a drive with faults,
// offline, gives its events as the debrief words them (each rule's title from the rules file, what
// was measured against its limit in units) and its mark "of 100", with no JSON, no hex float, no
// null and no code such as time_limit; --json gives the same events to a script.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <vector>

#include "support/process.h"

namespace {

using nlohmann::json;

const std::string kBin = FORKLIFT_BIN_DIR, kData = FORKLIFT_DATA_DIR;

struct Ran {
  int code;
  std::string out, err;
};

Ran run(const std::vector<std::string>& argv, const std::string& tag) {
  Process p(argv, testing::TempDir() + "/words_" + tag);
  const int code = p.wait(300);
  return {code, p.out(), p.err()};
}

// What a person must never read. The identifiers a person types (the scenario's name, its file)
// are taken out first.
void expect_words(const std::string& what, std::string text, const std::vector<std::string>& names) {
  SCOPED_TRACE(what + ":\n" + text);
  EXPECT_FALSE(text.empty());
  for (const char* bad : {"{", "}", "0x", "\"", "null", "nan", "inf "}) EXPECT_EQ(text.find(bad), std::string::npos) << "has " << bad;
  for (const std::string& n : names)
    for (size_t at; (at = text.find(n)) != std::string::npos;) text.erase(at, n.size());
  std::smatch code;
  EXPECT_FALSE(std::regex_search(text, code, std::regex("\\b[a-z]+_[a-z_]+\\b"))) << "has the code " << code.str();
}

TEST(Words, EvaluateAndTheWorkersReplayPrintEventsAndMarkInWordsJsonOnlyWhenAsked) {
  const std::string scenario = kData + "/scenarios/first_drive_yard.json";
  const std::string script = kData + "/evaluation/scripts/first_drive_yard_faults.csv";
  const std::string log = testing::TempDir() + "/words_faults.ctl";
  const Ran text = run({kBin + "/forklift-sim", "evaluate", "--scenario", scenario, "--script", script, "--out-log", log}, "text");
  ASSERT_EQ(text.code, 0) << text.err;
  const Ran as_json = run({kBin + "/forklift-sim", "evaluate", "--json", "--scenario", scenario, "--script", script}, "json");
  ASSERT_EQ(as_json.code, 0) << as_json.err;
  const json result = json::parse(as_json.out);
  ASSERT_FALSE(result["events"].empty()) << "the faulty drive has events";
  const std::vector<std::string> names = {scenario, "first_drive_yard"};
  expect_words("forklift-sim evaluate", text.out, names);

  // Each event, in the rules file's title, at its time; the mark of 100.
  std::ifstream rules_file(kData + "/evaluation/rules.json");
  const json rules = json::parse(rules_file);
  for (const json& e : result["events"]) {
    std::string title;
    for (const json& r : rules["rules"])
      if (r["id"] == e["rule"]) title = r.value("title", "");
    ASSERT_FALSE(title.empty()) << e["rule"] << " has a title in rules.json";
    EXPECT_NE(text.out.find(title), std::string::npos) << title << " in:\n" << text.out;
  }
  size_t lines = 0;
  for (size_t at = 0; (at = text.out.find("\n  at ", at)) != std::string::npos; ++at) ++lines;
  EXPECT_EQ(lines, result["events"].size()) << text.out;
  char mark[64];
  std::snprintf(mark, sizeof mark, "mark %.0f of 100", result["score"]["mark"].get<double>());
  EXPECT_NE(text.out.find(mark), std::string::npos) << mark << " in:\n" << text.out;

  // The worker's replay of the same log, in words too (--json for a script).
  const Ran replay = run({kBin + "/forklift-worker", "--replay", log}, "replay");
  EXPECT_EQ(replay.code, 0) << replay.err;
  expect_words("forklift-worker --replay", replay.out, names);
  EXPECT_NE(replay.out.find(mark), std::string::npos) << replay.out;
  EXPECT_NO_THROW((void)json::parse(run({kBin + "/forklift-worker", "--replay", log, "--json"}, "replay_json").out));
}

}  // namespace
