// The theory exam: the shipped question bank and policy, papers drawn per pupil with their choices
// shuffled, marking, and the HTTP API around them on a real forklift-server (its own port, DDS
// domain, SQLite file and, where a test needs other rules, its own --theory-policy file): two
// pupils' papers differ, a retake shares nothing with the last paper, the time limit ends a paper
// by the server's own clock, the retake rules refuse and an instructor unlocks, a practice quiz
// counts toward nothing, and no answer a pupil is sent carries the bank's answers.
#include <gtest/gtest.h>
#include <httplib.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <regex>
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

const std::string kData = FORKLIFT_DATA_DIR;
const std::string kBankFile = kData + "/theory/questions.json";
const std::string kPolicyFile = kData + "/theory/policy.json";

const fs::QuestionBank& bank() {
  static const fs::QuestionBank b = fs::load_question_bank(kBankFile);
  return b;
}

std::set<std::string> ids_of(const std::vector<std::string>& v) { return {v.begin(), v.end()}; }

// ---------------------------------------------------------------- the bank

TEST(QuestionBank, ShippedBankCoversTheOshaTopicsWithTheirSources) {
  const fs::QuestionBank& b = bank();
  EXPECT_GE(b.questions.size(), 150u);
  // OSHA 1910.178(l)(3)'s topics, each with enough questions that a retake can avoid the last
  // paper's (three times what a paper takes from a topic).
  const int per_paper = (b.questions_per_exam + static_cast<int>(b.topics.size()) - 1) / static_cast<int>(b.topics.size());
  std::map<std::string, int> per_topic;
  for (const auto& q : b.questions) ++per_topic[q.topic];
  for (const char* t : {"controls", "stability", "capacity", "loads", "inspection", "surfaces", "pedestrians", "environment", "parking"}) {
    EXPECT_GE(per_topic[t], 3 * per_paper) << t;
    ASSERT_NE(b.topic(t), nullptr) << t;
    EXPECT_EQ(b.topic(t)->osha.rfind("1910.178(l)(3)", 0), 0u) << t << ": " << b.topic(t)->osha;
  }
  EXPECT_EQ(b.topics.front().id, "controls");  // the file's order, not alphabetical
  EXPECT_DOUBLE_EQ(b.pass_mark, 0.8);
  EXPECT_FALSE(b.pass_mark_why.empty());
  // Every answer traced to a clause: of an OSHA rule, or of the standard it names.
  const std::regex source(R"(^(1910\.\d+(\([a-z0-9]+\))*( App\. A-\d)?|ISO \d+).*)");
  for (const auto& q : b.questions) EXPECT_TRUE(std::regex_match(q.reference, source)) << q.id << ": " << q.reference;
  // Neither the place nor the length of the right answer is a clue: every position holds about a
  // quarter of them, and the right answer is the longest no more often than chance.
  std::map<int, int> at;
  int longest = 0;
  for (const auto& q : b.questions) {
    ++at[q.answer];
    size_t others = 0;
    for (size_t k = 0; k < q.choices.size(); ++k)
      if (static_cast<int>(k) != q.answer) others = std::max(others, q.choices[k].size());
    longest += q.choices[static_cast<size_t>(q.answer)].size() > others;
  }
  for (int k = 0; k < 4; ++k) EXPECT_LE(at[k], static_cast<int>(b.questions.size()) * 35 / 100) << "position " << k;
  EXPECT_LE(longest, static_cast<int>(b.questions.size()) / 4) << "the right answer is the longest choice too often";
}

