// The shipped cab scripts (data/evaluation/scripts/drives.json) driven live, as a school runs
// them: a session started through the server's API, its worker spawned by the server, the script
// played by a real forklift-cab over DDS at real time, the mark and the events read back from the
// server. A clean drive ends its task with no event and mark 100; a faulty one gives exactly the
// faults it names. All at once, one cab each, so the test takes as long as the longest script.
// Scripts longer than 150 s are left to FORKLIFT_LIVE_ALL=1 (the whole test then takes 280 s): the
// exam course's runs live under DDS Security in tests/security/exam_record_test.cc, and the clean
// practical exam and lorry loading (4 and 4.5 min) are driven in the suite through a SessionRun
// (ShippedDrive). Here every drive runs in training (an exam needs DDS Security), whose rules
// are the exam's.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "support/process.h"
#include "support/server.h"

using nlohmann::json;
using forklift_test::kAdminPassword;
using forklift_test::Server;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;
const std::string kData = FORKLIFT_DATA_DIR;
constexpr double kLongestInTheSuite_s = 150;

// The script's last row's time: how long it drives.
double script_length_s(const std::string& path) {
  std::ifstream f(path);
  std::string line, last;
  while (std::getline(f, line))
    if (!line.empty() && line[0] != '#') last = line;
  return std::stod(last.substr(0, last.find(',')));
}

struct Drive {
  std::string script, scenario;
  std::set<std::string> faults;
  double length_s = 0;
  std::string cab, session;
  std::unique_ptr<Process> cab_process;
};

}  // namespace

TEST(ShippedDrivesLive, EachDrivesLiveToWhatItNames) {
  std::vector<Drive> drives;
  const json listed = json::parse(std::ifstream(kData + "/evaluation/scripts/drives.json"));
  for (const json& d : listed.at("drives")) {
    Drive drive;
    drive.script = d.at("script");
    drive.length_s = script_length_s(kData + "/evaluation/scripts/" + drive.script);
    if (drive.length_s > kLongestInTheSuite_s && !std::getenv("FORKLIFT_LIVE_ALL")) continue;
    const std::string scenario = d.at("scenario");  // "scenarios/NAME.json"
    drive.scenario = scenario.substr(scenario.rfind('/') + 1, scenario.size() - scenario.rfind('/') - 6);
    drive.faults = d.at("faults").get<std::set<std::string>>();
    drives.push_back(std::move(drive));
  }
  ASSERT_GE(drives.size(), 6u);

  // Faults are the evaluation's rules; the log's other events (a pallet picked up, set down) are not.
  std::set<std::string> rule_ids;
  const json rules_file = json::parse(std::ifstream(kData + "/evaluation/rules.json"));
  for (const json& r : rules_file.at("rules")) rule_ids.insert(r.at("id"));
  ASSERT_GT(rule_ids.count("collision_cone"), 0u);

  Server s("shipped_live", {"--max-workers", "16"});  // one per drive, more than a default machine runs
  const std::string admin = s.login("admin", kAdminPassword);
  const json pupil = s.call("POST", "/api/pupils", admin, R"({"name":"Lia Live"})").second;
  ASSERT_TRUE(pupil.contains("id")) << pupil;
  for (size_t i = 0; i < drives.size(); ++i) {
    Drive& d = drives[i];
    d.cab = "live" + std::to_string(i);
    // A clean drive ends with its task; a faulty one at its script's end, as forklift-sim
    // evaluate ends it, where the time given runs out (so it is not judged as parked), before
    // the dead man would stop a truck whose cab has gone quiet.
    const double limit_s = d.faults.empty() ? std::ceil(d.length_s + 30) : d.length_s + 0.1;
    const auto [st, sess] = s.call("POST", "/api/sessions", admin,
                                   json{{"pupil_id", pupil["id"]}, {"cab_id", d.cab}, {"scenario", d.scenario},
                                        {"time_limit_s", limit_s}}.dump());
    ASSERT_EQ(st, 201) << d.script << ": " << sess;
    d.session = sess["id"];
    d.cab_process = std::make_unique<Process>(
        std::vector<std::string>{kBin + "/forklift-cab", "--cab", d.cab, "--script", kData + "/evaluation/scripts/" + d.script,
                                 "--dds-domain", std::to_string(s.domain), "--wait-worker", "60", "--no-window", "--no-sound"},
        s.dir + "/cab-" + d.cab);
  }
  for (Drive& d : drives) {
    SCOPED_TRACE(d.script);
    const json done = s.wait_session(admin, d.session, d.length_s + 120);
    ASSERT_EQ(done["state"], "ended") << done.dump(1);
    std::set<std::string> rules;
    std::ostringstream events;
    for (const json& e : done["events"]) {
      if (rule_ids.count(e["kind"].get<std::string>())) rules.insert(e["kind"].get<std::string>());
      events << "  " << e["sim_time_s"] << " s " << e["kind"].get<std::string>() << "\n";
    }
    EXPECT_EQ(rules, d.faults) << events.str() << d.cab_process->out();
    if (d.faults.empty()) {
      EXPECT_EQ(done["reason"], "task_complete") << done.dump(1);
      EXPECT_EQ(done["score"]["mark"], 100) << done["score"];
    }
  }
}
