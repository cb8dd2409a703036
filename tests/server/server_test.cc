// forklift-server over real HTTP on loopback, with a real SQLite file and real workers and cabs.
// Each test runs its own server on its own port and DDS domain (support/ports.h).
#include <gtest/gtest.h>
#include <httplib.h>

#include <atomic>
#include <filesystem>
#include <functional>
#include <fstream>
#include <nlohmann/json.hpp>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include "forklift/protocol/protocol.h"
#include "support/cab_script.h"
#include "support/loopback.h"
#include "support/ports.h"
#include "support/process.h"
#include "support/server.h"
#include "support/speaking_cab.h"

using nlohmann::json;
using forklift_test::Server;
using forklift_test::error_code;
using forklift_test::kAdminPassword;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;
const std::string kData = FORKLIFT_DATA_DIR;
using forklift_test::short_script;

Process cab(const Server& s, const std::string& id, const std::string& script) {
  return Process({kBin + "/forklift-cab", "--cab", id, "--script", script, "--dds-domain", std::to_string(s.domain), "--wait-worker", "20"},
                 s.dir + "/cab-" + id);
}

}  // namespace

TEST(Server, LoginRolesAndVisibility) {
  Server s("roles");
  EXPECT_EQ(error_code(s.call("POST", "/api/login", "", R"({"username":"admin","password":"wrong"})").second), "bad_credentials");
  const std::string admin = s.login("admin", kAdminPassword);
  auto [st1, p1] = s.call("POST", "/api/pupils", admin, R"({"name":"Ana Pupil","username":"ana","password":"ana-pass-1"})");
  ASSERT_EQ(st1, 201) << p1;
  auto [st2, p2] = s.call("POST", "/api/pupils", admin, R"({"name":"Ben Pupil"})");
  ASSERT_EQ(st2, 201);
  EXPECT_EQ(s.call("POST", "/api/users", admin, R"({"username":"ines","password":"ines-pass-1","role":"instructor"})").first, 201);

  const std::string ana = s.login("ana", "ana-pass-1");
  const std::string ines = s.login("ines", "ines-pass-1");
  const std::string a_id = std::to_string(p1["id"].get<int64_t>()), b_id = std::to_string(p2["id"].get<int64_t>());
  EXPECT_EQ(s.call("GET", "/api/pupils/" + a_id + "/history", ana).first, 200);   // her own
  EXPECT_EQ(error_code(s.call("GET", "/api/pupils/" + b_id + "/history", ana).second), "forbidden");
  EXPECT_EQ(s.call("GET", "/api/pupils", ana).first, 403);                        // no list for pupils
  EXPECT_EQ(s.call("GET", "/api/pupils?search=ben", ines).second["total"], 1);      // case-insensitive search
  EXPECT_EQ(s.call("POST", "/api/users", ines, R"({"username":"x","password":"xxxxxxxx","role":"admin"})").first, 403);
  EXPECT_EQ(error_code(s.call("GET", "/api/pupils").second), "unauthenticated");
  // A licence: only an examiner or admin issues it, and only on passed exams (certificate_test.cc).
  EXPECT_EQ(s.call("POST", "/api/pupils/" + a_id + "/licence", ines).first, 403);
  auto [stl, lic] = s.call("POST", "/api/pupils/" + a_id + "/licence", admin);
  EXPECT_EQ(stl, 409) << lic;
  EXPECT_EQ(error_code(lic), "not_certified") << lic;
  EXPECT_TRUE(s.call("GET", "/api/pupils/" + a_id + "/history", ana).second["licence"].is_null());
  EXPECT_EQ(s.call("GET", "/api/pupils", "not-a-token").first, 401);
}

