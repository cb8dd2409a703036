// forklift-server on a PostgreSQL database (--db postgresql://...), over real HTTP with
// real workers and cabs: what the SQLite tests show of a session holds there too, and the
// database outlives the server. The PostgreSQL server is the test's own (support/postgres.h).
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <future>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "support/cab_script.h"
#include "support/postgres.h"
#include "support/process.h"
#include "support/server.h"

using nlohmann::json;
using forklift_test::error_code;
using forklift_test::kAdminPassword;
using forklift_test::Server;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;

// This test's own PostgreSQL server (support/postgres.h); null, the test failed saying why.
std::unique_ptr<forklift::test::PostgresServer> StartPostgres() {
  try {
    return std::make_unique<forklift::test::PostgresServer>(testing::TempDir() + "/postgresql-" + std::to_string(getpid()), false);
  } catch (const std::exception& e) {
    ADD_FAILURE() << "PostgreSQL could not be started: " << e.what();
    return nullptr;
  }
}

// The first column of `sql`'s rows in database `name`.
std::vector<std::string> Rows(const forklift::test::PostgresServer& pg, const std::string& name, const std::string& sql) {
  std::vector<std::string> rows;
  const std::string error = pg.exec(name, sql, &rows);
  if (!error.empty()) ADD_FAILURE() << sql << ": " << error;
  return rows;
}

}  // namespace

TEST(ServerOnPostgresql, ASessionIsStoredOnceAndTheDatabaseOutlivesTheServer) {
  const auto pg = StartPostgres();
  if (!pg) return;
  Server s("postgresql", Server::Database{pg->create_database("school")});
  const std::string admin = s.login("admin", kAdminPassword);
  const json pupil = s.call("POST", "/api/pupils", admin, R"({"name":"Carla"})").second;
  auto [st, sess] = s.call("POST", "/api/sessions", admin,
                           json{{"pupil_id", pupil["id"]}, {"cab_id", "cabP"}, {"scenario", "manoeuvre_1"}, {"time_limit_s", 3}}.dump());
  ASSERT_EQ(st, 201) << sess;
  Process cab({kBin + "/forklift-cab", "--cab", "cabP", "--script", forklift_test::short_script(s.dir, 1.0), "--dds-domain",
               std::to_string(s.domain), "--wait-worker", "20"},
              s.dir + "/cab");
  const json done = s.wait_session(admin, sess["id"], 30);
  EXPECT_EQ(done["state"], "ended") << done;
  EXPECT_TRUE(done["mark"].is_number()) << done;
  std::set<int64_t> seqs;
  for (const json& e : done["events"]) EXPECT_TRUE(seqs.insert(e["seq"].get<int64_t>()).second) << "event stored twice: " << e;
  EXPECT_FALSE(seqs.empty()) << done;
  // Everything is in the database: no SQLite file beside the server, and the rows are there.
  EXPECT_FALSE(std::filesystem::exists(s.dir + "/forklift.db"));
  std::vector<std::string> rows;
  ASSERT_EQ(pg->exec("school", "SELECT COUNT(*) FROM events", &rows), "");
  EXPECT_EQ(rows, std::vector<std::string>{std::to_string(seqs.size())});

  // A server started again on the database finds the admin, the pupil and the session as they were.
  s.proc->signal(SIGTERM);
  ASSERT_EQ(s.proc->wait(10), 0) << s.proc->err();
  s.start({"--log-dir", s.dir + "/logs"});
  const std::string admin2 = s.login("admin", kAdminPassword);
  const json h = s.call("GET", "/api/pupils/" + std::to_string(pupil["id"].get<int64_t>()) + "/history", admin2).second;
  ASSERT_EQ(h["sessions"].size(), 1u) << h;
  EXPECT_EQ(h["sessions"][0]["mark"], done["mark"]);
  EXPECT_EQ(s.call("GET", "/api/sessions/" + sess["id"].get<std::string>(), admin2).second["events"].size(), seqs.size());
}

// Two servers on one database (a fail-over pair, or two behind one name): a login made through
// one holds on the other, a logout or a lockout made through one holds on both, and a login
// outlives a restart. (A window of an hour: the failures cannot fall out of it mid-test.)
TEST(ServerOnPostgresql, LoginsLogoutsAndLockoutsHoldOnEveryServerOfTheDatabase) {
  const auto pg = StartPostgres();
  if (!pg) return;
  const std::string uri = pg->create_database("school");
  const std::vector<std::string> options = {"--login-window", "3600"};
  Server a("postgresql-a", Server::Database{uri}, options), b("postgresql-b", Server::Database{uri}, options);
  const std::string admin = a.login("admin", kAdminPassword);
  EXPECT_EQ(b.call("GET", "/api/pupils", admin).first, 200);
  const json pupil = a.call("POST", "/api/pupils", admin, R"({"name":"Ana","username":"ana","password":"ana-pass-1"})").second;
  const std::string record = "/api/pupils/" + std::to_string(pupil["id"].get<int64_t>());
  const std::string ana = b.login("ana", "ana-pass-1");
  EXPECT_EQ(a.call("GET", record, ana).first, 200);

  EXPECT_EQ(a.call("POST", "/api/logout", ana).first, 200);
  auto [status, body] = b.call("GET", record, ana);
  EXPECT_EQ(status, 401);
  EXPECT_EQ(error_code(body), "unauthenticated") << body;
  // Only the token's SHA-256 is in the database.
  EXPECT_EQ(Rows(*pg, "school", "SELECT COUNT(*) FROM login_tokens WHERE hash = '" + admin + "'"), std::vector<std::string>{"0"});

  const std::string wrong = json{{"username", "ana"}, {"password", "wrong"}}.dump();
  for (int i = 0; i < 5; ++i) EXPECT_EQ(a.call("POST", "/api/login", "", wrong).first, 401) << "attempt " << i + 1;
  auto [locked, refusal] = b.call("POST", "/api/login", "", json{{"username", "ana"}, {"password", "ana-pass-1"}}.dump());
  EXPECT_EQ(locked, 429) << refusal;
  EXPECT_EQ(error_code(refusal), "too_many_attempts");

  a.proc->signal(SIGTERM);
  ASSERT_EQ(a.proc->wait(10), 0) << a.proc->err();
  a.start({"--log-dir", a.dir + "/logs", "--login-window", "3600"});
  EXPECT_EQ(a.call("GET", "/api/pupils", admin).first, 200);
  EXPECT_EQ(a.call("POST", "/api/login", "", json{{"username", "ana"}, {"password", "ana-pass-1"}}.dump()).first, 429);
}

