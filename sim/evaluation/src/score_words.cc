// A score in words for a person (forklift/evaluation/evaluation.h: score_words).
#include <cstdio>

#include "forklift/evaluation/evaluation.h"

namespace forklift {
namespace {

// A rule's words; an id no rule has (an older log's) still reads as words, not as a code.
std::string rule_words(const Rules& rules, const std::string& id) {
  if (const Rule* rule = rules.find(id)) return rule->description;
  std::string words = id;
  for (char& c : words)
    if (c == '_') c = ' ';
  return words;
}

}  // namespace

std::string score_words(const Score& score, const Rules& rules) {
  char mark[32];
  std::snprintf(mark, sizeof mark, "%.0f", score.mark);
  std::string text = "mark " + std::string(mark) + " of 100, " + (score.passed ? "passed" : "not passed") + " (" + score.mode +
                     "), " + std::to_string(score.points) + " points off, task " +
                     (score.task_completed ? "completed" : "not completed") + "\n";
  if (score.counts.empty()) return text + "no faults or warnings\n";
  for (const auto& [id, count] : score.counts) text += "  " + std::to_string(count) + " x " + rule_words(rules, id) + "\n";
  constexpr std::string_view kRepeated = "repeated:";
  for (const std::string& why : score.automatic_failures) {
    const bool repeated = why.rfind(kRepeated, 0) == 0;
    text += "  fails by itself: " + rule_words(rules, repeated ? why.substr(kRepeated.size()) : why) + (repeated ? " (repeated)" : "") + "\n";
  }
  return text;
}

}  // namespace forklift
