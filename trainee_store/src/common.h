// What the store's SQL and its drivers share: the reasons a database is unavailable, a list's
// conditions and order, and the reading of whole rows, so that SQLite and PostgreSQL refuse and
// return the same. `Row` is a query positioned on a row (sql_driver.h's Query), with int64, real,
// text, is_null, opt_int64 and opt_real of a column by index. The store's rules are rules.h's.
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
#include "rules.h"

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

// Migration 15's first fill of each school's totals (school_totals), the same in both dialects.
// Migration 17, the same on both backends: which server runs each open session (claim_sessions),
// and each server's last sign of life.
#define SERVERS_MIGRATION              \
  "ALTER TABLE sessions ADD COLUMN server_id TEXT; " \
  "CREATE TABLE servers (id TEXT PRIMARY KEY, seen_at TEXT NOT NULL);"

// Migration 18's first fill of each pupil's fault counts (pupil_fault_counts), the same in both
// dialects: the events with a worry level, by the pupil whose session they happened in.
#define PUPIL_FAULT_COUNTS_FILL                                                                   \
  "INSERT INTO pupil_fault_counts(pupil_id, kind, count) SELECT s.pupil_id, e.kind, COUNT(*) "   \
  "FROM events e JOIN sessions s ON s.id = e.session_id WHERE e.worry_level > 0 "               \
  "GROUP BY s.pupil_id, e.kind;"

#define SCHOOL_TOTALS_FILL                                                                              \
  "INSERT INTO school_totals(school_id, pupils, sessions, exams) SELECT id, "                           \
  "(SELECT COUNT(*) FROM pupils p WHERE p.school_id = schools.id), "                                    \
  "(SELECT COUNT(*) FROM sessions s WHERE s.school_id = schools.id), "                                  \
  "(SELECT COUNT(*) FROM exams e JOIN pupils p ON p.id = e.pupil_id WHERE p.school_id = schools.id) "   \
  "FROM schools;"

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

// 1 if the session's score (FROM sessions, unaliased) notes the task left unfinished, else NULL: a
// scalar subquery, looked up by its key for each row a list reads. As an EXISTS, PostgreSQL 15
// hashed every such score of the store for a page of 50 (10 ms at 100,000 sessions, growing with
// the store); a scalar subquery it never hashes.
#define TASK_INCOMPLETE_SQL \
  "(SELECT 1 FROM score_counts c WHERE c.session_id = sessions.id AND c.kind = 'task_incomplete')"

// Session::task_left_unfinished of a session (FROM sessions, unaliased), read from its stored
// outcome: a session whose time ran out ("duration") timed out exactly when its task was left.
#define TASK_LEFT_SQL "(sessions.outcome = 'timed_out' AND sessions.reason = 'duration')"

// The terms that a session "completed and passed" (the lists' result "passed") met before the
// outcome was stored (migration 16), of its own row, as migrations 13 and 15 index them. `s`
// prefixes each column ("sessions." or "").
#define SESSION_PASSED_TERMS(s) \
  s "state = 'ended' AND " s "passed = TRUE AND " s "reason IN ('task_complete', 'parked', 'duration')"
// A session completed and passed, of its stored outcome (migration 16): spelled the same in the
// lists and in the partial indexes, so that both planners match them to the indexes.
#define SESSION_COMPLETED_PASSED(s) s "outcome = 'completed' AND " s "passed = TRUE"
// The outcomes a session row may hold (the session vocabulary's Outcome words), for its CHECK.
#define SESSION_OUTCOMES "('open', 'completed', 'timed_out', 'aborted', 'stopped', 'failed')"
// Migration 16: each session's outcome kept on its row (back-filled by the store, from
// session_outcome(): sql_store.cc), the passed sessions' indexes on it, and the school's sessions
// by outcome in time order.
#define OUTCOME_STORED(id_key)                                                                                 \
  "ALTER TABLE sessions ADD COLUMN outcome TEXT NOT NULL DEFAULT 'open' CHECK (outcome IN " SESSION_OUTCOMES "); " \
  "DROP INDEX sessions_passed_by_cab; DROP INDEX sessions_passed_by_school; "                                  \
  "CREATE INDEX sessions_passed_by_cab ON sessions(cab_id, created_at" id_key ") WHERE " SESSION_COMPLETED_PASSED("") "; " \
  "CREATE INDEX sessions_passed_by_school ON sessions(school_id, created_at" id_key ") WHERE " SESSION_COMPLETED_PASSED("") "; " \
  "CREATE INDEX sessions_by_school_outcome ON sessions(school_id, outcome, created_at" id_key ");"
// The schema version whose migration is OUTCOME_STORED: the store back-fills the outcome after it.
constexpr int kOutcomeStoredVersion = 16;

// Keyset paging: the rows of a list after the cursor's, whose sort key `key` is `key_value` and
// whose id (`id_column`) is `id`, found in the index where an offset would walk past every row
// before them. Spelled out rather than as a row value, which SQLite does not take to its index:
// the key's range first (from the index), then its ties by id.
inline void add_after(Conditions& where, const std::string& key, const std::string& id_column, const std::string& key_value,
                      int64_t id, bool descending) {
  const char* from = descending ? " <= ?" : " >= ?";
  const char* past = descending ? " < ?" : " > ?";
  where.add(key + from + " AND (" + key + past + " OR " + id_column + past + ")", {key_value, key_value, id});
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

// A word of the session vocabulary as a row holds it. The schema's CHECK keeps it one of the
// names, so another word is a database this store did not write.
template <class E>
E stored(const std::string& word, const char* column) {
  if (const std::optional<E> e = parse<E>(word)) return *e;
  throw StoreError(StoreError::kIo, std::string("the database holds an unknown ") + column + " '" + word + "'");
}

template <class Row>
Session read_session(const Row& q) {
  Session s;
  s.id = q.int64(0);
  s.public_id = q.is_null(1) ? session_public_id(s.id) : q.text(1);  // NULL: SQLite's, derived here
  s.pupil_id = q.int64(2);
  s.cab_id = q.text(3);
  s.scenario = q.text(4);
  s.mode = stored<Mode>(q.text(5), "session mode");
  s.state = stored<SessionPhase>(q.text(6), "session state");
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
  a.kind = stored<PaperKind>(q.text(7), "theory paper kind");
  a.deadline = q.text(8);
  a.finished_at = q.text(9);
  if (const std::string outcome = q.text(10); !outcome.empty()) a.outcome = stored<PaperOutcome>(outcome, "theory paper outcome");
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

template <class Row>
ExamRecord read_exam(const Row& q) {
  ExamRecord r;
  r.id = q.int64(0);
  r.pupil_id = q.int64(1);
  r.kind = stored<ExamKind>(q.text(2), "exam kind");
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
                 stored<Mode>(q.text(7), "booking mode"), q.opt_int64(8), q.text(9), q.text(10), q.text(11)};
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
