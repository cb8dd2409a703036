// The theory exam: the question bank (data/theory/questions.json, format in data/theory/README.md),
// the school's rules for papers (data/theory/policy.json), papers drawn from the bank for one
// pupil with their choices shuffled, and their marking. No HTTP and no store here: the server's
// routes hand out papers, keep them in the store, enforce the rules and record the marks.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace forklift::server {

struct Question {
  std::string id, topic, text;
  std::vector<std::string> choices;  // 2 to 6, all different
  int answer = 0;                    // index into choices
  std::string explanation;           // one line, for staff reviewing a paper (never sent to pupils)
  std::string reference;             // the clause the answer rests on, e.g. "29 CFR 1910.178(m)(2)"
  std::string image;                 // a picture under the bank's images/ ("plate_e16.svg"), or empty
  std::string image_alt;             // what the picture shows, in words (set when image is)
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
  std::string images_dir;            // <the bank's folder>/images
  std::vector<TheoryTopic> topics;   // in the file's order
  std::vector<Question> questions;   // every topic has at least one

  const Question* find(const std::string& id) const;  // nullptr if absent
  const TheoryTopic* topic(const std::string& id) const;  // nullptr if absent
};

// Reads and validates the bank: unique ids, known topics, an answer inside the choices, choices
// that differ and never name another choice's place ("all of the above" means nothing once
// choices are shuffled), a reference for every question, every picture present, every topic
// covered. Throws std::runtime_error naming the file and the question or key.
QuestionBank load_question_bank(const std::string& path);

// Whether `name` may name a picture of the bank: letters a-z, digits, '_' and '-', then ".svg".
bool is_image_name(const std::string& name);

// The school's rules for theory papers, loaded and checked once (data/theory/policy.json).
struct TheoryPolicy {
  double exam_time_limit_s = 0;      // a supervised exam paper's time, from hand-out to hand-in
  double practice_time_limit_s = 0;  // a practice paper's
  int practice_questions = 0;        // questions on a practice paper, 1 .. the bank's size
  // Answers arriving this long after the deadline are still marked: the page hands a paper in by
  // itself when its clock shows zero, and the answers take a moment to arrive.
  double grace_s = 0;
  double retake_wait_s = 0;  // after an exam paper that did not pass, before the next; 0: none
  // Exam papers a pupil may sit without passing (since their last pass or an instructor's
  // unlock) before an instructor must unlock further ones; 0: no limit.
  int max_attempts = 0;
};

// Throws std::runtime_error naming the file and the key. `bank` bounds practice_questions.
TheoryPolicy load_theory_policy(const std::string& path, const QuestionBank& bank);

// The school's rules for a licence, loaded and checked once (data/licence/rules.json): what the
// record must hold before an examiner may issue one, beside a passed practical exam on an exam
// course (always needed).
struct LicenceRules {
  // Marked training sessions (store::mark_of) on the truck class of the practical exam.
  int training_sessions = 0;
  // The theory exam's pass no older than this when the licence is issued; 0: any age.
  int theory_within_months = 0;
};

// Throws std::runtime_error naming the file and the key.
LicenceRules load_licence_rules(const std::string& path);

// A paper as handed out: its questions in order, and for each the order its choices are shown in
// (order[k] is the bank's index of the choice shown k-th).
struct Paper {
  std::vector<std::string> ids;
  std::vector<std::vector<int>> orders;
};

// What a pupil was given before, so that a new paper repeats as little as the bank allows.
struct PaperHistory {
  std::set<std::string> last;        // the questions of their last papers: avoided first
  std::map<std::string, int> seen;   // on how many of their papers each question was
};

// A paper of `count` questions for `seed`: spread over the topics as evenly as the bank allows
// (round robin over the topics in a shuffled order), within a topic the questions of `history.last`
// last, then the least seen, ties in random order; then the paper shuffled and each question's
// choices shuffled. So two pupils' papers differ, and a retake shares no question with the last
// paper while every topic has enough others. The same bank, seed and history give the same paper
// on every platform: std::mt19937_64 is fully specified and the bounded draws are our own.
Paper draw_paper(const QuestionBank& bank, uint64_t seed, int count, const PaperHistory& history = {});

// A paper as the store keeps it (JSON text: bank_version, ids, orders), and back. A paper kept
// before choices were shuffled has no orders: its choices are shown in the bank's order. Throws
// std::runtime_error if the text is not a paper or a question is no longer in the bank.
std::string paper_text(const QuestionBank& bank, const Paper& paper);
Paper read_paper(const QuestionBank& bank, const std::string& text);

struct MarkedQuestion {
  const Question* question = nullptr;
  std::optional<int> shown;   // the position chosen on the paper; none: not answered (wrong)
  std::optional<int> chosen;  // the same choice as the bank's index
  int answer_shown = 0;       // where the right choice was on the paper
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

// Marks `answers` (question id -> the position chosen on the paper) against `paper`. Questions
// without an answer are wrong. Throws BadAnswers; std::runtime_error if the paper names a
// question the bank no longer has.
Marking mark_paper(const QuestionBank& bank, const Paper& paper, const std::map<std::string, int>& answers);

// Wall-clock time in milliseconds since 1970 (UTC), as ISO-8601 with milliseconds
// ("2026-11-23T10:30:00.125Z"), and back (with or without the milliseconds; nullopt if `iso` is
// neither).
int64_t now_ms();
std::string iso8601_ms(int64_t ms);
std::optional<int64_t> parse_iso8601_ms(const std::string& iso);

}  // namespace forklift::server
