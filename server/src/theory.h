// The theory exam: the question bank (data/theory/questions.json, format in data/theory/README.md),
// papers drawn from it with a seed, and their marking. No HTTP and no store here: the server's
// routes hand out papers, keep them in the store and record the marks.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace forklift::server {

struct Question {
  std::string id, topic, text;
  std::vector<std::string> choices;  // 2 to 6
  int answer = 0;                    // index into choices
  std::string explanation;           // one line, shown after marking
  std::string reference;             // the clause the answer rests on, e.g. "1910.178(m)(2)"
};

struct TheoryTopic {
  std::string id, title, osha;  // osha: the clauses of 1910.178(l)(3) it covers
};

// Loaded and checked once; then const.
struct QuestionBank {
  int version = 0;
  int questions_per_exam = 0;  // 1 .. questions.size()
  double pass_mark = 0;        // fraction correct needed to pass, (0, 1]
  std::string pass_mark_why;
  std::vector<TheoryTopic> topics;   // in the file's order
  std::vector<Question> questions;   // every topic has at least one

  const Question* find(const std::string& id) const;  // nullptr if absent
};

// Reads and validates the bank: unique ids, known topics, an answer inside the choices, every
// topic covered. Throws std::runtime_error naming the file and the question or key.
QuestionBank load_question_bank(const std::string& path);

// The paper for `seed`: questions_per_exam question ids, spread over the topics as evenly as
// the bank allows (round robin over the topics in a shuffled order, each topic's questions
// shuffled), then shuffled. The same bank and seed give the same paper on every platform:
// std::mt19937_64 is fully specified and the bounded draws are our own.
std::vector<std::string> draw_paper(const QuestionBank& bank, uint64_t seed);

struct MarkedQuestion {
  const Question* question = nullptr;
  std::optional<int> chosen;  // none: not answered (counts as wrong)
  bool right = false;
};

struct Marking {
  std::vector<MarkedQuestion> items;  // in the paper's order
  int correct = 0, total = 0;
  double score = 0;  // correct / total
  bool passed = false;
  std::map<std::string, std::pair<int, int>> by_topic;  // topic -> (correct, total)
};

// Refused answers: an id not on the paper, or a choice outside the question's choices.
class BadAnswers : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Marks `answers` (question id -> chosen index) against `paper`. Questions without an answer are
// wrong. Throws BadAnswers; std::runtime_error if the paper names a question the bank no longer has.
Marking mark_paper(const QuestionBank& bank, const std::vector<std::string>& paper,
                   const std::map<std::string, int>& answers);

}  // namespace forklift::server
