#include "theory.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <regex>
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

json read_json(const std::string& path, const char* what) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open the " + what);
  try {
    return json::parse(in);
  } catch (const json::exception& e) {
    throw std::runtime_error(path + ": not valid JSON: " + e.what());
  }
}

// A choice that names another's place ("all of the above", "A and B") means nothing once the
// choices are shuffled.
bool names_other_choices(const std::string& choice) {
  static const std::regex places(R"((^|[^A-Za-z])(of the above|the above|[A-D] (and|or) [A-D])([^A-Za-z]|$))",
                                 std::regex::icase);
  return std::regex_search(choice, places);
}

}  // namespace

bool is_image_name(const std::string& name) {
  static const std::regex pattern("[a-z0-9_-]{1,64}\\.svg");
  return std::regex_match(name, pattern);
}

const TheoryTopic* QuestionBank::topic(const std::string& id) const {
  for (const TheoryTopic& t : topics)
    if (t.id == id) return &t;
  return nullptr;
}

const Question* QuestionBank::find(const std::string& id) const {
  for (const Question& q : questions)
    if (q.id == id) return &q;
  return nullptr;
}

QuestionBank load_question_bank(const std::string& path) {
  const json j = read_json(path, "question bank");
  QuestionBank b;
  b.images_dir = (std::filesystem::path(path).parent_path() / "images").string();
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
    std::string where = "questions[" + std::to_string(i) + "]";
    Question q;
    try {
      q.id = qs[i].at("id").get<std::string>();
      where += " (" + q.id + ")";
      q.topic = qs[i].at("topic").get<std::string>();
      q.text = qs[i].at("text").get<std::string>();
      q.choices = qs[i].at("choices").get<std::vector<std::string>>();
      q.answer = qs[i].at("answer").get<int>();
      q.explanation = qs[i].at("explanation").get<std::string>();
      q.reference = qs[i].value("reference", "");
      q.image = qs[i].value("image", "");
      q.image_alt = qs[i].value("image_alt", "");
    } catch (const json::exception& e) {
      fail(path, where, e.what());
    }
    if (q.id.empty() || !ids.insert(q.id).second) fail(path, where, "id '" + q.id + "' is empty or not unique");
    if (!topics.count(q.topic)) fail(path, where, "topic '" + q.topic + "' is not in 'topics'");
    if (q.text.empty() || q.explanation.empty()) fail(path, where, "empty text or explanation");
    if (q.reference.empty()) fail(path, where, "no reference: every answer rests on a clause");
    if (q.choices.size() < 2 || q.choices.size() > 6) fail(path, where, "needs 2 to 6 choices");
    if (q.answer < 0 || q.answer >= static_cast<int>(q.choices.size())) fail(path, where, "answer is not one of the choices");
    if (std::set<std::string>(q.choices.begin(), q.choices.end()).size() != q.choices.size())
      fail(path, where, "two choices are the same");
    for (const std::string& c : q.choices) {
      if (c.empty()) fail(path, where, "an empty choice");
      if (names_other_choices(c)) fail(path, where, "choice '" + c + "' names other choices, which are shuffled on each paper");
    }
    if (!q.image.empty()) {
      if (!is_image_name(q.image)) fail(path, where, "image '" + q.image + "' must be a-z, 0-9, '_' or '-', then .svg");
      if (!std::filesystem::is_regular_file(std::filesystem::path(b.images_dir) / q.image))
        fail(path, where, "image '" + q.image + "' is not in " + b.images_dir);
      if (q.image_alt.empty()) fail(path, where, "image '" + q.image + "' has no image_alt (what it shows, in words)");
    }
    covered.insert(q.topic);
    b.questions.push_back(std::move(q));
  }
  for (const TheoryTopic& t : b.topics)
    if (!covered.count(t.id)) fail(path, "topics." + t.id, "has no question");
  if (b.questions_per_exam < 1 || b.questions_per_exam > static_cast<int>(b.questions.size()))
    fail(path, "questions_per_exam", "must be between 1 and the number of questions");
  return b;
}

