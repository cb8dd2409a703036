// Losing nothing across a server restart: a real forklift-server
// killed with SIGKILL while its workers run on, then started again on the same SQLite file and
// log folder. A session that ended while no server listened is stored as its worker's log says;
// a worker left by a session that was still "starting" is adopted (its cab stays busy); a worker
// whose session is not open is stopped.
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

#include "support/cab_script.h"
#include "support/ports.h"
#include "support/process.h"
#include "support/server.h"

using forklift_test::error_code;
using forklift_test::kAdminPassword;
using forklift_test::Server;
using forklift_test::short_script;
using nlohmann::json;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;

Process cab(const Server& s, const std::string& id, const std::string& script) {
  return Process({kBin + "/forklift-cab", "--cab", id, "--script", script, "--no-window", "--dds-domain", std::to_string(s.domain),
                  "--wait-worker", "20"},
                 s.dir + "/cab-" + id);
}

void sql(const std::string& db, const std::string& statement) {
  sqlite3* h = nullptr;
  ASSERT_EQ(sqlite3_open(db.c_str(), &h), SQLITE_OK);
  sqlite3_busy_timeout(h, 5000);
  char* err = nullptr;
  const int rc = sqlite3_exec(h, statement.c_str(), nullptr, nullptr, &err);
  EXPECT_EQ(rc, SQLITE_OK) << (err ? err : "") << ": " << statement;
  sqlite3_free(err);
  sqlite3_close(h);
}

// Whether a process is still running (a zombie nobody reaps has ended).
bool alive(int pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
  const size_t paren = text.rfind(')');
  return paren != std::string::npos && paren + 2 < text.size() && text[paren + 2] != 'Z';
}

bool wait_gone(int pid, double seconds) {
  for (int i = 0; i < seconds * 20 && alive(pid); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  return !alive(pid);
}

json wait_state(const Server& s, const std::string& token, const std::string& id, const std::string& state, double seconds) {
  json j;
  for (int i = 0; i < seconds * 10; ++i) {
    j = s.call("GET", "/api/sessions/" + id, token).second;
    if (j.value("state", "") == state) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return j;
}

int worker_pid(const Server& s, const std::string& token, const std::string& id) {
  const json fleet = s.call("GET", "/api/fleet", token).second;
  if (!fleet.contains("workers")) ADD_FAILURE() << fleet;
  for (const json& w : fleet["workers"])
    if (w["session"] == id) return w["pid"].get<int>();
  return 0;
}

// What the worker's session log says: its mark and how many events it published.
struct Logged {
  double mark = -1;
  bool passed = false;
  size_t events = 0;
  bool ended = false;
};
Logged read_log(const std::string& path) {
  Logged l;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    std::istringstream w(line);
    std::string k;
    w >> k;
    if (k == "e" || (k == "w" && line.find("no_controls_from_cab") == std::string::npos)) ++l.events;
    if (k == "score") {
      std::string mark;
      int passed = 0;
      w >> mark >> passed;
      l.mark = std::strtod(mark.c_str(), nullptr);
      l.passed = passed == 1;
    }
    if (k == "end") l.ended = true;
  }
  return l;
}

struct Started {
  std::string admin, id;
};
Started start_session(const Server& s, const std::string& cab_id, double time_limit_s) {
  Started st;
  st.admin = s.login("admin", kAdminPassword);
  const json pupil = s.call("POST", "/api/pupils", st.admin, R"({"name":"Rita Restart"})").second;
  auto [code, sess] = s.call("POST", "/api/sessions", st.admin,
                             json{{"pupil_id", pupil["id"]}, {"cab_id", cab_id}, {"scenario", "manoeuvre_1"},
                                  {"time_limit_s", time_limit_s}}.dump());
  EXPECT_EQ(code, 201) << sess;
  st.id = sess.value("id", "");
  return st;
}

// The session's worker waits for its cab when the server is killed: the worker's pid (0 if the
// session never got as far).
int kill_server_while_waiting(const Server& s, const Started& st) {
  if (wait_state(s, st.admin, st.id, "waiting", 30)["state"] != "waiting") return 0;
  const int pid = worker_pid(s, st.admin, st.id);
  s.proc->signal(SIGKILL);
  s.proc->wait(5);
  return pid;
}

}  // namespace

