// forklift-menu start --drive on a server set up for exams, under DDS Security: the scripted cab
// it starts takes the school's security folder (the server's own, on the server's machine, or
// --security), so its session runs to its end and the menu exits 0; a cab with no identity in the
// folder starts no session, and a session that does not run to its end (aborted here: a failed
// one takes the same way out) makes the menu exit 3, saying why. A real server, worker and cab,
// with identities made by scripts/forklift-pki.sh.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "support/cab_script.h"
#include "support/ports.h"
#include "support/process.h"
#include "support/server.h"
#include "support/temp_dir.h"

using namespace forklift_test;
namespace fs = std::filesystem;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;
const std::string kPki = std::string(FORKLIFT_SOURCE_DIR) + "/scripts/forklift-pki.sh";

std::string tmp(const std::string& name) { return forklift_test::process_path("menu-drive", name); }

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

std::vector<std::string> menu_args(const Server& s, std::vector<std::string> args) {
  args.insert(args.begin(), {kBin + "/forklift-menu", "--server", s.url(), "--token-file", tmp("token")});
  return args;
}

}  // namespace

TEST(MenuDrive, AScriptedCabDrivesUnderTheServersDdsSecurityAndAnUnfinishedSessionFailsTheMenu) {
  unsetenv("FORKLIFT_SECURITY_DIR");  // the server's folder, found through the server, or --security
  const std::string pki = tmp("pki");
  fs::remove_all(pki);
  for (const std::string& cmd : {kPki + " init " + pki, kPki + " add-cab " + pki + " cab1", kPki + " issue " + pki + " server main"})
    ASSERT_EQ(std::system((cmd + " >/dev/null 2>&1").c_str()), 0) << cmd;
  Server s("menu-drive", {"--security", pki, "--frame-fps", "0"});
  const std::string admin = s.login("admin", kAdminPassword);
  const json fleet = s.call("GET", "/api/fleet", admin).second;
  EXPECT_EQ(fleet["dds_security"], true) << fleet;
  EXPECT_EQ(fleet["dds_security_dir"], pki) << fleet;
  int runs = 0;
  auto menu = [&](std::vector<std::string> args) { return Process(menu_args(s, std::move(args)), tmp("menu-" + std::to_string(++runs))); };
  Process login = menu({"login", "--user", "admin", "--password", kAdminPassword});
  ASSERT_EQ(login.wait(30), 0) << login.err();
  const json pupil = s.call("POST", "/api/pupils", admin, R"({"name":"Sam Secure"})").second;
  const std::string id = std::to_string(pupil["id"].get<int64_t>());

  // The server's own folder: the cab speaks to its worker, the session runs its 3 s and is marked.
  Process drive = menu({"start", "--pupil", id, "--cab", "cab1", "--scenario", "manoeuvre_1", "--time-limit", "3", "--drive",
                        short_script(fs::path(tmp("")).string(), 1.0)});
  ASSERT_EQ(drive.wait(180), 0) << drive.out() << drive.err();
  EXPECT_TRUE(contains(drive.out(), "ended")) << drive.out();
  EXPECT_TRUE(contains(drive.out(), "of 100")) << drive.out();

  // A cab with no identity in the folder given: refused in words before any session is made.
  const size_t sessions = s.call("GET", "/api/sessions?limit=100", admin).second["sessions"].size();
  Process stranger = menu({"start", "--pupil", id, "--cab", "cab9", "--scenario", "manoeuvre_1", "--security", pki, "--drive",
                           short_script(fs::path(tmp("")).string(), 1.0)});
  EXPECT_EQ(stranger.wait(60), 2) << stranger.out() << stranger.err();
  EXPECT_TRUE(contains(stranger.err(), "has no identities/cab.cab9")) << stranger.err();
  EXPECT_EQ(s.call("GET", "/api/sessions?limit=100", admin).second["sessions"].size(), sessions) << "no session was made";

  // A session that does not run to its end: the menu says so and exits 3. (Once the first
  // session's worker has gone: it signs its log after the session ends, and the cab is busy until then.)
  // (The fleet's workers, not /api/cabs: that lists only the cabs the school has registered.)
  // (The answer is kept: a range-for over a member of the call's temporary would read freed memory.)
  auto busy = [&] {
    const json fleet = s.call("GET", "/api/fleet", admin).second;
    for (const json& w : fleet["workers"])
      if (w.value("cab", "") == "cab1") return true;
    return false;
  };
  for (int i = 0; i < 600 && busy(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  Process long_drive = menu({"start", "--pupil", id, "--cab", "cab1", "--scenario", "manoeuvre_1", "--time-limit", "60", "--security",
                             pki, "--drive", short_script(fs::path(tmp("")).string(), 30.0)});
  std::smatch started;
  std::string out;
  for (int i = 0; i < 600 && !std::regex_search(out = long_drive.out(), started, std::regex("session (s-[0-9]+) started")) &&
                  long_drive.running();
       ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_FALSE(started.empty()) << out << long_drive.err();
  const std::string session = started[1];
  for (int i = 0; i < 300 && s.call("GET", "/api/sessions/" + session, admin).second["state"] != "running"; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_EQ(s.call("POST", "/api/sessions/" + session + "/abort", admin).first, 200);
  EXPECT_EQ(long_drive.wait(120), 3) << long_drive.out() << long_drive.err();
  EXPECT_TRUE(contains(long_drive.err(), "session " + session + " did not run to its end")) << long_drive.err();
  EXPECT_TRUE(contains(long_drive.err(), "aborted")) << long_drive.err();
}
