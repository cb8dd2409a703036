// What a result means: why a session or an exam did not pass, in the marking
// sheet's words, and what a practical exam's record keeps of it. A session's outcome and whether
// it has a mark are the store's one rule (forklift/store/store.h: session_outcome, mark_of); this
// adds the reasons, from the marking scheme in data/evaluation/rules.json.
#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "forklift/store/store.h"

namespace forklift::server {

// The marking scheme and the rules' words, as the evaluator reads them (data/evaluation/).
struct MarkingRules {
  struct Rule {
    std::string title;  // a few words for the pages ("Violent collision"); the id's words when the file has none
    std::string description;
    int worry_level = 0;
    bool automatic_fail = false;
  };
  std::map<std::string, Rule> rules;  // by id
  int fail_above_points = 40;
  int serious_worry_level = 5;
  int max_same_serious_fault = 3;
  double mark_start = 100;
};
// Throws std::runtime_error naming the file when it cannot be read.
MarkingRules load_marking_rules(const std::string& rules_json);

// One reason a result is not a pass: a code for programs, and words for the school.
struct Reason {
  std::string code;  // "aborted", "timed_out", "failed", "stopped", "automatic_failure", "repeated_serious_fault",
                     // "task_incomplete", "too_many_points", "not_passed", "evidence", "withdrawn", ...
  std::string text;
};
nlohmann::json reasons_json(const std::vector<Reason>& reasons);

// Why a session (an exam or a training run) did not pass: its outcome when it did not complete
// (with the session's reason), each automatic failure and serious fault repeated too often among
// `counts` (its score's faults by rule), the task left unfinished, the points over the limit.
// `points` is the score line's (else derived from the mark); `evaluator_passed` the score's.
// Empty for a completed session that passed.
std::vector<Reason> session_reasons(const MarkingRules& rules, const store::Session& s,
                                    const std::map<std::string, int>& counts, std::optional<int> points,
                                    std::optional<bool> evaluator_passed);

// The session as it stands once its score says how it ended: the store's session, or, while it
// is still open (the score comes before the worker's last status), ended with `end_reason`.
store::Session as_ended(store::Session s, const std::string& end_reason, const std::map<std::string, int>& counts);

// What a practical exam's record keeps beside its mark (store::ScoreRecord::exam_details), as it
// stood when the score came: how it ended ("outcome", "end_reason", "points") and why it did not
// pass ("reasons"); the pupil's and the examiner's names (a later edit of either changes no exam);
// the scenario and its exam course ("exam_course", null when it is none: such an exam is never
// cited by a certificate). JSON text.
std::string practical_exam_details(store::Store& db, const std::string& data_dir, const MarkingRules& rules,
                                   const std::string& session, const std::string& end_reason, std::optional<int> points,
                                   const std::map<std::string, int>& counts, bool passed);

}  // namespace forklift::server
