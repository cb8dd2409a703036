// A remote licence exam end to end with a real server, worker and cab under DDS Security: the
// examiner follows it live (state and frames), the record names the examiner, and any later
// change to the stored log, score or record is found by `forklift-menu verify`.
// Each test's server has its own port and DDS domain (support/ports.h).
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <thread>

#include "support/server.h"
#include "support/temp_dir.h"

using namespace forklift_test;
namespace fs = std::filesystem;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;
const std::string kPki = std::string(FORKLIFT_SOURCE_DIR) + "/scripts/forklift-pki.sh";
const std::string kScript = std::string(FORKLIFT_DATA_DIR) + "/evaluation/scripts/first_drive_yard_faults.csv";

std::string tmp(const std::string& name) { return forklift_test::process_path("exam-record", name); }

// Runs one SQL statement on the server's database file, as someone with the disk would.
std::string sql(const std::string& db, const std::string& statement) {
  sqlite3* h = nullptr;
  sqlite3_open(db.c_str(), &h);
  sqlite3_busy_timeout(h, 5000);
  char* err = nullptr;
  std::string out;
  sqlite3_exec(h, statement.c_str(), [](void* o, int n, char** v, char**) {
    for (int i = 0; i < n; ++i) *static_cast<std::string*>(o) += v[i] ? v[i] : "";
    return 0;
  }, &out, &err);
  const std::string error = err ? err : "";
  sqlite3_free(err);
  sqlite3_close(h);
  return error.empty() ? out : "ERROR: " + error;
}

class RemoteExam : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    fs::remove_all(pki());
    for (const std::string& cmd : {kPki + " init " + pki(), kPki + " add-cab " + pki() + " examcab", kPki + " issue " + pki() + " server main"})
      ASSERT_EQ(std::system((cmd + " >/dev/null 2>&1").c_str()), 0) << cmd;
  }
  static std::string pki() { return tmp("pki"); }

  // An examiner, a pupil, and an exam session started by the examiner and driven by the cab.
  struct Exam {
    std::string admin, examiner, id;
    int64_t pupil = 0;
  };
  Exam start_exam(const Server& s, double time_limit) {
    Exam e;
    e.admin = s.login("admin", kAdminPassword);
    EXPECT_EQ(s.call("POST", "/api/users", e.admin, json{{"username", "examiner1"}, {"password", "examine-123"}, {"role", "examiner"}}.dump()).first, 201);
    e.examiner = s.login("examiner1", "examine-123");
    auto [st, p] = s.call("POST", "/api/pupils", e.admin, json{{"name", "Remote Pupil"}}.dump());
    EXPECT_EQ(st, 201) << p;
    e.pupil = p.value("id", int64_t(0));
    auto [st2, sess] = s.call("POST", "/api/sessions", e.examiner,
                              json{{"pupil_id", e.pupil}, {"cab_id", "examcab"}, {"scenario", "first_drive_yard"}, {"mode", "exam"},
                                   {"time_limit_s", time_limit}}.dump());
    EXPECT_EQ(st2, 201) << sess;
    e.id = sess.value("id", "");
    return e;
  }
  // The cab saves its frames, so it asks the worker for them (frames_wanted), as a cab with a
  // window does: the examiner's live view has frames to show.
  Process cab(int domain, const std::string& name) {
    return Process({kBin + "/forklift-cab", "--cab", "examcab", "--script", kScript, "--no-window", "--security", pki(),
                    "--dds-domain", std::to_string(domain), "--wait-worker", "30", "--save-frame", tmp(name + ".png")},
                   tmp(name));
  }
  // forklift-menu verify, with the examiner's token and the school's CA: exit code and output.
  std::pair<int, std::string> verify(const Server& s, const std::string& token, const std::string& id) {
    const std::string token_file = tmp("token");
    std::ofstream(token_file) << token << '\n';
    Process p({kBin + "/forklift-menu", "--server", s.url(), "--token-file", token_file, "verify", id, "--school-ca", pki() + "/ca.pem"},
              tmp("verify-" + std::to_string(std::rand())));
    const int code = p.wait(30);
    return {code, p.out() + p.err()};
  }
};

