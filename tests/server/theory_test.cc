// The theory exam: the shipped question bank, papers drawn from a seed, marking, and the HTTP
// API around them on a real forklift-server (its own port, DDS domain and SQLite file), with the
// refusals: bad answer bodies, wrong roles, and one pupil reaching for another's paper.
#include <gtest/gtest.h>
#include <httplib.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "support/process.h"
#include "support/server.h"
#include "theory.h"

using nlohmann::json;
using forklift_test::Server;
using forklift_test::error_code;
namespace fs = forklift::server;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;
const std::string kData = FORKLIFT_DATA_DIR;
const std::string kBankFile = kData + "/theory/questions.json";

// ---------------------------------------------------------------- the bank, drawing, marking

TEST(QuestionBank, ShippedBankCoversTheOshaTopics) {
  const fs::QuestionBank bank = fs::load_question_bank(kBankFile);
  EXPECT_GE(bank.questions.size(), 40u);
  // OSHA 1910.178(l)(3): controls, stability, load capacity and centre, inspection, surfaces and
  // ramps, pedestrians, parking; every one with enough questions for each paper to ask three.
  std::map<std::string, int> per_topic;
  for (const auto& q : bank.questions) ++per_topic[q.topic];
  for (const char* t : {"controls", "stability", "capacity", "inspection", "surfaces", "pedestrians", "parking"})
    EXPECT_GE(per_topic[t], 3) << t;
  EXPECT_EQ(bank.topics.front().id, "controls");  // the file's order, not alphabetical
  EXPECT_DOUBLE_EQ(bank.pass_mark, 0.8);
  EXPECT_FALSE(bank.pass_mark_why.empty());
  std::set<int> answer_positions;
  for (const auto& q : bank.questions) {
    EXPECT_FALSE(q.reference.empty()) << q.id;
    answer_positions.insert(q.answer);
  }
  EXPECT_GE(answer_positions.size(), 4u);  // the right answer is not always in one place
}

