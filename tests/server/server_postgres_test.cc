// forklift-server on a PostgreSQL database (--db postgresql://..., issue 20), over real HTTP with
// real workers and cabs: what the SQLite tests show of a session holds there too, and the
// database outlives the server. The PostgreSQL server is the test's own (support/postgres.h).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>

#include "support/cab_script.h"
#include "support/postgres.h"
#include "support/process.h"
#include "support/server.h"

using nlohmann::json;
using forklift_test::kAdminPassword;
using forklift_test::Server;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;

}  // namespace

TEST(ServerOnPostgresql, ASessionIsStoredOnceAndTheDatabaseOutlivesTheServer) {
  std::unique_ptr<forklift::test::PostgresServer> pg;
  try {
    pg = std::make_unique<forklift::test::PostgresServer>(testing::TempDir() + "/postgresql-" + std::to_string(getpid()), false);
  } catch (const std::exception& e) {
    FAIL() << "PostgreSQL could not be started: " << e.what();
  }
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
