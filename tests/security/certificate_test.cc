// Certificates and exam records that stand up, on a real server under DDS
// Security with a real worker and cab: a pupil passes a supervised theory exam and a practical
// exam on the shipped exam course; no licence before both, no certificate before the licence; the
// certificate names the school and people by their full names and cites the exams; anyone can
// verify it by its number (no login), and the check finds a record changed behind the server's
// back, an exam changed or withdrawn, and a revocation. Nothing the API offers changes a finished
// exam: a correction is a new, audited record beside it. Ports and DDS domains come from
// tests/support/ports.h.
#include <gtest/gtest.h>
#include <signal.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <regex>
#include <thread>

#include "support/cab_script.h"
#include "support/exam_records.h"
#include "support/ports.h"
#include "support/server.h"
#include "support/temp_dir.h"

using namespace forklift_test;
namespace fs = std::filesystem;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;
const std::string kPki = std::string(FORKLIFT_SOURCE_DIR) + "/scripts/forklift-pki.sh";
const std::string kCourse = "counterbalance_exam";  // the shipped exam course (data/scenarios/)
const std::string kCleanDrive = std::string(FORKLIFT_DATA_DIR) + "/evaluation/scripts/counterbalance_exam_clean.csv";
const std::string kSchool = "Hillside Forklift School";
const int kTrainingSessions = 3;  // data/licence/rules.json's training.marked_sessions
const std::string kPublicUrl = "https://certificates.hillside.example";

std::string tmp(const std::string& name) { return process_path("certificate", name); }

// `j` at the JSON pointer `path`, null when it has nothing there.
json at(const json& j, const std::string& path) {
  const json::json_pointer p(path);
  return j.is_object() && j.contains(p) ? j[p] : json();
}