TEST_F(RemoteExam, FollowedLiveSignedChainedAndEveryChangeIsDetected) {
  Server s("remote-exam", {"--security", pki(), "--frame-fps", "10"});
  const Exam e = start_exam(s, 12);
  ASSERT_FALSE(e.id.empty());
  Process c = cab(s.domain, "exam-cab");

  // Live: the truck's state and a JPEG frame, to the examiner, while the exam runs.
  json live;
  std::string jpeg;
  for (int i = 0; i < 300 && jpeg.empty(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    auto [st, j] = s.call("GET", "/api/sessions/" + e.id + "/live", e.examiner);
    if (st != 200 || !j.value("frame_available", false)) continue;
    live = j;
    auto cl = s.client();
    auto r = cl.Get("/api/sessions/" + e.id + "/live/frame.jpg", {{"Authorization", "Bearer " + e.examiner}});
    if (r && r->status == 200) jpeg = r->body;
  }
  ASSERT_FALSE(jpeg.empty()) << "no live frame reached the examiner; last: " << live;
  EXPECT_EQ(jpeg.substr(0, 2), "\xFF\xD8") << "a JPEG";
  EXPECT_GT(live["state"]["sim_time_s"].get<double>(), 0.0) << live;
  EXPECT_EQ(c.wait(60), 0) << c.err();

  const json done = s.wait_session(e.examiner, e.id, 60);
  ASSERT_EQ(done["state"], "ended") << done;
  json evidence;
  for (int i = 0; i < 100; ++i) {
    auto [st, j] = s.call("GET", "/api/sessions/" + e.id + "/evidence", e.examiner);
    if (st == 200) { evidence = j; break; }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_TRUE(evidence.is_object()) << "the exam was never chained";
  EXPECT_EQ(evidence["record"]["examiner"], "examiner1") << "the exam record names its examiner";
  EXPECT_GT(evidence["record"]["events"].size(), 0u);
  auto [hs, history] = s.call("GET", "/api/pupils/" + std::to_string(e.pupil) + "/history", e.examiner);
  ASSERT_EQ(hs, 200);
  ASSERT_EQ(history["exams"].size(), 1u) << history;
  EXPECT_EQ(history["exams"][0]["examiner"], "examiner1");

  const auto [ok_code, ok_out] = verify(s, e.examiner, e.id);
  EXPECT_EQ(ok_code, 0) << ok_out;
  EXPECT_NE(ok_out.find("verified: exam " + e.id), std::string::npos) << ok_out;

  // One byte of the stored control log.
  const std::string where = " WHERE name = 'control' AND session_id = (SELECT id FROM sessions WHERE public_id = '" + e.id + "')";
  const std::string log = sql(s.db, "SELECT body FROM session_logs" + where);
  ASSERT_GT(log.size(), 1000u);
  const size_t at = log.find("\ni ") + 5;  // inside an input line: the lever values the signature covers
  std::string changed = log;
  changed[at] = changed[at] == '1' ? '2' : '1';
  auto set_log = [&](const std::string& body) {
    std::string quoted;
    for (char ch : body) quoted += ch == '\'' ? std::string("''") : std::string(1, ch);
    return sql(s.db, "UPDATE session_logs SET body = '" + quoted + "'" + where);
  };
  ASSERT_EQ(set_log(changed), "");
  auto [c1, out1] = verify(s, e.examiner, e.id);
  EXPECT_NE(c1, 0) << out1;
  EXPECT_NE(out1.find("log"), std::string::npos) << out1;
  ASSERT_EQ(set_log(log), "");
  EXPECT_EQ(verify(s, e.examiner, e.id).first, 0) << "restored";

  // The stored score.
  const std::string score_where = " WHERE session_id = (SELECT id FROM sessions WHERE public_id = '" + e.id + "')";
  ASSERT_EQ(sql(s.db, "UPDATE scores SET mark = mark + 1" + score_where), "");
  auto [c2, out2] = verify(s, e.examiner, e.id);
  EXPECT_NE(c2, 0) << out2;
  EXPECT_NE(out2.find("mark"), std::string::npos) << out2;
  ASSERT_EQ(sql(s.db, "UPDATE scores SET mark = mark - 1" + score_where), "");
  EXPECT_EQ(verify(s, e.examiner, e.id).first, 0) << "restored";

  // The exam record's examiner.
  ASSERT_EQ(sql(s.db, "UPDATE sessions SET examiner_id = 1 WHERE public_id = '" + e.id + "'"), "");
  EXPECT_NE(verify(s, e.examiner, e.id).first, 0);

  // The chain is append-only in the schema; an edit made around the triggers breaks the hashes.
  EXPECT_NE(sql(s.db, "UPDATE exam_chain SET entry = entry").find("append-only"), std::string::npos);
  ASSERT_EQ(sql(s.db, "DROP TRIGGER exam_chain_no_update; UPDATE exam_chain SET entry = json_set(entry, '$.record.examiner_id', 1, "
                      "'$.record.examiner', 'admin')"), "");
  auto [c3, out3] = verify(s, e.examiner, e.id);
  EXPECT_NE(c3, 0) << out3;
}

TEST_F(RemoteExam, ExaminerAbortsARunningExam) {
  Server s("remote-abort", {"--security", pki(), "--frame-fps", "0"});
  const Exam e = start_exam(s, 60);
  ASSERT_FALSE(e.id.empty());
  Process c = cab(s.domain, "abort-cab");
  for (int i = 0; i < 300; ++i) {
    if (s.call("GET", "/api/sessions/" + e.id, e.examiner).second.value("state", "") == "running") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  auto [st, j] = s.call("POST", "/api/sessions/" + e.id + "/abort", e.examiner);
  ASSERT_EQ(st, 200) << j;
  EXPECT_EQ(j["state"], "aborted");
  EXPECT_NE(j["reason"].get<std::string>().find("examiner1"), std::string::npos) << j;
  EXPECT_EQ(c.wait(30), 0) << "the cab is told and stops: " << c.err();
}

TEST_F(RemoteExam, ServerWithoutSecurityRefusesExamsButRunsTraining) {
  Server s("remote-clear");
  const std::string admin = s.login("admin", kAdminPassword);
  auto [ps, p] = s.call("POST", "/api/pupils", admin, json{{"name", "P"}}.dump());
  ASSERT_EQ(ps, 201);
  auto [st, j] = s.call("POST", "/api/sessions", admin,
                        json{{"pupil_id", p["id"]}, {"cab_id", "examcab"}, {"scenario", "first_drive_yard"}, {"mode", "exam"}}.dump());
  EXPECT_EQ(st, 409) << j;
  EXPECT_EQ(error_code(j), "security_required");
  auto [st2, j2] = s.call("POST", "/api/sessions", admin,
                          json{{"pupil_id", p["id"]}, {"cab_id", "examcab"}, {"scenario", "first_drive_yard"}, {"mode", "training"},
                               {"time_limit_s", 1}}.dump());
  EXPECT_EQ(st2, 201) << j2;
}

}  // namespace