TEST(Recovery, ASessionThatEndsWhileTheServerIsDownIsStoredWithItsEventsAndMark) {
  const int port = forklift::test::free_port();
  Server s(port, forklift::test::free_domain(), "recovery-down-" + std::to_string(port));
  const Started st = start_session(s, "down1", 5);
  Process driver = cab(s, "down1", short_script(s.dir, 3));
  ASSERT_EQ(wait_state(s, st.admin, st.id, "running", 30)["state"], "running") << driver.err();
  const int pid = worker_pid(s, st.admin, st.id);
  ASSERT_GT(pid, 0);
  // The server dies; the worker drives on to the end of the session, and its last samples
  // (events, score, "ended") reach nobody.
  s.proc->signal(SIGKILL);
  s.proc->wait(5);
  ASSERT_TRUE(wait_gone(pid, 30)) << "the worker did not finish";
  driver.wait(20);
  const Logged logged = read_log(s.db + ".logs/" + st.id + ".ctl");
  ASSERT_TRUE(logged.ended);
  ASSERT_GE(logged.mark, 0);
  ASSERT_GE(logged.events, 1u);

  s.start();
  const std::string admin = s.login("admin", kAdminPassword);
  const json done = wait_state(s, admin, st.id, "ended", 20);
  EXPECT_EQ(done["state"], "ended") << done;
  EXPECT_EQ(done["reason"], "duration") << done;  // the session's time limit, as the log ended it
  ASSERT_FALSE(done["mark"].is_null()) << done;
  EXPECT_EQ(done["mark"].get<double>(), logged.mark);
  EXPECT_EQ(done["passed"].get<bool>(), logged.passed);
  ASSERT_EQ(done["events"].size(), logged.events) << done["events"];
  for (size_t i = 0; i < logged.events; ++i) EXPECT_EQ(done["events"][i]["seq"], i + 1);
  const json fleet = s.call("GET", "/api/fleet", admin).second;
  EXPECT_EQ(fleet["recovered_from_logs"]["scores"], 1) << fleet;
  EXPECT_EQ(fleet["recovered_from_logs"]["events"], logged.events) << fleet;
  EXPECT_TRUE(fleet["workers"].empty()) << fleet;  // the cab is free again
}

TEST(Recovery, AWorkerLeftByAStartingSessionIsAdoptedAndItsCabStaysBusy) {
  const int port = forklift::test::free_port();
  Server s(port, forklift::test::free_domain(), "recovery-starting-" + std::to_string(port));
  const Started st = start_session(s, "orphan1", 4);
  const int pid = kill_server_while_waiting(s, st);
  ASSERT_GT(pid, 0);
  // Killed before it heard from its worker, as the store would have it: "starting".
  sql(s.db, "UPDATE sessions SET state = 'starting' WHERE public_id = '" + st.id + "'");

  s.start();
  const std::string admin = s.login("admin", kAdminPassword);
  EXPECT_EQ(worker_pid(s, admin, st.id), pid) << s.call("GET", "/api/fleet", admin).second;
  // No cab has two workers: a second session on it is refused while the first runs.
  const json pupil = s.call("POST", "/api/pupils", admin, R"({"name":"Second Try"})").second;
  auto [code, second] = s.call("POST", "/api/sessions", admin,
                               json{{"pupil_id", pupil["id"]}, {"cab_id", "orphan1"}, {"scenario", "manoeuvre_1"}}.dump());
  EXPECT_EQ(code, 409) << second;
  EXPECT_EQ(error_code(second), "cab_busy");
  // The adopted worker's reports are believed: the session runs and ends with its mark.
  Process driver = cab(s, "orphan1", short_script(s.dir, 2));
  const json done = s.wait_session(admin, st.id, 30);
  EXPECT_EQ(done["state"], "ended") << done;
  EXPECT_FALSE(done["mark"].is_null()) << done;
  EXPECT_EQ(done["mark"].get<double>(), read_log(s.db + ".logs/" + st.id + ".ctl").mark);
  driver.wait(20);
}

TEST(Recovery, AWorkerWhoseSessionIsNoLongerOpenIsStoppedAtStart) {
  const int port = forklift::test::free_port();
  Server s(port, forklift::test::free_domain(), "recovery-stray-" + std::to_string(port));
  const Started st = start_session(s, "stray1", 4);
  const int pid = kill_server_while_waiting(s, st);
  ASSERT_GT(pid, 0);
  sql(s.db, "UPDATE sessions SET state = 'failed', reason = 'closed by hand', ended_at = '2026-12-02T00:00:00Z' WHERE public_id = '" +
                st.id + "'");
  s.start();
  EXPECT_TRUE(wait_gone(pid, 10)) << "the stray worker still runs";
  const std::string admin = s.login("admin", kAdminPassword);
  EXPECT_EQ(worker_pid(s, admin, st.id), 0);
  EXPECT_EQ(s.call("GET", "/api/sessions/" + st.id, admin).second["reason"], "closed by hand");
}