// The school's licence rules (data/licence/rules.json, here a file of the test's own): a licence is
// refused with every missing item named in words, and a marked training session on the
// practical exam's truck class counts toward the training the rules ask for. The issue itself
// (it needs exams under DDS Security) is in certificate_test.cc.
TEST(Server, ALicenceIsRefusedWithEachMissingItemNamedAsTheSchoolsRulesSay) {
  const std::string rules = testing::TempDir() + "/licence-rules-two-sessions.json";
  std::ofstream(rules) << R"({"training": {"marked_sessions": 2}, "theory": {"within_months": 6}})";
  Server s("licence-rules", {"--licence-rules", rules});
  const std::string admin = s.login("admin", kAdminPassword);
  const json pupil = s.call("POST", "/api/pupils", admin, R"({"name":"Lena Learner"})").second;
  const std::string path = "/api/pupils/" + std::to_string(pupil["id"].get<int64_t>());
  const auto message = [](const json& answer) { return answer.is_object() && answer.contains("error") ? answer["error"].value("message", "") : ""; };

  auto [st0, none] = s.call("POST", path + "/licence", admin);
  EXPECT_EQ(st0, 409) << none;
  EXPECT_EQ(error_code(none), "not_certified") << none;
  for (const char* item : {"Lena Learner cannot be licensed yet", "has not passed the theory exam",
                           "has not passed a practical exam on an exam course", "has 0 of the 2 marked training sessions"})
    EXPECT_NE(message(none).find(item), std::string::npos) << item << " not in: " << none;

  // A training session on the training truck, run to its end and marked: one of the two.
  auto [st, sess] = s.call("POST", "/api/sessions", admin,
                           json{{"pupil_id", pupil["id"]}, {"cab_id", "cabL"}, {"scenario", "manoeuvre_1"}, {"truck", "linde_e16c"},
                                {"time_limit_s", 3}}.dump());
  ASSERT_EQ(st, 201) << sess;
  Process c = cab(s, "cabL", short_script(s.dir, 1.0));
  const json done = s.wait_session(admin, sess["id"], 60);
  ASSERT_EQ(done["outcome"], "completed") << done;
  ASSERT_TRUE(done["mark"].is_number()) << done;
  auto [st1, one] = s.call("POST", path + "/licence", admin);
  EXPECT_EQ(st1, 409) << one;
  EXPECT_NE(message(one).find("has 1 of the 2 marked training sessions"), std::string::npos) << one;
  EXPECT_NE(message(one).find("has not passed the theory exam"), std::string::npos) << one;
  EXPECT_EQ(s.call("GET", path + "/certificate", admin).first, 409);
  EXPECT_TRUE(s.call("GET", path + "/history", admin).second["licence"].is_null());
}

// A rules file the server cannot follow stops it at start, naming the file and the key.
TEST(Server, ABadLicenceRulesFileIsRefusedAtStartNamingTheKey) {
  const std::string rules = testing::TempDir() + "/licence-rules-bad.json";
  std::ofstream(rules) << R"({"training": {"marked_sessions": 1.5}, "theory": {"within_months": 6}})";
  const std::string dir = testing::TempDir() + "/licence-rules-bad";
  std::filesystem::create_directories(dir);
  Process p({kBin + "/forklift-server", "--db", dir + "/school.db", "--listen", "127.0.0.1:" + std::to_string(forklift::test::free_port()),
             "--dds-domain", std::to_string(forklift::test::free_domain()), "--licence-rules", rules},
            dir + "/server");
  EXPECT_EQ(p.wait(30), 2) << p.err();
  EXPECT_NE(p.err().find("training.marked_sessions: must be a whole number"), std::string::npos) << p.err();
}

// Token expiry (token_expired) is in http_security_test.cc.

TEST(Server, BadRequestsGetTheDocumentedErrorAndTheServerStaysUp) {
  Server s("bad");
  const std::string admin = s.login("admin", kAdminPassword);
  EXPECT_EQ(error_code(s.call("POST", "/api/pupils", admin, "{not json").second), "bad_json");
  EXPECT_EQ(error_code(s.call("POST", "/api/pupils", admin, R"({"name": 5})").second), "bad_request");
  EXPECT_EQ(error_code(s.call("POST", "/api/pupils", admin, R"({"email": "a@b"})").second), "bad_request");
  EXPECT_EQ(error_code(s.call("POST", "/api/pupils", admin, "[1,2]").second), "bad_request");
  EXPECT_EQ(s.call("POST", "/api/pupils", admin, std::string(2 << 20, 'x')).first, 413);
  EXPECT_EQ(error_code(s.call("GET", "/api/pupils/999999", admin).second), "not_found");
  EXPECT_EQ(error_code(s.call("GET", "/api/sessions/s-999999", admin).second), "not_found");
  EXPECT_EQ(error_code(s.call("GET", "/api/nothing-here", admin).second), "not_found");
  EXPECT_EQ(error_code(s.call("POST", "/api/sessions", admin, R"({"pupil_id": 1, "cab_id": "c1", "scenario": "nope"})").second), "not_found");
  EXPECT_EQ(error_code(s.call("POST", "/api/sessions", admin, R"({"pupil_id": "one"})").second), "bad_request");
  EXPECT_EQ(s.call("GET", "/api/health").first, 200);
  EXPECT_TRUE(s.proc->running());
}

