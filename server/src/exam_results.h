// A pupil's exams as the school's records count them: each exam record, and each exam
// session that ended without one, with its outcome, its mark if it has one, whether it passed and
// why not, its evidence, its corrections, and whether it counts toward a licence. History, the
// licence and the certificate all read them from here.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "context.h"
#include "exam_evidence.h"
#include "outcome.h"

namespace forklift::server {

struct ExamResult {
  std::optional<store::ExamRecord> record;  // none: an exam session that ended with no score
  std::optional<store::Session> session;    // a practical exam's session
  ExamKind kind = ExamKind::kPractical;
  std::string taken_at;
  Outcome outcome = Outcome::kFailed;  // practical: the session's (store::session_outcome); theory: completed or timed out
  // Practical: the evaluator's mark of a completed exam (store::mark_of), else none; theory: the
  // fraction right.
  std::optional<double> mark;
  // Passed as the school counts it: the record passed, nothing stands against it (reasons), the
  // evidence holds (practical) and no correction withdrew it.
  bool passed = false;
  std::vector<Reason> reasons;              // why it did not pass; empty when it passed
  std::optional<ExamStanding> evidence;     // practical exams with a session
  nlohmann::json course;                    // practical: the exam course it was taken on, else null
  std::vector<store::ExamCorrection> corrections;  // oldest first
  // Passed, and for a practical exam taken on an exam course: it counts toward a licence and a
  // certificate may cite it. `not_counted` says why a pass does not.
  bool counts = false;
  std::string not_counted;
  nlohmann::json details;  // the record's details as stored (an object, or null)
};

// The pupil's exams, oldest first: records, and exam sessions over without one.
std::vector<ExamResult> exam_results(Context& ctx, const store::PupilHistory& h);

// What a correction changes: {"passed": bool} and/or {"score": number} and/or {"note": text}. A
// correction that says "passed": false withdraws a pass; one that says true makes no failed exam
// count (a pupil passes by sitting an exam again), and the page says so.
bool withdrawn(const ExamResult& r);

// A user's full name and username, for records that name people: {"id", "username", "name"}.
nlohmann::json person_json(store::Store& db, std::optional<int64_t> user_id);

// An exam as history gives it: its record's id (null for an exam session without one), kind,
// outcome, score (a practical exam's mark only when it completed), passed and why not, whether it
// counts toward a licence, the examiner, the evidence and the corrections beside it.
nlohmann::json exam_result_json(Context& ctx, const ExamResult& r);
nlohmann::json licence_json(const std::optional<store::LicenceRecord>& l);

}  // namespace forklift::server
