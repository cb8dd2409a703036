// What the store's backends share besides the interface: argument checks and the reading of
// whole rows, so that SQLite and PostgreSQL refuse and return the same. No SQL here but a
// session's outcome (SESSION_OUTCOME_SQL, the same text in both dialects): each backend's
// statements live in its own source. `Row` is a backend's query positioned on a row,
// with int64, real, text, is_null, opt_int64 and opt_real of a column by index.
#pragma once

#include <algorithm>
#include <charconv>
#include <iterator>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "forklift/store/store.h"

namespace forklift::store::detail {

// StorageUnavailable's reasons, the same words from either backend.
constexpr const char* kDiskFull = "the disk that holds the school's records is full: make room on it";
constexpr const char* kReadOnly = "the school's records are read-only just now: the database or its disk cannot be written";
constexpr const char* kDiskFailed = "the disk that holds the school's records could not be read or written";
constexpr const char* kCannotOpen = "the database file of the school's records cannot be opened";
constexpr const char* kCannotReach = "the database server of the school's records cannot be reached";
constexpr const char* kConnectionLost = "the connection to the database server of the school's records was lost";
constexpr const char* kServerBusy = "the database server of the school's records is out of resources or restarting";

// Migration 11's words, the same in both dialects: the reason it gives the sessions it closes
// (SQL text: no quote in it), and which those are, of `sessions` read as `alias`: left open beside
// a later session on their cab.
#define ONE_OPEN_REASON "closed by the upgrade that keeps one open session per cab: a later session was open on the same cab"
#define OPEN_BESIDE_A_LATER(alias)                                                                              \
  alias ".state NOT IN ('ended', 'failed', 'aborted') AND EXISTS (SELECT 1 FROM sessions later WHERE later.cab_id = " \
  alias ".cab_id AND later.id > " alias ".id AND later.state NOT IN ('ended', 'failed', 'aborted'))"

inline bool is_state(const std::string& state) {
  return state == "starting" || state == "waiting" || state == "running" || is_terminal(state);
}

inline bool is_theory_outcome(const std::string& outcome) { return outcome == "marked" || outcome == "timed_out"; }

inline void require(bool ok, StoreError::Kind kind, const char* op, const std::string& what) {
  if (!ok) throw StoreError(kind, std::string(op) + ": " + what);
}

// The checks of a call's arguments that need no database, the same for every backend. Each
// throws StoreError naming `op`.
inline void check_new_session(const char* op, const std::string& mode, const std::string& cab_id,
                              const std::string& scenario) {
  require(mode == "training" || mode == "exam", StoreError::kInvalid, op, "mode '" + mode + "' is neither training nor exam");
  require(!cab_id.empty(), StoreError::kInvalid, op, "empty cab id");
  require(!scenario.empty(), StoreError::kInvalid, op, "empty scenario");
}

inline void check_new_theory_attempt(const char* op, const TheoryAttempt& a) {
  require(!a.exam_id && a.finished_at.empty() && a.outcome.empty() && a.result.empty(), StoreError::kInvalid, op,
          "a new attempt is not finished yet");
  require(a.kind == "exam" || a.kind == "practice", StoreError::kInvalid, op,
          "attempt kind '" + a.kind + "' is neither exam nor practice");
  require(a.seed >= 0 && a.seed < (int64_t{1} << 53), StoreError::kInvalid, op, "seed out of [0, 2^53)");
  require(!a.questions.empty(), StoreError::kInvalid, op, "no questions");
}

inline void check_theory_outcome(const char* op, const std::string& outcome) {
  require(is_theory_outcome(outcome), StoreError::kInvalid, op, "outcome '" + outcome + "' is neither marked nor timed_out");
}

// An exam paper `a` (as read, inside the transaction) finished with the record `r`.
inline void check_theory_finish(const char* op, int64_t attempt_id, const std::optional<TheoryAttempt>& a,
                                const ExamRecord& r) {
  require(a.has_value(), StoreError::kNotFound, op, "no theory attempt " + std::to_string(attempt_id));
  require(a->kind == "exam", StoreError::kInvalid, op,
          "attempt " + std::to_string(attempt_id) + " is a practice paper: it has no exam record");
  require(r.kind == "theory" && !r.session_public_id, StoreError::kInvalid, op,
          "a theory attempt is marked with a theory record without a session");
  require(r.pupil_id == a->pupil_id, StoreError::kInvalid, op,
          "attempt " + std::to_string(attempt_id) + " is not pupil " + std::to_string(r.pupil_id) + "'s");
  require(!a->exam_id && a->finished_at.empty(), StoreError::kConflict, op,
          "attempt " + std::to_string(attempt_id) + " was already finished");
}

// A practice paper `a` (as read, inside the transaction) about to be finished.
inline void check_practice_finish(const char* op, int64_t attempt_id, const std::optional<TheoryAttempt>& a) {
  require(a.has_value(), StoreError::kNotFound, op, "no theory attempt " + std::to_string(attempt_id));
  require(a->kind == "practice", StoreError::kInvalid, op,
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
  exam.kind = "practical";
  exam.session_public_id = session.public_id;
  exam.score = s.mark;
  exam.passed = s.passed;
  exam.examiner_id = session.examiner_id;
  exam.taken_at = now;
  exam.details = s.exam_details;
  return exam;
}

// The audit row of a session's move from `before`'s state to `state`, but for its details.
inline AuditRecord state_audit(const Session& before, const std::string& state, const std::string& now, const Actor& actor) {
  AuditRecord r;
  r.at = now;
  r.actor = actor;
  r.pupil_id = before.pupil_id;
  r.action = "session_" + state;
  return r;
}

// The WHERE clause of a list (find_pupils and the like) as its filters add up: each condition in
// the backend's dialect with `?` for its values, bound in order.
class Conditions {
 public:
  using Value = std::variant<int64_t, std::string>;
  void add(const std::string& condition, std::vector<Value> values = {}) {
    sql_ += (sql_.empty() ? " WHERE " : " AND ") + condition;
    for (auto& v : values) values_.push_back(std::move(v));
  }
  // A value bound after the conditions' (for a parameter in the ORDER BY).
  void add_value(Value v) { values_.push_back(std::move(v)); }
  const std::string& sql() const { return sql_; }
  const std::vector<Value>& values() const { return values_; }
  template <class Q>
  void bind(Q& q) const {
    for (const Value& v : values_) std::visit([&](const auto& x) { q.bind(x); }, v);
  }

 private:
  std::string sql_;
  std::vector<Value> values_;
};

// The ORDER BY terms of the sort key a list was asked for, looked up in its allow-list of (key,
// expression), ties broken by `tie_breaker`; else kInvalid naming the keys it has.
inline std::string order_by(const char* op, const std::vector<std::pair<std::string, std::string>>& keys,
                            const std::string& key, bool descending, const std::string& tie_breaker) {
  std::string names;
  for (const auto& [name, expr] : keys) {
    if (name == key) {
      const char* dir = descending ? " DESC" : " ASC";
      return expr + dir + ", " + tie_breaker + dir;
    }
    names += (names.empty() ? "" : ", ") + name;
  }
  throw StoreError(StoreError::kInvalid, std::string(op) + ": cannot sort by '" + key + "' (" + names + ")");
}

inline void check_page(const char* op, int limit, int offset) {
  require(limit >= 0 && offset >= 0, StoreError::kInvalid, op, "negative limit or offset");
}

// A session's outcome in SQL, as session_outcome() says it (the same text in both dialects); the
// statement reads FROM sessions, unaliased.
#define SESSION_OUTCOME_SQL                                                                                            \
  "(CASE WHEN sessions.state NOT IN ('ended', 'failed', 'aborted') THEN 'open' "                                       \
  "WHEN sessions.state = 'aborted' THEN 'aborted' WHEN sessions.state = 'failed' THEN 'failed' "                       \
  "WHEN sessions.reason IN ('task_complete', 'parked') THEN 'completed' "                                              \
  "WHEN sessions.reason = 'duration' THEN CASE WHEN EXISTS (SELECT 1 FROM score_counts c WHERE c.session_id = "       \
  "sessions.id AND c.kind = 'task_incomplete') THEN 'timed_out' ELSE 'completed' END "                                 \
  "WHEN sessions.reason = 'time_limit' THEN 'timed_out' WHEN sessions.reason = 'aborted' THEN 'aborted' "             \
  "WHEN sessions.reason = 'signal' THEN 'stopped' ELSE 'failed' END)"

inline void check_outcome_filter(const char* op, const SessionFilter& f) {
  static const char* const kOutcomes[] = {"open", "completed", "timed_out", "aborted", "stopped", "failed"};
  require(f.outcome.empty() || std::find(std::begin(kOutcomes), std::end(kOutcomes), f.outcome) != std::end(kOutcomes),
          StoreError::kInvalid, op, "unknown outcome '" + f.outcome + "'");
  require(f.result.empty() || f.result == "passed" || f.result == "not_passed", StoreError::kInvalid, op,
          "result '" + f.result + "' is neither passed nor not_passed");
  require(f.mode.empty() || f.mode == "training" || f.mode == "exam", StoreError::kInvalid, op, "unknown mode '" + f.mode + "'");
}

inline void check_booking(const char* op, const Booking& b) {
  require(b.mode == "training" || b.mode == "exam", StoreError::kInvalid, op, "mode '" + b.mode + "' is neither training nor exam");
  require(!b.cab_id.empty() && !b.scenario.empty(), StoreError::kInvalid, op, "a booking needs its cab and scenario");
  require(!b.starts_at.empty() && b.ends_at > b.starts_at, StoreError::kInvalid, op, "a booking ends after it starts");
}

// LIKE pattern for "contains `text`", with '\' escaping so that % and _ in it match literally.
inline std::string contains_pattern(const std::string& text) {
  std::string p = "%";
  for (char c : text) {
    if (c == '%' || c == '_' || c == '\\') p += '\\';
    p += c;
  }
  return p + "%";
}

// Least-squares slope of mark against the marked training sessions' index 0, 1, 2, ...: sessions
// without a mark (mark_of: aborted, timed out, failed...) are not attempts and do not count, and
// exams are results, shown apart.
inline std::optional<double> mark_trend(const std::vector<Session>& sessions) {
  std::vector<double> marks;
  for (const Session& s : sessions) {
    if (const auto m = mark_of(s); m && s.mode == "training") marks.push_back(*m);
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

// Rows read in the column order of the backends' USER_COLUMNS, PUPIL_COLUMNS, SESSION_COLUMNS,
// THEORY_ATTEMPT_COLUMNS, AUDIT_COLUMNS, STAFF_AUDIT_COLUMNS, CERTIFICATE_COLUMNS, CORRECTION_COLUMNS,
// REVOCATION_COLUMNS and EXAM_ROWS.
template <class Row>
User read_user(const Row& q) {
  User u;
  u.id = q.int64(0);
  u.username = q.text(1);
  u.password_hash = q.text(2);
  const std::optional<Role> role = parse_role(q.text(3));
  if (!role) throw StoreError(StoreError::kIo, "user " + u.username + " has unknown role '" + q.text(3) + "'");
  u.role = *role;
  u.school_id = q.int64(4);
  u.pupil_id = q.opt_int64(5);
  u.full_name = q.text(6);
  u.active = q.int64(7) != 0;
  u.login_generation = q.int64(8);
  return u;
}

// A row of the backends' USER_COLUMNS followed by a token's generation and expiry.
template <class Row>
LoginToken read_login_token(const Row& q, const std::string& hash) {
  LoginToken t;
  t.user = read_user(q);
  t.hash = hash;
  t.user_id = t.user.id;
  t.login_generation = q.int64(9);
  t.expires_at_ms = q.int64(10);
  return t;
}

template <class Row>
Pupil read_pupil(const Row& q) {
  return Pupil{q.int64(0), q.int64(1), q.text(2), q.text(3), q.text(4), q.opt_int64(5)};
}

// A session's public id as both schemas derive it from its id: "s-" and six digits, more when
// the id needs them (SQLite's printf('s-%06d', id), PostgreSQL's lpad). SQLite's column is
// virtual, computed by printf on every read (6 of the 48 us of reading a pupil's 50 sessions);
// its reads take it from here instead (StoreTest.PublicIdsAreDerivedAsTheSchemaDerivesThem).
// Written out rather than snprintf'd: 15 ns against 46.
inline std::string session_public_id(int64_t id) {
  char digits[24];
  const char* end = std::to_chars(digits, digits + sizeof digits, id).ptr;
  const size_t n = static_cast<size_t>(end - digits);
  std::string text = "s-";
  if (n < 6) text.append(6 - n, '0');
  return text.append(digits, n);
}

template <class Row>
Session read_session(const Row& q) {
  Session s;
  s.id = q.int64(0);
  s.public_id = q.is_null(1) ? session_public_id(s.id) : q.text(1);  // NULL: SQLite's, derived here
  s.pupil_id = q.int64(2);
  s.cab_id = q.text(3);
  s.scenario = q.text(4);
  s.mode = q.text(5);
  s.state = q.text(6);
  s.reason = q.text(7);
  s.examiner_id = q.opt_int64(8);
  s.created_at = q.text(9);
  s.ended_at = q.text(10);
  s.mark = q.opt_real(11);
  if (!q.is_null(12)) s.passed = q.int64(12) != 0;
  s.task_left_unfinished = q.int64(13) != 0;
  s.started_by = q.opt_int64(14);
  return s;
}

template <class Row>
TheoryAttempt read_theory_attempt(const Row& q) {
  TheoryAttempt a;
  a.id = q.int64(0);
  a.pupil_id = q.int64(1);
  a.seed = q.int64(2);
  a.questions = q.text(3);
  a.started_at = q.text(4);
  a.started_by = q.opt_int64(5);
  a.exam_id = q.opt_int64(6);
  a.kind = q.text(7);
  a.deadline = q.text(8);
  a.finished_at = q.text(9);
  a.outcome = q.text(10);
  a.result = q.text(11);
  return a;
}

template <class Row>
AuditRecord read_audit(const Row& q) {
  return AuditRecord{q.int64(0), q.text(1), Actor{q.opt_int64(2), q.text(3)}, q.int64(4), q.text(5), q.text(6)};
}

template <class Row>
StaffAuditRecord read_staff_audit(const Row& q) {
  return StaffAuditRecord{q.int64(0), q.text(1), Actor{q.opt_int64(2), q.text(3)}, q.int64(4), q.text(5), q.text(6)};
}

template <class Row>
SessionNote read_session_note(const Row& q) {
  return SessionNote{q.int64(0), q.text(1), q.int64(2), q.text(3), q.text(4)};
}

template <class Row>
SessionSignOff read_session_sign_off(const Row& q) {
  return SessionSignOff{q.text(0), q.int64(1), q.text(2), q.text(3)};
}

inline void check_new_audit(const char* op, const Actor& actor, const std::string& action) {
  require(!actor.name.empty(), StoreError::kInvalid, op, "empty actor");
  require(!action.empty(), StoreError::kInvalid, op, "empty action");
}

template <class Row>
ExamRecord read_exam(const Row& q) {
  ExamRecord r;
  r.id = q.int64(0);
  r.pupil_id = q.int64(1);
  r.kind = q.text(2);
  if (!q.is_null(3)) r.session_public_id = q.text(3);
  r.score = q.real(4);
  r.passed = q.int64(5) != 0;
  r.examiner_id = q.opt_int64(6);
  r.taken_at = q.text(7);
  r.details = q.text(8);
  return r;
}

template <class Row>
Group read_group(const Row& q) {
  return Group{q.int64(0), q.int64(1), q.text(2), q.opt_int64(3), q.text(4), q.int64(5)};
}

template <class Row>
Booking read_booking(const Row& q) {
  return Booking{q.int64(0), q.int64(1), q.int64(2), q.text(3), q.text(4), q.text(5), q.text(6),
                 q.text(7), q.opt_int64(8), q.text(9), q.text(10), q.text(11)};
}

template <class Row>
CertificateRecord read_certificate(const Row& q) {
  return CertificateRecord{q.int64(0), q.text(1), q.int64(2), q.int64(3), q.text(4), q.opt_int64(5), q.text(6), q.text(7)};
}

template <class Row>
ExamCorrection read_correction(const Row& q) {
  return ExamCorrection{q.int64(0), q.int64(1), q.int64(2), q.text(3), q.text(4), q.text(5)};
}

template <class Row>
CertificateRevocation read_revocation(const Row& q) {
  return CertificateRevocation{q.int64(0), q.int64(1), q.int64(2), q.text(3), q.text(4)};
}

}  // namespace forklift::store::detail