namespace {

using forklift_test::says_close;

// One kept-alive connection to a test server, asking GET (or HEAD) /api/health on it again and again.
class KeptConnection {
 public:
  explicit KeptConnection(int port) : c_(port, 20) {}
  // The whole answer's head ("" once the connection is gone).
  std::string ask(const std::string& method = "GET") {
    return c_.ask(method + " /api/health HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n", method == "HEAD");
  }
  unsigned data_segments_in() const { return c_.data_segments_in(); }

 private:
  forklift_test::KeptConnection c_;
};

}  // namespace

// A client keeps its connection: a hundred requests on one socket, each answered on it and none
// told "Connection: close" (a new connection for every few requests costs an accept and a thread).
TEST(Server, OneConnectionCarriesManyRequests) {
  Server s("keepalive");
  KeptConnection c(s.port);
  int answered = 0, told_to_close = 0;
  for (int i = 0; i < 100; ++i) {
    const std::string head = c.ask();
    if (head.empty()) break;
    EXPECT_EQ(head.rfind("HTTP/1.1 200", 0), 0u) << head;
    told_to_close += says_close(head);
    ++answered;
  }
  EXPECT_EQ(answered, 100);
  EXPECT_EQ(told_to_close, 0);
}

// An answer's head leaves with its body, one segment an answer rather than two (the kernel's count
// at the client's end); a head with no body to follow (HEAD) leaves when the answer is done.
TEST(Server, AnAnswerLeavesInOneSegment) {
  Server s("one-segment");
  KeptConnection c(s.port);
  for (const char* method : {"GET", "HEAD", "GET", "GET", "HEAD", "GET"}) {
    const unsigned before = c.data_segments_in();
    const std::string head = c.ask(method);
    ASSERT_EQ(head.rfind("HTTP/1.1 200", 0), 0u) << method << ": " << head;
    EXPECT_EQ(c.data_segments_in() - before, 1u) << method;
  }
}

// But a connection hands its thread back after 5 s, however busy: a page polling four times a
// second is told "Connection: close" once, after 5 s and not before, and the connection ends.
TEST(Server, AConnectionKeptBusyIsRetiredAfterFiveSeconds) {
  Server s("retire");
  const auto opened = std::chrono::steady_clock::now();
  KeptConnection c(s.port);
  double closed_after_s = -1;
  int answered = 0;
  while (std::chrono::steady_clock::now() - opened < std::chrono::seconds(30)) {
    const std::string head = c.ask();
    ASSERT_FALSE(head.empty()) << "the connection ended without saying so, after " << answered << " answers";
    ++answered;
    if (says_close(head)) {
      closed_after_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - opened).count();
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }
  EXPECT_GE(closed_after_s, 5.0) << answered << " answers";
  EXPECT_GE(answered, 10);
  EXPECT_TRUE(c.ask().empty());  // and it is gone
}