namespace {

// A rules file's numbers: `section`.`key`, within [lo, hi], or a failure naming the file and the key.
struct RulesFile {
  std::string path;
  json j;
  double number(const char* section, const char* key, double lo, double hi) const {
    const std::string where = std::string(section) + "." + key;
    const json* v = nullptr;
    if (j.is_object() && j.contains(section) && j[section].is_object() && j[section].contains(key)) v = &j[section][key];
    if (!v || !v->is_number()) fail(path, where, "must be a number");
    const double d = v->get<double>();
    if (!(d >= lo && d <= hi)) fail(path, where, "must be between " + json(lo).dump() + " and " + json(hi).dump());
    return d;
  }
  int whole(const char* section, const char* key, double lo, double hi) const {
    const double d = number(section, key, lo, hi);
    if (d != static_cast<double>(static_cast<int>(d))) fail(path, std::string(section) + "." + key, "must be a whole number");
    return static_cast<int>(d);
  }
};

}  // namespace

TheoryPolicy load_theory_policy(const std::string& path, const QuestionBank& bank) {
  const RulesFile f{path, read_json(path, "theory exam policy")};
  TheoryPolicy p;
  constexpr double kWeek = 7 * 86400, kYear = 366 * 86400;
  p.exam_time_limit_s = f.number("exam", "time_limit_s", 1, kWeek);
  p.retake_wait_s = f.number("exam", "retake_wait_s", 0, kYear);
  p.max_attempts = f.whole("exam", "max_attempts", 0, 1000);
  p.practice_time_limit_s = f.number("practice", "time_limit_s", 1, kWeek);
  p.practice_questions = f.whole("practice", "questions", 1, static_cast<double>(bank.questions.size()));
  p.grace_s = f.number("hand_in", "grace_s", 0, 600);
  return p;
}

LicenceRules load_licence_rules(const std::string& path) {
  const RulesFile f{path, read_json(path, "licence rules")};
  LicenceRules r;
  r.training_sessions = f.whole("training", "marked_sessions", 0, 1000);
  r.theory_within_months = f.whole("theory", "within_months", 0, 120);
  return r;
}

Paper draw_paper(const QuestionBank& bank, uint64_t seed, int count, const PaperHistory& history) {
  std::mt19937_64 rng(seed);
  count = std::clamp(count, 0, static_cast<int>(bank.questions.size()));
  // Within a topic: questions of the last papers last, then the least seen first, ties shuffled.
  const auto rank = [&](const std::string& id) {
    const auto it = history.seen.find(id);
    return std::pair(history.last.count(id) ? 1 : 0, it == history.seen.end() ? 0 : it->second);
  };
  std::vector<std::vector<std::string>> by_topic;
  for (const TheoryTopic& t : bank.topics) {
    by_topic.emplace_back();
    for (const Question& q : bank.questions)
      if (q.topic == t.id) by_topic.back().push_back(q.id);
    shuffle(by_topic.back(), rng);
    std::stable_sort(by_topic.back().begin(), by_topic.back().end(),
                     [&](const std::string& a, const std::string& b) { return rank(a) < rank(b); });
  }
  shuffle(by_topic, rng);
  Paper paper;
  for (size_t round = 0; static_cast<int>(paper.ids.size()) < count; ++round)
    for (const auto& ids : by_topic)
      if (round < ids.size() && static_cast<int>(paper.ids.size()) < count) paper.ids.push_back(ids[round]);
  shuffle(paper.ids, rng);
  for (const std::string& id : paper.ids) {
    std::vector<int> order(bank.find(id)->choices.size());
    for (size_t k = 0; k < order.size(); ++k) order[k] = static_cast<int>(k);
    shuffle(order, rng);
    paper.orders.push_back(std::move(order));
  }
  return paper;
}

std::string paper_text(const QuestionBank& bank, const Paper& paper) {
  return json{{"bank_version", bank.version}, {"ids", paper.ids}, {"orders", paper.orders}}.dump();
}

Paper read_paper(const QuestionBank& bank, const std::string& text) {
  const json j = json::parse(text, nullptr, false);
  if (!j.is_object() || !j.contains("ids") || !j["ids"].is_array()) throw std::runtime_error("a theory paper is unreadable");
  Paper p;
  try {
    p.ids = j["ids"].get<std::vector<std::string>>();
    if (j.contains("orders")) p.orders = j["orders"].get<std::vector<std::vector<int>>>();
  } catch (const json::exception& e) {
    throw std::runtime_error(std::string("a theory paper is unreadable: ") + e.what());
  }
  if (!p.orders.empty() && p.orders.size() != p.ids.size()) throw std::runtime_error("a theory paper's choice orders do not match its questions");
  for (size_t i = 0; i < p.ids.size(); ++i) {
    const Question* q = bank.find(p.ids[i]);
    if (!q) throw std::runtime_error("question '" + p.ids[i] + "' of this paper is no longer in the bank");
    if (p.orders.size() <= i) {  // kept before choices were shuffled: the bank's order
      p.orders.emplace_back(q->choices.size());
      for (size_t k = 0; k < q->choices.size(); ++k) p.orders.back()[k] = static_cast<int>(k);
    }
    std::vector<int> sorted = p.orders[i];
    std::sort(sorted.begin(), sorted.end());
    for (size_t k = 0; k < sorted.size(); ++k)
      if (sorted.size() != q->choices.size() || sorted[k] != static_cast<int>(k))
        throw std::runtime_error("question '" + q->id + "' of this paper has choices the bank no longer has");
  }
  return p;
}