class Certificates : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    fs::remove_all(pki());
    for (const std::string& cmd : {kPki + " init " + pki() + " --school '" + kSchool + "'", kPki + " add-cab " + pki() + " certcab",
                                   kPki + " issue " + pki() + " server main"})
      ASSERT_EQ(std::system((cmd + " >/dev/null 2>&1").c_str()), 0) << cmd;
  }
  static std::string pki() { return tmp("pki"); }
  // Two failed logins (and so 8 unknown certificate numbers) per address and minute.
  static std::vector<std::string> secure(const std::string& folder = pki()) {
    return {"--security", folder, "--frame-fps", "0", "--login-attempts", "2"};
  }

  // The school's people: an administrator without a full name (as accounts made before names
  // were kept), an examiner and an instructor with theirs, and a pupil with a login.
  struct School {
    std::string admin, examiner, instructor, pupil_token;
    int64_t pupil = 0, examiner_id = 0;
  };
  static School people(const Server& s) {
    School p;
    p.admin = s.login("admin", kAdminPassword);
    auto [st, eric] = s.call("POST", "/api/users", p.admin,
                             json{{"username", "eric"}, {"password", "examine-123"}, {"role", "examiner"}, {"full_name", "Eric Examiner"}}.dump());
    EXPECT_EQ(st, 201) << eric;
    p.examiner_id = eric.value("id", int64_t(0));
    EXPECT_EQ(s.call("POST", "/api/users", p.admin,
                     json{{"username", "ines"}, {"password", "instruct-123"}, {"role", "instructor"}, {"full_name", "Ines Instructor"}}.dump()).first,
              201);
    p.examiner = s.login("eric", "examine-123");
    p.instructor = s.login("ines", "instruct-123");
    auto [ps, pupil] = s.call("POST", "/api/pupils", p.admin,
                              json{{"name", "Ann Driver"}, {"username", "ann"}, {"password", "ann-pass-1"}}.dump());
    EXPECT_EQ(ps, 201) << pupil;
    p.pupil = pupil.value("id", int64_t(0));
    p.pupil_token = s.login("ann", "ann-pass-1");
    return p;
  }
  static std::string pupil_path(const School& p) { return "/api/pupils/" + std::to_string(p.pupil); }
  static json exam_of(const json& history, const std::string& kind) {
    for (const json& e : at(history, "/exams"))
      if (e["kind"] == kind && !e["id"].is_null()) return e;
    return nullptr;
  }
  // `sessions` marked training sessions for the pupil on cab certcab: the paper's first manoeuvre
  // on the training truck (the exam course's truck class), 3 s of it, a scripted cab driving the
  // first second; the run's end marks it.
  static void train(const Server& s, const std::string& token, int64_t pupil, const std::string& security, int sessions) {
    for (int i = 0; i < sessions; ++i) {
      auto [st, session] = s.call("POST", "/api/sessions", token,
                                  json{{"pupil_id", pupil}, {"cab_id", "certcab"}, {"scenario", "manoeuvre_1"}, {"truck", "linde_e16c"},
                                       {"time_limit_s", 3}}.dump());
      ASSERT_EQ(st, 201) << session;
      Process cab(std::vector<std::string>{kBin + "/forklift-cab", "--cab", "certcab", "--script", short_script(s.dir, 1.0), "--no-window",
                                           "--security", security, "--dds-domain", std::to_string(s.domain), "--wait-worker", "30"},
                  tmp("training-cab-" + std::to_string(i)));
      const json done = s.wait_session(token, session["id"], 60);
      ASSERT_EQ(done["outcome"], "completed") << done;
      ASSERT_TRUE(done["mark"].is_number()) << done;
      // The cab is free once the fleet has let the worker go.
      for (int k = 0; k < 100 && cab_busy(s, token); ++k) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }
  static bool cab_busy(const Server& s, const std::string& token) {
    for (const json& w : s.call("GET", "/api/fleet", token).second.value("workers", json::array()))
      if (w.value("cab", "") == "certcab") return true;
    return false;
  }
  // The school the exam course's drive leaves: ctest's fixture folder, or one of this process's.
  static std::string exam_course_school() {
    const char* folder = std::getenv("FORKLIFT_EXAM_COURSE_SCHOOL");
    return folder && *folder ? folder : tmp("exam-course");
  }
  // A secured server with the school's people, whose pupil Ann drives the exam course's clean
  // drive live; once the exam is chained with its evidence verified, the server is stopped and
  // `folder` keeps its database, workers' logs and security folder, with school.json naming who
  // is who. The security folder also holds the web test's two cabs.
  static void make_exam_course_school(const std::string& folder) {
    fs::remove_all(folder);
    fs::create_directories(folder);
    const std::string security = folder + "/pki";
    for (const std::string& cmd : {kPki + " init " + security + " --school '" + kSchool + "'", kPki + " add-cab " + security + " certcab",
                                   kPki + " add-cab " + security + " webcab1", kPki + " add-cab " + security + " webcab2",
                                   kPki + " issue " + security + " server main"})
      ASSERT_EQ(std::system((cmd + " >/dev/null 2>&1").c_str()), 0) << cmd;
    const int port = forklift::test::free_port(), domain = forklift::test::free_domain();
    Server s(port, domain, "exam-course-" + std::to_string(port), secure(security));
    const School p = people(s);
    // The training the school's licence rules ask for (data/licence/rules.json: 3 marked sessions).
    ASSERT_NO_FATAL_FAILURE(train(s, p.examiner, p.pupil, security, kTrainingSessions));
    auto [es, exam] = s.call("POST", "/api/sessions", p.examiner,
                             json{{"pupil_id", p.pupil}, {"cab_id", "certcab"}, {"scenario", kCourse}, {"mode", "exam"}}.dump());
    ASSERT_EQ(es, 201) << exam;
    const std::string session = exam["id"];
    Process cab(std::vector<std::string>{kBin + "/forklift-cab", "--cab", "certcab", "--script", kCleanDrive, "--no-window", "--security",
                                         security, "--dds-domain", std::to_string(domain), "--wait-worker", "30"},
                tmp("cab"));
    ASSERT_EQ(cab.wait(600), 0) << cab.err();
    const json done = s.wait_session(p.examiner, session, 60);
    ASSERT_EQ(done["state"], "ended") << done;
    ASSERT_EQ(done["outcome"], "completed") << done;
    json history, practical;
    for (int i = 0; i < 200 && !at(practical, "/counts_toward_licence").is_boolean(); ++i) {  // chained once its worker exits
      history = s.call("GET", pupil_path(p) + "/history", p.examiner).second;
      practical = exam_of(history, "practical");
      if (at(practical, "/evidence/verified") != true) practical = nullptr;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    ASSERT_EQ(at(practical, "/passed"), true) << history;
    // The shipped clean drive is clean live, as it is offline: mark 100, no fault, its end the
    // pupil's (the task done and the truck let be), not the instant the truck came to rest.
    const json marked = s.call("GET", "/api/sessions/" + session, p.examiner).second;
    EXPECT_EQ(marked["reason"], "task_complete") << marked;
    EXPECT_EQ(marked["mark"], 100.0) << marked["events"].dump(1);
    for (const json& e : marked["events"]) EXPECT_EQ(e["worry_level"], 0) << "a fault in the clean drive: " << e.dump();
    ASSERT_EQ(s.stop(), 0) << s.proc->err();
    for (const char* part : Server::kSchoolParts) fs::copy(s.dir + "/" + part, folder + "/" + part, fs::copy_options::recursive);
    std::ofstream(folder + "/school.json") << json{{"school", kSchool}, {"pupil", p.pupil}, {"examiner_id", p.examiner_id}, {"session", session},
                                                  {"admin_password", kAdminPassword}, {"logins", {{"examiner", {"eric", "examine-123"}},
                                                  {"instructor", {"ines", "instruct-123"}}, {"pupil", {"ann", "ann-pass-1"}}}}}.dump(2);
  }
  // The people of a school made by make_exam_course_school(), logged in.
  static School log_in(const Server& s, const json& made) {
    School p;
    p.admin = s.login("admin", made["admin_password"]);
    p.examiner = s.login(made["logins"]["examiner"][0], made["logins"]["examiner"][1]);
    p.instructor = s.login(made["logins"]["instructor"][0], made["logins"]["instructor"][1]);
    p.pupil_token = s.login(made["logins"]["pupil"][0], made["logins"]["pupil"][1]);
    p.pupil = made["pupil"];
    p.examiner_id = made["examiner_id"];
    return p;
  }
  static std::string read_file(const std::string& path) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }
  // The certificate's check, anyone's: no token.
  static std::pair<int, json> verify(const Server& s, const std::string& number) { return s.call("GET", "/api/certificates/" + number); }
};

