// A remote licence exam end to end with a real server, worker and cab under DDS Security: the
// examiner follows it live (state and frames), the record names the examiner, and any later
// change to the stored log, score or record, to the pupils' names or the audit log, to the exam
// chain (its last entry deleted, the server restarted) is found by `forklift-menu verify`, refused
// by the server's start-up and not counted by history or the certificate. Ports and DDS domains
// come from tests/support/ports.h.
#include <gtest/gtest.h>

#include <signal.h>
#include <sqlite3.h>

#include <filesystem>
#include <functional>
#include <fstream>
#include <sstream>
#include <thread>

#include "support/exam_records.h"
#include "support/ports.h"
#include "support/server.h"
#include "support/temp_dir.h"

using namespace forklift_test;
namespace fs = std::filesystem;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;
const std::string kPki = std::string(FORKLIFT_SOURCE_DIR) + "/scripts/forklift-pki.sh";
// The exam course's clean drive (its first seconds: the exams here are cut short by their time limit).
const std::string kScript = std::string(FORKLIFT_DATA_DIR) + "/evaluation/scripts/counterbalance_exam_clean.csv";

std::string tmp(const std::string& name) { return forklift_test::process_path("exam-record", name); }

using forklift_test::drop_keeping_triggers;
using forklift_test::sql;

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
                              json{{"pupil_id", e.pupil}, {"cab_id", "examcab"}, {"scenario", "counterbalance_exam"}, {"mode", "exam"},
                                   {"time_limit_s", time_limit}}.dump());
    EXPECT_EQ(st2, 201) << sess;
    e.id = sess.value("id", "");
    return e;
  }
  // A training session on the exam course for a new pupil, started by `staff`: its id ("" if refused).
  static std::string start_training(const Server& s, const std::string& staff, const std::string& pupil) {
    auto [ps, p] = s.call("POST", "/api/pupils", staff, json{{"name", pupil}}.dump());
    EXPECT_EQ(ps, 201) << p;
    auto [st, sess] = s.call("POST", "/api/sessions", staff,
                             json{{"pupil_id", p["id"]}, {"cab_id", "examcab"}, {"scenario", "counterbalance_exam"}}.dump());
    EXPECT_EQ(st, 201) << sess;
    return sess.value("id", "");
  }
  // The cab saves its frames, so it asks the worker for them (frames_wanted), as a cab with a
  // window does: the examiner's live view has frames to show.
  Process cab(int domain, const std::string& name) {
    return Process({kBin + "/forklift-cab", "--cab", "examcab", "--script", kScript, "--no-window", "--security", pki(),
                    "--dds-domain", std::to_string(domain), "--wait-worker", "30", "--save-frame", tmp(name + ".png")},
                   tmp(name));
  }
  static std::vector<std::string> secure(const char* frame_fps = "0") { return {"--security", pki(), "--frame-fps", frame_fps}; }
  // An exam session run to its end by the scripted cab.
  Exam run_exam(const Server& s, int domain, const std::string& name, double time_limit) {
    Exam e = start_exam(s, time_limit);
    EXPECT_FALSE(e.id.empty());
    Process c = cab(domain, name);
    EXPECT_EQ(c.wait(60), 0) << c.err();
    EXPECT_EQ(s.wait_session(e.examiner, e.id, 60)["state"], "ended");
    return e;
  }
  // A server of its own, and one exam run on it to its end, chained and verified as it stands.
  struct Chained {
    std::unique_ptr<Server> server;
    Exam exam;
  };
  Chained chained_exam(const std::string& name) {
    const int port = forklift::test::free_port(), domain = forklift::test::free_domain();
    Chained c{std::make_unique<Server>(port, domain, name + "-" + std::to_string(port), secure()), {}};
    c.exam = run_exam(*c.server, domain, name + "-cab", 8);
    EXPECT_TRUE(wait_chained(*c.server, c.exam.examiner, c.exam.id)) << "the exam was never chained";
    EXPECT_EQ(verify(*c.server, c.exam.examiner, c.exam.id).first, 0);
    return c;
  }
  static bool in_chain(const json& evidence, const std::string& id) {
    if (!evidence.is_object() || !evidence["chain"].is_array()) return false;
    for (const json& e : evidence["chain"])
      if (e.is_object() && e.value("session", "") == id) return true;
    return false;
  }
  static json evidence_of(const Server& s, const std::string& token, const std::string& id) {
    return s.call("GET", "/api/sessions/" + id + "/evidence", token).second;
  }
  // The server chains an exam once its worker has exited and its score is in.
  static bool wait_chained(const Server& s, const std::string& token, const std::string& id) {
    for (int i = 0; i < 200; ++i) {
      if (in_chain(evidence_of(s, token, id), id)) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return false;
  }
  // Stopped (SIGTERM, as a school's service manager would) and started again on the same files.
  static void restart(Server& s, const std::vector<std::string>& args) {
    s.proc->signal(SIGTERM);
    ASSERT_EQ(s.proc->wait(30), 0) << s.proc->err();
    s.start(args);
  }
  // After a start, the server's check of its chain has had its say on exam `id` once the exam is
  // chained again, or the fleet reports a refusal or a broken chain.
  static void wait_chain_checked(const Server& s, const std::string& admin, const std::string& id) {
    for (int i = 0; i < 200; ++i) {
      const json c = json_at(s.call("GET", "/api/fleet", admin).second, "/exam_chain");
      if (json_at(c, "/ok") == false || (json_at(c, "/refused").is_number() && json_at(c, "/refused") > 0)) return;
      if (in_chain(evidence_of(s, admin, id), id)) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }
  static std::string where_session(const std::string& id) {
    return " WHERE session_id = (SELECT id FROM sessions WHERE public_id = '" + id + "')";
  }
  // The audit rows of the school with `action`.
  static std::vector<json> audit_rows(const Server& s, const std::string& admin, const std::string& action) {
    std::vector<json> out;
    for (const json& r : s.call("GET", "/api/audit?limit=1000", admin).second)
      if (r.value("action", "") == action) out.push_back(r);
    return out;
  }
  static void pass_theory(const Server& s, const std::string& staff, int64_t pupil) { forklift_test::pass_theory(s, staff, pupil); }
  // The pupil's practical exam in a history, null if it has none.
  static json practical(const json& history) {
    for (const json& e : json_at(history, "/exams"))
      if (json_at(e, "/kind") == "practical") return e;
    return nullptr;
  }
  // `j` at the JSON pointer `path`, null when it has nothing there.
  static json json_at(const json& j, const std::string& path) {
    const json::json_pointer p(path);
    return j.contains(p) ? j[p] : json();
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
  const int port = forklift::test::free_port(), domain = forklift::test::free_domain();
  Server s(port, domain, "remote-exam-" + std::to_string(port), secure("10"));
  const Exam e = start_exam(s, 12);
  ASSERT_FALSE(e.id.empty());
  Process c = cab(domain, "exam-cab");

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
  ASSERT_TRUE(wait_chained(s, e.examiner, e.id)) << "the exam was never chained";
  json evidence = evidence_of(s, e.examiner, e.id);
  EXPECT_EQ(evidence["record"]["examiner"], "examiner1") << "the exam record names its examiner";
  EXPECT_GT(evidence["record"]["events"].size(), 0u);
  auto [hs, history] = s.call("GET", "/api/pupils/" + std::to_string(e.pupil) + "/history", e.examiner);
  ASSERT_EQ(hs, 200);
  ASSERT_EQ(history["exams"].size(), 1u) << history;
  EXPECT_EQ(history["exams"][0]["examiner"], "examiner1");

  const auto [ok_code, ok_out] = verify(s, e.examiner, e.id);
  EXPECT_EQ(ok_code, 0) << ok_out;
  EXPECT_NE(ok_out.find("verified: exam " + e.id), std::string::npos) << ok_out;
  // Cut short by its time limit, the exam has no mark, and verify says so rather than the
  // evaluator's count of an unfinished drive ("mark 100 of 100, not passed").
  EXPECT_NE(ok_out.find("no mark: the time ran out, not passed"), std::string::npos) << ok_out;
  EXPECT_EQ(ok_out.find(" of 100"), std::string::npos) << ok_out;

  // The store keeps a finished exam as written: it refuses to change it. Someone
  // with the disk drops those triggers first; the evidence must find what they change.
  const std::string kept_where = " WHERE session_id = (SELECT id FROM sessions WHERE public_id = '" + e.id + "')";
  for (const std::string& edit : {"UPDATE scores SET mark = mark + 1" + kept_where, "UPDATE exams SET passed = 1 - passed" + kept_where,
                                   "UPDATE session_logs SET body = body || ' '" + kept_where,
                                   "UPDATE sessions SET examiner_id = 1 WHERE public_id = '" + e.id + "'"})
    EXPECT_NE(sql(s.db, edit).find("kept"), std::string::npos) << edit;
  ASSERT_EQ(drop_keeping_triggers(s.db), "");

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

  // History counts the exam with its evidence, which holds.
  EXPECT_EQ(json_at(practical(history), "/evidence/verified"), true) << history;

  // The pupil's name: corrected through the API (audited), the record still verifies; swapped with
  // another pupil's in the database, it does not.
  EXPECT_EQ(evidence["record"]["pupil"], "Remote Pupil") << "the record names the pupil";
  auto [os, other] = s.call("POST", "/api/pupils", e.admin, json{{"name", "Other Pupil"}}.dump());
  ASSERT_EQ(os, 201) << other;
  const std::string pupil_path = "/api/pupils/" + std::to_string(e.pupil);
  ASSERT_EQ(s.call("PATCH", pupil_path, e.admin, json{{"name", "Remote Pupil-Smith"}}.dump()).first, 200);
  const auto [renamed_code, renamed_out] = verify(s, e.examiner, e.id);
  EXPECT_EQ(renamed_code, 0) << "an audited correction of the name is no tampering\n" << renamed_out;
  const std::string ids = std::to_string(e.pupil) + ", " + std::to_string(other["id"].get<int64_t>());
  ASSERT_EQ(sql(s.db, "UPDATE pupils SET name = CASE id WHEN " + std::to_string(e.pupil) + " THEN 'Other Pupil' ELSE "
                      "'Remote Pupil-Smith' END WHERE id IN (" + ids + ")"), "");
  auto [c4, out4] = verify(s, e.examiner, e.id);
  EXPECT_EQ(c4, 3) << out4;
  EXPECT_NE(out4.find("differs from the current record in: pupil"), std::string::npos) << out4;
  ASSERT_EQ(sql(s.db, "UPDATE pupils SET name = CASE id WHEN " + std::to_string(e.pupil) + " THEN 'Remote Pupil-Smith' ELSE "
                      "'Other Pupil' END WHERE id IN (" + ids + ")"), "");
  EXPECT_EQ(verify(s, e.examiner, e.id).first, 0) << "restored";

  // The audit log: the row of the exam's start edited around its trigger.
  const std::string started = " WHERE action = 'session_started' AND json_extract(details, '$.session') = '" + e.id + "'";
  const std::string details = sql(s.db, "SELECT details FROM audit_log" + started);
  ASSERT_NE(details.find(e.id), std::string::npos) << details;
  EXPECT_NE(sql(s.db, "UPDATE audit_log SET details = details" + started).find("append-only"), std::string::npos);
  ASSERT_EQ(sql(s.db, "DROP TRIGGER audit_log_no_update; UPDATE audit_log SET details = json_set(details, '$.time_limit_s', 600)" +
                      started), "");
  auto [c5, out5] = verify(s, e.examiner, e.id);
  EXPECT_EQ(c5, 3) << out5;
  EXPECT_NE(out5.find("differs from the current record in: audit"), std::string::npos) << out5;
  ASSERT_EQ(sql(s.db, "UPDATE audit_log SET details = json('" + details + "')" + started), "");
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

// The last chain entry deleted around the trigger, the exam moved to another
// pupil and examiner, the server restarted. Its start-up must not chain the edited record again:
// the chain is shorter than its anchor, and verify says the chain was cut short.
TEST_F(RemoteExam, ChainCutShortAndTheExamMovedIsRefusedAtStartAndReportedByVerify) {
  auto [server, e] = chained_exam("remote-cut");
  ASSERT_FALSE(HasFailure());
  Server& s = *server;
  auto [ps, other] = s.call("POST", "/api/pupils", e.admin, json{{"name", "Someone Else"}}.dump());
  ASSERT_EQ(ps, 201);
  ASSERT_EQ(s.call("POST", "/api/users", e.admin, json{{"username", "examiner2"}, {"password", "examine-456"}, {"role", "examiner"}}.dump()).first, 201);
  const std::string other_pupil = std::to_string(other["id"].get<int64_t>());

  s.proc->signal(SIGTERM);
  ASSERT_EQ(s.proc->wait(30), 0) << s.proc->err();
  ASSERT_EQ(drop_keeping_triggers(s.db), "");
  ASSERT_EQ(sql(s.db, "DROP TRIGGER exam_chain_no_delete; DELETE FROM exam_chain WHERE seq = (SELECT MAX(seq) FROM exam_chain); "
                      "UPDATE sessions SET pupil_id = " + other_pupil + ", examiner_id = (SELECT id FROM users WHERE username = "
                      "'examiner2') WHERE public_id = '" + e.id + "'; UPDATE exams SET pupil_id = " + other_pupil +
                      ", examiner_id = (SELECT id FROM users WHERE username = 'examiner2')" + where_session(e.id)), "");
  ASSERT_EQ(sql(s.db, "SELECT COUNT(*) FROM exam_chain"), "0");
  s.start(secure());
  const std::string admin = s.login("admin", kAdminPassword);
  wait_chain_checked(s, admin, e.id);

  // Refused at start: not chained again, said on stderr, on the fleet and in the audit log.
  const json ev = evidence_of(s, admin, e.id);
  EXPECT_FALSE(in_chain(ev, e.id)) << "the server chained the edited record again: " << ev["chain"];
  const json chain = json_at(s.call("GET", "/api/fleet", admin).second, "/exam_chain");
  EXPECT_EQ(json_at(chain, "/ok"), false) << chain;
  EXPECT_NE(json_at(chain, "/problem").dump().find("the chain is cut short"), std::string::npos) << chain;
  EXPECT_NE(s.proc->err().find("No exam is chained"), std::string::npos) << s.proc->err();
  const std::vector<json> cut = audit_rows(s, admin, "exam_chain_cut_short");
  EXPECT_EQ(cut.size(), 1u) << s.call("GET", "/api/audit", admin).second;
  for (const json& r : cut) EXPECT_EQ(json_at(r, "/details/session"), e.id);

  // verify: tampering (exit 3), not "not a chained exam".
  auto [code, out] = verify(s, admin, e.id);
  EXPECT_EQ(code, 3) << out;
  EXPECT_NE(out.find("the chain is cut short"), std::string::npos) << out;
  EXPECT_NE(out.find("its entry was deleted"), std::string::npos) << out;
  EXPECT_NE(out.find("TAMPERED"), std::string::npos) << out;

  // History does not count it for the pupil it was moved to.
  const json exam = practical(s.call("GET", "/api/pupils/" + other_pupil + "/history", admin).second);
  ASSERT_FALSE(exam.is_null());
  EXPECT_EQ(json_at(exam, "/passed"), false) << exam;
  EXPECT_EQ(json_at(exam, "/evidence/verified"), false) << exam;
}

// The last entry and the log's signature deleted and the exam set passed.
// verify says tampering (the anchor names the exam's entry), and neither history nor the
// certificate counts the pass.
TEST_F(RemoteExam, DeletedEntryAndSignatureWithPassedSetIsTamperingAndCountsForNothing) {
  auto [server, e] = chained_exam("remote-unsigned");
  ASSERT_FALSE(HasFailure());
  Server& s = *server;
  pass_theory(s, e.admin, e.pupil);
  const std::string pupil = "/api/pupils/" + std::to_string(e.pupil);
  const json before = practical(s.call("GET", pupil + "/history", e.admin).second);
  ASSERT_TRUE(json_at(before, "/passed").is_boolean()) << before;
  EXPECT_EQ(json_at(before, "/evidence/verified"), true) << before;
  // No certificate before a licence, and none at all on an exam that was not on an exam course.
  EXPECT_EQ(error_code(s.call("GET", pupil + "/certificate", e.admin).second), "not_certified");

  ASSERT_EQ(drop_keeping_triggers(s.db), "");
  ASSERT_EQ(sql(s.db, "DROP TRIGGER exam_chain_no_delete; DELETE FROM exam_chain WHERE seq = (SELECT MAX(seq) FROM exam_chain); "
                      "DELETE FROM session_logs" + where_session(e.id) + " AND name = 'signature'; "
                      "UPDATE scores SET passed = 1" + where_session(e.id) + "; UPDATE exams SET passed = 1" + where_session(e.id) +
                      "; UPDATE sessions SET passed = 1 WHERE public_id = '" + e.id + "'"), "");

  auto [code, out] = verify(s, e.examiner, e.id);
  EXPECT_EQ(code, 3) << out;
  EXPECT_NE(out.find("its entry was deleted"), std::string::npos) << out;
  const json after = s.call("GET", pupil + "/history", e.admin).second;
  EXPECT_EQ(json_at(practical(after), "/passed"), false) << after;
  EXPECT_EQ(json_at(practical(after), "/evidence/verified"), false) << after;
  for (const json& x : json_at(after, "/sessions")) {
    if (json_at(x, "/id") == e.id) {
      EXPECT_EQ(json_at(x, "/passed"), false) << x;
    }
  }
  // The pass set behind the server's back counts for nothing: no licence, and so no certificate.
  auto [ls, licence] = s.call("POST", pupil + "/licence", e.admin);
  EXPECT_EQ(ls, 409) << licence;
  EXPECT_EQ(error_code(licence), "not_certified") << licence;
  EXPECT_NE(licence.dump().find("does not verify"), std::string::npos) << licence;
  EXPECT_EQ(error_code(s.call("GET", pupil + "/certificate", e.admin).second), "not_certified");
}

// A server that stopped between a worker's exit and the chaining chains the
// exam at its next start, but only if the record agrees with the worker's signed log. Here the
// result was flipped meanwhile: refused (logged, counted, audited) and verify says "not chained";
// put back, it is chained at the next start.
TEST_F(RemoteExam, UnchainedExamIsCheckedAgainstItsSignedLogAtStart) {
  auto [server, e] = chained_exam("remote-unchained");
  ASSERT_FALSE(HasFailure());
  Server& s = *server;
  const std::string passed = sql(s.db, "SELECT passed FROM scores" + where_session(e.id));
  ASSERT_TRUE(passed == "0" || passed == "1") << passed;
  const std::string flipped = passed == "1" ? "0" : "1";

  // The state a stop between the two would have left: no chain entry, and no anchor line for it.
  s.proc->signal(SIGTERM);
  ASSERT_EQ(s.proc->wait(30), 0) << s.proc->err();
  ASSERT_EQ(sql(s.db, "DROP TRIGGER exam_chain_no_delete; DELETE FROM exam_chain" + where_session(e.id)), "");
  const std::string anchor = s.db + ".logs/exam-chain.anchor";
  if (fs::exists(anchor)) {
    std::ifstream in(anchor);
    std::string kept, line;
    while (std::getline(in, line))
      if (line.find("\"" + e.id + "\"") == std::string::npos) kept += line + "\n";
    in.close();
    std::ofstream(anchor, std::ios::trunc) << kept;
  }
  ASSERT_EQ(drop_keeping_triggers(s.db), "");
  auto set_passed = [&](const std::string& v) {
    return sql(s.db, "UPDATE scores SET passed = " + v + where_session(e.id) + "; UPDATE exams SET passed = " + v + where_session(e.id) +
                     "; UPDATE sessions SET passed = " + v + " WHERE public_id = '" + e.id + "'");
  };
  ASSERT_EQ(set_passed(flipped), "");
  s.start(secure());
  const std::string admin = s.login("admin", kAdminPassword);
  wait_chain_checked(s, admin, e.id);

  EXPECT_FALSE(in_chain(evidence_of(s, admin, e.id), e.id)) << "a record that disagrees with its signed log was chained";
  const json chain = json_at(s.call("GET", "/api/fleet", admin).second, "/exam_chain");
  EXPECT_EQ(json_at(chain, "/refused"), 1) << chain;
  EXPECT_EQ(json_at(chain, "/ok"), true) << chain;
  EXPECT_NE(s.proc->err().find(e.id + " is not chained"), std::string::npos) << s.proc->err();
  const std::vector<json> refused = audit_rows(s, admin, "exam_chain_refused");
  EXPECT_EQ(refused.size(), 1u);
  for (const json& r : refused) {
    EXPECT_EQ(json_at(r, "/details/session"), e.id);
    EXPECT_NE(json_at(r, "/details/reason").dump().find("log score says"), std::string::npos) << r;
  }
  auto [code, out] = verify(s, admin, e.id);
  EXPECT_EQ(code, 4) << out;
  EXPECT_NE(out.find("NOT CHAINED"), std::string::npos) << out;
  EXPECT_NE(out.find("the server refused to chain it"), std::string::npos) << out;
  const json h = s.call("GET", "/api/pupils/" + std::to_string(e.pupil) + "/history", admin).second;
  EXPECT_EQ(json_at(practical(h), "/passed"), false) << h;

  ASSERT_EQ(set_passed(passed), "");
  restart(s, secure());
  const std::string again = s.login("admin", kAdminPassword);  // logins do not outlive the server
  ASSERT_TRUE(wait_chained(s, again, e.id)) << "the record, put back, agrees with its log again: " << s.proc->err();
  auto [code2, out2] = verify(s, again, e.id);
  EXPECT_EQ(code2, 0) << out2;
}

TEST_F(RemoteExam, ExaminerAbortsARunningExamAndMayNotPauseMessageOrRewindIt) {
  const int port = forklift::test::free_port(), domain = forklift::test::free_domain();
  Server s(port, domain, "remote-abort-" + std::to_string(port), secure());
  const Exam e = start_exam(s, 60);
  ASSERT_FALSE(e.id.empty());
  Process c = cab(domain, "abort-cab");
  for (int i = 0; i < 300; ++i) {
    if (s.call("GET", "/api/sessions/" + e.id, e.examiner).second.value("state", "") == "running") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  // An exam runs as the examinee drives it: no pause, message or rewind, only the abort.
  for (const char* body : {R"({"action":"pause"})", R"({"action":"message","text":"Good luck"})", R"({"action":"rewind","seconds":5})"}) {
    const auto [code, answer] = s.call("POST", "/api/sessions/" + e.id + "/instructor", e.examiner, body);
    EXPECT_EQ(code, 409) << body << " -> " << answer;
    EXPECT_EQ(answer["error"]["code"], "exam") << answer;
  }
  auto [st, j] = s.call("POST", "/api/sessions/" + e.id + "/abort", e.examiner);
  ASSERT_EQ(st, 200) << j;
  EXPECT_EQ(j["state"], "aborted");
  EXPECT_NE(j["reason"].get<std::string>().find("examiner1"), std::string::npos) << j;
  EXPECT_EQ(c.wait(30), 0) << "the cab is told and stops: " << c.err();
}

// Under DDS Security the server's pause and message reach a training session's worker, which
// believes them from the server's identity alone (the instructor partition's permissions): its
// state, as the live view reads it, shows both.
TEST_F(RemoteExam, UnderSecurityTheServersPauseAndMessageReachATrainingSessionsWorker) {
  const int port = forklift::test::free_port(), domain = forklift::test::free_domain();
  Server s(port, domain, "remote-pause-" + std::to_string(port), secure());
  const std::string admin = s.login("admin", kAdminPassword);
  const std::string id = start_training(s, admin, "Trained Pupil");
  ASSERT_FALSE(id.empty());
  Process c = cab(domain, "pause-cab");
  auto live_until = [&](const std::function<bool(const json&)>& done) { return s.live_until(admin, id, done); };
  ASSERT_TRUE(live_until([](const json& t) { return t["sim_time_s"].get<double>() > 0.5; })) << c.err();
  const std::string path = "/api/sessions/" + id + "/instructor";
  ASSERT_EQ(s.call("POST", path, admin, R"({"action":"pause"})").first, 200);
  EXPECT_TRUE(live_until([](const json& t) { return t["paused"] == true; }));
  ASSERT_EQ(s.call("POST", path, admin, R"({"action":"message","text":"Secure and sound"})").first, 200);
  EXPECT_TRUE(live_until([](const json& t) { return t["instructor_message"] == "Secure and sound"; }));
  ASSERT_EQ(s.call("POST", path, admin, R"({"action":"resume"})").first, 200);
  EXPECT_TRUE(live_until([](const json& t) { return t["paused"] == false; }));
  EXPECT_EQ(s.call("POST", "/api/sessions/" + id + "/abort", admin).first, 200);
  c.wait(30);
}

// Under DDS Security the server's rewind reaches a training session's worker too: paused (so that
// its time stands), taken back 2 s, the session's state is the kept point's: its time at least 2 s
// earlier, on a kept point's 2 s step, and the truck where the worker's "rewound" event says the
// point had it, metres back along its drive.
TEST_F(RemoteExam, UnderSecurityTheServersRewindTakesATrainingSessionsStateBack) {
  const int port = forklift::test::free_port(), domain = forklift::test::free_domain();
  Server s(port, domain, "remote-rewind-" + std::to_string(port), secure());
  const std::string admin = s.login("admin", kAdminPassword);
  const std::string id = start_training(s, admin, "Rewound Pupil");
  ASSERT_FALSE(id.empty());
  Process c = cab(domain, "rewind-cab");
  auto live_until = [&](const std::function<bool(const json&)>& done) { return s.live_until(admin, id, done); };
  const std::string path = "/api/sessions/" + id + "/instructor";
  // The script drives off at 1 s: by 6 s the truck is well on its way.
  ASSERT_TRUE(live_until([](const json& t) { return t["sim_time_s"].get<double>() > 6.0; })) << c.err();
  ASSERT_EQ(s.call("POST", path, admin, R"({"action":"pause"})").first, 200);
  json paused;
  ASSERT_TRUE(live_until([&](const json& t) { paused = t; return t["paused"] == true; }));
  const double from_s = paused["sim_time_s"];
  ASSERT_EQ(s.call("POST", path, admin, R"({"action":"rewind","seconds":2})").first, 200);
  json back;
  ASSERT_TRUE(live_until([&](const json& t) { back = t; return t["sim_time_s"].get<double>() <= from_s - 2; }))
      << "the state never went back: " << paused;
  const double to_s = back["sim_time_s"];
  EXPECT_TRUE(back["paused"] == true) << "still paused: the clock stands at the point";
  EXPECT_GE(to_s, from_s - 4) << "the newest point at least 2 s back (one is kept every 2 s)";
  EXPECT_NEAR(std::remainder(to_s, 2.0), 0.0, 1e-6) << to_s;
  // The worker's event says where the kept point had the truck; its state is there.
  json rewound;
  for (int i = 0; i < 200 && rewound.is_null(); ++i) {
    const json now = s.call("GET", "/api/sessions/" + id, admin).second;
    for (const json& e : now["events"])
      if (e.value("kind", "") == "rewound") rewound = json::parse(e.value("details", "{}"), nullptr, false);
    if (rewound.is_null()) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_TRUE(rewound.is_object()) << "no rewound event reached the server";
  EXPECT_DOUBLE_EQ(rewound["to_s"].get<double>(), to_s);
  // (hex floats, as the session log writes them)
  const auto exact = [](const json& v) { return std::strtod(v.get<std::string>().c_str(), nullptr); };
  EXPECT_EQ(back["x_m"].get<double>(), exact(rewound["state"]["x_m"]));
  EXPECT_EQ(back["y_m"].get<double>(), exact(rewound["state"]["y_m"]));
  EXPECT_GT(std::hypot(back["x_m"].get<double>() - paused["x_m"].get<double>(), back["y_m"].get<double>() - paused["y_m"].get<double>()), 0.5)
      << "the truck is back where it was 2 s earlier: " << paused << " then " << back;
  ASSERT_EQ(s.call("POST", path, admin, R"({"action":"resume"})").first, 200);
  EXPECT_TRUE(live_until([&](const json& t) { return t["paused"] == false && t["sim_time_s"].get<double>() > to_s; }));
  EXPECT_EQ(s.call("POST", "/api/sessions/" + id + "/abort", admin).first, 200);
  c.wait(30);
}

TEST_F(RemoteExam, ServerWithoutSecurityRefusesExamsButRunsTraining) {
  const int port = forklift::test::free_port();
  Server s(port, forklift::test::free_domain(), "remote-clear-" + std::to_string(port));
  const std::string admin = s.login("admin", kAdminPassword);
  auto [ps, p] = s.call("POST", "/api/pupils", admin, json{{"name", "P"}}.dump());
  ASSERT_EQ(ps, 201);
  auto [st, j] = s.call("POST", "/api/sessions", admin,
                        json{{"pupil_id", p["id"]}, {"cab_id", "examcab"}, {"scenario", "counterbalance_exam"}, {"mode", "exam"}}.dump());
  EXPECT_EQ(st, 409) << j;
  EXPECT_EQ(error_code(j), "security_required");
  auto [st2, j2] = s.call("POST", "/api/sessions", admin,
                          json{{"pupil_id", p["id"]}, {"cab_id", "examcab"}, {"scenario", "first_drive_yard"}, {"mode", "training"},
                               {"time_limit_s", 1}}.dump());
  EXPECT_EQ(st2, 201) << j2;
}

}  // namespace