TEST(QuestionBank, PicturesShowTheSignsPlatesAndChartsTheQuestionsAskAbout) {
  std::map<std::string, int> uses;
  for (const auto& q : bank().questions)
    if (!q.image.empty()) {
      ++uses[q.image];
      EXPECT_FALSE(q.image_alt.empty()) << q.id;
      std::ifstream in(bank().images_dir + "/" + q.image);
      const std::string svg((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      EXPECT_EQ(svg.rfind("<svg xmlns=\"http://www.w3.org/2000/svg\"", 0), 0u) << q.image;
      EXPECT_EQ(svg.find("<script"), std::string::npos) << q.image;
      EXPECT_EQ(svg.find("href"), std::string::npos) << q.image << ": the pictures load nothing else";
    }
  int plates = 0, charts = 0, signs = 0;
  for (const auto& [name, n] : uses) {
    plates += name.rfind("plate_", 0) == 0;
    charts += name.find("chart") != std::string::npos;
    signs += name.rfind("sign_", 0) == 0;
  }
  EXPECT_GE(plates, 2);
  EXPECT_GE(charts, 1);
  EXPECT_GE(signs, 8);
  EXPECT_TRUE(fs::is_image_name("plate_e16.svg"));
  for (const char* bad : {"../questions.json", "a.svg/..", "A.svg", "x.png", ".svg", "a b.svg"}) EXPECT_FALSE(fs::is_image_name(bad)) << bad;
}

TEST(QuestionBank, BadBanksAreRefusedNamingTheQuestion) {
  const std::string dir = testing::TempDir() + "/bad_bank";
  std::filesystem::create_directories(dir + "/images");
  std::ofstream(dir + "/images/sign.svg") << "<svg xmlns=\"http://www.w3.org/2000/svg\"/>";
  const std::string path = dir + "/bad_bank.json";
  const auto refuse = [&](const json& b, const std::string& needle) {
    std::ofstream(path) << b.dump();
    try {
      fs::load_question_bank(path);
      ADD_FAILURE() << "accepted: " << b.dump();
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  const json q = {{"id", "a"}, {"topic", "t"}, {"text", "?"}, {"choices", {"x", "y"}}, {"answer", 1}, {"explanation", "because"},
                  {"reference", "1910.178(m)(2)"}};
  json good = {{"version", 1}, {"questions_per_exam", 1}, {"pass_mark", 0.5}, {"topics", {{"t", {{"title", "T"}, {"osha", "-"}}}}},
               {"questions", {q}}};
  good["questions"][0]["image"] = "sign.svg";
  good["questions"][0]["image_alt"] = "a sign";
  std::ofstream(path) << good.dump();
  EXPECT_EQ(fs::load_question_bank(path).questions.size(), 1u);

  json b = good;
  b["questions"][0]["answer"] = 2;
  refuse(b, "questions[0] (a)");
  b = good;
  b["questions"][0]["topic"] = "nope";
  refuse(b, "topic 'nope'");
  b = good;
  b["questions"].push_back(good["questions"][0]);
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
  b = good;
  b["questions"][0].erase("reference");
  refuse(b, "no reference");
  b = good;
  b["questions"][0]["choices"] = {"x", "x"};
  refuse(b, "two choices are the same");
  for (const char* placed : {"All of the above", "none of the above", "A and C"}) {
    b = good;
    b["questions"][0]["choices"] = {"x", placed};
    refuse(b, "shuffled");
  }
  b = good;
  b["questions"][0]["image"] = "missing.svg";
  refuse(b, "'missing.svg' is not in");
  b = good;
  b["questions"][0]["image"] = "../bad_bank.json";
  refuse(b, "must be a-z");
  b = good;
  b["questions"][0].erase("image_alt");
  refuse(b, "no image_alt");
}

TEST(TheoryPolicy, ShippedPolicyAndBadOnesRefusedNamingTheKey) {
  const fs::TheoryPolicy p = fs::load_theory_policy(kPolicyFile, bank());
  EXPECT_GT(p.exam_time_limit_s, 0);
  EXPECT_GT(p.practice_time_limit_s, 0);
  EXPECT_GE(p.retake_wait_s, 0);
  EXPECT_GE(p.max_attempts, 0);
  EXPECT_GE(p.practice_questions, 1);
  std::ifstream in(kPolicyFile);
  const json good = json::parse(in);
  const std::string path = testing::TempDir() + "/bad_policy.json";
  const auto refuse = [&](const std::string& pointer, const json& v, const std::string& needle) {
    json b = good;
    b[json::json_pointer(pointer)] = v;
    std::ofstream(path) << b.dump();
    try {
      fs::load_theory_policy(path, bank());
      ADD_FAILURE() << "accepted " << pointer << " = " << v;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  refuse("/exam/time_limit_s", 0, "exam.time_limit_s");
  refuse("/exam/time_limit_s", "45 min", "exam.time_limit_s");
  refuse("/exam/retake_wait_s", -1, "exam.retake_wait_s");
  refuse("/exam/max_attempts", 2.5, "exam.max_attempts");
  refuse("/practice/questions", 100000, "practice.questions");
  refuse("/hand_in/grace_s", nullptr, "hand_in.grace_s");
}

TEST(TheoryTime, Iso8601WithMillisecondsRoundTrips) {
  const int64_t t = 1795000000123;  // 2026-11-18
  EXPECT_EQ(fs::iso8601_ms(t), "2026-11-18T11:06:40.123Z");
  EXPECT_EQ(fs::parse_iso8601_ms(fs::iso8601_ms(t)), t);
  EXPECT_EQ(fs::parse_iso8601_ms("2026-11-18T11:06:40Z"), t - 123);  // the store's own times, without milliseconds
  for (const char* bad : {"", "2026-11-18", "2026-13-01T00:00:00Z", "2026-11-18T10:13:20.12Z", "yesterday"})
    EXPECT_FALSE(fs::parse_iso8601_ms(bad).has_value()) << bad;
  EXPECT_LE(std::abs(fs::now_ms() - *fs::parse_iso8601_ms(fs::iso8601_ms(fs::now_ms()))), 1000);
}

// ---------------------------------------------------------------- drawing and marking

TEST(TheoryPaper, APaperIsTheSameForTheSameSeedAndCoversEveryTopicWithItsChoicesShuffled) {
  const fs::QuestionBank& b = bank();
  const int n = b.questions_per_exam;
  const fs::Paper a = fs::draw_paper(b, 42, n), again = fs::draw_paper(b, 42, n), other = fs::draw_paper(b, 43, n);
  ASSERT_EQ(a.ids.size(), static_cast<size_t>(n));
  ASSERT_EQ(a.orders.size(), a.ids.size());
  EXPECT_EQ(a.ids, again.ids);
  EXPECT_EQ(a.orders, again.orders);
  EXPECT_NE(ids_of(a.ids), ids_of(other.ids));
  EXPECT_EQ(ids_of(a.ids).size(), a.ids.size());  // no question twice
  std::map<std::string, int> per_topic;
  for (const auto& id : a.ids) ++per_topic[b.find(id)->topic];
  for (const auto& t : b.topics) EXPECT_GE(per_topic[t.id], n / static_cast<int>(b.topics.size())) << t.id;
  // Each question's choices are a shuffle of the bank's, and where the right one is shown varies.
  std::map<int, int> shown_at;
  for (uint64_t seed = 0; seed < 40; ++seed) {
    const fs::Paper p = fs::draw_paper(b, seed, n);
    for (size_t i = 0; i < p.ids.size(); ++i) {
      const fs::Question& q = *b.find(p.ids[i]);
      std::vector<int> sorted = p.orders[i];
      std::sort(sorted.begin(), sorted.end());
      for (size_t k = 0; k < sorted.size(); ++k) ASSERT_EQ(sorted[k], static_cast<int>(k)) << q.id;
      ++shown_at[static_cast<int>(std::find(p.orders[i].begin(), p.orders[i].end(), q.answer) - p.orders[i].begin())];
    }
  }
  for (int k = 0; k < 4; ++k) EXPECT_GT(shown_at[k], 40 * n / 8) << "the right answer is rarely shown at " << k;
  // A paper as the store keeps it reads back the same.
  const fs::Paper read = fs::read_paper(b, fs::paper_text(b, a));
  EXPECT_EQ(read.ids, a.ids);
  EXPECT_EQ(read.orders, a.orders);
  // One kept before choices were shuffled shows them in the bank's order.
  const fs::Paper old = fs::read_paper(b, json{{"bank_version", 1}, {"ids", {"con-01", "sta-01"}}}.dump());
  EXPECT_EQ(old.orders[0], (std::vector<int>{0, 1, 2, 3}));
  EXPECT_THROW(fs::read_paper(b, R"({"ids":["no-such-question"]})"), std::runtime_error);
  EXPECT_THROW(fs::read_paper(b, R"({"ids":["con-01"],"orders":[[0,0,1,2]]})"), std::runtime_error);
}

TEST(TheoryPaper, ARetakeSharesNoQuestionWithTheLastPaper) {
  const fs::QuestionBank& b = bank();
  for (uint64_t seed = 0; seed < 30; ++seed) {
    const fs::Paper first = fs::draw_paper(b, seed, b.questions_per_exam);
    fs::PaperHistory h;
    h.last = ids_of(first.ids);
    for (const auto& id : first.ids) ++h.seen[id];
    const fs::Paper retake = fs::draw_paper(b, seed + 1000, b.questions_per_exam, h);
    for (const auto& id : retake.ids) EXPECT_EQ(h.last.count(id), 0u) << "seed " << seed << ": " << id << " again";
  }
}

// The positions on `paper` of its questions' right answers, with the first `wrong` of them wrong.
std::map<std::string, int> positions(const fs::Paper& paper, int wrong) {
  std::map<std::string, int> a;
  for (size_t i = 0; i < paper.ids.size(); ++i) {
    const fs::Question& q = *bank().find(paper.ids[i]);
    const int right = static_cast<int>(std::find(paper.orders[i].begin(), paper.orders[i].end(), q.answer) - paper.orders[i].begin());
    a[q.id] = static_cast<int>(i) < wrong ? (right + 1) % static_cast<int>(q.choices.size()) : right;
  }
  return a;
}

TEST(TheoryPaper, MarkingReadsThePaperOrderAndCountsWholeQuestionsAgainstThePassMark) {
  const fs::QuestionBank& b = bank();
  const fs::Paper paper = fs::draw_paper(b, 7, b.questions_per_exam);
  const int n = static_cast<int>(paper.ids.size());
  const fs::Marking all = fs::mark_paper(b, paper, positions(paper, 0));
  EXPECT_EQ(all.correct, n);
  EXPECT_DOUBLE_EQ(all.score, 1.0);
  EXPECT_TRUE(all.passed);
  for (const auto& it : all.items) {
    EXPECT_EQ(it.chosen, it.question->answer);  // the position mapped back to the bank
    EXPECT_EQ(it.shown, it.answer_shown);
  }
  // The bank's index instead of the paper's position is wrong wherever the paper moved the answer.
  std::map<std::string, int> bank_indices;
  int moved = 0;
  for (size_t i = 0; i < paper.ids.size(); ++i) {
    bank_indices[paper.ids[i]] = bank().find(paper.ids[i])->answer;
    moved += paper.orders[i][static_cast<size_t>(bank().find(paper.ids[i])->answer)] != bank().find(paper.ids[i])->answer;
  }
  EXPECT_EQ(fs::mark_paper(b, paper, bank_indices).correct, n - moved);
  const int needed = static_cast<int>(std::ceil(b.pass_mark * n - 1e-9));  // 20 of 25 at 0.8
  EXPECT_TRUE(fs::mark_paper(b, paper, positions(paper, n - needed)).passed);
  EXPECT_FALSE(fs::mark_paper(b, paper, positions(paper, n - needed + 1)).passed);
  const fs::Marking none = fs::mark_paper(b, paper, {});  // unanswered questions are wrong
  EXPECT_EQ(none.correct, 0);
  EXPECT_FALSE(none.items[0].chosen.has_value());
  EXPECT_FALSE(none.passed);
  int by_topic_total = 0;
  for (const auto& [t, ct] : all.by_topic) by_topic_total += ct.second;
  EXPECT_EQ(by_topic_total, n);
  std::string off_paper;
  for (const auto& q : b.questions)
    if (!ids_of(paper.ids).count(q.id)) off_paper = q.id;
  EXPECT_THROW(fs::mark_paper(b, paper, {{off_paper, 0}}), fs::BadAnswers);
  EXPECT_THROW(fs::mark_paper(b, paper, {{paper.ids[0], 99}}), fs::BadAnswers);
  EXPECT_THROW(fs::mark_paper(b, paper, {{paper.ids[0], -1}}), fs::BadAnswers);
}

// ---------------------------------------------------------------- over HTTP

// The positions of the right answers on a paper the server handed out, read from the bank on
// disk by each choice's text (as someone holding the bank would); the first `wrong` answered
// wrong.
json right_answers(const json& attempt, int wrong = 0) {
  json a = json::object();
  int i = 0;
  for (const auto& q : attempt["questions"]) {
    const fs::Question& bq = *bank().find(q["id"]);
    const std::string right = bq.choices[static_cast<size_t>(bq.answer)];
    int at = 0;
    for (size_t k = 0; k < q["choices"].size(); ++k)
      if (q["choices"][k] == right) at = static_cast<int>(k);
    a[q["id"].get<std::string>()] = i++ < wrong ? (at + 1) % static_cast<int>(q["choices"].size()) : at;
  }
  return a;
}

std::set<std::string> paper_ids(const json& attempt) {
  std::set<std::string> s;
  for (const auto& q : attempt["questions"]) s.insert(q["id"].get<std::string>());
  return s;
}

// How many questions two papers share.
size_t shared(const std::set<std::string>& a, const std::set<std::string>& b) {
  size_t n = 0;
  for (const auto& id : a) n += b.count(id);
  return n;
}

// Each test its own server (port, DDS domain, database, and policy file when it needs other
// rules): ctest runs them as separate processes, maybe at once. Two pupils with logins, an
// instructor and an examiner.
class TheoryApi : public testing::Test {
 protected:
  void Start(const std::string& name, const json& policy_changes = json::object()) {
    std::vector<std::string> extra;
    if (!policy_changes.empty()) {
      std::ifstream in(kPolicyFile);
      json policy = json::parse(in);
      policy.merge_patch(policy_changes);
      const std::string path = testing::TempDir() + "/theory-policy-" + name + ".json";
      std::ofstream(path) << policy.dump();
      extra = {"--theory-policy", path};
    }
    s = std::make_unique<Server>("theory-" + name, extra);  // its own folder, apart from server_test's
    admin = s->login("admin", forklift_test::kAdminPassword);
    ana_id = s->call("POST", "/api/pupils", admin, R"({"name":"Ana","username":"ana","password":"ana-pass-1"})").second["id"];
    ben_id = s->call("POST", "/api/pupils", admin, R"({"name":"Ben","username":"ben","password":"ben-pass-1"})").second["id"];
    s->call("POST", "/api/users", admin, R"({"username":"ines","password":"ines-pass-1","role":"instructor"})");
    s->call("POST", "/api/users", admin, R"({"username":"eve","password":"eve-pass-1","role":"examiner"})");
    ana = s->login("ana", "ana-pass-1");
    ben = s->login("ben", "ben-pass-1");
    ines = s->login("ines", "ines-pass-1");
    eve = s->login("eve", "eve-pass-1");
  }
  // A paper handed out: by staff for `pupil` (an exam unless `kind` says), or by a pupil.
  json paper(const std::string& token, std::optional<int64_t> pupil, const std::string& kind = "") {
    json body = json::object();
    if (pupil) body["pupil_id"] = *pupil;
    if (!kind.empty()) body["kind"] = kind;
    auto [st, a] = s->call("POST", "/api/theory/attempts", token, body.dump());
    EXPECT_EQ(st, 201) << a;
    return a;
  }
  static std::string path(const json& a) { return "/api/theory/attempts/" + std::to_string(a["id"].get<int64_t>()); }
  std::pair<int, json> hand_in(const std::string& token, const json& a, const json& answers) {
    return s->call("POST", path(a) + "/answers", token, json{{"answers", answers}}.dump());
  }
  json standing(const std::string& token, int64_t pupil) { return s->call("GET", "/api/theory/pupils/" + std::to_string(pupil), token).second; }

  std::unique_ptr<Server> s;
  std::string admin, ana, ben, ines, eve;
  int64_t ana_id = 0, ben_id = 0;
};

TEST_F(TheoryApi, TwoPupilsPapersDifferAndEachIsShuffled) {
  Start("differ");
  const json a = paper(eve, ana_id), b = paper(eve, ben_id);
  ASSERT_EQ(a["questions"].size(), 25u);
  ASSERT_EQ(b["questions"].size(), 25u);
  EXPECT_NE(paper_ids(a), paper_ids(b));
  // Practice quizzes too, the pupils' own, once their exam papers are in.
  ASSERT_EQ(hand_in(ana, a, json::object()).first, 200);
  ASSERT_EQ(hand_in(ben, b, json::object()).first, 200);
  const json pa = paper(ana, std::nullopt), pb = paper(ben, std::nullopt);
  EXPECT_EQ(pa["kind"], "practice");
  EXPECT_NE(paper_ids(pa), paper_ids(pb));
  // The choices are not in the bank's order on every question, and the right one is not always
  // in one place.
  int reordered = 0;
  std::set<int> right_at;
  for (const json* p : {&a, &b})
    for (const auto& q : (*p)["questions"]) {
      reordered += q["choices"].get<std::vector<std::string>>() != bank().find(q["id"])->choices;
      right_at.insert(right_answers(json{{"questions", json::array({q})}})[q["id"].get<std::string>()].get<int>());
    }
  EXPECT_GE(reordered, 25);
  EXPECT_EQ(right_at.size(), 4u);
}

TEST_F(TheoryApi, ASupervisedExamIsMarkedOnceAndNamesItsSupervisor) {
  Start("supervised");
  const json info = s->call("GET", "/api/theory", ana).second;
  EXPECT_EQ(info["questions_per_exam"], 25);
  EXPECT_GE(info["questions_in_bank"].get<int>(), 150);
  EXPECT_DOUBLE_EQ(info["policy"]["exam_time_limit_s"].get<double>(), fs::load_theory_policy(kPolicyFile, bank()).exam_time_limit_s);
  // A pupil may not hand themselves an exam, only a practice quiz.
  auto [st_self, self] = s->call("POST", "/api/theory/attempts", ana, R"({"kind":"exam"})");
  EXPECT_EQ(st_self, 403) << self;
  EXPECT_NE(self["error"]["message"].get<std::string>().find("supervision"), std::string::npos) << self;

  const json a = paper(eve, ana_id);  // the examiner sits Ana at an exam
  EXPECT_EQ(a["kind"], "exam");
  EXPECT_EQ(a["supervised_by"], "eve");
  EXPECT_EQ(a["pupil_id"], ana_id);
  EXPECT_FALSE(a["finished"].get<bool>());
  EXPECT_DOUBLE_EQ(a["time_limit_s"].get<double>(), info["policy"]["exam_time_limit_s"].get<double>());
  EXPECT_GT(a["time_left_s"].get<double>(), 0);
  // Ana answers it on her own login: 24 of 25.
  auto [st, marked] = hand_in(ana, a, right_answers(a, 1));
  ASSERT_EQ(st, 200) << marked;
  EXPECT_TRUE(marked["finished"].get<bool>());
  EXPECT_EQ(marked["outcome"], "marked");
  EXPECT_TRUE(marked["questions"].empty());  // a finished paper is not sent again
  const json& r = marked["result"];
  EXPECT_EQ(r["correct"], 24);
  EXPECT_EQ(r["total"], 25);
  EXPECT_TRUE(r["passed"].get<bool>());
  EXPECT_TRUE(r["counts"].get<bool>());
  EXPECT_EQ(r["supervised_by"], "eve");
  EXPECT_EQ(r["handed_in_by"], "ana");
  ASSERT_EQ(r["to_revise"].size(), 1u);  // the one wrong answer's topic and clause
  const fs::Question& missed = *bank().find(a["questions"][0]["id"]);
  EXPECT_EQ(r["to_revise"][0]["topic"], missed.topic);
  EXPECT_EQ(r["to_revise"][0]["missed"], 1);
  EXPECT_EQ(r["to_revise"][0]["clauses"], json::array({missed.reference}));
  // Stored as the pupil's theory exam record, examined by the supervisor.
  const json h = s->call("GET", "/api/pupils/" + std::to_string(ana_id) + "/history", ana).second;
  ASSERT_EQ(h["exams"].size(), 1u);
  EXPECT_EQ(h["exams"][0]["kind"], "theory");
  EXPECT_EQ(h["exams"][0]["attempt"], a["id"]);
  EXPECT_EQ(h["exams"][0]["examiner"], "eve");
  EXPECT_NEAR(h["exams"][0]["score"].get<double>(), 0.96, 1e-9);
  // A second hand-in is refused and changes nothing.
  EXPECT_EQ(error_code(hand_in(ana, a, right_answers(a)).second), "already_marked");
  EXPECT_EQ(s->call("GET", "/api/pupils/" + std::to_string(ana_id) + "/history", ana).second["exams"].size(), 1u);
  EXPECT_EQ(s->call("GET", path(a), ana).second["result"]["correct"], 24);
  // Staff go over it question by question: the choice made and the right one, as on the paper.
  EXPECT_EQ(error_code(s->call("GET", path(a) + "/review", ana).second), "forbidden");
  const json review = s->call("GET", path(a) + "/review", ines).second;
  ASSERT_EQ(review["items"].size(), 25u);
  for (size_t i = 0; i < 25; ++i) {
    const json& it = review["items"][i];
    EXPECT_EQ(it["choices"], a["questions"][i]["choices"]);
    EXPECT_EQ(it["answer"], right_answers(a)[it["id"].get<std::string>()]);
    EXPECT_EQ(it["right"], i != 0);
  }
  // Passed theory alone is not a certificate.
  EXPECT_EQ(error_code(s->call("GET", "/api/pupils/" + std::to_string(ana_id) + "/certificate", ana).second), "not_certified");
}

TEST_F(TheoryApi, APracticeQuizCountsTowardNothing) {
  Start("practice");
  const json p = paper(ana, std::nullopt);
  EXPECT_EQ(p["kind"], "practice");
  EXPECT_FALSE(p["counts"].get<bool>());
  EXPECT_TRUE(p["supervised_by"].is_null());
  EXPECT_EQ(p["questions"].size(), static_cast<size_t>(fs::load_theory_policy(kPolicyFile, bank()).practice_questions));
  auto [st, r] = hand_in(ana, p, right_answers(p));
  ASSERT_EQ(st, 200) << r;
  EXPECT_TRUE(r["result"]["passed"].get<bool>());  // all right ...
  EXPECT_FALSE(r["result"]["counts"].get<bool>());  // ... and it counts for nothing:
  EXPECT_TRUE(r["result"]["exam_id"].is_null());
  const std::string history = "/api/pupils/" + std::to_string(ana_id) + "/history";
  EXPECT_TRUE(s->call("GET", history, ana).second["exams"].empty());  // no theory exam on the record
  const json cert = s->call("GET", "/api/pupils/" + std::to_string(ana_id) + "/certificate", ines).second;
  EXPECT_EQ(error_code(cert), "not_certified");
  EXPECT_NE(cert["error"]["message"].get<std::string>().find("theory"), std::string::npos) << cert;
  const json t = standing(ana, ana_id);
  EXPECT_EQ(t["exam"]["attempts_since_reset"], 0);  // nor toward the retake rules
  ASSERT_EQ(t["papers"].size(), 1u);
  EXPECT_EQ(t["papers"][0]["kind"], "practice");
  // Staff may hand a pupil a practice quiz too; it is still practice.
  const json sp = paper(ines, ben_id, "practice");
  EXPECT_EQ(hand_in(ben, sp, right_answers(sp)).first, 200);
  EXPECT_TRUE(s->call("GET", "/api/pupils/" + std::to_string(ben_id) + "/history", ines).second["exams"].empty());
  // One paper at a time: a second quiz waits for the open one.
  const json open = paper(ana, std::nullopt);
  auto [st2, refused] = s->call("POST", "/api/theory/attempts", ana, "{}");
  EXPECT_EQ(st2, 409);
  EXPECT_EQ(error_code(refused), "paper_open");
  EXPECT_NE(refused["error"]["message"].get<std::string>().find(std::to_string(open["id"].get<int64_t>())), std::string::npos);
}

// Every key and value anywhere in `j`, but for an open paper's questions (which show every
// choice, the right one among them, by design).
void walk(const json& j, const std::function<void(const std::string& key, const json& v)>& f, const std::string& key = "") {
  f(key, j);
  if (key == "questions") return;
  if (j.is_object())
    for (const auto& [k, v] : j.items()) walk(v, f, k);
  else if (j.is_array())
    for (const auto& v : j) walk(v, f, key);
}

// What in `j` would tell its reader the bank's answers: an answer, a choice made or marked right,
// an explanation (each names the right answer), or a right answer's text outside a paper's choices.
std::vector<std::string> leaks(const json& j) {
  std::set<std::string> telling;
  for (const auto& q : bank().questions) {
    telling.insert(q.explanation);
    telling.insert(q.choices[static_cast<size_t>(q.answer)]);
  }
  std::vector<std::string> found;
  walk(j, [&](const std::string& key, const json& v) {
    for (const char* k : {"answer", "answers", "explanation", "chosen", "shown", "right", "items", "orders"})
      if (key == k) found.push_back("key '" + key + "'");
    if (v.is_string() && telling.count(v.get<std::string>())) found.push_back("an answer or explanation: " + v.get<std::string>());
  });
  return found;
}

TEST_F(TheoryApi, NoAnswerOfTheBankIsSentToAPupil) {
  Start("noleak");
  std::vector<json> to_pupil;  // every answer Ana gets
  const auto as_ana = [&](const std::string& method, const std::string& p, const std::string& body = "") {
    auto r = s->call(method, p, ana, body);
    to_pupil.push_back(r.second);
    return r;
  };
  as_ana("GET", "/api/theory");
  as_ana("GET", "/api/theory/questions");  // refused
  const json exam = paper(eve, ana_id);
  as_ana("GET", path(exam));  // the paper as Ana opens it
  as_ana("GET", "/api/theory/pupils/" + std::to_string(ana_id));
  const json marked = as_ana("POST", path(exam) + "/answers", json{{"answers", right_answers(exam, 6)}}.dump()).second;  // 19 of 25
  as_ana("GET", path(exam));
  as_ana("GET", path(exam) + "/review");  // refused
  as_ana("GET", "/api/theory/pupils/" + std::to_string(ana_id));
  as_ana("GET", "/api/pupils/" + std::to_string(ana_id) + "/history");
  const json quiz = as_ana("POST", "/api/theory/attempts", "{}").second;
  as_ana("POST", path(quiz) + "/answers", json{{"answers", right_answers(quiz, 3)}}.dump());
  as_ana("GET", path(quiz));
  ASSERT_EQ(marked["result"]["correct"], 19) << marked;
  EXPECT_FALSE(marked["result"]["passed"].get<bool>());
  EXPECT_FALSE(marked["result"]["to_revise"].empty());  // the topics missed and the clauses to read ...
  for (const json& r : to_pupil) EXPECT_TRUE(leaks(r).empty()) << leaks(r)[0] << " in " << r;  // ... and nothing more
  // The check can see a leak: staff's review carries every answer.
  EXPECT_FALSE(leaks(s->call("GET", path(exam) + "/review", eve).second).empty());
  EXPECT_FALSE(leaks(s->call("GET", "/api/theory/questions", eve).second).empty());
}

TEST_F(TheoryApi, ThePaperTimeLimitEndsItByTheServersClock) {
  Start("timelimit", {{"exam", {{"time_limit_s", 1}}}, {"hand_in", {{"grace_s", 0}}}});
  const json a = paper(ines, ana_id);
  EXPECT_DOUBLE_EQ(a["time_limit_s"].get<double>(), 1.0);
  ASSERT_TRUE(a["deadline"].is_string());
  // Wait for the server's own verdict that the time is up (the clock here is not the judge).
  json now = a;
  for (int i = 0; i < 300 && now["time_left_s"].get<double>() > 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    now = s->call("GET", path(a), ana).second;
  }
  ASSERT_DOUBLE_EQ(now["time_left_s"].get<double>(), 0.0) << now;
  // Answers after the deadline are not marked, and the paper is a timed-out exam, right answers or not.
  auto [st, late] = hand_in(ana, a, right_answers(a));
  EXPECT_EQ(st, 409) << late;
  EXPECT_EQ(error_code(late), "timed_out");
  const json ended = s->call("GET", path(a), ana).second;
  EXPECT_EQ(ended["outcome"], "timed_out");
  EXPECT_EQ(ended["result"]["outcome"], "timed_out");
  EXPECT_FALSE(ended["result"]["passed"].get<bool>());
  EXPECT_EQ(ended["result"]["correct"], 0);
  const json h = s->call("GET", "/api/pupils/" + std::to_string(ana_id) + "/history", ines).second;
  ASSERT_EQ(h["exams"].size(), 1u);
  EXPECT_FALSE(h["exams"][0]["passed"].get<bool>());
  EXPECT_EQ(error_code(hand_in(ana, a, right_answers(a)).second), "timed_out");  // and stays so
  // A paper nobody touches ends too: the server's clock records it, with no request about it.
  const json b = paper(ines, ben_id);
  json bh;
  for (int i = 0; i < 300; ++i) {  // the history does not end papers itself
    bh = s->call("GET", "/api/pupils/" + std::to_string(ben_id) + "/history", ines).second;
    if (!bh["exams"].empty()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_EQ(bh["exams"].size(), 1u) << bh;
  EXPECT_EQ(bh["exams"][0]["attempt"], b["id"]);
  EXPECT_FALSE(bh["exams"][0]["passed"].get<bool>());
  bool audited = false;
  for (const json& row : s->call("GET", "/api/pupils/" + std::to_string(ben_id) + "/audit", ines).second)
    audited |= row["action"] == "theory_timed_out" && row["actor"] == "server" && row["details"]["attempt"] == b["id"];
  EXPECT_TRUE(audited);
}

TEST_F(TheoryApi, ARetakeInsideTheWaitIsRefusedUntilAnInstructorUnlocks) {
  Start("wait", {{"exam", {{"retake_wait_s", 3600}, {"max_attempts", 0}}}});
  const json first = paper(eve, ana_id);
  // No second exam while one is open.
  auto [st_open, open] = s->call("POST", "/api/theory/attempts", eve, json{{"pupil_id", ana_id}}.dump());
  EXPECT_EQ(st_open, 409);
  EXPECT_EQ(error_code(open), "paper_open");
  ASSERT_EQ(hand_in(ana, first, json::object()).first, 200);  // nothing answered: not passed
  httplib::Client c = s->client();
  const auto refused = c.Post("/api/theory/attempts", {{"Authorization", "Bearer " + eve}}, json{{"pupil_id", ana_id}}.dump(), "application/json");
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 409);
  const json body = json::parse(refused->body);
  EXPECT_EQ(error_code(body), "retake_too_soon");
  const int retry_after = std::stoi("0" + refused->get_header_value("Retry-After"));
  EXPECT_GT(retry_after, 3500);
  EXPECT_LE(retry_after, 3600);
  // The message says when, and who can change it; the standing says when too.
  const json t = standing(ana, ana_id);
  ASSERT_TRUE(t["exam"]["from"].is_string()) << t;
  EXPECT_NE(body["error"]["message"].get<std::string>().find(t["exam"]["from"].get<std::string>()), std::string::npos) << body;
  EXPECT_NE(body["error"]["message"].get<std::string>().find("instructor"), std::string::npos) << body;
  const int64_t from = *fs::parse_iso8601_ms(t["exam"]["from"]), finished = *fs::parse_iso8601_ms(t["papers"][0]["finished_at"]);
  EXPECT_EQ(from - finished, 3600 * 1000);
  EXPECT_FALSE(t["exam"]["allowed"].get<bool>());
  EXPECT_TRUE(t["practice"]["allowed"].get<bool>());  // practice is not held back
  // An examiner or the pupil cannot unlock; an instructor can, and it is audited.
  EXPECT_EQ(error_code(s->call("POST", "/api/theory/pupils/" + std::to_string(ana_id) + "/unlock", eve, "{}").second), "forbidden");
  EXPECT_EQ(error_code(s->call("POST", "/api/theory/pupils/" + std::to_string(ana_id) + "/unlock", ana, "{}").second), "forbidden");
  auto [st_u, unlocked] = s->call("POST", "/api/theory/pupils/" + std::to_string(ana_id) + "/unlock", ines, R"({"reason":"retrained"})");
  ASSERT_EQ(st_u, 201) << unlocked;
  EXPECT_TRUE(unlocked["exam"]["allowed"].get<bool>());
  EXPECT_EQ(unlocked["unlocks"][0]["by"], "ines");
  const json second = paper(eve, ana_id);
  EXPECT_EQ(shared(paper_ids(second), paper_ids(first)), 0u) << "a retake repeats a question of the last paper";
  bool audited = false;
  for (const json& row : s->call("GET", "/api/pupils/" + std::to_string(ana_id) + "/audit", ines).second)
    audited |= row["action"] == "theory_unlocked" && row["actor"] == "ines" && row["details"]["was"] == "retake_too_soon";
  EXPECT_TRUE(audited);
}

TEST_F(TheoryApi, AfterTheLimitOfAttemptsOnlyAnInstructorUnlocks) {
  Start("limit", {{"exam", {{"retake_wait_s", 0}, {"max_attempts", 2}}}});
  std::set<std::string> last;
  for (int i = 0; i < 2; ++i) {
    const json a = paper(eve, ana_id);
    EXPECT_EQ(shared(paper_ids(a), last), 0u) << "retake " << i << " repeats a question of the last paper";
    last = paper_ids(a);
    ASSERT_EQ(hand_in(ana, a, right_answers(a, 10)).first, 200);  // 15 of 25: not passed
  }
  auto [st, refused] = s->call("POST", "/api/theory/attempts", eve, json{{"pupil_id", ana_id}}.dump());
  EXPECT_EQ(st, 409);
  EXPECT_EQ(error_code(refused), "retake_locked");
  EXPECT_NE(refused["error"]["message"].get<std::string>().find("an instructor must unlock"), std::string::npos) << refused;
  EXPECT_EQ(standing(ana, ana_id)["exam"]["attempts_since_reset"], 2);
  EXPECT_EQ(paper(ana, std::nullopt)["kind"], "practice");  // practice goes on meanwhile
  // Ben, with no attempts, is not held back by Ana's.
  EXPECT_EQ(paper(eve, ben_id)["kind"], "exam");
  EXPECT_EQ(s->call("POST", "/api/theory/pupils/" + std::to_string(ana_id) + "/unlock", admin, "").first, 201);
  const json third = paper(eve, ana_id);
  EXPECT_EQ(shared(paper_ids(third), last), 0u);
  // A pass starts the count again.
  ASSERT_TRUE(hand_in(ana, third, right_answers(third)).second["result"]["passed"].get<bool>());
  EXPECT_EQ(standing(ana, ana_id)["exam"]["attempts_since_reset"], 0);
}

TEST_F(TheoryApi, BadAnswerBodiesAreRefusedAndLeaveThePaperOpen) {
  Start("bad");
  const json a = paper(ben, std::nullopt);
  const std::string answers = path(a) + "/answers";
  const std::string first = a["questions"][0]["id"];
  for (const json& body : {json{{"answers", json::array({1, 2})}}, json{{"answers", "all of them"}}, json{{"answerz", json::object()}},
                           json{{"answers", {{first, "2"}}}}, json{{"answers", {{first, 1.5}}}}, json{{"answers", {{first, -1}}}},
                           json{{"answers", {{first, 7}}}}, json{{"answers", {{first, 4000000000LL}}}},
                           json{{"answers", {{"no-such-question", 0}}}}}) {
    auto [st, j] = s->call("POST", answers, ben, body.dump());
    EXPECT_EQ(st, 400) << body << " -> " << j;
    EXPECT_EQ(error_code(j), "bad_request") << body;
  }
  EXPECT_EQ(error_code(s->call("POST", answers, ben, "{not json").second), "bad_json");
  EXPECT_EQ(error_code(s->call("POST", answers, ben, "").second), "bad_request");
  EXPECT_EQ(s->call("POST", "/api/theory/attempts/999999/answers", ben, R"({"answers":{}})").first, 404);
  for (const json& body : {json{{"kind", "quiz"}}, json{{"kind", 5}}, json{{"seed", 5}}}) {
    json b = body;
    b["pupil_id"] = ben_id;
    EXPECT_EQ(error_code(s->call("POST", "/api/theory/attempts", ines, b.dump()).second), "bad_request") << b;
  }
  // Nothing above was stored: the paper is still open, and an empty hand-in is a (failed) mark.
  EXPECT_FALSE(s->call("GET", path(a), ben).second["finished"].get<bool>());
  auto [st, r] = s->call("POST", answers, ben, R"({"answers":{}})");
  ASSERT_EQ(st, 200) << r;
  EXPECT_EQ(r["result"]["correct"], 0);
  EXPECT_FALSE(r["result"]["passed"].get<bool>());
}

TEST_F(TheoryApi, RolesOtherPupilsPapersAndPictures) {
  Start("roles");
  EXPECT_EQ(error_code(s->call("POST", "/api/theory/attempts", "", "{}").second), "unauthenticated");
  EXPECT_EQ(error_code(s->call("GET", "/api/theory/questions", ana).second), "forbidden");  // the answers are for staff
  EXPECT_EQ(s->call("GET", "/api/theory/questions", ines).second.size(), bank().questions.size());
  EXPECT_EQ(error_code(s->call("POST", "/api/theory/attempts", ana, json{{"pupil_id", ben_id}}.dump()).second), "forbidden");
  EXPECT_EQ(error_code(s->call("POST", "/api/theory/attempts", ines, "{}").second), "bad_request");  // staff name the pupil
  EXPECT_EQ(error_code(s->call("POST", "/api/theory/attempts", ines, R"({"pupil_id": 999999})").second), "not_found");
  EXPECT_EQ(error_code(s->call("GET", "/api/theory/pupils/" + std::to_string(ben_id), ana).second), "forbidden");

  // Ana's paper: Ben may neither read it nor hand it in; staff of the school may read it.
  const json a = paper(ines, ana_id);
  EXPECT_EQ(error_code(s->call("GET", path(a), ben).second), "forbidden");
  EXPECT_EQ(error_code(hand_in(ben, a, right_answers(a)).second), "forbidden");
  EXPECT_FALSE(s->call("GET", path(a), ana).second["finished"].get<bool>());
  EXPECT_EQ(s->call("GET", path(a), ines).first, 200);
  EXPECT_EQ(error_code(s->call("GET", path(a) + "/review", ines).second), "paper_open");  // no answers while it is open

  // The pictures: to anyone logged in, as SVG; nothing outside the bank's pictures.
  httplib::Client c = s->client();
  const httplib::Headers auth = {{"Authorization", "Bearer " + ana}};
  auto pic = c.Get("/api/theory/images/plate_e16.svg", auth);
  ASSERT_TRUE(pic);
  EXPECT_EQ(pic->status, 200);
  EXPECT_EQ(pic->get_header_value("Content-Type"), "image/svg+xml");
  EXPECT_EQ(pic->body.rfind("<svg", 0), 0u);
  EXPECT_EQ(c.Get("/api/theory/images/plate_e16.svg")->status, 401);
  for (const char* bad : {"/api/theory/images/nothing.svg", "/api/theory/images/..%2Fquestions.json", "/api/theory/images/policy.json"})
    EXPECT_EQ(c.Get(bad, auth)->status, 404) << bad;
  // A paper's picture is named by its question.
  for (const auto& q : s->call("GET", "/api/theory/questions", ines).second) {
    if (!q.contains("image")) continue;
    EXPECT_EQ(c.Get(q["image"].get<std::string>(), auth)->status, 200) << q["image"];
  }
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
