#include "theory.h"

#include <algorithm>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <set>

namespace forklift::server {
namespace {

using json = nlohmann::ordered_json;  // keeps the topics in the file's order

[[noreturn]] void fail(const std::string& path, const std::string& where, const std::string& what) {
  throw std::runtime_error(path + ": " + where + ": " + what);
}

// A uniform integer in [0, n) from the generator, without modulo bias, and the same on every
// platform (std::uniform_int_distribution is not specified bit for bit).
uint64_t below(std::mt19937_64& rng, uint64_t n) {
  const uint64_t limit = std::numeric_limits<uint64_t>::max() - std::numeric_limits<uint64_t>::max() % n;
  uint64_t v;
  do v = rng(); while (v >= limit);
  return v % n;
}

template <typename T>
void shuffle(std::vector<T>& v, std::mt19937_64& rng) {
  for (size_t i = v.size(); i > 1; --i) std::swap(v[i - 1], v[below(rng, i)]);
}

}  // namespace

const Question* QuestionBank::find(const std::string& id) const {
  for (const Question& q : questions)
    if (q.id == id) return &q;
  return nullptr;
}

QuestionBank load_question_bank(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open the question bank");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::exception& e) {
    throw std::runtime_error(path + ": not valid JSON: " + e.what());
  }
  QuestionBank b;
  try {
    b.version = j.at("version").get<int>();
    b.questions_per_exam = j.at("questions_per_exam").get<int>();
    b.pass_mark = j.at("pass_mark").get<double>();
    b.pass_mark_why = j.value("_pass_mark_why", "");
    for (const auto& [id, t] : j.at("topics").items())
      b.topics.push_back({id, t.at("title").get<std::string>(), t.at("osha").get<std::string>()});
  } catch (const json::exception& e) {
    fail(path, "header", e.what());
  }
  if (!(b.pass_mark > 0 && b.pass_mark <= 1)) fail(path, "pass_mark", "must be a fraction in (0, 1]");
  std::set<std::string> topics, ids, covered;
  for (const TheoryTopic& t : b.topics) topics.insert(t.id);
  const json& qs = j.contains("questions") ? j["questions"] : json();
  if (!qs.is_array() || qs.empty()) fail(path, "questions", "must be a non-empty array");
  for (size_t i = 0; i < qs.size(); ++i) {
    const std::string where = "questions[" + std::to_string(i) + "]";
    Question q;
    try {
      q.id = qs[i].at("id").get<std::string>();
      q.topic = qs[i].at("topic").get<std::string>();
      q.text = qs[i].at("text").get<std::string>();
      q.choices = qs[i].at("choices").get<std::vector<std::string>>();
      q.answer = qs[i].at("answer").get<int>();
      q.explanation = qs[i].at("explanation").get<std::string>();
      q.reference = qs[i].value("reference", "");
    } catch (const json::exception& e) {
      fail(path, where, e.what());
    }
    if (q.id.empty() || !ids.insert(q.id).second) fail(path, where, "id '" + q.id + "' is empty or not unique");
    if (!topics.count(q.topic)) fail(path, where, "topic '" + q.topic + "' is not in 'topics'");
    if (q.text.empty() || q.explanation.empty()) fail(path, where, "empty text or explanation");
    if (q.choices.size() < 2 || q.choices.size() > 6) fail(path, where, "needs 2 to 6 choices");
    if (q.answer < 0 || q.answer >= static_cast<int>(q.choices.size())) fail(path, where, "answer is not one of the choices");
    covered.insert(q.topic);
    b.questions.push_back(std::move(q));
  }
  for (const TheoryTopic& t : b.topics)
    if (!covered.count(t.id)) fail(path, "topics." + t.id, "has no question");
  if (b.questions_per_exam < 1 || b.questions_per_exam > static_cast<int>(b.questions.size()))
    fail(path, "questions_per_exam", "must be between 1 and the number of questions");
  return b;
}

std::vector<std::string> draw_paper(const QuestionBank& bank, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<std::vector<std::string>> by_topic;
  for (const TheoryTopic& t : bank.topics) {
    by_topic.emplace_back();
    for (const Question& q : bank.questions)
      if (q.topic == t.id) by_topic.back().push_back(q.id);
    shuffle(by_topic.back(), rng);
  }
  shuffle(by_topic, rng);
  std::vector<std::string> paper;
  for (size_t round = 0; static_cast<int>(paper.size()) < bank.questions_per_exam; ++round)
    for (const auto& ids : by_topic)
      if (round < ids.size() && static_cast<int>(paper.size()) < bank.questions_per_exam) paper.push_back(ids[round]);
  shuffle(paper, rng);
  return paper;
}

Marking mark_paper(const QuestionBank& bank, const std::vector<std::string>& paper,
                   const std::map<std::string, int>& answers) {
  Marking m;
  for (const auto& [id, choice] : answers) {
    if (std::find(paper.begin(), paper.end(), id) == paper.end()) throw BadAnswers("question '" + id + "' is not on this paper");
    const Question* q = bank.find(id);
    if (q && (choice < 0 || choice >= static_cast<int>(q->choices.size())))
      throw BadAnswers("question '" + id + "' has choices 0 to " + std::to_string(q->choices.size() - 1));
  }
  for (const std::string& id : paper) {
    const Question* q = bank.find(id);
    if (!q) throw std::runtime_error("question '" + id + "' of this paper is no longer in the bank");
    MarkedQuestion item{q, std::nullopt, false};
    if (auto it = answers.find(id); it != answers.end()) item.chosen = it->second;
    item.right = item.chosen && *item.chosen == q->answer;
    m.correct += item.right;
    auto& [right, total] = m.by_topic[q->topic];
    right += item.right;
    ++total;
    m.items.push_back(item);
  }
  m.total = static_cast<int>(paper.size());
  m.score = m.total > 0 ? static_cast<double>(m.correct) / m.total : 0;
  // Compared in whole questions, so that 20 of 25 at a pass mark of 0.8 passes whatever the rounding.
  m.passed = m.total > 0 && m.correct * 1.0 >= bank.pass_mark * m.total - 1e-9;
  return m;
}

}  // namespace forklift::server