// Fifty starts of a session on one cab at once, half through each of two servers: the store lets
// one open, the other 49 are answered 409 cab_busy in words, and nothing of theirs is left behind.
TEST(ServerOnPostgresql, FiftyStartsOnOneCabThroughTwoServersOpenOneSession) {
  const auto pg = StartPostgres();
  if (!pg) return;
  const std::string uri = pg->create_database("school");
  Server a("postgresql-race-a", Server::Database{uri}), b("postgresql-race-b", Server::Database{uri});
  const std::string admin = a.login("admin", kAdminPassword);
  const json pupil = a.call("POST", "/api/pupils", admin, R"({"name":"Carla"})").second;
  const std::string start =
      json{{"pupil_id", pupil["id"]}, {"cab_id", "cabRace"}, {"scenario", "manoeuvre_1"}, {"time_limit_s", 60}}.dump();
  constexpr int kStarts = 50;
  std::promise<void> go;
  const std::shared_future<void> ready = go.get_future().share();
  std::vector<std::future<std::pair<int, json>>> answers;
  std::atomic<int> resent{0};
  for (int i = 0; i < kStarts; ++i)
    answers.push_back(std::async(std::launch::async, [&, i]() -> std::pair<int, json> {
      httplib::Client c = (i % 2 ? b : a).client();
      c.set_connection_timeout(60);
      c.set_read_timeout(60);
      ready.wait();
      // Twenty-five connections at once overflow a server's listen backlog (httplib's, 5): the
      // kernel drops some, and the server never reads their request (its access log has none).
      // Such a request gets no answer at all and is sent again; an answer lost after the server
      // acted would show here as a second 409 and no 201.
      for (int attempt = 0;; ++attempt) {
        const auto r = c.Post("/api/sessions", {{"Authorization", "Bearer " + admin}}, start, "application/json");
        if (r) return {r->status, json::parse(r->body, nullptr, false)};
        if (attempt == 3) return {0, httplib::to_string(r.error())};
        ++resent;
      }
    }));
  go.set_value();
  std::map<int, int> count;
  std::string started;
  for (auto& f : answers) {
    const auto [status, body] = f.get();
    ++count[status];
    if (status == 201) started = body["id"];
    if (status != 201 && status != 409) ADD_FAILURE() << status << ": " << body;
    if (status == 409) {
      EXPECT_EQ(error_code(body), "cab_busy") << body;
      EXPECT_NE(body["error"].value("message", "").find("cabRace"), std::string::npos) << body;
    }
  }
  EXPECT_EQ(count[201], 1);
  EXPECT_EQ(count[409], kStarts - 1);
  std::printf("%d of %d starts sent again: no answer came\n", resent.load(), kStarts);
  EXPECT_EQ(Rows(*pg, "school", "SELECT COUNT(*) FROM sessions"), std::vector<std::string>{"1"});
  EXPECT_EQ(Rows(*pg, "school", "SELECT COUNT(*) FROM audit_log WHERE action = 'session_started'"), std::vector<std::string>{"1"});
  EXPECT_EQ(Rows(*pg, "school", "SELECT COUNT(*) FROM session_logs"), std::vector<std::string>{"1"});  // its scenario
  ASSERT_FALSE(started.empty());
  EXPECT_EQ(b.call("POST", "/api/sessions/" + started + "/abort", admin).first, 200);
}

// A kept PostgreSQL folder (a bench's generated stores) whose server another run still has going
// is refused, and that server outlives the refused run's process (whose watchdog stopped it).
TEST(ServerOnPostgresql, ASecondRunOnAKeptFolderLeavesTheFirstRunsServerAlone) {
  const std::string dir = testing::TempDir() + "/postgresql-kept-" + std::to_string(getpid());
  {
    forklift::test::PostgresServer first(dir, true);
    const std::string db = "kept";
    first.create_database(db);
    // The second run is a process of its own, as a second bench is: 3 if it was refused in words.
    const pid_t second = fork();
    ASSERT_GE(second, 0);
    if (second == 0) {
      try {
        forklift::test::PostgresServer again(dir, true);
        _exit(1);
      } catch (const std::runtime_error& e) {
        _exit(std::string(e.what()).find("already runs in") != std::string::npos ? 3 : 2);
      }
    }
    int status = 0;
    ASSERT_EQ(waitpid(second, &status, 0), second);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 3) << "the second run's end: " << status;
    // Its watchdog, had it one, acts as soon as the process is gone.
    for (int i = 0; i < 10; ++i) {
      std::vector<std::string> rows;
      ASSERT_EQ(first.exec(db, "SELECT 1", &rows), "") << "the first run's server was stopped";
      EXPECT_EQ(rows, std::vector<std::string>{"1"});
      usleep(100000);
    }
  }
  std::filesystem::remove_all(dir);
}
