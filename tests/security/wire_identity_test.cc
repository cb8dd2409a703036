// Under DDS Security a worker's identity confines it to its own cab: the
// identity worker.cab2 cannot even write scores in cab1's worker partition, and what it writes in
// its own partition about a cab1 session is refused by the server and counted; the session keeps
// the mark its own worker logged. A real server, worker and cab, all with identities made by
// scripts/forklift-pki.sh.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "forklift/protocol/protocol.h"
#include "support/ports.h"
#include "support/server.h"
#include "support/temp_dir.h"

using namespace forklift_test;
namespace fs = std::filesystem;
namespace dds = forklift::dds;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;
const std::string kPki = std::string(FORKLIFT_SOURCE_DIR) + "/scripts/forklift-pki.sh";

std::string tmp(const std::string& name) { return forklift_test::process_path("wire-identity", name); }

double logged_mark(const std::string& log) {
  std::ifstream in(log);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("score ", 0) == 0) return std::strtod(line.substr(6).c_str(), nullptr);
  return -1;
}

}  // namespace

TEST(WireIdentity, AnotherCabsWorkerCannotMarkThisCabsSession) {
  const std::string pki = tmp("pki");
  fs::remove_all(pki);
  for (const std::string& cmd : {kPki + " init " + pki, kPki + " add-cab " + pki + " cab1", kPki + " add-cab " + pki + " cab2",
                                 kPki + " issue " + pki + " server main"})
    ASSERT_EQ(std::system((cmd + " >/dev/null 2>&1").c_str()), 0) << cmd;
  const int port = forklift::test::free_port(), domain = forklift::test::free_domain();
  Server s(port, domain, "wire-identity-" + std::to_string(port), {"--security", pki, "--frame-fps", "0"});
  const std::string admin = s.login("admin", kAdminPassword);
  const json pupil = s.call("POST", "/api/pupils", admin, R"({"name":"Ida Identity"})").second;
  auto [st, sess] = s.call("POST", "/api/sessions", admin,
                           json{{"pupil_id", pupil["id"]}, {"cab_id", "cab1"}, {"scenario", "manoeuvre_1"}, {"time_limit_s", 6}}.dump());
  ASSERT_EQ(st, 201) << sess;
  const std::string id = sess["id"];

  // The other cab's worker identity.
  dds::Participant rogue(dds::DomainSettings::resolve(domain, "", pki, "worker.cab2"));
  EXPECT_THROW(dds::Writer<fk_Score>(rogue, dds::worker_partition("cab1")), std::runtime_error)
      << "worker.cab2 may publish in cab1's worker partition";
  EXPECT_THROW(dds::Writer<fk_Score>(rogue, ""), std::runtime_error) << "worker.cab2 may publish scores for any cab";
  dds::Writer<fk_Score> scores(rogue, dds::worker_partition("cab2"));
  dds::Writer<fk_SessionStatus> statuses(rogue, dds::worker_partition("cab2"));
  for (int i = 0; i < 200 && (scores.matched() == 0 || statuses.matched() == 0); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ASSERT_GT(scores.matched(), 0) << "the server reads worker.* (worker.cab2 included)";
  fk_Score perfect{};
  dds::set_string(perfect.session_id, id);
  perfect.mark = 99.25;  // no evaluation's mark: a forged one is told apart
  perfect.passed = true;
  ASSERT_TRUE(scores.write(perfect));
  fk_SessionStatus ended{};
  dds::set_string(ended.session_id, id);
  dds::set_string(ended.cab_id, "cab1");
  dds::set_string(ended.state, "ended");
  ASSERT_TRUE(statuses.write(ended));

  std::ofstream(tmp("drive.csv")) << "t,steer,accelerator,brake,lift,tilt,shift\n0,0,0.4,0,0,0,0\n2,0,0,1,0,0,0\n";
  Process cab({kBin + "/forklift-cab", "--cab", "cab1", "--script", tmp("drive.csv"), "--no-window", "--security", pki,
               "--dds-domain", std::to_string(domain), "--wait-worker", "30"},
              tmp("cab"));
  const json done = s.wait_session(admin, id, 40);
  EXPECT_EQ(done["state"], "ended") << done;
  EXPECT_EQ(done["reason"], "duration") << "a forged end would have no reason: " << done;
  ASSERT_FALSE(done["mark"].is_null()) << done;
  EXPECT_EQ(done["mark"].get<double>(), logged_mark(s.db + ".logs/" + id + ".ctl"));
  EXPECT_NE(done["mark"].get<double>(), 99.25);
  const json fleet = s.call("GET", "/api/fleet", admin).second;
  EXPECT_GE(fleet["refused_samples"]["wrong_sender"].get<int>(), 2) << fleet;
  cab.wait(20);
}