// The exam course's clean drive takes 255 s of real time, so the suite drives it once: this test
// (ctest's fixture "exam_course", tests/CMakeLists.txt) leaves a school whose pupil passed it, a
// secured server's database and workers' logs with its DDS Security folder, in
// FORKLIFT_EXAM_COURSE_SCHOOL; web_e2e and the licence test below start their servers on copies.
TEST_F(Certificates, TheExamCourseDrivenCleanLiveLeavesASchoolWithAPassedChainedExam) {
  const std::string folder = exam_course_school();
  fs::remove_all(folder);
  const std::string staging = folder + ".making";
  ASSERT_NO_FATAL_FAILURE(make_exam_course_school(staging));
  fs::rename(staging, folder);
}

TEST_F(Certificates, IssuedWithTheLicenceOnVerifiedExamsCheckedByAnyoneAndRefusedWhenChangedOrRevoked) {
  std::string school = exam_course_school();
  if (!fs::exists(school + "/school.json")) {  // run on its own, not by ctest: the drive is made here
    school = tmp("exam-course-school");
    ASSERT_NO_FATAL_FAILURE(make_exam_course_school(school));
  }
  const json made = json::parse(read_file(school + "/school.json"));
  const int port = forklift::test::free_port();
  // Rules that ask for one training session more than the school's pupil has had, and the
  // school's public address.
  const std::string rules = tmp("licence-rules.json");
  std::ofstream(rules) << json{{"training", {{"marked_sessions", kTrainingSessions + 1}}}, {"theory", {{"within_months", 12}}}}.dump();
  std::vector<std::string> args = secure(school + "/pki");
  args.insert(args.end(), {"--licence-rules", rules, "--public-url", kPublicUrl + "/"});
  Server s("certificate-" + std::to_string(port), Server::Copy{school}, args);
  const School p = log_in(s, made);
  const std::string path = pupil_path(p);
  const std::string session = made["session"];

  // Nothing passed: no licence, no certificate, for anyone.
  auto [bs, bo] = s.call("POST", "/api/pupils", p.admin, json{{"name", "Bo Newcomer"}, {"username", "bo"}, {"password", "bo-pass-12"}}.dump());
  ASSERT_EQ(bs, 201) << bo;
  const std::string bo_path = "/api/pupils/" + bo["id"].dump();
  auto [l0, none] = s.call("POST", bo_path + "/licence", p.examiner);
  EXPECT_EQ(l0, 409) << none;
  EXPECT_EQ(error_code(none), "not_certified");
  EXPECT_EQ(error_code(s.call("GET", bo_path + "/certificate", s.login("bo", "bo-pass-12")).second), "not_certified");

  // The practical exam alone, passed on the exam course: still no licence without the theory exam.
  auto [l1, practical_only] = s.call("POST", path + "/licence", p.examiner);
  EXPECT_EQ(l1, 409) << practical_only;
  EXPECT_EQ(error_code(practical_only), "not_certified") << practical_only;
  EXPECT_NE(practical_only.dump().find("theory"), std::string::npos) << practical_only;

  // The theory exam, supervised by the examiner.
  pass_theory(s, p.examiner, p.pupil);
  const json history = s.call("GET", path + "/history", p.examiner).second;
  const json practical = exam_of(history, "practical");
  ASSERT_EQ(at(practical, "/passed"), true) << history;
  ASSERT_EQ(at(practical, "/evidence/verified"), true) << practical;
  ASSERT_EQ(at(practical, "/counts_toward_licence"), true) << practical;
  EXPECT_EQ(at(practical, "/examiner_name"), "Eric Examiner");
  const json theory = exam_of(history, "theory");

  // Both passed, yet no certificate to print before the licence is issued.
  auto [c0, before] = s.call("GET", path + "/certificate", p.pupil_token);
  EXPECT_EQ(c0, 409) << before;
  EXPECT_NE(before.dump().find("no licence has been issued"), std::string::npos) << before;
  // Both exams passed, the training short of the rules: refused, naming the training alone.
  auto [l2t, untrained] = s.call("POST", path + "/licence", p.examiner);
  EXPECT_EQ(l2t, 409) << untrained;
  EXPECT_EQ(error_code(untrained), "not_certified") << untrained;
  const std::string untrained_why =
      at(untrained, "/error/message").is_string() ? at(untrained, "/error/message").get<std::string>() : "";
  EXPECT_NE(untrained_why.find("has " + std::to_string(kTrainingSessions) + " of the " + std::to_string(kTrainingSessions + 1) +
                     " marked training sessions the school's rules ask for on the practical exam's truck (Class I"),
            std::string::npos) << untrained_why;
  EXPECT_EQ(untrained_why.find("theory"), std::string::npos) << untrained_why;
  EXPECT_EQ(untrained_why.find("has not passed a practical exam"), std::string::npos) << untrained_why;
  ASSERT_NO_FATAL_FAILURE(train(s, p.examiner, p.pupil, school + "/pki", 1));
  // The certificate names whoever issues the licence by their full name: the administrator has none.
  EXPECT_EQ(s.call("POST", path + "/licence", p.instructor).first, 403);
  auto [l2, nameless] = s.call("POST", path + "/licence", p.admin);
  EXPECT_EQ(l2, 409) << nameless;
  EXPECT_EQ(error_code(nameless), "full_name_missing") << nameless;
  EXPECT_TRUE(s.call("GET", path + "/history", p.admin).second["licence"].is_null()) << "a refused licence leaves nothing";

  auto [l3, licence] = s.call("POST", path + "/licence", p.examiner);
  ASSERT_EQ(l3, 201) << licence;
  const std::string number = licence.value("certificate", "");
  EXPECT_TRUE(std::regex_match(number, std::regex("HFS(-[0-9A-HJKMNP-TV-Z]{4}){4}"))) << number;

  bool issued = false;  // audited, by whom, with the certificate's number and the re-evaluation date
  for (const json& r : s.call("GET", path + "/audit", p.admin).second)
    issued = issued || (r["action"] == "licence_issued" && r["actor"] == "eric" && at(r, "/details/certificate") == number &&
                        at(r, "/details/reevaluation_due").is_string());
  EXPECT_TRUE(issued);

  // The certificate, as the pupil prints it.
  auto [c1, mine] = s.call("GET", path + "/certificate", p.pupil_token);
  ASSERT_EQ(c1, 200) << mine;
  EXPECT_EQ(mine["status"], "valid") << mine;
  const json& c = mine["certificate"];
  EXPECT_EQ(c["number"], number);
  EXPECT_EQ(c["school"], kSchool) << "the school of the security folder's CA";
  EXPECT_EQ(at(c, "/pupil/name"), "Ann Driver");
  EXPECT_EQ(at(c, "/licence/issued_by/name"), "Eric Examiner");
  EXPECT_EQ(at(c, "/theory/examiner/name"), "Eric Examiner");
  EXPECT_EQ(at(c, "/theory/exam_id"), theory["id"]);
  ASSERT_EQ(at(c, "/practical").size(), 1u) << c;
  EXPECT_EQ(at(c, "/practical/0/session"), session);
  EXPECT_EQ(at(c, "/practical/0/scenario"), kCourse);
  EXPECT_EQ(at(c, "/practical/0/examiner/name"), "Eric Examiner");
  EXPECT_EQ(at(c, "/practical/0/score"), practical["score"]);
  EXPECT_FALSE(at(c, "/practical/0/chain/entry_hash").is_null());
  // The training it lists is the record's: each marked session with its date and mark, and a
  // statement that claims no more than that.
  EXPECT_EQ(at(c, "/training/sessions"), kTrainingSessions + 1) << c;
  ASSERT_EQ(at(c, "/training/list").size(), size_t(kTrainingSessions + 1)) << c;
  for (const json& t : at(c, "/training/list")) {
    EXPECT_EQ(t["scenario"], "manoeuvre_1") << t;
    EXPECT_TRUE(t["mark"].is_number() && t["at"].is_string()) << t;
  }
  EXPECT_NE(at(c, "/training/truck_class").dump().find("Class I"), std::string::npos) << c;
  EXPECT_EQ(at(c, "/statement").dump().find("formal instruction"), std::string::npos) << c;
  EXPECT_NE(at(c, "/statement").dump().find("marked practical training sessions"), std::string::npos) << c;
  // Its QR code and link carry the school's public address, not the one this request used.
  EXPECT_EQ(mine["verify_url"], kPublicUrl + "/verify.html?number=" + number) << mine;
  // OSHA 1910.178(l)(4)(iii): evaluated again within three years of the evaluation.
  const std::string evaluated = at(c, "/evaluated_at"), due = at(c, "/reevaluation_due");
  EXPECT_EQ(evaluated, practical["taken_at"]);
  EXPECT_EQ(std::stoi(due.substr(0, 4)), std::stoi(evaluated.substr(0, 4)) + 3);
  EXPECT_EQ(due.substr(4), evaluated.substr(4));

  // Anyone can check it by its number, typed in small letters too, without logging in.
  auto [v1, valid] = verify(s, number);
  ASSERT_EQ(v1, 200) << valid;
  EXPECT_EQ(valid["status"], "valid") << valid;
  EXPECT_TRUE(valid["problems"].empty()) << valid;
  EXPECT_EQ(at(valid, "/certificate/pupil/name"), "Ann Driver");
  std::string typed = number;
  for (char& ch : typed) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  EXPECT_EQ(at(verify(s, typed).second, "/status"), "valid");

  // The record edited in the database behind the server's back: the signature no longer holds.
  ASSERT_NE(sql(s.db, "UPDATE certificates SET record = record").find("append-only"), std::string::npos);
  const std::string where = " WHERE number = '" + number + "'";
  ASSERT_EQ(sql(s.db, "DROP TRIGGER certificates_no_update; UPDATE certificates SET record = replace(record, 'Ann Driver', 'Ann Other')" +
                          where),
            "");
  auto [v2, changed] = verify(s, number);
  ASSERT_EQ(v2, 200) << changed;
  EXPECT_EQ(changed["status"], "does_not_verify") << changed;
  EXPECT_NE(changed["problems"].dump().find("changed after it was signed"), std::string::npos) << changed;
  ASSERT_EQ(sql(s.db, "UPDATE certificates SET record = replace(record, 'Ann Other', 'Ann Driver')" + where), "");
  EXPECT_EQ(at(verify(s, number).second, "/status"), "valid") << "put back";

  // An exam it cites, changed around the triggers that keep exams as written: the theory exam's
  // record, and the practical exam's score (its signed log and chain then disagree with it).
  ASSERT_NE(sql(s.db, "UPDATE exams SET score = 1").find("kept"), std::string::npos);
  ASSERT_EQ(drop_keeping_triggers(s.db), "");
  const std::string theory_where = " WHERE id = " + theory["id"].dump();
  const std::string score = sql(s.db, "SELECT score FROM exams" + theory_where);
  ASSERT_EQ(sql(s.db, "UPDATE exams SET score = score - 0.04" + theory_where), "");  // one answer fewer right
  auto [v3, theory_changed] = verify(s, number);
  EXPECT_EQ(theory_changed["status"], "does_not_verify") << theory_changed;
  EXPECT_NE(theory_changed["problems"].dump().find("theory exam " + theory["id"].dump() + " was changed"), std::string::npos)
      << theory_changed;
  ASSERT_EQ(sql(s.db, "UPDATE exams SET score = " + score + theory_where), "");
  const std::string score_where = " WHERE session_id = (SELECT id FROM sessions WHERE public_id = '" + session + "')";
  ASSERT_EQ(sql(s.db, "UPDATE scores SET mark = mark - 1" + score_where), "");
  auto [v4, practical_changed] = verify(s, number);
  EXPECT_EQ(practical_changed["status"], "does_not_verify") << practical_changed;
  EXPECT_NE(practical_changed["problems"].dump().find("evidence does not verify"), std::string::npos) << practical_changed;
  ASSERT_EQ(sql(s.db, "UPDATE scores SET mark = mark + 1" + score_where), "");
  // The scenario it ran, no longer an exam course: such an exam is never cited.
  const std::string logs_where = score_where + " AND name = 'scenario'";
  const std::string course = sql(s.db, "SELECT body FROM session_logs" + logs_where);
  ASSERT_EQ(sql(s.db, "UPDATE session_logs SET body = json_remove(body, '$.exam_course')" + logs_where), "");
  auto [v5, no_course] = verify(s, number);
  EXPECT_EQ(no_course["status"], "does_not_verify") << no_course;
  EXPECT_NE(no_course["problems"].dump().find("not taken on an exam course"), std::string::npos) << no_course;
  const json not_course = exam_of(s.call("GET", path + "/history", p.examiner).second, "practical");
  EXPECT_EQ(at(not_course, "/counts_toward_licence"), false) << not_course;
  EXPECT_NE(at(not_course, "/not_counted").dump().find("exam course"), std::string::npos) << not_course;
  auto [l4, off_course] = s.call("POST", path + "/licence", p.examiner);
  EXPECT_EQ(l4, 409) << off_course;
  std::string quoted;  // as an SQL string
  for (char ch : course) quoted += ch == '\'' ? std::string("''") : std::string(1, ch);
  ASSERT_EQ(sql(s.db, "UPDATE session_logs SET body = '" + quoted + "'" + logs_where), "");
  EXPECT_EQ(at(verify(s, number).second, "/status"), "valid") << "all put back";

  // Revoked by an examiner, with a reason: audited, kept, and said by the check.
  const std::string revoke = "/api/certificates/" + number + "/revoke";
  EXPECT_EQ(s.call("POST", revoke, p.pupil_token, R"({"reason":"mine"})").first, 403);
  EXPECT_EQ(s.call("POST", revoke, p.instructor, R"({"reason":"x"})").first, 403);
  EXPECT_EQ(error_code(s.call("POST", revoke, p.examiner, R"({"reason":" "})").second), "bad_request");
  auto [r1, revoked] = s.call("POST", revoke, p.examiner, R"({"reason":"the practical exam was driven by someone else"})");
  ASSERT_EQ(r1, 200) << revoked;
  EXPECT_EQ(revoked["status"], "revoked");
  auto [v6, public_view] = verify(s, number);
  EXPECT_EQ(public_view["status"], "revoked") << public_view;
  EXPECT_EQ(at(public_view, "/revocation/reason"), "the practical exam was driven by someone else");
  EXPECT_EQ(at(public_view, "/revocation/by"), "Eric Examiner");
  EXPECT_EQ(s.call("POST", revoke, p.examiner, R"({"reason":"again"})").first, 409);
  bool audited = false;
  for (const json& r : s.call("GET", path + "/audit", p.examiner).second)
    audited = audited || (r["action"] == "certificate_revoked" && at(r, "/details/certificate") == number && r["actor"] == "eric");
  EXPECT_TRUE(audited);

  // The number with one character changed: not found (80 random bits: no near miss is another's).
  std::string near = number;
  near.back() = near.back() == '7' ? '8' : '7';
  auto [nf, not_found] = verify(s, near);
  EXPECT_EQ(nf, 404) << not_found;
  EXPECT_EQ(error_code(not_found), "not_found") << not_found;

  // Numbers nobody was given: not found, and an address that tries them one after another is
  // held back as a guesser of passwords is (here 8 a minute, the near miss above among them),
  // whatever it asks next.
  int status = 0;
  for (int i = 0; i < 7 && status != 429; ++i) status = verify(s, "HFS-0000-0000-0000-000" + std::to_string(i)).first;
  EXPECT_EQ(status, 404);
  auto [held, why] = verify(s, "HFS-0000-0000-0000-0009");
  EXPECT_EQ(held, 429) << why;
  EXPECT_EQ(verify(s, number).first, 429);
}