TEST(Server, ScriptedSessionEndsAndItsEventsAreStoredOnce) {
  Server s("session");
  const std::string admin = s.login("admin", kAdminPassword);
  const json pupil = s.call("POST", "/api/pupils", admin, R"({"name":"Carla"})").second;
  auto [st, sess] = s.call("POST", "/api/sessions", admin,
                           json{{"pupil_id", pupil["id"]}, {"cab_id", "cabA"}, {"scenario", "manoeuvre_1"}, {"time_limit_s", 3}}.dump());
  ASSERT_EQ(st, 201) << sess;
  EXPECT_EQ(s.call("POST", "/api/sessions", admin, json{{"pupil_id", pupil["id"]}, {"cab_id", "cabA"}, {"scenario", "manoeuvre_1"}}.dump()).first, 409);
  Process c = cab(s, "cabA", short_script(s.dir, 1.0));
  const json done = s.wait_session(admin, sess["id"], 30);
  EXPECT_EQ(done["state"], "ended") << done;
  // The cab went silent after 1 s: one dead-man stop, and the evaluation's mark at the end.
  int deadman_stops = 0;
  std::set<int64_t> seqs;
  for (const json& e : done["events"]) {
    deadman_stops += e["kind"] == "deadman_stop";
    EXPECT_TRUE(seqs.insert(e["seq"].get<int64_t>()).second) << "event stored twice: " << e;
  }
  EXPECT_EQ(deadman_stops, 1) << done;
  EXPECT_TRUE(done["mark"].is_number()) << done;
  const json h = s.call("GET", "/api/pupils/" + std::to_string(pupil["id"].get<int64_t>()) + "/history", admin).second;
  EXPECT_EQ(h["sessions"].size(), 1u);
  // The worker process outlives its final status by a moment; then the fleet lets it go.
  size_t workers = 1;
  for (int i = 0; i < 50 && workers > 0; ++i) {
    workers = s.call("GET", "/api/fleet", admin).second["workers"].size();
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_EQ(workers, 0u);
}

TEST(Server, AKilledWorkerFailsItsSessionAndNothingElse) {
  Server s("kill");
  const std::string admin = s.login("admin", kAdminPassword);
  const json pupil = s.call("POST", "/api/pupils", admin, R"({"name":"Dan"})").second;
  const json a = s.call("POST", "/api/sessions", admin, json{{"pupil_id", pupil["id"]}, {"cab_id", "k1"}, {"scenario", "manoeuvre_1"}, {"time_limit_s", 6}}.dump()).second;
  const json b = s.call("POST", "/api/sessions", admin, json{{"pupil_id", pupil["id"]}, {"cab_id", "k2"}, {"scenario", "manoeuvre_1"}, {"time_limit_s", 6}}.dump()).second;
  Process c1 = cab(s, "k1", kData + "/manoeuvres/manoeuvre_1.csv");
  Process c2 = cab(s, "k2", kData + "/manoeuvres/manoeuvre_1.csv");
  int pid = 0;
  for (int i = 0; i < 100 && pid == 0; ++i) {
    const json fleet = s.call("GET", "/api/fleet", admin).second;  // a local: the loop must not walk a temporary
    for (const auto& w : fleet["workers"])
      if (w["session"] == a["id"] && !w["sim_time_s"].is_null() && w["sim_time_s"].get<double>() > 1.0) pid = w["pid"];
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_GT(pid, 0);
  kill(pid, SIGKILL);
  const json fa = s.wait_session(admin, a["id"], 10);
  EXPECT_EQ(fa["state"], "failed");
  EXPECT_EQ(fa["reason"], "worker killed by signal 9");
  EXPECT_TRUE(fa["mark"].is_null());  // never passed
  const json fb = s.wait_session(admin, b["id"], 20);
  EXPECT_EQ(fb["state"], "ended") << fb;
}

TEST(Server, RestartMidSessionLosesAndDoublesNoEvent) {
  Server s("restart");
  const std::string admin = s.login("admin", kAdminPassword);
  const json pupil = s.call("POST", "/api/pupils", admin, R"({"name":"Eva"})").second;
  const json sess = s.call("POST", "/api/sessions", admin, json{{"pupil_id", pupil["id"]}, {"cab_id", "r1"}, {"scenario", "manoeuvre_1"}, {"time_limit_s", 7}}.dump()).second;
  // A cab that drives in bursts (a cab program per burst, silent in between): every silence
  // gives a dead-man event, every burst a resume.
  const std::string script = short_script(s.dir, 0.6);
  std::thread bursts([&] {
    for (int k = 0; k < 4; ++k) {
      Process c = cab(s, "r1", script);
      c.wait(10);
      std::this_thread::sleep_for(std::chrono::milliseconds(900));
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  s.proc->signal(SIGKILL);
  s.proc->wait(5);
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // events happen while no server listens
  s.start();
  const std::string admin2 = s.login("admin", kAdminPassword);  // tokens do not outlive the server
  const json done = s.wait_session(admin2, sess["id"], 30);
  bursts.join();
  EXPECT_EQ(done["state"], "ended") << done;
  std::set<int64_t> seqs;
  for (const auto& e : done["events"]) EXPECT_TRUE(seqs.insert(e["seq"].get<int64_t>()).second) << "doubled " << e;
  ASSERT_GE(seqs.size(), 5u) << done;
  EXPECT_EQ(*seqs.rbegin(), static_cast<int64_t>(seqs.size()));  // 1..N: none lost
}

// The instructor's abort, end to end: the server signals the worker, which ends the session as
// "aborted" and tells the cab so in its own partition (the cab says "aborted by your
// instructor"); the session stays aborted, by whom, and the worker's mark says why it ended.
TEST(Server, AnAbortedSessionEndsAsAbortedAndTheCabIsToldWhy) {
  Server s("abort");
  const std::string admin = s.login("admin", kAdminPassword);
  const json pupil = s.call("POST", "/api/pupils", admin, R"({"name":"Ida"})").second;
  auto [st, sess] = s.call("POST", "/api/sessions", admin,
                           json{{"pupil_id", pupil["id"]}, {"cab_id", "abortcab"}, {"scenario", "manoeuvre_1"}}.dump());
  ASSERT_EQ(st, 201) << sess;
  const std::string id = sess["id"];
  // The cab: this test, in the cab's partition only.
  forklift::dds::Participant p(forklift::dds::DomainSettings::resolve(s.domain, ""));
  forklift::dds::Writer<fk_Controls> controls(p, forklift::dds::cab_partition("abortcab"));
  forklift::dds::Reader<fk_SessionStatus> status(p, forklift::dds::cab_partition("abortcab"));
  fk_Controls c{};
  forklift::dds::set_string(c.cab_id, "abortcab");
  std::string state, reason;
  auto hear = [&] {
    status.take_each([&](const fk_SessionStatus& x) {
      if (std::string(x.session_id) == id) { state = x.state; reason = x.reason; }
    });
  };
  for (uint32_t seq = 1; seq < 1000 && state != "running"; ++seq) {
    c.seq = seq;
    controls.write(c);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    hear();
  }
  ASSERT_EQ(state, "running");
  auto [ast, aborted] = s.call("POST", "/api/sessions/" + id + "/abort", admin);
  ASSERT_EQ(ast, 200) << aborted;
  for (int i = 0; i < 500 && state != "ended"; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    hear();
  }
  EXPECT_EQ(state, "ended");
  EXPECT_EQ(reason, "aborted");
  // The worker has gone; the record keeps the instructor's abort.
  size_t workers = 1;
  for (int i = 0; i < 100 && workers > 0; ++i) {
    workers = s.call("GET", "/api/fleet", admin).second["workers"].size();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(workers, 0u);
  const json after = s.call("GET", "/api/sessions/" + id, admin).second;
  EXPECT_EQ(after["state"], "aborted");
  EXPECT_EQ(after["reason"], "aborted by admin");
  std::ifstream out(s.db + ".logs/" + id + ".out");
  std::stringstream text;
  text << out.rdbuf();
  // The worker's summary, in words for whoever opens the file.
  EXPECT_NE(text.str().find("ended (aborted by an instructor)"), std::string::npos) << text.str();
}

// Only a session that ran its course has a mark. An aborted session and one
// whose time ran out with its task undone keep the evaluator's score in the store (their workers
// sent one), but the API gives them an outcome and no mark, leaves them out of the marks the
// pupil's chart draws and out of the trend, lists them apart, and exports no mark for them.
TEST(Server, AbortedAndTimedOutSessionsHaveNoMarkAndStayOutOfTheChartAndTheTrend) {
  Server s("unmarked");
  const std::string admin = s.login("admin", kAdminPassword);
  const json pupil = s.call("POST", "/api/pupils", admin, R"({"name":"Ulla"})").second;
  const std::string pupil_path = "/api/pupils/" + std::to_string(pupil["id"].get<int64_t>());
  auto start = [&](const std::string& cab_id, const std::string& scenario, std::optional<double> limit) {
    json b = {{"pupil_id", pupil["id"]}, {"cab_id", cab_id}, {"scenario", scenario}};
    if (limit) b["time_limit_s"] = *limit;
    auto [st, sess] = s.call("POST", "/api/sessions", admin, b.dump());
    EXPECT_EQ(st, 201) << sess;
    return sess.value("id", "");
  };
  // Two that run their course: the paper's manoeuvre 1 cut to 3 s (no task: its time is its course).
  const std::string a = start("um1", "manoeuvre_1", 3);
  Process ca = cab(s, "um1", kData + "/manoeuvres/manoeuvre_1.csv");
  ASSERT_EQ(s.wait_session(admin, a, 30)["state"], "ended");
  const std::string b = start("um2", "manoeuvre_1", 3);
  Process cb = cab(s, "um2", short_script(s.dir, 3.0));
  // One whose time runs out with its task undone: the practical exam course's scenario cut to 3 s.
  const std::string t = start("ut1", "practical_exam", 3);
  Process ct = cab(s, "ut1", short_script(s.dir, 3.0));
  // One aborted while it runs.
  const std::string d = start("ua1", "manoeuvre_1", std::nullopt);
  Process cd = cab(s, "ua1", kData + "/manoeuvres/manoeuvre_1.csv");
  std::string state;
  for (int i = 0; i < 300 && state != "running"; ++i) {
    state = s.call("GET", "/api/sessions/" + d, admin).second.value("state", "");
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_EQ(state, "running");
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  ASSERT_EQ(s.call("POST", "/api/sessions/" + d + "/abort", admin).first, 200);
  for (const std::string& id : {b, t, d}) {
    const std::string st = s.wait_session(admin, id, 30).value("state", "");
    EXPECT_TRUE(st == "ended" || st == "aborted") << id << " is " << st;
  }
  // The worker's score of the aborted and the timed-out sessions arrives after their end: the
  // session then shows the faults it counted, never a mark.
  json ts, ds;
  for (int i = 0; i < 100 && !(ts.contains("counts") && ds.contains("counts")); ++i) {
    ts = s.call("GET", "/api/sessions/" + t, admin).second;
    ds = s.call("GET", "/api/sessions/" + d, admin).second;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_TRUE(ts.contains("counts") && ds.contains("counts")) << ts << "\n" << ds;
  EXPECT_EQ(ts["outcome"], "timed_out") << ts;
  EXPECT_EQ(ds["outcome"], "aborted") << ds;
  for (const json& x : {ts, ds}) {
    EXPECT_TRUE(x["mark"].is_null()) << x;
    EXPECT_TRUE(x["passed"].is_null()) << x;
    EXPECT_FALSE(x.contains("score")) << x;
    ASSERT_FALSE(x["reasons"].empty()) << x;
  }
  EXPECT_EQ(ts["reasons"][0]["code"], "timed_out");
  EXPECT_EQ(ds["reasons"][0]["code"], "aborted");
  // The evaluator did mark them: the audit log has each session's score as it was stored.
  std::map<std::string, double> scored;
  for (const json& r : s.call("GET", pupil_path + "/audit", admin).second)
    if (r["action"] == "session_scored") scored[r["details"]["session"]] = r["details"]["mark"].get<double>();
  EXPECT_TRUE(scored.count(t) && scored.count(d)) << "the worker sent no score to leave out";

  const json h = s.call("GET", pupil_path + "/history", admin).second;
  std::map<std::string, double> marks;
  for (const json& m : h["marks"]) marks[m["session"]] = m["mark"].get<double>();
  ASSERT_EQ(marks.size(), 2u) << h["marks"];
  ASSERT_TRUE(marks.count(a) && marks.count(b)) << h["marks"];
  std::map<std::string, std::string> unmarked;
  for (const json& u : h["unmarked"]) unmarked[u["session"]] = u["outcome"];
  EXPECT_EQ(unmarked[t], "timed_out") << h["unmarked"];
  EXPECT_EQ(unmarked[d], "aborted") << h["unmarked"];
  // The slope of two marks is their difference: the aborted and timed-out ones do not enter it.
  ASSERT_TRUE(h["trend"].is_number()) << h;
  EXPECT_NEAR(h["trend"].get<double>(), marks[b] - marks[a], 1e-9);
  for (const json& x : h["sessions"])
    if (x["id"] == t || x["id"] == d) {
      EXPECT_TRUE(x["mark"].is_null()) << x;
    }

  // The export: the pupil's name on each row, no mark, and the outcome; a completed session's mark
  // to one decimal, in the practical marks' column.
  auto c = s.client();
  const auto csv = c.Get(pupil_path + "/history.csv", {{"Authorization", "Bearer " + admin}});
  ASSERT_TRUE(csv && csv->status == 200);
  std::istringstream lines(csv->body);
  int seen = 0, marked = 0;
  std::string header;
  std::getline(lines, header);
  EXPECT_EQ(header, "pupil,record,id,date,scenario_or_kind,mode,state,practical_mark,theory_percent,passed,outcome,why_not_passed\r");
  for (std::string line; std::getline(lines, line);) {
    std::vector<std::string> f;
    std::istringstream fields(line);
    for (std::string x; std::getline(fields, x, ',');) f.push_back(x);
    ASSERT_GE(f.size(), 11u) << line;
    EXPECT_EQ(f[0], pupil["name"]) << line;
    if (f[1] == "session" && (f[2] == a || f[2] == b)) {
      ++marked;
      char expected[32];
      std::snprintf(expected, sizeof expected, "%.1f", marks[f[2]]);
      EXPECT_EQ(f[7], expected) << line;
      EXPECT_EQ(f[8], "") << "a practical mark is not a theory score: " << line;
    }
    if (f[1] != "session" || (f[2] != t && f[2] != d)) continue;
    ++seen;
    EXPECT_EQ(f[7], "") << "no mark: " << line;
    EXPECT_EQ(f[10], f[2] == t ? "timed_out" : "aborted") << line;
  }
  EXPECT_EQ(marked, 2) << csv->body;
  EXPECT_EQ(seen, 2) << csv->body;
}

// The instructor's hand on a running training session through the API: only staff, only a good
// body, each action audited on the pupil's record and reaching the worker over DDS (its state, as
// the live page reads it, shows the pause, the message and the time gone back); a pause while
// paused is refused.
TEST(Server, TheInstructorPausesMessagesRewindsAndResumesARunningSessionAndOnlyStaffMay) {
  Server s("instruct");
  const std::string admin = s.login("admin", kAdminPassword);
  ASSERT_EQ(s.call("POST", "/api/users", admin, R"({"username":"ines","password":"ines-pass-1","role":"instructor"})").first, 201);
  const json pupil = s.call("POST", "/api/pupils", admin, R"({"name":"Ana Pupil","username":"ana","password":"ana-pass-1"})").second;
  const std::string ines = s.login("ines", "ines-pass-1"), ana = s.login("ana", "ana-pass-1");
  auto [st, sess] = s.call("POST", "/api/sessions", admin,
                           json{{"pupil_id", pupil["id"]}, {"cab_id", "inscab"}, {"scenario", "first_drive_yard"}}.dump());
  ASSERT_EQ(st, 201) << sess;
  const std::string id = sess["id"], path = "/api/sessions/" + id + "/instructor";

  // Before it runs: refused as not running (the body is good).
  EXPECT_EQ(error_code(s.call("POST", path, ines, R"({"action":"pause"})").second), "not_running");
  // The cab: this test, speaking 50 times a second until the end.
  forklift::dds::Participant p(forklift::dds::DomainSettings::resolve(s.domain, ""));
  forklift_test::SpeakingCab cab(p, "inscab");
  // Live, as the page polls it, until `done` says so (the bound only stops a test that would hang).
  auto live_until = [&](const std::function<bool(const json&)>& done) { return s.live_until(ines, id, done); };
  ASSERT_TRUE(live_until([](const json& t) { return t["sim_time_s"].get<double>() > 1.2; }));

  // Who may: staff; a pupil, even on her own session, may not, nor anyone without a login.
  EXPECT_EQ(s.call("POST", path, ana, R"({"action":"pause"})").first, 403);
  EXPECT_EQ(s.call("POST", path, "", R"({"action":"pause"})").first, 401);
  EXPECT_EQ(s.call("POST", "/api/sessions/s-999999/instructor", ines, R"({"action":"pause"})").first, 404);
  // Bad bodies: 400 naming the field, and nothing reaches the worker.
  const std::string long_text(121, 'a');
  for (const std::string& bad : {std::string("not json"), std::string("{}"), std::string(R"({"action":"rewind"})"),
                                 std::string(R"({"action":"message"})"), std::string(R"({"action":"message","text":""})"),
                                 std::string(R"({"action":"message","text":"two\nlines"})"),
                                 std::string(R"({"action":"message","text":" padded "})"),
                                 std::string(R"({"action":"message","text":"bell\u0007"})"),
                                 json{{"action", "message"}, {"text", long_text}}.dump(), std::string(R"({"action":"message","text":42})"),
                                 std::string(R"({"action":"pause","text":"now"})"), std::string(R"({"action":"pause","by":"me"})"),
                                 std::string(R"({"action":"rewind","seconds":0})"), std::string(R"({"action":"rewind","seconds":-2})"),
                                 std::string(R"({"action":"rewind","seconds":4000})"), std::string(R"({"action":"rewind","seconds":"5"})"),
                                 std::string(R"({"action":"pause","seconds":3})"), std::string(R"({"action":"hazard"})"),
                                 std::string(R"({"action":"hazard","pedestrian":"W1"})"),  // the yard has nobody walking
                                 std::string(R"({"action":"pause","pedestrian":"W1"})"),
                                 std::string(R"(["pause"])")}) {
    const auto [code, body] = s.call("POST", path, ines, bad);
    EXPECT_EQ(code, 400) << bad << " -> " << body;
    EXPECT_EQ(error_code(body), bad == "not json" ? "bad_json" : "bad_request") << bad;
  }

  // Pause: the worker's state says so, and a second pause is refused.
  auto [pst, paused] = s.call("POST", path, ines, R"({"action":"pause"})");
  ASSERT_EQ(pst, 200) << paused;
  ASSERT_TRUE(live_until([](const json& t) { return t["paused"] == true; }));
  EXPECT_EQ(s.call("POST", path, ines, R"({"action":"pause"})").first, 409);
  // A message, non-ASCII and all: on the cab's display, as the live state shows.
  const std::string said = "Look over your shoulder before reversing \u2014 every time";
  EXPECT_EQ(s.call("POST", path, ines, json{{"action", "message"}, {"text", said}}.dump()).first, 200);
  EXPECT_TRUE(live_until([&](const json& t) { return t["instructor_message"] == said; }));
  // Try that again: paused, back at least a second, to a state the worker kept.
  double paused_at_s = 0;
  live_until([&](const json& t) { return (paused_at_s = t["sim_time_s"].get<double>()) > 0; });
  EXPECT_EQ(s.call("POST", path, ines, R"({"action":"rewind","seconds":1})").first, 200);
  EXPECT_TRUE(live_until([&](const json& t) { return t["sim_time_s"].get<double>() <= paused_at_s - 1; }));
  EXPECT_EQ(s.call("POST", path, admin, R"({"action":"resume"})").first, 200);
  EXPECT_TRUE(live_until([](const json& t) { return t["paused"] == false; }));
  // The rewind is on the session's record, with from when to when.
  bool rewound_event = false;
  for (int i = 0; i < 500 && !rewound_event; ++i) {
    const json record = s.call("GET", "/api/sessions/" + id, ines).second;
    for (const json& e : record["events"]) rewound_event |= e["kind"] == "rewound";
    if (!rewound_event) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_TRUE(rewound_event);

  // Each on the pupil's record: who and what.
  auto [ast, rows] = s.call("GET", "/api/pupils/" + std::to_string(pupil["id"].get<int64_t>()) + "/audit", ines);
  ASSERT_EQ(ast, 200) << rows;
  std::map<std::string, json> by_action;
  for (const json& r : rows) by_action[r["action"]] = r;
  EXPECT_EQ(by_action["session_paused"]["actor"], "ines");
  EXPECT_EQ(by_action["session_paused"]["details"]["session"], id);
  EXPECT_EQ(by_action["instructor_message_sent"]["details"]["text"], said);
  EXPECT_EQ(by_action["session_resumed"]["actor"], "admin");
  EXPECT_EQ(by_action["session_rewound"]["details"]["seconds"], 1);
  EXPECT_EQ(s.call("POST", "/api/sessions/" + id + "/abort", admin).first, 200);
}