Marking mark_paper(const QuestionBank& bank, const Paper& paper, const std::map<std::string, int>& answers) {
  Marking m;
  for (const auto& [id, shown] : answers) {
    const auto at = std::find(paper.ids.begin(), paper.ids.end(), id);
    if (at == paper.ids.end()) throw BadAnswers("question '" + id + "' is not on this paper");
    const size_t n = paper.orders[static_cast<size_t>(at - paper.ids.begin())].size();
    if (shown < 0 || shown >= static_cast<int>(n))
      throw BadAnswers("question '" + id + "' has choices 0 to " + std::to_string(n - 1));
  }
  for (size_t i = 0; i < paper.ids.size(); ++i) {
    const Question* q = bank.find(paper.ids[i]);
    if (!q) throw std::runtime_error("question '" + paper.ids[i] + "' of this paper is no longer in the bank");
    const std::vector<int>& order = paper.orders[i];
    MarkedQuestion item;
    item.question = q;
    item.answer_shown = static_cast<int>(std::find(order.begin(), order.end(), q->answer) - order.begin());
    if (auto it = answers.find(q->id); it != answers.end()) {
      item.shown = it->second;
      item.chosen = order[static_cast<size_t>(it->second)];
    }
    item.right = item.chosen && *item.chosen == q->answer;
    m.correct += item.right;
    auto& [right, total] = m.by_topic[q->topic];
    right += item.right;
    ++total;
    m.items.push_back(item);
  }
  m.total = static_cast<int>(paper.ids.size());
  m.score = m.total > 0 ? static_cast<double>(m.correct) / m.total : 0;
  // Compared in whole questions, so that 20 of 25 at a pass mark of 0.8 passes whatever the rounding.
  m.passed = m.total > 0 && m.correct * 1.0 >= bank.pass_mark * m.total - 1e-9;
  return m;
}

int64_t now_ms() {
  using namespace std::chrono;
  return duration_cast<milliseconds>(system_clock::now().time_since_epoch()).count();
}

std::string iso8601_ms(int64_t ms) {
  using namespace std::chrono;
  const sys_time<milliseconds> t{milliseconds(ms)};
  const auto day = floor<days>(t);
  const year_month_day ymd{day};
  const hh_mm_ss hms{t - day};
  char buf[40];
  std::snprintf(buf, sizeof buf, "%04d-%02u-%02uT%02d:%02d:%02d.%03dZ", static_cast<int>(ymd.year()),
                static_cast<unsigned>(ymd.month()), static_cast<unsigned>(ymd.day()), static_cast<int>(hms.hours().count()),
                static_cast<int>(hms.minutes().count()), static_cast<int>(hms.seconds().count()),
                static_cast<int>(hms.subseconds().count()));
  return buf;
}

std::optional<int64_t> parse_iso8601_ms(const std::string& iso) {
  static const std::regex pattern(R"((\d{4})-(\d{2})-(\d{2})T(\d{2}):(\d{2}):(\d{2})(\.(\d{3}))?Z)");
  std::smatch m;
  if (!std::regex_match(iso, m, pattern)) return std::nullopt;
  using namespace std::chrono;
  const year_month_day ymd{year(std::stoi(m[1])), month(static_cast<unsigned>(std::stoi(m[2]))), day(static_cast<unsigned>(std::stoi(m[3])))};
  if (!ymd.ok()) return std::nullopt;
  const int h = std::stoi(m[4]), mi = std::stoi(m[5]), sec = std::stoi(m[6]);
  if (h > 23 || mi > 59 || sec > 60) return std::nullopt;
  const sys_days d{ymd};
  return duration_cast<milliseconds>(d.time_since_epoch()).count() + ((h * 60 + mi) * 60 + sec) * int64_t{1000} +
         (m[8].matched ? std::stoi(m[8]) : 0);
}

}  // namespace forklift::server
