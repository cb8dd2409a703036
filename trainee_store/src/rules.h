// The store's rules, in one place for both backends: which arguments a call refuses before it
// touches the database, and what the records mean (the practical exam record an exam's score
// makes, a licence's re-evaluation, a session's audit row, the marks' trend). The SQL that keeps
// them is sql_store.cc's; the rules that only the schema can keep across servers (the first score
// stands, an event is stored once, a session over never changes) are its unique keys and guarded
// updates, named where they are written.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "forklift/store/store.h"

namespace forklift::store::detail {

inline void require(bool ok, StoreError::Kind kind, const char* op, const std::string& what) {
  if (!ok) throw StoreError(kind, std::string(op) + ": " + what);
}

// The checks of a call's arguments that need no database, the same for every backend. Each
// throws StoreError naming `op`.
inline void check_new_session(const char* op, const std::string& cab_id, const std::string& scenario) {
  require(!cab_id.empty(), StoreError::kInvalid, op, "empty cab id");
  require(!scenario.empty(), StoreError::kInvalid, op, "empty scenario");
}

inline void check_new_theory_attempt(const char* op, const TheoryAttempt& a) {
  require(!a.exam_id && a.finished_at.empty() && !a.outcome && a.result.empty(), StoreError::kInvalid, op,
          "a new attempt is not finished yet");
  require(a.seed >= 0 && a.seed < (int64_t{1} << 53), StoreError::kInvalid, op, "seed out of [0, 2^53)");
  require(!a.questions.empty(), StoreError::kInvalid, op, "no questions");
}

// An exam paper `a` (as read, inside the transaction) finished with the record `r`.
inline void check_theory_finish(const char* op, int64_t attempt_id, const std::optional<TheoryAttempt>& a,
                                const ExamRecord& r) {
  require(a.has_value(), StoreError::kNotFound, op, "no theory attempt " + std::to_string(attempt_id));
  require(a->kind == PaperKind::kExam, StoreError::kInvalid, op,
          "attempt " + std::to_string(attempt_id) + " is a practice paper: it has no exam record");
  require(r.kind == ExamKind::kTheory && !r.session_public_id, StoreError::kInvalid, op,
          "a theory attempt is marked with a theory record without a session");
  require(r.pupil_id == a->pupil_id, StoreError::kInvalid, op,
          "attempt " + std::to_string(attempt_id) + " is not pupil " + std::to_string(r.pupil_id) + "'s");
  require(!a->exam_id && a->finished_at.empty(), StoreError::kConflict, op,
          "attempt " + std::to_string(attempt_id) + " was already finished");
}

// A practice paper `a` (as read, inside the transaction) about to be finished.
inline void check_practice_finish(const char* op, int64_t attempt_id, const std::optional<TheoryAttempt>& a) {
  require(a.has_value(), StoreError::kNotFound, op, "no theory attempt " + std::to_string(attempt_id));
  require(a->kind == PaperKind::kPractice, StoreError::kInvalid, op,
          "attempt " + std::to_string(attempt_id) + " is an exam paper: it is finished with its exam record");
}

// Entry `e` follows `last` (the chain's last entry) and its session `chained` is not chained yet.
inline void check_chain_append(const char* op, const ChainEntry& e, const std::optional<ChainEntry>& last, bool chained) {
  require(e.seq == (last ? last->seq + 1 : 1), StoreError::kConflict, op,
          "chain entry " + std::to_string(e.seq) + " does not follow the last one");
  require(!chained, StoreError::kConflict, op, "session " + e.session_public_id + " is already chained");
}

inline void check_token_hash(const char* op, const std::string& hash) {
  require(hash.size() == 64 && hash.find_first_not_of("0123456789abcdef") == std::string::npos, StoreError::kInvalid, op,
          "a token's hash is 64 lower-case hex digits");
}

inline void check_attempt_key(const char* op, const std::string& key) {
  require(!key.empty(), StoreError::kInvalid, op, "an attempt needs its key");
}

inline void check_new_correction(const char* op, const ExamCorrection& c) {
  require(!c.reason.empty(), StoreError::kInvalid, op, "a correction needs its reason");
}

inline void check_new_certificate(const char* op, const CertificateRecord& c) {
  require(!c.number.empty(), StoreError::kInvalid, op, "a certificate needs its number");
}

// The certificate's licence, whose pupil is `licence_pupil` (as read, inside the transaction),
// is its pupil's.
inline void check_certificate_licence(const char* op, const CertificateRecord& c, const std::optional<int64_t>& licence_pupil) {
  require(licence_pupil.has_value(), StoreError::kNotFound, op, "no licence " + std::to_string(c.licence_id));
  require(*licence_pupil == c.pupil_id, StoreError::kInvalid, op,
          "licence " + std::to_string(c.licence_id) + " is not pupil " + std::to_string(c.pupil_id) + "'s");
}

inline void check_new_revocation(const char* op, const CertificateRevocation& r) {
  require(!r.reason.empty(), StoreError::kInvalid, op, "a revocation needs its reason");
}

// The practical exam record an exam session's score makes.
inline ExamRecord practical_exam(const Session& session, const ScoreRecord& s, const std::string& now) {
  ExamRecord exam;
  exam.pupil_id = session.pupil_id;
  exam.kind = ExamKind::kPractical;
  exam.session_public_id = session.public_id;
  exam.score = s.mark;
  exam.passed = s.passed;
  exam.examiner_id = session.examiner_id;
  exam.taken_at = now;
  exam.details = s.exam_details;
  return exam;
}

// The audit row of a session's move from `before`'s state to `state`, but for its details.
inline AuditRecord state_audit(const Session& before, SessionPhase state, const std::string& now, const Actor& actor) {
  AuditRecord r;
  r.at = now;
  r.actor = actor;
  r.pupil_id = before.pupil_id;
  r.action = std::string("session_") + name(state);
  return r;
}

inline void check_page(const char* op, int limit, int offset) {
  require(limit >= 0 && offset >= 0, StoreError::kInvalid, op, "negative limit or offset");
}

inline void check_result_filter(const char* op, const SessionFilter& f) {
  require(f.result.empty() || f.result == "passed" || f.result == "not_passed", StoreError::kInvalid, op,
          "result '" + f.result + "' is neither passed nor not_passed");
}

inline void check_booking(const char* op, const Booking& b) {
  require(!b.cab_id.empty() && !b.scenario.empty(), StoreError::kInvalid, op, "a booking needs its cab and scenario");
  require(!b.starts_at.empty() && b.ends_at > b.starts_at, StoreError::kInvalid, op, "a booking ends after it starts");
}

// Least-squares slope of mark against the marked training sessions' index 0, 1, 2, ...: sessions
// without a mark (mark_of: aborted, timed out, failed...) are not attempts and do not count, and
// exams are results, shown apart.
inline std::optional<double> mark_trend(const std::vector<Session>& sessions) {
  std::vector<double> marks;
  for (const Session& s : sessions) {
    if (const auto m = mark_of(s); m && s.mode == Mode::kTraining) marks.push_back(*m);
  }
  if (marks.size() < 2) return std::nullopt;
  const double n = static_cast<double>(marks.size());
  const double x_mean = (n - 1) / 2;
  double y_mean = 0;
  for (double m : marks) y_mean += m / n;
  double sxy = 0, sxx = 0;
  for (size_t i = 0; i < marks.size(); ++i) {
    const double dx = static_cast<double>(i) - x_mean;
    sxy += dx * (marks[i] - y_mean);
    sxx += dx * dx;
  }
  return sxy / sxx;
}

inline void check_new_audit(const char* op, const Actor& actor, const std::string& action) {
  require(!actor.name.empty(), StoreError::kInvalid, op, "empty actor");
  require(!action.empty(), StoreError::kInvalid, op, "empty action");
}

// Whether a session's first score makes its practical exam record (an exam's does).
inline bool makes_practical_record(const Session& session) { return session.mode == Mode::kExam; }

// When a licence issued at `issued_at` is due its re-evaluation. OSHA 1910.178(l)(4)(iii): an
// operator's performance is evaluated at least every three years.
inline std::string reevaluation_due(const std::string& issued_at) { return add_years_iso8601(issued_at, 3); }

// A user `u` may be deactivated unless it is its school's last active admin (`other_active_admins`
// counted inside the transaction).
inline void check_deactivation(const char* op, const User& u, int64_t other_active_admins) {
  require(u.role != Role::kAdmin || other_active_admins > 0, StoreError::kConflict, op,
          "user " + std::to_string(u.id) + " is the school's last active admin");
}

inline void check_username(const char* op, const std::string& username) {
  require(canonical_username(username) == username, StoreError::kInvalid, op,
          "username '" + username + "' is not of lower-case letters, digits, '.', '_' and '-' (1 to 64)");
}

}  // namespace forklift::store::detail