TEST(QuestionBank, BadBanksAreRefusedNamingTheQuestion) {
  const std::string path = testing::TempDir() + "/bad_bank.json";
  const auto refuse = [&](const json& bank, const std::string& needle) {
    std::ofstream(path) << bank.dump();
    try {
      fs::load_question_bank(path);
      ADD_FAILURE() << "accepted: " << bank.dump();
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  const json q = {{"id", "a"}, {"topic", "t"}, {"text", "?"}, {"choices", {"x", "y"}}, {"answer", 1}, {"explanation", "because"}};
  json good = {{"version", 1}, {"questions_per_exam", 1}, {"pass_mark", 0.5}, {"topics", {{"t", {{"title", "T"}, {"osha", "-"}}}}},
               {"questions", {q}}};
  std::ofstream(path) << good.dump();
  EXPECT_EQ(fs::load_question_bank(path).questions.size(), 1u);

  json b = good;
  b["questions"][0]["answer"] = 2;
  refuse(b, "questions[0]");
  b = good;
  b["questions"][0]["topic"] = "nope";
  refuse(b, "topic 'nope'");
  b = good;
  b["questions"].push_back(q);
  refuse(b, "not unique");
  b = good;
  b["questions_per_exam"] = 2;
  refuse(b, "questions_per_exam");
  b = good;
  b["pass_mark"] = 80;
  refuse(b, "pass_mark");
  b = good;
  b["topics"]["u"] = {{"title", "U"}, {"osha", "-"}};
  refuse(b, "topics.u");
}

TEST(QuestionBank, APaperIsTheSameForTheSameSeedAndCoversEveryTopic) {
  const fs::QuestionBank bank = fs::load_question_bank(kBankFile);
  const auto a = fs::draw_paper(bank, 42), again = fs::draw_paper(bank, 42), other = fs::draw_paper(bank, 43);
  ASSERT_EQ(a.size(), static_cast<size_t>(bank.questions_per_exam));
  EXPECT_EQ(a, again);
  EXPECT_NE(a, other);
  EXPECT_EQ(std::set<std::string>(a.begin(), a.end()).size(), a.size());  // no question twice
  std::map<std::string, int> per_topic;
  for (const auto& id : a) ++per_topic[bank.find(id)->topic];
  for (const auto& t : bank.topics) EXPECT_GE(per_topic[t.id], bank.questions_per_exam / static_cast<int>(bank.topics.size())) << t.id;
  // The draw's order is random too: the first question is not always from one topic.
  std::set<std::string> first_topics;
  for (uint64_t seed = 0; seed < 40; ++seed) first_topics.insert(bank.find(fs::draw_paper(bank, seed)[0])->topic);
  EXPECT_GE(first_topics.size(), 4u);
}

TEST(QuestionBank, MarkingCountsWholeQuestionsAgainstThePassMark) {
  const fs::QuestionBank bank = fs::load_question_bank(kBankFile);
  const auto paper = fs::draw_paper(bank, 7);
  const int n = static_cast<int>(paper.size());
  const auto answers_with_right = [&](int right) {
    std::map<std::string, int> a;
    for (int i = 0; i < n; ++i) {
      const auto* q = bank.find(paper[i]);
      a[q->id] = i < right ? q->answer : (q->answer + 1) % static_cast<int>(q->choices.size());
    }
    return a;
  };
  const fs::Marking all = fs::mark_paper(bank, paper, answers_with_right(n));
  EXPECT_EQ(all.correct, n);
  EXPECT_DOUBLE_EQ(all.score, 1.0);
  EXPECT_TRUE(all.passed);
  const int needed = static_cast<int>(std::ceil(bank.pass_mark * n - 1e-9));  // 20 of 25 at 0.8
  EXPECT_TRUE(fs::mark_paper(bank, paper, answers_with_right(needed)).passed);
  EXPECT_FALSE(fs::mark_paper(bank, paper, answers_with_right(needed - 1)).passed);
  // Unanswered questions are wrong.
  const fs::Marking none = fs::mark_paper(bank, paper, {});
  EXPECT_EQ(none.correct, 0);
  EXPECT_FALSE(none.items[0].chosen.has_value());
  EXPECT_FALSE(none.passed);
  int by_topic_total = 0;
  for (const auto& [t, ct] : all.by_topic) by_topic_total += ct.second;
  EXPECT_EQ(by_topic_total, n);
  // Refused: a question not on the paper, a choice it does not have.
  std::string off_paper;
  for (const auto& q : bank.questions)
    if (std::find(paper.begin(), paper.end(), q.id) == paper.end()) off_paper = q.id;
  EXPECT_THROW(fs::mark_paper(bank, paper, {{off_paper, 0}}), fs::BadAnswers);
  EXPECT_THROW(fs::mark_paper(bank, paper, {{paper[0], 99}}), fs::BadAnswers);
  EXPECT_THROW(fs::mark_paper(bank, paper, {{paper[0], -1}}), fs::BadAnswers);
}

// ---------------------------------------------------------------- over HTTP

// The right answers to a paper, from the bank on disk.
json right_answers(const json& attempt) {
  const fs::QuestionBank bank = fs::load_question_bank(kBankFile);
  json a = json::object();
  for (const auto& q : attempt["questions"]) a[q["id"].get<std::string>()] = bank.find(q["id"])->answer;
  return a;
}

// Each test its own server (port, DDS domain, database): ctest runs them as separate processes,
// maybe at once. Two pupils with logins and an instructor.
class TheoryApi : public testing::Test {
 protected:
  void Start(const std::string& name) {
    s = std::make_unique<Server>("theory-" + name);  // its own folder, apart from server_test's
    admin = s->login("admin", "admin-pass-1");
    ana_id = s->call("POST", "/api/pupils", admin, R"({"name":"Ana","username":"ana","password":"ana-pass-1"})").second["id"];
    ben_id = s->call("POST", "/api/pupils", admin, R"({"name":"Ben","username":"ben","password":"ben-pass-1"})").second["id"];
    s->call("POST", "/api/users", admin, R"({"username":"ines","password":"ines-pass-1","role":"instructor"})");
    ana = s->login("ana", "ana-pass-1");
    ben = s->login("ben", "ben-pass-1");
    ines = s->login("ines", "ines-pass-1");
  }
  json new_paper(const std::string& token, const json& body = json::object()) {
    auto [st, a] = s->call("POST", "/api/theory/attempts", token, body.dump());
    EXPECT_EQ(st, 201) << a;
    return a;
  }
  std::unique_ptr<Server> s;
  std::string admin, ana, ben, ines;
  int64_t ana_id = 0, ben_id = 0;
};

TEST_F(TheoryApi, APupilTakesAPaperAndTheMarkIsStoredOnce) {
  Start("stored");
  const json info = s->call("GET", "/api/theory", ana).second;
  EXPECT_EQ(info["questions_per_exam"], 25);
  EXPECT_DOUBLE_EQ(info["pass_mark"].get<double>(), 0.8);
  const json a = new_paper(ana);
  EXPECT_EQ(a["pupil_id"], ana_id);
  EXPECT_EQ(a["questions"].size(), 25u);
  EXPECT_FALSE(a["marked"].get<bool>());
  for (const auto& q : a["questions"]) {
    EXPECT_FALSE(q.contains("answer")) << "a paper never carries its answers";
    EXPECT_FALSE(q.contains("explanation"));
  }
  json answers = right_answers(a);
  answers.erase(answers.begin());  // one left unanswered: 24 of 25
  const std::string path = "/api/theory/attempts/" + std::to_string(a["id"].get<int64_t>());
  auto [st, marked] = s->call("POST", path + "/answers", ana, json{{"answers", answers}}.dump());
  ASSERT_EQ(st, 200) << marked;
  EXPECT_TRUE(marked["marked"].get<bool>());
  const json& r = marked["result"];
  EXPECT_EQ(r["correct"], 24);
  EXPECT_EQ(r["total"], 25);
  EXPECT_TRUE(r["passed"].get<bool>());
  EXPECT_EQ(r["items"].size(), 25u);
  EXPECT_TRUE(r["items"][0].contains("explanation"));  // after marking, the answers and why
  // Stored as the pupil's theory exam record.
  const json h = s->call("GET", "/api/pupils/" + std::to_string(ana_id) + "/history", ana).second;
  ASSERT_EQ(h["exams"].size(), 1u);
  EXPECT_EQ(h["exams"][0]["kind"], "theory");
  EXPECT_EQ(h["exams"][0]["attempt"], a["id"]);
  EXPECT_NEAR(h["exams"][0]["score"].get<double>(), 0.96, 1e-9);
  // A second hand-in is refused and changes nothing.
  EXPECT_EQ(error_code(s->call("POST", path + "/answers", ana, json{{"answers", right_answers(a)}}.dump()).second), "already_marked");
  EXPECT_EQ(s->call("GET", "/api/pupils/" + std::to_string(ana_id) + "/history", ana).second["exams"].size(), 1u);
  EXPECT_EQ(s->call("GET", path, ana).second["result"]["correct"], 24);
  // Passed theory alone is not a certificate.
  EXPECT_EQ(error_code(s->call("GET", "/api/pupils/" + std::to_string(ana_id) + "/certificate", ana).second), "not_certified");
}

TEST_F(TheoryApi, BadAnswerBodiesAreRefusedAndLeaveThePaperOpen) {
  Start("bad");
  const json a = new_paper(ben);
  const std::string path = "/api/theory/attempts/" + std::to_string(a["id"].get<int64_t>()) + "/answers";
  const std::string first = a["questions"][0]["id"];
  std::string off_paper = "no-such-question";
  for (const json& body : {json{{"answers", json::array({1, 2})}}, json{{"answers", "all of them"}}, json{{"answerz", json::object()}},
                           json{{"answers", {{first, "2"}}}}, json{{"answers", {{first, 1.5}}}}, json{{"answers", {{first, -1}}}},
                           json{{"answers", {{first, 7}}}}, json{{"answers", {{first, 4000000000LL}}}},
                           json{{"answers", {{off_paper, 0}}}}}) {
    auto [st, j] = s->call("POST", path, ben, body.dump());
    EXPECT_EQ(st, 400) << body << " -> " << j;
    EXPECT_EQ(error_code(j), "bad_request") << body;
  }
  EXPECT_EQ(error_code(s->call("POST", path, ben, "{not json").second), "bad_json");
  EXPECT_EQ(error_code(s->call("POST", path, ben, "").second), "bad_request");
  EXPECT_EQ(s->call("POST", "/api/theory/attempts/999999/answers", ben, R"({"answers":{}})").first, 404);
  // Nothing above was stored: the paper is still open, and an empty hand-in is a (failed) mark.
  EXPECT_FALSE(s->call("GET", "/api/theory/attempts/" + std::to_string(a["id"].get<int64_t>()), ben).second["marked"].get<bool>());
  auto [st, r] = s->call("POST", path, ben, R"({"answers":{}})");
  ASSERT_EQ(st, 200) << r;
  EXPECT_EQ(r["result"]["correct"], 0);
  EXPECT_FALSE(r["result"]["passed"].get<bool>());
}

TEST_F(TheoryApi, RolesAndOtherPupilsPapers) {
  Start("roles");
  EXPECT_EQ(error_code(s->call("POST", "/api/theory/attempts", "", "{}").second), "unauthenticated");
  EXPECT_EQ(error_code(s->call("GET", "/api/theory/questions", ana).second), "forbidden");  // the answers are for staff
  EXPECT_EQ(s->call("GET", "/api/theory/questions", ines).second.size(), 49u);
  EXPECT_EQ(error_code(s->call("POST", "/api/theory/attempts", ana, json{{"pupil_id", ben_id}}.dump()).second), "forbidden");
  EXPECT_EQ(error_code(s->call("POST", "/api/theory/attempts", ana, R"({"seed": 5})").second), "forbidden");
  EXPECT_EQ(error_code(s->call("POST", "/api/theory/attempts", ines, "{}").second), "bad_request");  // staff name the pupil
  EXPECT_EQ(error_code(s->call("POST", "/api/theory/attempts", ines, R"({"pupil_id": 999999})").second), "not_found");

  // Ana's paper: Ben may neither read it nor hand it in; staff of the school may do both.
  const json a = new_paper(ana);
  const std::string path = "/api/theory/attempts/" + std::to_string(a["id"].get<int64_t>());
  EXPECT_EQ(error_code(s->call("GET", path, ben).second), "forbidden");
  EXPECT_EQ(error_code(s->call("POST", path + "/answers", ben, json{{"answers", right_answers(a)}}.dump()).second), "forbidden");
  EXPECT_FALSE(s->call("GET", path, ana).second["marked"].get<bool>());
  EXPECT_EQ(s->call("GET", path, ines).first, 200);

  // Staff hand out a paper again from its seed: the same questions in the same order.
  const json again = new_paper(ines, {{"pupil_id", ana_id}, {"seed", a["seed"]}});
  EXPECT_EQ(again["questions"], a["questions"]);
  EXPECT_NE(again["id"], a["id"]);
  EXPECT_EQ(error_code(s->call("POST", "/api/theory/attempts", ines, json{{"pupil_id", ana_id}, {"seed", -3}}.dump()).second), "bad_request");
  // Marked at a supervised station: the record names who handed it in.
  auto [st, r] = s->call("POST", "/api/theory/attempts/" + std::to_string(again["id"].get<int64_t>()) + "/answers", ines,
                         json{{"answers", right_answers(again)}}.dump());
  ASSERT_EQ(st, 200) << r;
  EXPECT_EQ(r["result"]["marked_by"], "ines");
}

TEST_F(TheoryApi, PagesAreServedWithSecurityHeaders) {
  Start("pages");
  httplib::Client c("127.0.0.1", s->port);
  for (const char* page : {"/", "/fleet.html", "/pupil.html", "/theory.html", "/vendor/chart.umd.min.js"}) {
    auto r = c.Get(page);
    ASSERT_TRUE(r) << page;
    EXPECT_EQ(r->status, 200) << page;
    EXPECT_EQ(r->get_header_value("X-Content-Type-Options"), "nosniff") << page;
    EXPECT_NE(r->get_header_value("Content-Security-Policy").find("script-src 'self'"), std::string::npos) << page;
  }
  auto api = c.Get("/api/health");
  ASSERT_TRUE(api);
  EXPECT_EQ(api->get_header_value("Cache-Control"), "no-store");
  EXPECT_EQ(api->get_header_value("X-Content-Type-Options"), "nosniff");
  auto outside = c.Get("/../CMakeCache.txt");
  ASSERT_TRUE(outside);
  EXPECT_EQ(outside->status, 404);
  // A logout ends the token at once.
  const std::string t = s->login("ines", "ines-pass-1");
  EXPECT_EQ(s->call("POST", "/api/logout", t).first, 200);
  EXPECT_EQ(error_code(s->call("GET", "/api/theory", t).second), "unauthenticated");
}

}  // namespace