// Whatever the API is asked, a finished exam stays as it was written; a
// correction is a new record beside it, with its reason, by an examiner, audited; a correction
// that withdraws a pass stops the exam counting toward a licence.
TEST_F(Certificates, NoApiCallChangesAFinishedExamAndACorrectionIsANewAuditedRecord) {
  const int port = forklift::test::free_port();
  Server s(port, forklift::test::free_domain(), "kept-" + std::to_string(port), secure());
  const School p = people(s);
  const std::string path = pupil_path(p);
  pass_theory(s, p.examiner, p.pupil);
  const json theory = exam_of(s.call("GET", path + "/history", p.admin).second, "theory");
  ASSERT_FALSE(theory.is_null());
  const std::string exam = "/api/exams/" + theory["id"].dump();
  const json original = s.call("GET", exam, p.admin).second;
  ASSERT_EQ(original["passed"], true) << original;
  EXPECT_EQ(original["examiner_name"], "Eric Examiner");

  // Every way the API could be asked to change or delete it.
  auto cl = s.client();
  const httplib::Headers admin = {{"Authorization", "Bearer " + p.admin}};
  const std::string body = R"({"score":1,"passed":false,"taken_at":"2020-01-01T00:00:00Z"})";
  for (const std::string& target : {exam, "/api/theory/attempts/" + original["attempt"].dump()}) {
    const auto put = cl.Put(target, admin, body, "application/json");
    const auto patch = cl.Patch(target, admin, body, "application/json");
    const auto del = cl.Delete(target, admin);
    ASSERT_TRUE(put && patch && del);
    for (int code : {put->status, patch->status, del->status}) EXPECT_TRUE(code == 404 || code == 405) << target << ": " << code;
  }
  auto [again, why] = s.call("POST", "/api/theory/attempts/" + original["attempt"].dump() + "/answers", p.examiner, R"({"answers":{}})");
  EXPECT_EQ(again, 409) << why;
  // The pupil's name corrected: the exam keeps the names it was written with.
  ASSERT_EQ(s.call("PATCH", path, p.admin, R"({"name":"Ann Driver-Lee"})").first, 200);
  EXPECT_EQ(s.call("GET", exam, p.admin).second, original);

  // A correction: an examiner's, with a reason; not the pupil's or an instructor's.
  const std::string corrections = exam + "/corrections";
  EXPECT_EQ(s.call("POST", corrections, p.pupil_token, R"({"reason":"x","passed":true})").first, 403);
  EXPECT_EQ(s.call("POST", corrections, p.instructor, R"({"reason":"x","passed":false})").first, 403);
  EXPECT_EQ(error_code(s.call("POST", corrections, p.examiner, R"({"passed":false})").second), "bad_request");
  EXPECT_EQ(error_code(s.call("POST", corrections, p.examiner, R"({"reason":"x","taken_at":"2020-01-01T00:00:00Z"})").second), "bad_request");
  EXPECT_EQ(error_code(s.call("POST", corrections, p.examiner, R"({"reason":"x","score":2})").second), "bad_request");
  auto [cs, corrected] = s.call("POST", corrections, p.examiner,
                                R"({"reason":"the candidate had the answers on a phone","passed":false,"note":"seen on the station's camera"})");
  ASSERT_EQ(cs, 201) << corrected;
  // Beside the original, which is as it was: its score, date and examiner; the result now says why.
  ASSERT_EQ(corrected["corrections"].size(), 1u) << corrected;
  const json& c = corrected["corrections"][0];
  EXPECT_EQ(c["reason"], "the candidate had the answers on a phone");
  EXPECT_EQ(c["by_name"], "Eric Examiner");
  EXPECT_EQ(at(c, "/correction/passed"), false);
  EXPECT_EQ(corrected["score"], original["score"]);
  EXPECT_EQ(corrected["taken_at"], original["taken_at"]);
  EXPECT_EQ(corrected["examiner_name"], original["examiner_name"]);
  EXPECT_EQ(corrected["passed"], false) << "withdrawn";
  EXPECT_NE(corrected["reasons"].dump().find("withdrawn by correction"), std::string::npos) << corrected;
  EXPECT_EQ(s.call("GET", path + "/history", p.pupil_token).second["exams"][0]["corrections"].size(), 1u);
  bool audited = false;
  for (const json& r : s.call("GET", path + "/audit", p.admin).second)
    audited = audited || (r["action"] == "exam_corrected" && at(r, "/details/exam_id") == theory["id"] && at(r, "/details/original/passed") == true);
  EXPECT_TRUE(audited);
  // The store keeps it so too, whoever writes to the file.
  EXPECT_NE(sql(s.db, "UPDATE exams SET passed = 1").find("kept"), std::string::npos);
  EXPECT_NE(sql(s.db, "DELETE FROM exam_corrections").find("append-only"), std::string::npos);
}

// Older records: a practical exam recorded on a scenario that is no exam course (before exam
// courses existed, "first_drive_yard"), marked 96 and passed, is never cited and never counts.
TEST_F(Certificates, AnExamOnAScenarioThatIsNoExamCourseNeverCounts) {
  const int port = forklift::test::free_port();
  Server s(port, forklift::test::free_domain(), "old-exam-" + std::to_string(port), secure());
  const School p = people(s);
  const std::string path = pupil_path(p);
  pass_theory(s, p.examiner, p.pupil);
  const std::string pupil = std::to_string(p.pupil), examiner = std::to_string(p.examiner_id);
  ASSERT_EQ(sql(s.db, "INSERT INTO sessions(pupil_id, cab_id, scenario, mode, state, reason, examiner_id, created_at, ended_at, mark, passed) "
                      "VALUES (" + pupil + ", 'oldcab', 'first_drive_yard', 'exam', 'ended', 'task_complete', " + examiner +
                      ", '2025-03-01T10:00:00Z', '2025-03-01T10:05:00Z', 96, 1); "
                      "INSERT INTO scores(session_id, mark, passed) VALUES (last_insert_rowid(), 96, 1); "
                      "INSERT INTO exams(pupil_id, kind, session_id, score, passed, examiner_id, taken_at, school_id) VALUES (" + pupil +
                      ", 'practical', (SELECT MAX(id) FROM sessions), 96, 1, " + examiner +
                      ", '2025-03-01T10:05:00Z', (SELECT school_id FROM pupils WHERE id = " + pupil + "))"),
            "");
  const json old = exam_of(s.call("GET", path + "/history", p.examiner).second, "practical");
  ASSERT_FALSE(old.is_null());
  EXPECT_EQ(old["counts_toward_licence"], false) << old;
  EXPECT_TRUE(old["exam_course"].is_null()) << old;
  auto [st, refused] = s.call("POST", path + "/licence", p.examiner);
  EXPECT_EQ(st, 409) << refused;
  EXPECT_EQ(error_code(refused), "not_certified");
  EXPECT_NE(refused.dump().find("practical exam on an exam course"), std::string::npos) << refused;
  EXPECT_EQ(error_code(s.call("GET", path + "/certificate", p.pupil_token).second), "not_certified");
}

}  // namespace
