// forklift-server as a service: a second server on a taken port exits saying so and the first
// keeps serving; the access log (text and JSON) has a line per request and no secret; the
// server's own log as JSON; a --db in a folder that does not exist is refused and nothing is
// made; forklift-menu's scripted cab drives in the server's DDS domain.
#include <gtest/gtest.h>
#include <httplib.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "support/cab_script.h"
#include "support/ports.h"
#include "support/process.h"
#include "support/server.h"

using nlohmann::json;
using forklift_test::kAdminPassword;
using forklift_test::Server;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

std::vector<std::string> lines_of(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  return lines;
}

// The access log's lines once a line holds each of `markers`: the server writes a request's line
// just after its answer, so one answered before another may be written after it; the test waits
// for all (at most 30 s, however slow the machine).
std::vector<std::string> access_lines(const std::string& path, const std::vector<std::string>& markers) {
  std::vector<std::string> lines;
  for (int i = 0; i < 600; ++i) {
    lines = lines_of(path);
    if (std::all_of(markers.begin(), markers.end(), [&](const std::string& m) {
          return std::any_of(lines.begin(), lines.end(), [&](const std::string& l) { return contains(l, m); });
        }))
      break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return lines;
}

// A folder of the test's own, empty.
std::string fresh_dir(const std::string& name) {
  const std::string dir = testing::TempDir() + "/" + name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// A server's own process arguments, on `port` and `domain`, for a server the test expects not to start.
std::vector<std::string> server_args(const std::string& db, int port, int domain) {
  return {kBin + "/forklift-server", "--db", db, "--listen", "127.0.0.1:" + std::to_string(port), "--dds-domain", std::to_string(domain),
          "--admin-password", kAdminPassword};
}

// What each test sends: a login (its password in the body), an authenticated list with a token
// and a password in the query, a wrong token, an unknown path. Returns the admin's token.
std::string send_requests(const Server& s) {
  const std::string token = s.login("admin", kAdminPassword);
  EXPECT_EQ(s.call("GET", "/api/pupils?search=ann&token=query-token-1&Password=query-pass-1", token).first, 200);
  EXPECT_EQ(s.call("GET", "/api/pupils", "not-a-real-token-2").first, 401);
  EXPECT_EQ(s.call("GET", "/api/no-such-thing", token).first, 404);
  return token;
}

// Nothing of what send_requests() sent that lets anyone in is in `text`.
void expect_no_secrets(const std::string& text, const std::string& token) {
  for (const std::string& secret : {std::string(kAdminPassword), token, std::string("query-token-1"), std::string("query-pass-1"),
                                   std::string("not-a-real-token-2")})
    EXPECT_FALSE(contains(text, secret)) << "the log holds " << secret << ":\n" << text;
}

std::string text_of(const std::string& path) {
  std::string text;
  for (const auto& l : lines_of(path)) text += l + "\n";
  return text;
}

// How many lines the access log has of each of send_requests()' requests: one each.
struct Seen {
  int login = 0, listed = 0, refused = 0, unknown = 0;
  void expect_each_once() const {
    EXPECT_EQ(login, 1);
    EXPECT_EQ(listed, 1);
    EXPECT_EQ(refused, 1);
    EXPECT_EQ(unknown, 1);
  }
};

}  // namespace

TEST(Service, ASecondServerOnATakenPortExitsNamingThePortAndTheFirstKeepsServing) {
  Server first("service-port");
  const std::string dir = fresh_dir("service-port-second");
  Process second(server_args(dir + "/second.db", first.port, forklift::test::free_domain()), dir + "/second");
  EXPECT_EQ(second.wait(60), 2) << "-1: the second server was still running after 60 s, sharing the port";
  const std::string err = second.err();
  EXPECT_TRUE(contains(err, "port " + std::to_string(first.port))) << err;
  EXPECT_TRUE(contains(err, "127.0.0.1")) << err;
  EXPECT_TRUE(contains(err, "already using")) << err;
  // It bound first, so it touched no database.
  EXPECT_FALSE(std::filesystem::exists(dir + "/second.db"));
  // Every request reaches the first server, which knows its login: none is answered 401 by another.
  const std::string token = first.login("admin", kAdminPassword);
  for (int i = 0; i < 20; ++i) EXPECT_EQ(first.call("GET", "/api/pupils", token).first, 200);
}

TEST(Service, TheTextAccessLogHasALinePerRequestWithItsStatusAndNoSecret) {
  Server s("service-access-text");  // the default: <db>.logs/access.log, text
  const std::string log = s.db + ".logs/access.log";
  const std::string token = send_requests(s);
  Seen seen;
  for (const std::string& l : access_lines(log, {"POST /api/login ", "token=***", "/api/pupils 401 ", "/api/no-such-thing"})) {
    // <time> <client> <user> <method> <path> <status> <bytes> <ms>ms
    std::istringstream in(l);
    std::string time, client, user, method, path, ms;
    int status = 0;
    long bytes = -1;
    in >> time >> client >> user >> method >> path >> status >> bytes >> ms;
    ASSERT_TRUE(in) << l;
    EXPECT_EQ(time.size(), 24u) << l;  // 2026-12-02T09:41:29.123Z
    EXPECT_EQ(time.back(), 'Z') << l;
    EXPECT_EQ(client, "127.0.0.1") << l;
    EXPECT_EQ(ms.substr(ms.size() - 2), "ms") << l;
    EXPECT_GE(std::stod(ms), 0.0) << l;
    if (method == "POST" && path == "/api/login") {
      ++seen.login;
      EXPECT_EQ(status, 200);
      EXPECT_EQ(user, "-");  // not yet authenticated
      EXPECT_GT(bytes, 0);
    }
    if (path.rfind("/api/pupils?", 0) == 0) {
      ++seen.listed;
      EXPECT_EQ(status, 200);
      EXPECT_EQ(user, "admin");
      EXPECT_EQ(path, "/api/pupils?search=ann&token=***&Password=***");
    }
    if (path == "/api/pupils" && status == 401) {
      ++seen.refused;
      EXPECT_EQ(user, "-");
    }
    if (path == "/api/no-such-thing") {
      ++seen.unknown;
      EXPECT_EQ(status, 404);
    }
  }
  seen.expect_each_once();
  expect_no_secrets(text_of(log), token);
  expect_no_secrets(s.proc->err(), token);
}

TEST(Service, TheJsonLogsAreOneObjectALineWithNoSecret) {
  const std::string log = fresh_dir("service-access-json-log") + "/requests.jsonl";
  Server s("service-access-json", {"--log-format", "json", "--access-log", log});
  const std::string token = send_requests(s);
  Seen seen;
  for (const std::string& l : access_lines(log, {R"("/api/login")", "token=***", R"("status":401)", "/api/no-such-thing"})) {
    json j;
    ASSERT_NO_THROW(j = json::parse(l)) << l;
    for (const char* key : {"time", "client", "user", "method", "path", "status", "bytes", "duration_ms"}) EXPECT_TRUE(j.contains(key)) << key << " in " << l;
    EXPECT_EQ(j["client"], "127.0.0.1");
    EXPECT_GE(j["duration_ms"].get<double>(), 0.0);
    if (j["path"] == "/api/login") {
      ++seen.login;
      EXPECT_EQ(j["status"], 200);
      EXPECT_TRUE(j["user"].is_null());
      EXPECT_GT(j["bytes"].get<long>(), 0);
    }
    if (j["path"] == "/api/pupils?search=ann&token=***&Password=***") {
      ++seen.listed;
      EXPECT_EQ(j["status"], 200);
      EXPECT_EQ(j["user"], "admin");
    }
    if (j["path"] == "/api/pupils" && j["status"] == 401) {
      ++seen.refused;
      EXPECT_TRUE(j["user"].is_null());
    }
    if (j["path"] == "/api/no-such-thing") {
      ++seen.unknown;
      EXPECT_EQ(j["status"], 404);
      EXPECT_EQ(j["method"], "GET");
    }
  }
  seen.expect_each_once();
  expect_no_secrets(text_of(log), token);
  // The server's own log on stderr: every line an object, the start among them.
  bool listening = false;
  std::istringstream err(s.proc->err());
  for (std::string l; std::getline(err, l);) {
    json j;
    ASSERT_NO_THROW(j = json::parse(l)) << l;
    EXPECT_TRUE(j.contains("time") && j.contains("level") && j.contains("message")) << l;
    listening = listening || contains(j.value("message", ""), "listening on http://127.0.0.1:" + std::to_string(s.port));
  }
  EXPECT_TRUE(listening) << s.proc->err();
  expect_no_secrets(s.proc->err(), token);
}

TEST(Service, ADatabaseInAFolderThatDoesNotExistIsRefusedAndNothingIsMade) {
  const std::string dir = fresh_dir("service-no-folder");
  const std::string missing = dir + "/not-made/dir";
  Process p(server_args(missing + "/x.db", forklift::test::free_port(), forklift::test::free_domain()), dir + "/server");
  EXPECT_EQ(p.wait(60), 2);
  EXPECT_TRUE(contains(p.err(), "the folder " + missing + " does not exist")) << p.err();
  EXPECT_FALSE(std::filesystem::exists(dir + "/not-made"));
}

TEST(Service, MenusScriptedCabDrivesInTheServersDomain) {
  Server s("service-menu-domain");
  // The environment names another domain: only the server's own gets the cab to its worker.
  const int elsewhere = forklift::test::free_domain();
  ASSERT_EQ(setenv("FORKLIFT_DDS_DOMAIN", std::to_string(elsewhere).c_str(), 1), 0);
  const std::string token = s.login("admin", kAdminPassword);
  const json pupil = s.call("POST", "/api/pupils", token, R"({"name":"Dara Driver"})").second;
  const std::string token_file = s.dir + "/menu-token";
  std::ofstream(token_file) << token << '\n';
  Process menu({kBin + "/forklift-menu", "--server", s.url(), "--token-file", token_file, "start", "--pupil",
                std::to_string(pupil["id"].get<int64_t>()), "--cab", "cabM", "--scenario", "manoeuvre_1", "--time-limit", "3", "--drive",
                forklift_test::short_script(s.dir, 1.0)},
               s.dir + "/menu");
  const int code = menu.wait(180);
  unsetenv("FORKLIFT_DDS_DOMAIN");
  EXPECT_EQ(code, 0) << menu.out() << menu.err();
  EXPECT_TRUE(contains(menu.out(), ": ended")) << menu.out() << menu.err();
  EXPECT_EQ(s.call("GET", "/api/fleet", token).second["dds_domain"], s.domain);
}

// The session log: a line for each thing that happens to a session, started to
// scored, as JSON objects with --log-format json, and nothing from HTTP requests.
TEST(Service, TheSessionLogFollowsASessionFromItsStartToItsMark) {
  const std::string dir = testing::TempDir() + "/service-session-log";
  std::filesystem::create_directories(dir);
  const std::string log = dir + "/sessions.jsonl";
  std::filesystem::remove(log);
  Server s("service-session-log", {"--log-format", "json", "--session-log", log});
  const std::string token = s.login("admin", kAdminPassword);
  const json pupil = s.call("POST", "/api/pupils", token, R"({"name":"Sam Session"})").second;
  auto [st, sess] = s.call("POST", "/api/sessions", token,
                           json{{"pupil_id", pupil["id"]}, {"cab_id", "cabL"}, {"scenario", "manoeuvre_1"}, {"time_limit_s", 3}}.dump());
  ASSERT_EQ(st, 201) << sess;
  Process cab({kBin + "/forklift-cab", "--cab", "cabL", "--script", forklift_test::short_script(s.dir, 1.0), "--dds-domain",
               std::to_string(s.domain), "--wait-worker", "20"},
              s.dir + "/cab");
  const json done = s.wait_session(token, sess["id"], 60);
  ASSERT_EQ(done["state"], "ended") << done;
  // The score follows the end a moment later.
  std::vector<std::string> events;
  for (int i = 0; i < 100; ++i) {
    events.clear();
    for (const std::string& line : lines_of(log)) {
      const json j = json::parse(line);  // every line one JSON object
      EXPECT_EQ(j["session"], sess["id"]) << line;
      EXPECT_TRUE(j["time"].is_string()) << line;
      events.push_back(j["event"]);
      if (j["event"] == "started") {
        EXPECT_EQ(j["cab"], "cabL");
        EXPECT_EQ(j["by"], "admin");
        EXPECT_EQ(j["pupil"], pupil["id"]);
      }
      if (j["event"] == "scored") {
        EXPECT_TRUE(j["mark"].is_number()) << line;
      }
    }
    if (std::find(events.begin(), events.end(), "scored") != events.end()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.front(), "started");
  for (const char* e : {"running", "ended", "scored"})
    EXPECT_NE(std::find(events.begin(), events.end(), e), events.end()) << e << " missing from " << json(events);
}
