// The SQLite backend of the trainee store. Every SQL statement of the store lives in this file.
#include "forklift/store/store.h"

#include "common.h"

#include <sqlite3.h>
#include <sys/statvfs.h>

#include <cctype>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iterator>
#include <string_view>
#include <unordered_map>
#include <utility>

namespace forklift::store {

namespace {

using namespace detail;

// Schema migrations in order: entry i brings the schema to version i + 1. Append new ones;
// never edit one that has shipped.
const char* const kMigrations[] = {
    R"sql(
CREATE TABLE schools (
  id INTEGER PRIMARY KEY,
  name TEXT NOT NULL CHECK (name <> '')
);
CREATE TABLE pupils (
  id INTEGER PRIMARY KEY,
  school_id INTEGER NOT NULL REFERENCES schools(id),
  name TEXT NOT NULL CHECK (name <> ''),
  email TEXT NOT NULL DEFAULT '',
  created_at TEXT NOT NULL
);
-- NOCASE so that list_pupils reads the school's pupils in display order straight from the index.
CREATE INDEX pupils_by_school_name ON pupils(school_id, name COLLATE NOCASE);
CREATE TABLE users (
  id INTEGER PRIMARY KEY,
  username TEXT NOT NULL UNIQUE CHECK (username <> ''),
  password_hash TEXT NOT NULL,
  role TEXT NOT NULL CHECK (role IN ('admin', 'instructor', 'examiner', 'pupil')),
  school_id INTEGER NOT NULL REFERENCES schools(id),
  pupil_id INTEGER REFERENCES pupils(id)
);
CREATE TABLE cabs (
  id TEXT PRIMARY KEY CHECK (id <> ''),
  school_id INTEGER NOT NULL REFERENCES schools(id),
  last_seen_at TEXT NOT NULL DEFAULT ''
);
-- cab_id is not a foreign key: a session may be booked on a cab that has not announced itself yet.
-- public_id is derived from id, so the two can never disagree.
CREATE TABLE sessions (
  id INTEGER PRIMARY KEY,
  public_id TEXT GENERATED ALWAYS AS (printf('s-%06d', id)) VIRTUAL UNIQUE,
  pupil_id INTEGER NOT NULL REFERENCES pupils(id),
  cab_id TEXT NOT NULL CHECK (cab_id <> ''),
  scenario TEXT NOT NULL CHECK (scenario <> ''),
  mode TEXT NOT NULL CHECK (mode IN ('training', 'exam')),
  state TEXT NOT NULL CHECK (state IN ('starting', 'waiting', 'running', 'ended', 'failed', 'aborted')),
  reason TEXT NOT NULL DEFAULT '',
  examiner_id INTEGER REFERENCES users(id),
  created_at TEXT NOT NULL,
  ended_at TEXT NOT NULL DEFAULT '',
  mark REAL,
  passed INTEGER
);
CREATE INDEX sessions_by_pupil ON sessions(pupil_id, created_at);
-- Open sessions are few: a restarted server finds them without reading the whole history.
CREATE INDEX sessions_open ON sessions(id) WHERE state NOT IN ('ended', 'failed', 'aborted');
CREATE TABLE events (
  session_id INTEGER NOT NULL REFERENCES sessions(id),
  seq INTEGER NOT NULL CHECK (seq >= 1),
  sim_time_s REAL NOT NULL,
  kind TEXT NOT NULL,
  worry_level INTEGER NOT NULL,
  x_m REAL NOT NULL,
  y_m REAL NOT NULL,
  details TEXT NOT NULL,
  PRIMARY KEY (session_id, seq)
);
-- The primary key indexes events by session. This partial index covers history()'s fault count,
-- so that it reads no event row; worry_level is a key column so that the planner picks it even
-- without statistics.
CREATE INDEX events_faults_by_session ON events(session_id, worry_level, kind) WHERE worry_level > 0;
CREATE TABLE scores (
  session_id INTEGER PRIMARY KEY REFERENCES sessions(id),
  mark REAL NOT NULL,
  passed INTEGER NOT NULL
);
CREATE TABLE score_counts (
  session_id INTEGER NOT NULL REFERENCES scores(session_id),
  kind TEXT NOT NULL,
  count INTEGER NOT NULL,
  PRIMARY KEY (session_id, kind)
);
CREATE TABLE exams (
  id INTEGER PRIMARY KEY,
  pupil_id INTEGER NOT NULL REFERENCES pupils(id),
  kind TEXT NOT NULL CHECK (kind IN ('theory', 'practical')),
  session_id INTEGER UNIQUE REFERENCES sessions(id),
  score REAL NOT NULL,
  passed INTEGER NOT NULL,
  examiner_id INTEGER REFERENCES users(id),
  taken_at TEXT NOT NULL,
  details TEXT NOT NULL DEFAULT ''
);
CREATE INDEX exams_by_pupil ON exams(pupil_id, taken_at);
CREATE TABLE licences (
  id INTEGER PRIMARY KEY,
  pupil_id INTEGER NOT NULL REFERENCES pupils(id),
  issued_at TEXT NOT NULL,
  reevaluation_due TEXT NOT NULL,
  issued_by TEXT NOT NULL CHECK (issued_by <> '')
);
CREATE INDEX licences_by_pupil ON licences(pupil_id, issued_at);
CREATE TABLE session_logs (
  session_id INTEGER NOT NULL REFERENCES sessions(id),
  name TEXT NOT NULL CHECK (name <> ''),
  body TEXT NOT NULL,
  PRIMARY KEY (session_id, name)
);
)sql",
    // 2: theory papers (the questions handed out and the seed they were drawn with) and each
    // session's downsampled truck path, for the web pages.
    R"sql(
CREATE TABLE theory_attempts (
  id INTEGER PRIMARY KEY,
  pupil_id INTEGER NOT NULL REFERENCES pupils(id),
  seed INTEGER NOT NULL,
  questions TEXT NOT NULL,
  started_at TEXT NOT NULL,
  started_by INTEGER REFERENCES users(id),
  exam_id INTEGER UNIQUE REFERENCES exams(id)
);
CREATE INDEX theory_attempts_by_pupil ON theory_attempts(pupil_id, started_at);
-- WITHOUT ROWID: the rows are read back only by session, in time order, straight from the key.
CREATE TABLE path_points (
  session_id INTEGER NOT NULL REFERENCES sessions(id),
  sim_time_s REAL NOT NULL,
  x_m REAL NOT NULL,
  y_m REAL NOT NULL,
  yaw_rad REAL NOT NULL,
  speed_m_s REAL NOT NULL,
  lift_m REAL NOT NULL,
  PRIMARY KEY (session_id, sim_time_s)
) WITHOUT ROWID;
)sql",
    // 3: the audit log of changes to pupils' records (remote licence exams must be traceable).
    // Append-only: the triggers refuse any UPDATE or DELETE, from this program or any other.
    R"sql(
CREATE TABLE audit_log (
  id INTEGER PRIMARY KEY,
  at TEXT NOT NULL,
  actor_user_id INTEGER REFERENCES users(id),
  actor TEXT NOT NULL CHECK (actor <> ''),
  pupil_id INTEGER NOT NULL REFERENCES pupils(id),
  action TEXT NOT NULL CHECK (action <> ''),
  details TEXT NOT NULL CHECK (json_valid(details) AND json_type(details) = 'object')
);
CREATE INDEX audit_log_by_pupil ON audit_log(pupil_id, id);
CREATE TRIGGER audit_log_no_update BEFORE UPDATE ON audit_log
BEGIN
  SELECT RAISE(ABORT, 'audit_log is append-only');
END;
CREATE TRIGGER audit_log_no_delete BEFORE DELETE ON audit_log
BEGIN
  SELECT RAISE(ABORT, 'audit_log is append-only');
END;
)sql",
    // 4: the hash chain of practical exams (server/src/exam_evidence.cc): one entry per exam, in
    // order, each naming the previous one's hash. Append-only like the audit log; the entries
    // themselves make any edit made around the triggers detectable (forklift-menu verify).
    R"sql(
CREATE TABLE exam_chain (
  seq INTEGER PRIMARY KEY CHECK (seq >= 1),
  session_id INTEGER NOT NULL UNIQUE REFERENCES sessions(id),
  entry TEXT NOT NULL CHECK (json_valid(entry))
);
CREATE TRIGGER exam_chain_no_update BEFORE UPDATE ON exam_chain
BEGIN
  SELECT RAISE(ABORT, 'exam_chain is append-only');
END;
CREATE TRIGGER exam_chain_no_delete BEFORE DELETE ON exam_chain
BEGIN
  SELECT RAISE(ABORT, 'exam_chain is append-only');
END;
)sql",
    // 5: theory papers that stand up: supervised exams apart from self-service practice, a
    // deadline and how each paper ended (practice keeps its marking here: it has no exam record),
    // and instructors' unlocks of further attempts. Papers marked before this are "marked" exams.
    R"sql(
ALTER TABLE theory_attempts ADD COLUMN kind TEXT NOT NULL DEFAULT 'exam' CHECK (kind IN ('exam', 'practice'));
ALTER TABLE theory_attempts ADD COLUMN deadline TEXT NOT NULL DEFAULT '';
ALTER TABLE theory_attempts ADD COLUMN finished_at TEXT NOT NULL DEFAULT '';
ALTER TABLE theory_attempts ADD COLUMN outcome TEXT NOT NULL DEFAULT '' CHECK (outcome IN ('', 'marked', 'timed_out'));
ALTER TABLE theory_attempts ADD COLUMN result TEXT NOT NULL DEFAULT '';
UPDATE theory_attempts SET outcome = 'marked', finished_at = (SELECT taken_at FROM exams WHERE exams.id = exam_id)
  WHERE exam_id IS NOT NULL;
-- Open papers are few: the server finds those whose time is up without reading them all.
CREATE INDEX theory_attempts_open ON theory_attempts(id) WHERE finished_at = '';
CREATE TABLE theory_unlocks (
  id INTEGER PRIMARY KEY,
  pupil_id INTEGER NOT NULL REFERENCES pupils(id),
  unlocked_by INTEGER NOT NULL REFERENCES users(id),
  at TEXT NOT NULL,
  reason TEXT NOT NULL DEFAULT ''
);
CREATE INDEX theory_unlocks_by_pupil ON theory_unlocks(pupil_id, id);
CREATE TRIGGER theory_unlocks_no_update BEFORE UPDATE ON theory_unlocks
BEGIN
  SELECT RAISE(ABORT, 'theory_unlocks is append-only');
END;
CREATE TRIGGER theory_unlocks_no_delete BEFORE DELETE ON theory_unlocks
BEGIN
  SELECT RAISE(ABORT, 'theory_unlocks is append-only');
END;
)sql",
    // 6: exam records kept as written (issue 17, item 5): the triggers named kept_* refuse any
    // change to an exam record, to an exam session once it is over (but for its first score: a
    // score may follow an abort), to its score, events and logs (the server's note
    // 'chain_refused' excepted), and to a finished theory exam paper; a correction is a new,
    // append-only record. Certificates issued with licences and their revocations, append-only
    // (issue 17, item 4), and staff's full names, which certificates print.
    R"sql(
ALTER TABLE users ADD COLUMN full_name TEXT NOT NULL DEFAULT '';
CREATE TRIGGER kept_exams_no_update BEFORE UPDATE ON exams
BEGIN
  SELECT RAISE(ABORT, 'exam records are kept as written: a correction is a new record');
END;
CREATE TRIGGER kept_exams_no_delete BEFORE DELETE ON exams
BEGIN
  SELECT RAISE(ABORT, 'exam records are kept as written: a correction is a new record');
END;
CREATE TRIGGER kept_exam_sessions_no_update BEFORE UPDATE ON sessions
WHEN OLD.mode = 'exam' AND OLD.state IN ('ended', 'failed', 'aborted') AND NOT (
  NEW.id IS OLD.id AND NEW.pupil_id IS OLD.pupil_id AND NEW.cab_id IS OLD.cab_id AND NEW.scenario IS OLD.scenario
  AND NEW.mode IS OLD.mode AND NEW.state IS OLD.state AND NEW.reason IS OLD.reason AND NEW.examiner_id IS OLD.examiner_id
  AND NEW.created_at IS OLD.created_at AND NEW.ended_at IS OLD.ended_at
  AND ((OLD.mark IS NULL AND OLD.passed IS NULL) OR (NEW.mark IS OLD.mark AND NEW.passed IS OLD.passed)))
BEGIN
  SELECT RAISE(ABORT, 'an exam session that is over is kept as it ended');
END;
CREATE TRIGGER kept_exam_sessions_no_delete BEFORE DELETE ON sessions WHEN OLD.mode = 'exam'
BEGIN
  SELECT RAISE(ABORT, 'exam sessions are kept');
END;
CREATE TRIGGER kept_exam_scores_no_update BEFORE UPDATE ON scores
WHEN (SELECT mode FROM sessions WHERE id = OLD.session_id) = 'exam'
BEGIN
  SELECT RAISE(ABORT, 'an exam''s score is kept as written');
END;
CREATE TRIGGER kept_exam_scores_no_delete BEFORE DELETE ON scores
WHEN (SELECT mode FROM sessions WHERE id = OLD.session_id) = 'exam'
BEGIN
  SELECT RAISE(ABORT, 'an exam''s score is kept as written');
END;
CREATE TRIGGER kept_exam_score_counts_no_update BEFORE UPDATE ON score_counts
WHEN (SELECT mode FROM sessions WHERE id = OLD.session_id) = 'exam'
BEGIN
  SELECT RAISE(ABORT, 'an exam''s score is kept as written');
END;
CREATE TRIGGER kept_exam_score_counts_no_delete BEFORE DELETE ON score_counts
WHEN (SELECT mode FROM sessions WHERE id = OLD.session_id) = 'exam'
BEGIN
  SELECT RAISE(ABORT, 'an exam''s score is kept as written');
END;
CREATE TRIGGER kept_exam_events_no_update BEFORE UPDATE ON events
WHEN (SELECT mode FROM sessions WHERE id = OLD.session_id) = 'exam'
BEGIN
  SELECT RAISE(ABORT, 'an exam''s events are kept as written');
END;
CREATE TRIGGER kept_exam_events_no_delete BEFORE DELETE ON events
WHEN (SELECT mode FROM sessions WHERE id = OLD.session_id) = 'exam'
BEGIN
  SELECT RAISE(ABORT, 'an exam''s events are kept as written');
END;
CREATE TRIGGER kept_exam_logs_no_update BEFORE UPDATE ON session_logs
WHEN OLD.name <> 'chain_refused' AND NEW.body IS NOT OLD.body AND EXISTS (SELECT 1 FROM sessions
  WHERE id = OLD.session_id AND mode = 'exam' AND state IN ('ended', 'failed', 'aborted'))
BEGIN
  SELECT RAISE(ABORT, 'the logs of an exam that is over are kept as written');
END;
CREATE TRIGGER kept_exam_logs_no_delete BEFORE DELETE ON session_logs
WHEN OLD.name <> 'chain_refused' AND (SELECT mode FROM sessions WHERE id = OLD.session_id) = 'exam'
BEGIN
  SELECT RAISE(ABORT, 'the logs of an exam are kept');
END;
CREATE TRIGGER kept_theory_exam_papers_no_update BEFORE UPDATE ON theory_attempts WHEN OLD.exam_id IS NOT NULL
BEGIN
  SELECT RAISE(ABORT, 'a finished theory exam paper is kept as written');
END;
CREATE TRIGGER kept_theory_exam_papers_no_delete BEFORE DELETE ON theory_attempts WHEN OLD.exam_id IS NOT NULL
BEGIN
  SELECT RAISE(ABORT, 'a finished theory exam paper is kept as written');
END;
CREATE TABLE exam_corrections (
  id INTEGER PRIMARY KEY,
  exam_id INTEGER NOT NULL REFERENCES exams(id),
  corrected_by INTEGER NOT NULL REFERENCES users(id),
  at TEXT NOT NULL,
  reason TEXT NOT NULL CHECK (reason <> ''),
  correction TEXT NOT NULL CHECK (json_valid(correction) AND json_type(correction) = 'object')
);
CREATE INDEX exam_corrections_by_exam ON exam_corrections(exam_id, id);
CREATE TRIGGER exam_corrections_no_update BEFORE UPDATE ON exam_corrections
BEGIN
  SELECT RAISE(ABORT, 'exam_corrections is append-only');
END;
CREATE TRIGGER exam_corrections_no_delete BEFORE DELETE ON exam_corrections
BEGIN
  SELECT RAISE(ABORT, 'exam_corrections is append-only');
END;
CREATE TABLE certificates (
  id INTEGER PRIMARY KEY,
  number TEXT NOT NULL UNIQUE CHECK (number <> ''),
  pupil_id INTEGER NOT NULL REFERENCES pupils(id),
  licence_id INTEGER NOT NULL UNIQUE REFERENCES licences(id),
  issued_at TEXT NOT NULL,
  issued_by INTEGER REFERENCES users(id),
  record TEXT NOT NULL CHECK (json_valid(record)),
  signature TEXT NOT NULL CHECK (json_valid(signature))
);
CREATE INDEX certificates_by_pupil ON certificates(pupil_id, id);
CREATE TRIGGER certificates_no_update BEFORE UPDATE ON certificates
BEGIN
  SELECT RAISE(ABORT, 'certificates is append-only: revoke a certificate instead');
END;
CREATE TRIGGER certificates_no_delete BEFORE DELETE ON certificates
BEGIN
  SELECT RAISE(ABORT, 'certificates is append-only: revoke a certificate instead');
END;
CREATE TABLE certificate_revocations (
  id INTEGER PRIMARY KEY,
  certificate_id INTEGER NOT NULL UNIQUE REFERENCES certificates(id),
  revoked_by INTEGER NOT NULL REFERENCES users(id),
  at TEXT NOT NULL,
  reason TEXT NOT NULL CHECK (reason <> '')
);
CREATE TRIGGER certificate_revocations_no_update BEFORE UPDATE ON certificate_revocations
BEGIN
  SELECT RAISE(ABORT, 'certificate_revocations is append-only');
END;
CREATE TRIGGER certificate_revocations_no_delete BEFORE DELETE ON certificate_revocations
BEGIN
  SELECT RAISE(ABORT, 'certificate_revocations is append-only');
END;
)sql",
    // 7: staff administration (issue 18, item 2): accounts deactivated and their logins ended
    // (login_generation, raised by a password reset or a deactivation), listed by full name, and
    // the staff audit log of administrators' changes to accounts, append-only like the audit log.
    R"sql(
ALTER TABLE users ADD COLUMN active INTEGER NOT NULL DEFAULT 1 CHECK (active IN (0, 1));
ALTER TABLE users ADD COLUMN login_generation INTEGER NOT NULL DEFAULT 0;
CREATE INDEX users_by_school_name ON users(school_id, full_name COLLATE NOCASE);
CREATE TABLE staff_audit_log (
  id INTEGER PRIMARY KEY,
  at TEXT NOT NULL,
  actor_user_id INTEGER REFERENCES users(id),
  actor TEXT NOT NULL CHECK (actor <> ''),
  user_id INTEGER NOT NULL REFERENCES users(id),
  action TEXT NOT NULL CHECK (action <> ''),
  details TEXT NOT NULL CHECK (json_valid(details) AND json_type(details) = 'object')
);
CREATE INDEX staff_audit_log_by_user ON staff_audit_log(user_id, id);
CREATE TRIGGER staff_audit_log_no_update BEFORE UPDATE ON staff_audit_log
BEGIN
  SELECT RAISE(ABORT, 'staff_audit_log is append-only');
END;
CREATE TRIGGER staff_audit_log_no_delete BEFORE DELETE ON staff_audit_log
BEGIN
  SELECT RAISE(ABORT, 'staff_audit_log is append-only');
END;
)sql",
    // 8: lists a school works with, groups and bookings (issue 18, items 1 and 4): who started a
    // session; the indexes the lists filter and sort by; groups (courses) of pupils with their
    // instructor, a pupil in at most one; cabs booked for a session at a time.
    R"sql(
ALTER TABLE sessions ADD COLUMN started_by INTEGER REFERENCES users(id);
-- The pupil's school, kept with the session so that a list counts a school's sessions from one
-- index (joining every session to its pupil cost 40 ms for a day of 10,000).
ALTER TABLE sessions ADD COLUMN school_id INTEGER REFERENCES schools(id);
UPDATE sessions SET school_id = (SELECT school_id FROM pupils WHERE pupils.id = sessions.pupil_id);
CREATE INDEX sessions_by_school_time ON sessions(school_id, created_at);
CREATE INDEX sessions_by_time ON sessions(created_at);
CREATE INDEX sessions_by_cab ON sessions(cab_id, created_at);
CREATE INDEX sessions_by_starter ON sessions(started_by, created_at);
CREATE INDEX exams_by_time ON exams(taken_at);
CREATE INDEX pupils_by_school_email ON pupils(school_id, email COLLATE NOCASE);
CREATE TABLE pupil_groups (
  id INTEGER PRIMARY KEY,
  school_id INTEGER NOT NULL REFERENCES schools(id),
  name TEXT NOT NULL CHECK (name <> ''),
  instructor_id INTEGER REFERENCES users(id),
  created_at TEXT NOT NULL
);
CREATE UNIQUE INDEX pupil_groups_by_name ON pupil_groups(school_id, name COLLATE NOCASE);
CREATE INDEX pupil_groups_by_instructor ON pupil_groups(instructor_id);
ALTER TABLE pupils ADD COLUMN group_id INTEGER REFERENCES pupil_groups(id);
CREATE INDEX pupils_by_group ON pupils(group_id, name COLLATE NOCASE);
CREATE TABLE bookings (
  id INTEGER PRIMARY KEY,
  school_id INTEGER NOT NULL REFERENCES schools(id),
  pupil_id INTEGER NOT NULL REFERENCES pupils(id),
  cab_id TEXT NOT NULL CHECK (cab_id <> ''),
  starts_at TEXT NOT NULL,
  ends_at TEXT NOT NULL CHECK (ends_at > starts_at),
  scenario TEXT NOT NULL CHECK (scenario <> ''),
  mode TEXT NOT NULL CHECK (mode IN ('training', 'exam')),
  instructor_id INTEGER REFERENCES users(id),
  session_id INTEGER UNIQUE REFERENCES sessions(id),
  created_at TEXT NOT NULL
);
CREATE INDEX bookings_by_cab ON bookings(cab_id, starts_at);
CREATE INDEX bookings_by_school ON bookings(school_id, starts_at);
)sql",
    // 9: the debrief (issue 18, item 3): instructors' notes on a session and its sign-off, both
    // kept for ever like the audit log.
    R"sql(
CREATE TABLE session_notes (
  id INTEGER PRIMARY KEY,
  session_id INTEGER NOT NULL REFERENCES sessions(id),
  author_user_id INTEGER NOT NULL REFERENCES users(id),
  at TEXT NOT NULL,
  text TEXT NOT NULL CHECK (text <> '')
);
CREATE INDEX session_notes_by_session ON session_notes(session_id, id);
CREATE TRIGGER session_notes_no_update BEFORE UPDATE ON session_notes
BEGIN
  SELECT RAISE(ABORT, 'session_notes is append-only');
END;
CREATE TRIGGER session_notes_no_delete BEFORE DELETE ON session_notes
BEGIN
  SELECT RAISE(ABORT, 'session_notes is append-only');
END;
CREATE TABLE session_sign_offs (
  session_id INTEGER PRIMARY KEY REFERENCES sessions(id),
  signed_by INTEGER NOT NULL REFERENCES users(id),
  at TEXT NOT NULL,
  comment TEXT NOT NULL DEFAULT ''
);
CREATE TRIGGER session_sign_offs_no_update BEFORE UPDATE ON session_sign_offs
BEGIN
  SELECT RAISE(ABORT, 'session_sign_offs is append-only');
END;
CREATE TRIGGER session_sign_offs_no_delete BEFORE DELETE ON session_sign_offs
BEGIN
  SELECT RAISE(ABORT, 'session_sign_offs is append-only');
END;
)sql",
    // 10: the sessions whose score notes the task left unfinished, apart: reading a pupil's
    // sessions asks this of each one (SESSION_COLUMNS), and this index holds those alone.
    R"sql(
CREATE INDEX score_counts_task_incomplete ON score_counts(session_id, kind) WHERE kind = 'task_incomplete';
)sql",
    // 11: one open session per cab, kept by the store itself, so that two servers starting a
    // session on one cab at once cannot both succeed. A session left open beside a later one on
    // its cab (a database from before) is closed first, failed with the reason in words, and
    // audited as the server audits a failed session.
    R"sql(
INSERT INTO audit_log(at, actor_user_id, actor, pupil_id, action, details)
  SELECT strftime('%Y-%m-%dT%H:%M:%SZ', 'now'), NULL, 'server', s.pupil_id, 'session_failed',
         json_object('session', s.public_id, 'from', s.state, 'to', 'failed', 'reason', ')sql" ONE_OPEN_REASON R"sql(')
  FROM sessions s WHERE )sql" OPEN_BESIDE_A_LATER("s") R"sql(
  ORDER BY s.id;
UPDATE sessions SET state = 'failed', reason = ')sql" ONE_OPEN_REASON R"sql(',
    ended_at = strftime('%Y-%m-%dT%H:%M:%SZ', 'now')
  WHERE )sql" OPEN_BESIDE_A_LATER("sessions") R"sql(;
CREATE UNIQUE INDEX sessions_one_open_per_cab ON sessions(cab_id) WHERE state NOT IN ('ended', 'failed', 'aborted');
)sql",
    // 12: logins that hold on every server sharing the store, and across a restart: the bearer
    // tokens (their SHA-256 only: a copy of the database logs no one in), and the attempts and
    // lockouts that limit failed logins per username and per address.
    R"sql(
CREATE TABLE login_tokens (
  hash TEXT PRIMARY KEY CHECK (length(hash) = 64),
  user_id INTEGER NOT NULL REFERENCES users(id),
  generation INTEGER NOT NULL,
  expires_at_ms INTEGER NOT NULL
) WITHOUT ROWID;
CREATE INDEX login_tokens_by_expiry ON login_tokens(expires_at_ms);
CREATE TABLE login_attempts (
  id INTEGER PRIMARY KEY,
  key TEXT NOT NULL CHECK (key <> ''),
  at_ms INTEGER NOT NULL,
  pending INTEGER NOT NULL CHECK (pending IN (0, 1))
);
CREATE INDEX login_attempts_by_key ON login_attempts(key, at_ms);
CREATE INDEX login_attempts_by_time ON login_attempts(at_ms);
CREATE TABLE login_lockouts (
  key TEXT PRIMARY KEY CHECK (key <> ''),
  until_ms INTEGER NOT NULL
) WITHOUT ROWID;
)sql",
};

// Column lists shared by the statements that read whole rows (see read_user and the like).
#define USER_COLUMNS "id, username, password_hash, role, school_id, pupil_id, full_name, active, login_generation"
#define PUPIL_COLUMNS "pupils.id, pupils.school_id, pupils.name, pupils.email, pupils.created_at, pupils.group_id"
#define AUDIT_COLUMNS "id, at, actor_user_id, actor, pupil_id, action, details"
#define STAFF_AUDIT_COLUMNS "id, at, actor_user_id, actor, user_id, action, details"
#define THEORY_ATTEMPT_COLUMNS \
  "id, pupil_id, seed, questions, started_at, started_by, exam_id, kind, deadline, finished_at, outcome, result"
// Read FROM SESSIONS. The second column is NULL: read_session derives the public id from the id,
// as the schema does, without the schema's printf on every row. The one before last says whether
// the score notes the task left unfinished (the evaluator's rule "task_incomplete"), which
// session_outcome() needs: joined from the partial index of those sessions alone (migration 10;
// the planner would take the whole key's index). A correlated EXISTS per row made reading a
// pupil's 50 sessions 58 us; this join, 44 us, of which 2 us is the flag.
#define SESSION_COLUMNS                                                                                            \
  "sessions.id, NULL, sessions.pupil_id, sessions.cab_id, sessions.scenario, sessions.mode, "                       \
  "sessions.state, sessions.reason, sessions.examiner_id, sessions.created_at, sessions.ended_at, sessions.mark, "   \
  "sessions.passed, incomplete.session_id IS NOT NULL, sessions.started_by"
#define SESSIONS                                                                                  \
  "sessions LEFT JOIN score_counts incomplete INDEXED BY score_counts_task_incomplete "             \
  "ON incomplete.session_id = sessions.id AND incomplete.kind = 'task_incomplete'"
#define CERTIFICATE_COLUMNS "id, number, pupil_id, licence_id, issued_at, issued_by, record, signature"
#define EXAM_ROWS                                                                                           \
  "e.id, e.pupil_id, e.kind, s.public_id, e.score, e.passed, e.examiner_id, e.taken_at, e.details FROM exams e " \
  "LEFT JOIN sessions s ON s.id = e.session_id"
#define CORRECTION_COLUMNS "id, exam_id, corrected_by, at, reason, correction"
#define REVOCATION_COLUMNS "id, certificate_id, revoked_by, at, reason"
#define GROUP_COLUMNS \
  "g.id, g.school_id, g.name, g.instructor_id, g.created_at, (SELECT COUNT(*) FROM pupils p WHERE p.group_id = g.id)"
#define BOOKING_COLUMNS                                                                                          \
  "b.id, b.school_id, b.pupil_id, b.cab_id, b.starts_at, b.ends_at, b.scenario, b.mode, b.instructor_id, "       \
  "COALESCE(s.public_id, ''), b.created_at, p.name FROM bookings b JOIN pupils p ON p.id = b.pupil_id "          \
  "LEFT JOIN sessions s ON s.id = b.session_id"

// Why SQLite's primary result code `rc` says that the database cannot be written or read just
// now (StorageUnavailable), or null for any other failure.
const char* storage_reason(int rc) {
  switch (rc & 0xff) {
    case SQLITE_FULL: return kDiskFull;
    case SQLITE_READONLY:
    case SQLITE_PERM: return kReadOnly;
    case SQLITE_IOERR:
    case SQLITE_NOLFS: return kDiskFailed;
    case SQLITE_CANTOPEN: return kCannotOpen;
    default: return nullptr;
  }
}

// The last error on `db` as a StoreError of the contract's kind.
[[noreturn]] void throw_db_error(sqlite3* db, const char* op) {
  const std::string what = std::string(op) + ": " + sqlite3_errmsg(db);
  if (const char* reason = storage_reason(sqlite3_extended_errcode(db))) throw StorageUnavailable(what, reason);
  switch (sqlite3_extended_errcode(db)) {
    case SQLITE_CONSTRAINT_UNIQUE:
    case SQLITE_CONSTRAINT_PRIMARYKEY:
    case SQLITE_CONSTRAINT_TRIGGER: throw StoreError(StoreError::kConflict, what);  // a record kept as written
    case SQLITE_CONSTRAINT_FOREIGNKEY: throw StoreError(StoreError::kNotFound, what);
    case SQLITE_CONSTRAINT_CHECK:
    case SQLITE_CONSTRAINT_NOTNULL: throw StoreError(StoreError::kInvalid, what);
    default: throw StoreError(StoreError::kIo, what);
  }
}

void exec(sqlite3* db, const char* op, const char* sql) {
  if (sqlite3_exec(db, sql, nullptr, nullptr, nullptr) != SQLITE_OK) throw_db_error(db, op);
}

struct DbCloser {
  void operator()(sqlite3* db) const { sqlite3_close_v2(db); }
};
struct StmtFinalizer {
  void operator()(sqlite3_stmt* s) const { sqlite3_finalize(s); }
};

// One use of a prepared statement: binds parameters in order, steps, reads columns. Resets the
// statement when it goes out of scope, so that no read snapshot outlives the call.
class Query {
 public:
  Query(sqlite3* db, sqlite3_stmt* stmt, const char* op) : db_(db), stmt_(stmt), op_(op) {}
  ~Query() {
    sqlite3_reset(stmt_);
    sqlite3_clear_bindings(stmt_);
  }
  Query(const Query&) = delete;
  Query& operator=(const Query&) = delete;

  Query& bind(int v) { return bind(static_cast<int64_t>(v)); }  // also bool
  Query& bind(int64_t v) { return check(sqlite3_bind_int64(stmt_, ++param_, v)); }
  Query& bind(double v) { return check(sqlite3_bind_double(stmt_, ++param_, v)); }
  Query& bind(const std::string& v) {
    return check(sqlite3_bind_text(stmt_, ++param_, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
  }
  template <class T>
  Query& bind(const std::optional<T>& v) {
    return v ? bind(*v) : check(sqlite3_bind_null(stmt_, ++param_));
  }

  // True when a row is ready.
  bool step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc != SQLITE_DONE) throw_db_error(db_, op_);
    return false;
  }
  void run() {
    while (step()) {
    }
  }

  int64_t int64(int col) const { return sqlite3_column_int64(stmt_, col); }
  double real(int col) const { return sqlite3_column_double(stmt_, col); }
  std::string text(int col) const {
    const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(stmt_, col));
    return p ? std::string(p, static_cast<size_t>(sqlite3_column_bytes(stmt_, col))) : std::string();
  }
  bool is_null(int col) const { return sqlite3_column_type(stmt_, col) == SQLITE_NULL; }
  std::optional<int64_t> opt_int64(int col) const { return is_null(col) ? std::nullopt : std::optional(int64(col)); }
  std::optional<double> opt_real(int col) const { return is_null(col) ? std::nullopt : std::optional(real(col)); }

 private:
  Query& check(int rc) {
    if (rc != SQLITE_OK) throw_db_error(db_, op_);
    return *this;
  }

  sqlite3* db_;
  sqlite3_stmt* stmt_;
  const char* op_;
  int param_ = 0;
};

// A transaction rolled back unless committed. Writers BEGIN IMMEDIATE: they take the write lock
// up front (waiting on the busy timeout) rather than fail when upgrading a read.
// One atomic unit. Inside an open transaction (a batch) it becomes a savepoint, so a failed
// call inside a batch undoes only itself and the batch decides the rest.
class Transaction {
 public:
  enum Mode { kRead, kWrite };
  Transaction(sqlite3* db, const char* op, Mode mode) : db_(db), op_(op), nested_(!sqlite3_get_autocommit(db)) {
    exec(db_, op_, nested_ ? "SAVEPOINT op" : mode == kWrite ? "BEGIN IMMEDIATE" : "BEGIN");
  }
  ~Transaction() {
    if (!open_) return;
    sqlite3_exec(db_, nested_ ? "ROLLBACK TO op; RELEASE op" : "ROLLBACK", nullptr, nullptr, nullptr);
  }
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;

  void commit() {
    exec(db_, op_, nested_ ? "RELEASE op" : "COMMIT");
    open_ = false;
  }

 private:
  sqlite3* db_;
  const char* op_;
  bool nested_;
  bool open_ = true;
};

// Commits within this scope are synced to disk (an exam result must survive a power cut).
// synchronous cannot change inside a transaction, so this scope must enclose the transaction;
// inside a batch it does nothing and the batch's own commit decides.
class FullSync {
 public:
  FullSync(sqlite3* db, const char* op) : db_(db), active_(sqlite3_get_autocommit(db)) {
    if (active_) exec(db_, op, "PRAGMA synchronous=FULL");
  }
  ~FullSync() {
    if (active_) sqlite3_exec(db_, "PRAGMA synchronous=NORMAL", nullptr, nullptr, nullptr);
  }
  FullSync(const FullSync&) = delete;
  FullSync& operator=(const FullSync&) = delete;

 private:
  sqlite3* db_;
  bool active_;
};


// Before SQLite's first use in the process: no count of the memory it holds. The count takes one
// process-wide mutex on every allocation, which the server's HTTP threads, a connection each,
// then queue on (perf: 8 % of a history request's CPU in that mutex). Nothing reads the count.
void configure_sqlite_once() {
  static const bool configured = [] {
    // SQLITE_MISUSE if something in the process started SQLite already; the count stays then.
    sqlite3_config(SQLITE_CONFIG_MEMSTATUS, 0);
    return true;
  }();
  (void)configured;
}

// Below this much free space on the database's file system, storage_problem() calls it full.
constexpr uint64_t kLeastRoomBytes = 64 * 1024;

class SqliteStore final : public Store {
 public:
  explicit SqliteStore(const std::string& path) {
    configure_sqlite_once();
    sqlite3* db = nullptr;
    const int rc =
        sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX, nullptr);
    db_.reset(db);  // a failed open still allocates a handle to close
    if (rc != SQLITE_OK) {
      const std::string what = "open " + path + ": " + (db ? sqlite3_errmsg(db) : sqlite3_errstr(rc));
      if (const char* reason = storage_reason(rc)) throw StorageUnavailable(what, reason);
      throw StoreError(StoreError::kIo, what);
    }
    sqlite3_extended_result_codes(db, 1);
    // Set first: WAL needs a moment of exclusive access if another connection is opening too.
    sqlite3_busy_timeout(db, 5000);
    exec(db, "open", "PRAGMA journal_mode=WAL");
    exec(db, "open", "PRAGMA foreign_keys=ON");
    // In WAL mode NORMAL loses at most the last commits on power loss, never consistency.
    exec(db, "open", "PRAGMA synchronous=NORMAL");
    // Read pages through a memory map instead of one pread each: a history() on a large store
    // touches a few hundred scattered pages (10,000 pupils x 50 sessions x 20 events: 590 us per
    // call with pread, 270 with mmap).
    exec(db, "open", "PRAGMA mmap_size=1073741824");
    migrate();
  }

  int schema_version() override {
    Query q = query(__func__, "SELECT COALESCE(MAX(version), 0) FROM schema_migrations");
    q.step();
    return static_cast<int>(q.int64(0));
  }

  std::optional<std::string> storage_problem() override {
    const char* file = sqlite3_db_filename(db(), "main");
    struct statvfs fs {};
    if (file && *file && statvfs(std::filesystem::path(file).parent_path().c_str(), &fs) == 0) {
      if (fs.f_flag & ST_RDONLY) return kReadOnly;
      // Less room than a few pages' writes need: a commit would fail part-way (and be undone).
      if (static_cast<uint64_t>(fs.f_bavail) * fs.f_frsize < kLeastRoomBytes) return kDiskFull;
    }
    if (sqlite3_db_readonly(db(), "main") == 1) return kReadOnly;
    return std::nullopt;
  }

  void batch(const std::function<void()>& writes) override {
    require(sqlite3_get_autocommit(db()), StoreError::kInvalid, __func__, "batches do not nest");
    FullSync full_sync(db(), __func__);  // the batch may hold exam results
    Transaction tx(db(), __func__, Transaction::kWrite);
    writes();
    tx.commit();
  }

  int64_t create_school(const std::string& name) override {
    require(!name.empty(), StoreError::kInvalid, __func__, "empty school name");
    Query q = query(__func__, "INSERT INTO schools(name) VALUES (?)");
    q.bind(name).run();
    return sqlite3_last_insert_rowid(db());
  }

  int64_t create_user(const std::string& username, const std::string& password_hash, Role role, int64_t school_id,
                      std::optional<int64_t> pupil_id, const std::string& full_name) override {
    require(canonical_username(username) == username, StoreError::kInvalid, __func__,
            "username '" + username + "' is not of lower-case letters, digits, '.', '_' and '-' (1 to 64)");
    // NOCASE folds ASCII capitals only, as canonical_username() does.
    Query q = query(__func__,
                    "INSERT INTO users(username, password_hash, role, school_id, pupil_id, full_name) "
                    "SELECT ?1, ?2, ?3, ?4, ?5, ?6 WHERE NOT EXISTS (SELECT 1 FROM users WHERE username = ?1 COLLATE NOCASE)");
    q.bind(username).bind(password_hash).bind(std::string(role_name(role))).bind(school_id).bind(pupil_id).bind(full_name).run();
    require(sqlite3_changes(db()) > 0, StoreError::kConflict, __func__, "username '" + username + "' is taken");
    return sqlite3_last_insert_rowid(db());
  }

  void set_user_full_name(int64_t id, const std::string& full_name) override {
    query(__func__, "UPDATE users SET full_name = ? WHERE id = ?").bind(full_name).bind(id).run();
    require(sqlite3_changes(db()) > 0, StoreError::kNotFound, __func__, "no user " + std::to_string(id));
  }

  std::optional<School> get_school(int64_t id) override {
    Query q = query(__func__, "SELECT id, name FROM schools WHERE id = ?");
    q.bind(id);
    return q.step() ? std::optional(School{q.int64(0), q.text(1)}) : std::nullopt;
  }

  std::optional<User> find_user(const std::string& username) override {
    Query q = query(__func__,
                    "SELECT " USER_COLUMNS " FROM users WHERE username = ?1 COLLATE NOCASE ORDER BY username = ?1 DESC, id LIMIT 1");
    q.bind(username);
    return q.step() ? std::optional(read_user(q)) : std::nullopt;
  }

  std::optional<User> get_user(int64_t id) override {
    Query q = query(__func__, "SELECT " USER_COLUMNS " FROM users WHERE id = ?");
    q.bind(id);
    return q.step() ? std::optional(read_user(q)) : std::nullopt;
  }

  UserPage list_users(const UserFilter& f, int limit, int offset) override {
    require(limit >= 0 && offset >= 0, StoreError::kInvalid, __func__, "negative limit or offset");
    Transaction tx(db(), __func__, Transaction::kRead);
    // ?1 school, ?2 pupils too, ?3 role or NULL, ?4 active or NULL.
#define USERS_WHERE \
  " FROM users WHERE school_id = ?1 AND (?2 OR role <> 'pupil') AND (?3 IS NULL OR role = ?3) AND (?4 IS NULL OR active = ?4)"
    const auto bind_filter = [&](Query& q) {
      q.bind(f.school_id).bind(f.include_pupils);
      q.bind(f.role ? std::optional<std::string>(role_name(*f.role)) : std::nullopt).bind(f.active);
    };
    UserPage page;
    {
      Query q = query(__func__, "SELECT COUNT(*)" USERS_WHERE);
      bind_filter(q);
      q.step();
      page.total = q.int64(0);
    }
    Query q = query(__func__, "SELECT " USER_COLUMNS USERS_WHERE
                              " ORDER BY full_name = '', full_name COLLATE NOCASE, username, id LIMIT ?5 OFFSET ?6");
#undef USERS_WHERE
    bind_filter(q);
    q.bind(limit).bind(offset);
    while (q.step()) page.users.push_back(read_user(q));
    tx.commit();
    return page;
  }

  void set_user_password(int64_t id, const std::string& password_hash) override {
    query(__func__, "UPDATE users SET password_hash = ?, login_generation = login_generation + 1 WHERE id = ?")
        .bind(password_hash).bind(id).run();
    require(sqlite3_changes(db()) > 0, StoreError::kNotFound, __func__, "no user " + std::to_string(id));
  }

  bool set_user_active(int64_t id, bool active) override {
    Transaction tx(db(), __func__, Transaction::kWrite);
    const std::optional<User> u = get_user(id);
    require(u.has_value(), StoreError::kNotFound, __func__, "no user " + std::to_string(id));
    if (u->active == active) return false;
    if (!active && u->role == Role::kAdmin) {
      Query q = query(__func__, "SELECT COUNT(*) FROM users WHERE school_id = ? AND role = 'admin' AND active = 1 AND id <> ?");
      q.bind(u->school_id).bind(id).step();
      require(q.int64(0) > 0, StoreError::kConflict, __func__, "user " + std::to_string(id) + " is the school's last active admin");
    }
    query(__func__, "UPDATE users SET active = ?, login_generation = login_generation + ? WHERE id = ?")
        .bind(active).bind(active ? 0 : 1).bind(id).run();
    tx.commit();
    return true;
  }

  int64_t create_pupil(int64_t school_id, const std::string& name, const std::string& email) override {
    require(!name.empty(), StoreError::kInvalid, __func__, "empty pupil name");
    Query q = query(__func__, "INSERT INTO pupils(school_id, name, email, created_at) VALUES (?, ?, ?, ?)");
    q.bind(school_id).bind(name).bind(email).bind(now_iso8601()).run();
    return sqlite3_last_insert_rowid(db());
  }

  std::optional<Pupil> get_pupil(int64_t id) override { return pupil(__func__, id); }

  void update_pupil(int64_t id, const std::string& name, const std::string& email) override {
    require(!name.empty(), StoreError::kInvalid, __func__, "empty pupil name");
    query(__func__, "UPDATE pupils SET name = ?, email = ? WHERE id = ?").bind(name).bind(email).bind(id).run();
    require(sqlite3_changes(db()) > 0, StoreError::kNotFound, __func__, "no pupil " + std::to_string(id));
  }

  std::vector<Pupil> list_pupils(int64_t school_id, const std::string& search, int limit, int offset) override {
    require(limit >= 0 && offset >= 0, StoreError::kInvalid, __func__, "negative limit or offset");
    require_school(__func__, school_id);
    Query q = query(__func__, "SELECT " PUPIL_COLUMNS " FROM pupils WHERE school_id = ? AND name LIKE ? ESCAPE '\\' "
                              "ORDER BY name COLLATE NOCASE, id LIMIT ? OFFSET ?");
    q.bind(school_id).bind(contains_pattern(search)).bind(limit).bind(offset);
    std::vector<Pupil> pupils;
    while (q.step()) pupils.push_back(read_pupil(q));
    return pupils;
  }

  PupilPage find_pupils(const PupilFilter& f, int limit, int offset) override {
    check_page(__func__, limit, offset);
    const std::string order =
        order_by(__func__,
                 {{"name", "pupils.name COLLATE NOCASE"},
                  {"email", "pupils.email COLLATE NOCASE"},
                  {"created_at", "pupils.created_at"},
                  {"group", "COALESCE((SELECT g.name FROM pupil_groups g WHERE g.id = pupils.group_id), '') COLLATE NOCASE"}},
                 f.sort, f.descending, "pupils.id");
    Transaction tx(db(), __func__, Transaction::kRead);
    require_school(__func__, f.school_id);
    Conditions where;
    where.add("pupils.school_id = ?", {f.school_id});
    if (!f.search.empty()) {
      const std::string like = contains_pattern(f.search);
      where.add("(pupils.name LIKE ? ESCAPE '\\' OR pupils.email LIKE ? ESCAPE '\\')", {like, like});
    }
    if (f.group_id == 0) where.add("pupils.group_id IS NULL");
    else if (f.group_id) where.add("pupils.group_id = ?", {*f.group_id});
    if (f.instructor_id)
      where.add("pupils.group_id IN (SELECT id FROM pupil_groups WHERE instructor_id = ?)", {*f.instructor_id});
    PupilPage page;
    page.total = count(__func__, "SELECT COUNT(*) FROM pupils" + where.sql(), where);
    // An instructor's own pupils first: a first sort key ahead of the one asked for.
    std::string sql = "SELECT " PUPIL_COLUMNS " FROM pupils" + where.sql() + " ORDER BY ";
    Conditions bound = where;
    if (f.first_for) {
      sql += "EXISTS (SELECT 1 FROM pupil_groups g WHERE g.id = pupils.group_id AND g.instructor_id = ?) DESC, ";
      bound.add_value(*f.first_for);
    }
    sql += order;
    Query q = query(__func__, (sql + " LIMIT ? OFFSET ?").c_str());
    bound.bind(q);
    q.bind(limit).bind(offset);
    while (q.step()) page.pupils.push_back(read_pupil(q));
    tx.commit();
    return page;
  }

  SessionPage find_sessions(const SessionFilter& f, int limit, int offset) override {
    check_page(__func__, limit, offset);
    check_outcome_filter(__func__, f);
    const std::string order = order_by(__func__,
                                       {{"created_at", "sessions.created_at"},
                                        {"pupil", "p.name COLLATE NOCASE"},
                                        {"cab", "sessions.cab_id"},
                                        {"scenario", "sessions.scenario"},
                                        {"mode", "sessions.mode"},
                                        {"mark", "COALESCE(sessions.mark, -1)"}},
                                       f.sort, f.descending, "sessions.id");
    Conditions where;
    // A pupil's sessions are found by the pupil's index: "+" keeps the school's (a planner without
    // statistics took it, and read all 500,000 sessions of a school for one pupil's 50: 3.4 s).
    where.add(f.pupil_id ? "+sessions.school_id = ?" : "sessions.school_id = ?", {f.school_id});
    if (f.pupil_id) where.add("sessions.pupil_id = ?", {*f.pupil_id});
    if (!f.search.empty()) {
      const std::string like = contains_pattern(f.search);
      where.add("(p.name LIKE ? ESCAPE '\\' OR p.email LIKE ? ESCAPE '\\')", {like, like});
    }
    if (!f.from.empty()) where.add("sessions.created_at >= ?", {f.from});
    if (!f.to.empty()) where.add("sessions.created_at < ?", {f.to});
    if (!f.cab_id.empty()) where.add("sessions.cab_id = ?", {f.cab_id});
    if (!f.scenario.empty()) where.add("sessions.scenario = ?", {f.scenario});
    if (!f.mode.empty()) where.add("sessions.mode = ?", {f.mode});
    if (f.instructor_id) where.add("sessions.started_by = ?", {*f.instructor_id});
    if (f.group_id) where.add("p.group_id = ?", {*f.group_id});
    if (!f.outcome.empty()) where.add(SESSION_OUTCOME_SQL " = ?", {f.outcome});
    if (f.result == "passed") where.add(SESSION_OUTCOME_SQL " = 'completed' AND sessions.passed = 1");
    if (f.result == "not_passed")
      where.add("sessions.state IN ('ended', 'failed', 'aborted') AND NOT (" SESSION_OUTCOME_SQL
                " = 'completed' AND COALESCE(sessions.passed, 0) = 1)");
    const std::string from = " FROM sessions JOIN pupils p ON p.id = sessions.pupil_id" + where.sql();
    Transaction tx(db(), __func__, Transaction::kRead);
    SessionPage page;
    // Counted without the pupils unless a filter needs them.
    const bool by_pupil = !f.search.empty() || f.group_id;
    page.total = count(__func__, "SELECT COUNT(*)" + (by_pupil ? from : " FROM sessions" + where.sql()), where);
    // The page reads sessions first (CROSS JOIN fixes SQLite's join order): through the index of
    // their order or filter, it stops after a page; pupils first, it sorted every session of the
    // day (35 ms for a day of 10,000 sessions, 0.3 ms so). The count keeps the planner's order.
    Query q = query(__func__, ("SELECT " SESSION_COLUMNS ", p.name FROM " SESSIONS " CROSS JOIN pupils p ON p.id = sessions.pupil_id" +
                               where.sql() + " ORDER BY " + order + " LIMIT ? OFFSET ?")
                                  .c_str());
    where.bind(q);
    q.bind(limit).bind(offset);
    while (q.step()) page.sessions.push_back({read_session(q), q.text(15)});
    tx.commit();
    return page;
  }

  ExamPage find_exams(const ExamFilter& f, int limit, int offset) override {
    check_page(__func__, limit, offset);
    require(f.kind.empty() || f.kind == "theory" || f.kind == "practical", StoreError::kInvalid, __func__,
            "exam kind '" + f.kind + "' is neither theory nor practical");
    const std::string order = order_by(__func__,
                                       {{"taken_at", "e.taken_at"},
                                        {"pupil", "p.name COLLATE NOCASE"},
                                        {"kind", "e.kind"},
                                        {"score", "e.score"}},
                                       f.sort, f.descending, "e.id");
    Conditions where;
    where.add("p.school_id = ?", {f.school_id});
    if (f.pupil_id) where.add("e.pupil_id = ?", {*f.pupil_id});
    if (!f.search.empty()) {
      const std::string like = contains_pattern(f.search);
      where.add("(p.name LIKE ? ESCAPE '\\' OR p.email LIKE ? ESCAPE '\\')", {like, like});
    }
    if (!f.kind.empty()) where.add("e.kind = ?", {f.kind});
    if (!f.from.empty()) where.add("e.taken_at >= ?", {f.from});
    if (!f.to.empty()) where.add("e.taken_at < ?", {f.to});
    if (f.passed) where.add("e.passed = ?", {int64_t{*f.passed}});
    if (f.examiner_id) where.add("e.examiner_id = ?", {*f.examiner_id});
    if (f.group_id) where.add("p.group_id = ?", {*f.group_id});
    const std::string from =
        " FROM exams e JOIN pupils p ON p.id = e.pupil_id LEFT JOIN sessions s ON s.id = e.session_id" + where.sql();
    Transaction tx(db(), __func__, Transaction::kRead);
    ExamPage page;
    page.total = count(__func__, "SELECT COUNT(*)" + from, where);
    Query q = query(__func__, ("SELECT e.id, e.pupil_id, e.kind, s.public_id, e.score, e.passed, e.examiner_id, e.taken_at, "
                               "e.details, p.name, (SELECT COUNT(*) FROM exam_corrections c WHERE c.exam_id = e.id)" +
                               from + " ORDER BY " + order + " LIMIT ? OFFSET ?")
                                  .c_str());
    where.bind(q);
    q.bind(limit).bind(offset);
    while (q.step()) page.exams.push_back({read_exam(q), q.text(9), q.int64(10)});
    tx.commit();
    return page;
  }

  int64_t create_group(int64_t school_id, const std::string& name, std::optional<int64_t> instructor_id) override {
    require(!name.empty(), StoreError::kInvalid, __func__, "empty group name");
    Transaction tx(db(), __func__, Transaction::kWrite);
    require_school(__func__, school_id);
    check_instructor(__func__, school_id, instructor_id);
    query(__func__, "INSERT INTO pupil_groups(school_id, name, instructor_id, created_at) VALUES (?, ?, ?, ?)")
        .bind(school_id).bind(name).bind(instructor_id).bind(now_iso8601()).run();
    const int64_t id = sqlite3_last_insert_rowid(db());
    tx.commit();
    return id;
  }

  std::optional<Group> get_group(int64_t id) override {
    Query q = query(__func__, "SELECT " GROUP_COLUMNS " FROM pupil_groups g WHERE g.id = ?");
    q.bind(id);
    return q.step() ? std::optional(read_group(q)) : std::nullopt;
  }

  std::vector<Group> list_groups(int64_t school_id) override {
    Query q = query(__func__, "SELECT " GROUP_COLUMNS " FROM pupil_groups g WHERE g.school_id = ? ORDER BY g.name COLLATE NOCASE, g.id");
    q.bind(school_id);
    std::vector<Group> out;
    while (q.step()) out.push_back(read_group(q));
    return out;
  }

  void update_group(int64_t id, const std::string& name, std::optional<int64_t> instructor_id) override {
    require(!name.empty(), StoreError::kInvalid, __func__, "empty group name");
    Transaction tx(db(), __func__, Transaction::kWrite);
    const std::optional<Group> g = get_group(id);
    require(g.has_value(), StoreError::kNotFound, __func__, "no group " + std::to_string(id));
    check_instructor(__func__, g->school_id, instructor_id);
    query(__func__, "UPDATE pupil_groups SET name = ?, instructor_id = ? WHERE id = ?").bind(name).bind(instructor_id).bind(id).run();
    tx.commit();
  }

  void set_pupil_group(int64_t pupil_id, std::optional<int64_t> group_id) override {
    Transaction tx(db(), __func__, Transaction::kWrite);
    const std::optional<Pupil> p = pupil(__func__, pupil_id);
    require(p.has_value(), StoreError::kNotFound, __func__, "no pupil " + std::to_string(pupil_id));
    if (group_id) {
      const std::optional<Group> g = get_group(*group_id);
      require(g.has_value(), StoreError::kNotFound, __func__, "no group " + std::to_string(*group_id));
      require(g->school_id == p->school_id, StoreError::kInvalid, __func__, "group and pupil are of different schools");
    }
    query(__func__, "UPDATE pupils SET group_id = ? WHERE id = ?").bind(group_id).bind(pupil_id).run();
    tx.commit();
  }

  int64_t create_booking(const Booking& b) override {
    check_booking(__func__, b);
    Transaction tx(db(), __func__, Transaction::kWrite);  // the check and the insert under one write lock
    const std::optional<Pupil> p = pupil(__func__, b.pupil_id);
    require(p.has_value(), StoreError::kNotFound, __func__, "no pupil " + std::to_string(b.pupil_id));
    check_instructor(__func__, p->school_id, b.instructor_id);
    {
      Query q = query(__func__, "SELECT starts_at, ends_at FROM bookings WHERE cab_id = ? AND starts_at < ? AND ends_at > ? LIMIT 1");
      q.bind(b.cab_id).bind(b.ends_at).bind(b.starts_at);
      if (q.step())
        throw StoreError(StoreError::kConflict, std::string(__func__) + ": cab " + b.cab_id + " is booked from " + q.text(0) +
                                                    " to " + q.text(1));
    }
    query(__func__,
          "INSERT INTO bookings(school_id, pupil_id, cab_id, starts_at, ends_at, scenario, mode, instructor_id, created_at) "
          "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)")
        .bind(p->school_id).bind(b.pupil_id).bind(b.cab_id).bind(b.starts_at).bind(b.ends_at).bind(b.scenario).bind(b.mode)
        .bind(b.instructor_id).bind(now_iso8601()).run();
    const int64_t id = sqlite3_last_insert_rowid(db());
    tx.commit();
    return id;
  }

  std::optional<Booking> get_booking(int64_t id) override {
    Query q = query(__func__, "SELECT " BOOKING_COLUMNS " WHERE b.id = ?");
    q.bind(id);
    return q.step() ? std::optional(read_booking(q)) : std::nullopt;
  }

  std::vector<Booking> list_bookings(int64_t school_id, const std::string& from, const std::string& to) override {
    Query q = query(__func__, "SELECT " BOOKING_COLUMNS " WHERE b.school_id = ? AND b.starts_at < ? AND b.ends_at > ? "
                              "ORDER BY b.cab_id, b.starts_at, b.id");
    q.bind(school_id).bind(to).bind(from);
    std::vector<Booking> out;
    while (q.step()) out.push_back(read_booking(q));
    return out;
  }

  void set_booking_session(int64_t booking_id, const std::string& session_public_id) override {
    Transaction tx(db(), __func__, Transaction::kWrite);
    const std::optional<Booking> b = get_booking(booking_id);
    require(b.has_value(), StoreError::kNotFound, __func__, "no booking " + std::to_string(booking_id));
    require(b->session_public_id.empty(), StoreError::kConflict, __func__, "booking " + std::to_string(booking_id) + " has its session");
    query(__func__, "UPDATE bookings SET session_id = (SELECT id FROM sessions WHERE public_id = ?) WHERE id = ?")
        .bind(session_public_id).bind(booking_id).run();
    require(get_booking(booking_id)->session_public_id == session_public_id, StoreError::kNotFound, __func__,
            "no session '" + session_public_id + "'");
    tx.commit();
  }

  void delete_booking(int64_t booking_id) override {
    Transaction tx(db(), __func__, Transaction::kWrite);
    const std::optional<Booking> b = get_booking(booking_id);
    require(b.has_value(), StoreError::kNotFound, __func__, "no booking " + std::to_string(booking_id));
    require(b->session_public_id.empty(), StoreError::kConflict, __func__, "booking " + std::to_string(booking_id) + " has started");
    query(__func__, "DELETE FROM bookings WHERE id = ?").bind(booking_id).run();
    tx.commit();
  }

  void cab_seen(const std::string& cab_id, int64_t school_id, const std::string& now) override {
    require(!cab_id.empty(), StoreError::kInvalid, __func__, "empty cab id");
    // A known cab only refreshes last_seen_at; the same id announced by another school is a conflict.
    Query q = query(__func__,
                    "INSERT INTO cabs(id, school_id, last_seen_at) VALUES (?, ?, ?) "
                    "ON CONFLICT (id) DO UPDATE SET last_seen_at = excluded.last_seen_at "
                    "WHERE cabs.school_id = excluded.school_id");
    q.bind(cab_id).bind(school_id).bind(now).run();
    require(sqlite3_changes(db()) > 0, StoreError::kConflict, __func__, "cab " + cab_id + " belongs to another school");
  }

  std::vector<Cab> list_cabs(int64_t school_id) override {
    require_school(__func__, school_id);
    Query q = query(__func__, "SELECT id, school_id, last_seen_at FROM cabs WHERE school_id = ? ORDER BY id");
    q.bind(school_id);
    std::vector<Cab> cabs;
    while (q.step()) cabs.push_back(Cab{q.text(0), q.int64(1), q.text(2)});
    return cabs;
  }

  Session create_session(int64_t pupil_id, const std::string& cab_id, const std::string& scenario,
                         const std::string& mode, std::optional<int64_t> examiner_id, const std::string& now,
                         std::optional<int64_t> started_by) override {
    check_new_session(__func__, mode, cab_id, scenario);
    const std::optional<Pupil> of = pupil(__func__, pupil_id);
    require(of.has_value(), StoreError::kNotFound, __func__, "no pupil " + std::to_string(pupil_id));
    Query q = query(__func__,
                    "INSERT INTO sessions(pupil_id, cab_id, scenario, mode, state, examiner_id, created_at, started_by, school_id) "
                    "VALUES (?, ?, ?, ?, 'starting', ?, ?, ?, ?) RETURNING id, public_id");
    q.bind(pupil_id).bind(cab_id).bind(scenario).bind(mode).bind(examiner_id).bind(now).bind(started_by).bind(of->school_id);
    q.step();
    Session s;
    s.id = q.int64(0);
    s.public_id = q.text(1);
    q.run();  // the insert completes when RETURNING has no more rows
    s.pupil_id = pupil_id;
    s.cab_id = cab_id;
    s.scenario = scenario;
    s.mode = mode;
    s.state = "starting";
    s.examiner_id = examiner_id;
    s.created_at = now;
    s.started_by = started_by;
    return s;
  }

  std::optional<Session> get_session(const std::string& public_id) override {
    Query q = query(__func__, "SELECT " SESSION_COLUMNS " FROM " SESSIONS " WHERE public_id = ?");
    q.bind(public_id);
    return q.step() ? std::optional(read_session(q)) : std::nullopt;
  }

  std::vector<Session> list_sessions_for_pupil(int64_t pupil_id) override {
    require(pupil(__func__, pupil_id).has_value(), StoreError::kNotFound, __func__,
            "no pupil " + std::to_string(pupil_id));
    return sessions_of(__func__, pupil_id);
  }

  std::vector<Session> open_sessions() override {
    Query q = query(__func__, "SELECT " SESSION_COLUMNS " FROM " SESSIONS " "
                              "WHERE state NOT IN ('ended', 'failed', 'aborted') ORDER BY id");
    std::vector<Session> sessions;
    while (q.step()) sessions.push_back(read_session(q));
    return sessions;
  }

  bool set_session_state(const std::string& public_id, const std::string& state, const std::string& reason,
                         const std::string& now) override {
    require(is_state(state), StoreError::kInvalid, __func__, "unknown session state '" + state + "'");
    // One statement, so that two writers cannot both move a session out of an open state.
    Query q = query(__func__,
                    "UPDATE sessions SET state = ?, reason = ?, ended_at = ? "
                    "WHERE public_id = ? AND state NOT IN ('ended', 'failed', 'aborted')");
    q.bind(state).bind(reason).bind(is_terminal(state) ? now : std::string()).bind(public_id).run();
    if (sqlite3_changes(db()) > 0) return true;
    require_session(__func__, public_id);  // kNotFound rather than false for an unknown session
    return false;
  }

  bool add_event(const EventRecord& e) override {
    const int64_t session_id = require_session(__func__, e.session_public_id).id;
    Query q = query(__func__,
                    "INSERT INTO events(session_id, seq, sim_time_s, kind, worry_level, x_m, y_m, details) "
                    "VALUES (?, ?, ?, ?, ?, ?, ?, ?) ON CONFLICT (session_id, seq) DO NOTHING");
    q.bind(session_id).bind(e.seq).bind(e.sim_time_s).bind(e.kind).bind(e.worry_level).bind(e.x_m).bind(e.y_m);
    q.bind(e.details).run();
    return sqlite3_changes(db()) > 0;
  }

  std::vector<EventRecord> list_events(const std::string& session_public_id) override {
    const int64_t session_id = require_session(__func__, session_public_id).id;
    Query q = query(__func__,
                    "SELECT seq, sim_time_s, kind, worry_level, x_m, y_m, details FROM events "
                    "WHERE session_id = ? ORDER BY seq");
    q.bind(session_id);
    std::vector<EventRecord> events;
    while (q.step()) {
      events.push_back(EventRecord{session_public_id, q.int64(0), q.real(1), q.text(2),
                                   static_cast<int>(q.int64(3)), q.real(4), q.real(5), q.text(6)});
    }
    return events;
  }

  bool set_score(const ScoreRecord& s, const std::string& now) override {
    FullSync full_sync(db(), __func__);
    Transaction tx(db(), __func__, Transaction::kWrite);
    const Session session = require_session(__func__, s.session_public_id);
    {
      Query q = query(__func__,
                      "INSERT INTO scores(session_id, mark, passed) VALUES (?, ?, ?) "
                      "ON CONFLICT (session_id) DO NOTHING");
      q.bind(session.id).bind(s.mark).bind(s.passed).run();
      if (sqlite3_changes(db()) == 0) return false;  // the first score stands
    }
    for (const auto& [kind, count] : s.counts) {
      Query q = query(__func__, "INSERT INTO score_counts(session_id, kind, count) VALUES (?, ?, ?)");
      q.bind(session.id).bind(kind).bind(count).run();
    }
    query(__func__, "UPDATE sessions SET mark = ?, passed = ? WHERE id = ?")
        .bind(s.mark)
        .bind(s.passed)
        .bind(session.id)
        .run();
    if (session.mode == "exam") insert_exam(__func__, practical_exam(session, s, now), session.id);
    tx.commit();
    return true;
  }

  std::optional<ScoreRecord> get_score(const std::string& session_public_id) override {
    const std::optional<Session> session = get_session(session_public_id);
    if (!session) return std::nullopt;
    ScoreRecord score;
    {
      Query q = query(__func__, "SELECT mark, passed FROM scores WHERE session_id = ?");
      q.bind(session->id);
      if (!q.step()) return std::nullopt;
      score.session_public_id = session_public_id;
      score.mark = q.real(0);
      score.passed = q.int64(1) != 0;
    }
    // Written with the score in one transaction, so present whenever the score is.
    Query q = query(__func__, "SELECT kind, count FROM score_counts WHERE session_id = ?");
    q.bind(session->id);
    while (q.step()) score.counts[q.text(0)] = static_cast<int>(q.int64(1));
    return score;
  }

  int64_t add_exam(const ExamRecord& r) override {
    require(r.kind == "theory" || r.kind == "practical", StoreError::kInvalid, __func__,
            "exam kind '" + r.kind + "' is neither theory nor practical");
    FullSync full_sync(db(), __func__);
    Transaction tx(db(), __func__, Transaction::kWrite);
    std::optional<int64_t> session_id;
    if (r.session_public_id) {
      const Session session = require_session(__func__, *r.session_public_id);
      require(session.pupil_id == r.pupil_id, StoreError::kInvalid, __func__,
              "session " + session.public_id + " is not pupil " + std::to_string(r.pupil_id) + "'s");
      session_id = session.id;
    }
    const int64_t id = insert_exam(__func__, r, session_id);
    tx.commit();
    return id;
  }

  std::optional<ExamRecord> get_exam(int64_t id) override {
    Query q = query(__func__, "SELECT " EXAM_ROWS " WHERE e.id = ?");
    q.bind(id);
    return q.step() ? std::optional(read_exam(q)) : std::nullopt;
  }

  int64_t add_exam_correction(const ExamCorrection& c) override {
    check_new_correction(__func__, c);
    FullSync full_sync(db(), __func__);
    Query q = query(__func__,
                    "INSERT INTO exam_corrections(exam_id, corrected_by, at, reason, correction) VALUES (?, ?, ?, ?, ?)");
    q.bind(c.exam_id).bind(c.corrected_by).bind(c.at.empty() ? now_iso8601() : c.at).bind(c.reason).bind(c.correction).run();
    return sqlite3_last_insert_rowid(db());
  }

  std::vector<ExamCorrection> list_exam_corrections(int64_t exam_id) override {
    Query q = query(__func__, "SELECT " CORRECTION_COLUMNS " FROM exam_corrections WHERE exam_id = ? ORDER BY id");
    q.bind(exam_id);
    std::vector<ExamCorrection> out;
    while (q.step()) out.push_back(read_correction(q));
    return out;
  }

  int64_t create_theory_attempt(const TheoryAttempt& a) override {
    check_new_theory_attempt(__func__, a);
    Query q = query(__func__,
                    "INSERT INTO theory_attempts(pupil_id, seed, questions, started_at, started_by, kind, deadline) "
                    "VALUES (?, ?, ?, ?, ?, ?, ?)");
    q.bind(a.pupil_id).bind(a.seed).bind(a.questions).bind(a.started_at.empty() ? now_iso8601() : a.started_at);
    q.bind(a.started_by).bind(a.kind).bind(a.deadline).run();
    return sqlite3_last_insert_rowid(db());
  }

  std::optional<TheoryAttempt> get_theory_attempt(int64_t id) override {
    Query q = query(__func__, "SELECT " THEORY_ATTEMPT_COLUMNS " FROM theory_attempts WHERE id = ?");
    q.bind(id);
    if (!q.step()) return std::nullopt;
    return read_theory_attempt(q);
  }

  int64_t finish_theory_attempt(int64_t attempt_id, const ExamRecord& r, const std::string& outcome) override {
    check_theory_outcome(__func__, outcome);
    FullSync full_sync(db(), __func__);
    Transaction tx(db(), __func__, Transaction::kWrite);
    const std::optional<TheoryAttempt> a = get_theory_attempt(attempt_id);
    check_theory_finish(__func__, attempt_id, a, r);
    ExamRecord record = r;
    if (record.taken_at.empty()) record.taken_at = now_iso8601();
    const int64_t exam = insert_exam(__func__, record, std::nullopt);
    // The guard repeats the check above in the statement itself, so that two connections cannot
    // both finish one attempt.
    query(__func__,
          "UPDATE theory_attempts SET exam_id = ?, outcome = ?, finished_at = ? "
          "WHERE id = ? AND exam_id IS NULL AND finished_at = ''")
        .bind(exam)
        .bind(outcome)
        .bind(record.taken_at)
        .bind(attempt_id)
        .run();
    require(sqlite3_changes(db()) > 0, StoreError::kConflict, __func__,
            "attempt " + std::to_string(attempt_id) + " was already finished");
    tx.commit();
    return exam;
  }

  void finish_practice_attempt(int64_t attempt_id, const std::string& outcome, const std::string& result,
                               const std::string& finished_at) override {
    check_theory_outcome(__func__, outcome);
    Transaction tx(db(), __func__, Transaction::kWrite);
    const std::optional<TheoryAttempt> a = get_theory_attempt(attempt_id);
    check_practice_finish(__func__, attempt_id, a);
    query(__func__, "UPDATE theory_attempts SET outcome = ?, result = ?, finished_at = ? WHERE id = ? AND finished_at = ''")
        .bind(outcome)
        .bind(result)
        .bind(finished_at.empty() ? now_iso8601() : finished_at)
        .bind(attempt_id)
        .run();
    require(sqlite3_changes(db()) > 0, StoreError::kConflict, __func__,
            "attempt " + std::to_string(attempt_id) + " was already finished");
    tx.commit();
  }

  std::vector<TheoryAttempt> list_theory_attempts(int64_t pupil_id) override {
    Query q = query(__func__, "SELECT " THEORY_ATTEMPT_COLUMNS " FROM theory_attempts WHERE pupil_id = ? ORDER BY id");
    q.bind(pupil_id);
    std::vector<TheoryAttempt> out;
    while (q.step()) out.push_back(read_theory_attempt(q));
    return out;
  }

  std::vector<TheoryAttempt> open_theory_attempts() override {
    // "finished_at = ''" spelled as in the partial index, so that the planner uses it.
    Query q = query(__func__, "SELECT " THEORY_ATTEMPT_COLUMNS " FROM theory_attempts "
                              "WHERE finished_at = '' AND deadline <> '' ORDER BY id");
    std::vector<TheoryAttempt> out;
    while (q.step()) out.push_back(read_theory_attempt(q));
    return out;
  }

  int64_t add_theory_unlock(const TheoryUnlock& u) override {
    Query q = query(__func__, "INSERT INTO theory_unlocks(pupil_id, unlocked_by, at, reason) VALUES (?, ?, ?, ?)");
    q.bind(u.pupil_id).bind(u.unlocked_by).bind(u.at.empty() ? now_iso8601() : u.at).bind(u.reason).run();
    return sqlite3_last_insert_rowid(db());
  }

  std::vector<TheoryUnlock> list_theory_unlocks(int64_t pupil_id) override {
    Query q = query(__func__, "SELECT id, pupil_id, unlocked_by, at, reason FROM theory_unlocks WHERE pupil_id = ? ORDER BY id");
    q.bind(pupil_id);
    std::vector<TheoryUnlock> out;
    while (q.step()) out.push_back({q.int64(0), q.int64(1), q.int64(2), q.text(3), q.text(4)});
    return out;
  }

  void add_path_points(const std::string& session_public_id, const std::vector<PathPoint>& points) override {
    if (points.empty()) return;
    Transaction tx(db(), __func__, Transaction::kWrite);  // one commit for the lot
    const int64_t session_id = require_session(__func__, session_public_id).id;
    for (const PathPoint& p : points) {
      Query q = query(__func__,
                      "INSERT INTO path_points(session_id, sim_time_s, x_m, y_m, yaw_rad, speed_m_s, lift_m) "
                      "VALUES (?, ?, ?, ?, ?, ?, ?) ON CONFLICT (session_id, sim_time_s) DO NOTHING");
      q.bind(session_id).bind(p.sim_time_s).bind(p.x_m).bind(p.y_m).bind(p.yaw_rad).bind(p.speed_m_s).bind(p.lift_m);
      q.run();
    }
    tx.commit();
  }

  std::vector<PathPoint> list_path(const std::string& session_public_id) override {
    const int64_t session_id = require_session(__func__, session_public_id).id;
    Query q = query(__func__,
                    "SELECT sim_time_s, x_m, y_m, yaw_rad, speed_m_s, lift_m FROM path_points "
                    "WHERE session_id = ? ORDER BY sim_time_s");
    q.bind(session_id);
    std::vector<PathPoint> points;
    while (q.step()) points.push_back(PathPoint{q.real(0), q.real(1), q.real(2), q.real(3), q.real(4), q.real(5)});
    return points;
  }

  int64_t add_licence(int64_t pupil_id, const std::string& issued_at, const std::string& issued_by) override {
    require(!issued_by.empty(), StoreError::kInvalid, __func__, "empty issued_by");
    // OSHA 1910.178(l)(4)(iii): an operator's performance is evaluated at least every three years.
    const std::string due = add_years_iso8601(issued_at, 3);
    Query q = query(__func__,
                    "INSERT INTO licences(pupil_id, issued_at, reevaluation_due, issued_by) VALUES (?, ?, ?, ?)");
    q.bind(pupil_id).bind(issued_at).bind(due).bind(issued_by).run();
    return sqlite3_last_insert_rowid(db());
  }

  int64_t add_certificate(const CertificateRecord& c) override {
    check_new_certificate(__func__, c);
    FullSync full_sync(db(), __func__);
    Transaction tx(db(), __func__, Transaction::kWrite);
    {
      Query q = query(__func__, "SELECT pupil_id FROM licences WHERE id = ?");
      q.bind(c.licence_id);
      check_certificate_licence(__func__, c, q.step() ? std::optional(q.int64(0)) : std::nullopt);
    }
    Query q = query(__func__,
                    "INSERT INTO certificates(number, pupil_id, licence_id, issued_at, issued_by, record, signature) "
                    "VALUES (?, ?, ?, ?, ?, ?, ?)");
    q.bind(c.number).bind(c.pupil_id).bind(c.licence_id).bind(c.issued_at.empty() ? now_iso8601() : c.issued_at);
    q.bind(c.issued_by).bind(c.record).bind(c.signature).run();
    const int64_t id = sqlite3_last_insert_rowid(db());
    tx.commit();
    return id;
  }

  std::optional<CertificateRecord> find_certificate(const std::string& number) override {
    Query q = query(__func__, "SELECT " CERTIFICATE_COLUMNS " FROM certificates WHERE number = ?");
    q.bind(number);
    return q.step() ? std::optional(read_certificate(q)) : std::nullopt;
  }

  std::vector<CertificateRecord> list_certificates(int64_t pupil_id) override {
    Query q = query(__func__, "SELECT " CERTIFICATE_COLUMNS " FROM certificates WHERE pupil_id = ? ORDER BY id");
    q.bind(pupil_id);
    std::vector<CertificateRecord> out;
    while (q.step()) out.push_back(read_certificate(q));
    return out;
  }

  int64_t revoke_certificate(const CertificateRevocation& r) override {
    check_new_revocation(__func__, r);
    FullSync full_sync(db(), __func__);
    Query q = query(__func__, "INSERT INTO certificate_revocations(certificate_id, revoked_by, at, reason) VALUES (?, ?, ?, ?)");
    q.bind(r.certificate_id).bind(r.revoked_by).bind(r.at.empty() ? now_iso8601() : r.at).bind(r.reason).run();
    return sqlite3_last_insert_rowid(db());
  }

  std::optional<CertificateRevocation> certificate_revocation(int64_t certificate_id) override {
    Query q = query(__func__, "SELECT " REVOCATION_COLUMNS " FROM certificate_revocations WHERE certificate_id = ?");
    q.bind(certificate_id);
    return q.step() ? std::optional(read_revocation(q)) : std::nullopt;
  }

  void put_session_log(const std::string& session_public_id, const std::string& name,
                       const std::string& text) override {
    require(!name.empty(), StoreError::kInvalid, __func__, "empty log name");
    const int64_t session_id = require_session(__func__, session_public_id).id;
    Query q = query(__func__,
                    "INSERT INTO session_logs(session_id, name, body) VALUES (?, ?, ?) "
                    "ON CONFLICT (session_id, name) DO UPDATE SET body = excluded.body "
                    "WHERE session_logs.body IS NOT excluded.body");  // the same again (a second server settling it) is no write
    q.bind(session_id).bind(name).bind(text).run();
  }

  std::optional<std::string> get_session_log(const std::string& session_public_id, const std::string& name) override {
    Query q = query(__func__,
                    "SELECT l.body FROM session_logs l JOIN sessions s ON s.id = l.session_id "
                    "WHERE s.public_id = ? AND l.name = ?");
    q.bind(session_public_id).bind(name);
    return q.step() ? std::optional(q.text(0)) : std::nullopt;
  }

  void append_chain_entry(const ChainEntry& e) override {
    const int64_t session_id = require_session(__func__, e.session_public_id).id;
    const auto last = last_chain_entry();
    check_chain_append(__func__, e, last, get_chain_entry(e.session_public_id).has_value());
    Query q = query(__func__, "INSERT INTO exam_chain(seq, session_id, entry) VALUES (?, ?, ?)");
    q.bind(e.seq).bind(session_id).bind(e.entry).run();
  }

  std::optional<ChainEntry> last_chain_entry() override {
    Query q = query(__func__, "SELECT c.seq, s.public_id, c.entry FROM exam_chain c "
                              "JOIN sessions s ON s.id = c.session_id ORDER BY c.seq DESC LIMIT 1");
    return one_chain_entry(q);
  }

  std::optional<ChainEntry> get_chain_entry(const std::string& session_public_id) override {
    Query q = query(__func__, "SELECT c.seq, s.public_id, c.entry FROM exam_chain c "
                              "JOIN sessions s ON s.id = c.session_id WHERE s.public_id = ?");
    q.bind(session_public_id);
    return one_chain_entry(q);
  }

  std::vector<std::string> unchained_signed_exams() override {
    Query q = query(__func__,
                    "SELECT s.public_id FROM sessions s JOIN session_logs l ON l.session_id = s.id AND l.name = 'signature' "
                    "LEFT JOIN exam_chain c ON c.session_id = s.id WHERE s.mode = 'exam' AND c.seq IS NULL ORDER BY s.id");
    std::vector<std::string> out;
    while (q.step()) out.push_back(q.text(0));
    return out;
  }

  static std::optional<ChainEntry> one_chain_entry(Query& q) {
    if (!q.step()) return std::nullopt;
    return ChainEntry{q.int64(0), q.text(1), q.text(2)};
  }

  std::vector<ChainEntry> list_chain() override {
    Query q = query(__func__, "SELECT c.seq, s.public_id, c.entry FROM exam_chain c JOIN sessions s ON s.id = c.session_id ORDER BY c.seq");
    std::vector<ChainEntry> out;
    while (q.step()) out.push_back({q.int64(0), q.text(1), q.text(2)});
    return out;
  }

  int64_t count_chain_entries() override {
    Query q = query(__func__, "SELECT COUNT(*) FROM exam_chain");
    q.step();
    return q.int64(0);
  }

  int64_t add_audit(const AuditRecord& r) override {
    check_new_audit(__func__, r.actor, r.action);
    Query q = query(__func__,
                    "INSERT INTO audit_log(at, actor_user_id, actor, pupil_id, action, details) VALUES (?, ?, ?, ?, ?, ?)");
    q.bind(r.at.empty() ? now_iso8601() : r.at).bind(r.actor.user_id).bind(r.actor.name).bind(r.pupil_id);
    q.bind(r.action).bind(r.details).run();
    return sqlite3_last_insert_rowid(db());
  }

  std::vector<AuditRecord> list_audit(const AuditScope& scope, int limit, int offset) override {
    require(limit >= 0 && offset >= 0, StoreError::kInvalid, __func__, "negative limit or offset");
    // One statement per scope, so that each reads its rows straight from an index.
    Query q = scope.pupil_id    ? query(__func__, "SELECT " AUDIT_COLUMNS " FROM audit_log WHERE pupil_id = ? "
                                                  "ORDER BY id DESC LIMIT ? OFFSET ?")
              : scope.school_id ? query(__func__, "SELECT " AUDIT_COLUMNS " FROM audit_log WHERE pupil_id IN "
                                                  "(SELECT id FROM pupils WHERE school_id = ?) ORDER BY id DESC LIMIT ? OFFSET ?")
                                : query(__func__, "SELECT " AUDIT_COLUMNS " FROM audit_log ORDER BY id DESC LIMIT ? OFFSET ?");
    if (scope.pupil_id || scope.school_id) q.bind(scope.pupil_id ? *scope.pupil_id : *scope.school_id);
    q.bind(limit).bind(offset);
    std::vector<AuditRecord> rows;
    while (q.step()) rows.push_back(read_audit(q));
    return rows;
  }

  int64_t add_staff_audit(const StaffAuditRecord& r) override {
    check_new_audit(__func__, r.actor, r.action);
    Query q = query(__func__,
                    "INSERT INTO staff_audit_log(at, actor_user_id, actor, user_id, action, details) VALUES (?, ?, ?, ?, ?, ?)");
    q.bind(r.at.empty() ? now_iso8601() : r.at).bind(r.actor.user_id).bind(r.actor.name).bind(r.user_id);
    q.bind(r.action).bind(r.details).run();
    return sqlite3_last_insert_rowid(db());
  }

  std::vector<StaffAuditRecord> list_staff_audit(int64_t school_id, std::optional<int64_t> user_id, int limit,
                                                 int offset) override {
    require(limit >= 0 && offset >= 0, StoreError::kInvalid, __func__, "negative limit or offset");
    Query q = query(__func__, "SELECT " STAFF_AUDIT_COLUMNS " FROM staff_audit_log WHERE user_id IN "
                              "(SELECT id FROM users WHERE school_id = ?1) AND (?2 IS NULL OR user_id = ?2) "
                              "ORDER BY id DESC LIMIT ?3 OFFSET ?4");
    q.bind(school_id).bind(user_id).bind(limit).bind(offset);
    std::vector<StaffAuditRecord> rows;
    while (q.step()) rows.push_back(read_staff_audit(q));
    return rows;
  }

  int64_t add_session_note(const SessionNote& n) override {
    require(!n.text.empty(), StoreError::kInvalid, __func__, "empty note");
    Transaction tx(db(), __func__, Transaction::kWrite);
    const int64_t session_id = require_session(__func__, n.session_public_id).id;
    Query signed_off = query(__func__, "SELECT 1 FROM session_sign_offs WHERE session_id = ?");
    require(!signed_off.bind(session_id).step(), StoreError::kConflict, __func__,
            "session " + n.session_public_id + " is signed off");
    Query q = query(__func__, "INSERT INTO session_notes(session_id, author_user_id, at, text) VALUES (?, ?, ?, ?)");
    q.bind(session_id).bind(n.author_id).bind(n.at.empty() ? now_iso8601() : n.at).bind(n.text).run();
    const int64_t id = sqlite3_last_insert_rowid(db());
    tx.commit();
    return id;
  }

  std::vector<SessionNote> list_session_notes(const std::string& session_public_id) override {
    Query q = query(__func__, "SELECT n.id, s.public_id, n.author_user_id, n.at, n.text FROM session_notes n "
                              "JOIN sessions s ON s.id = n.session_id WHERE s.public_id = ? ORDER BY n.id");
    q.bind(session_public_id);
    std::vector<SessionNote> rows;
    while (q.step()) rows.push_back(read_session_note(q));
    return rows;
  }

  bool sign_off_session(const SessionSignOff& s) override {
    Transaction tx(db(), __func__, Transaction::kWrite);
    const int64_t session_id = require_session(__func__, s.session_public_id).id;
    Query q = query(__func__, "INSERT INTO session_sign_offs(session_id, signed_by, at, comment) VALUES (?, ?, ?, ?) "
                              "ON CONFLICT (session_id) DO NOTHING");
    q.bind(session_id).bind(s.signed_by).bind(s.at.empty() ? now_iso8601() : s.at).bind(s.comment).run();
    const bool added = sqlite3_changes(db()) > 0;
    tx.commit();
    return added;
  }

  std::optional<SessionSignOff> get_session_sign_off(const std::string& session_public_id) override {
    Query q = query(__func__, "SELECT s.public_id, o.signed_by, o.at, o.comment FROM session_sign_offs o "
                              "JOIN sessions s ON s.id = o.session_id WHERE s.public_id = ?");
    q.bind(session_public_id);
    if (!q.step()) return std::nullopt;
    return read_session_sign_off(q);
  }

  bool set_score_audited(const ScoreRecord& s, const std::string& now, const Actor& actor) override {
    FullSync full_sync(db(), __func__);
    Transaction tx(db(), __func__, Transaction::kWrite);
    if (!set_score(s, now)) return false;
    const Session session = require_session(__func__, s.session_public_id);
    // The details from the rows just written, so that they say what was stored.
    Query q = query(__func__,
                    "INSERT INTO audit_log(at, actor_user_id, actor, pupil_id, action, details) "
                    "SELECT ?, ?, ?, s.pupil_id, 'session_scored', json_object('session', s.public_id, "
                    "'mode', s.mode, 'mark', sc.mark, 'passed', json(CASE WHEN sc.passed THEN 'true' ELSE 'false' END), "
                    "'counts', (SELECT json_group_object(kind, count) FROM score_counts WHERE session_id = s.id), "
                    "'exam_id', (SELECT id FROM exams WHERE session_id = s.id)) "
                    "FROM sessions s JOIN scores sc ON sc.session_id = s.id WHERE s.id = ?");
    q.bind(now).bind(actor.user_id).bind(actor.name).bind(session.id).run();
    tx.commit();
    return true;
  }

  bool set_session_state_audited(const std::string& public_id, const std::string& state, const std::string& reason,
                                 const std::string& now, const Actor& actor) override {
    Transaction tx(db(), __func__, Transaction::kWrite);
    const Session before = require_session(__func__, public_id);
    if (!set_session_state(public_id, state, reason, now)) return false;
    AuditRecord r = state_audit(before, state, now, actor);
    {
      Query q = query(__func__, "SELECT json_object('session', ?, 'from', ?, 'to', ?, 'reason', ?)");
      q.bind(public_id).bind(before.state).bind(state).bind(reason).step();
      r.details = q.text(0);
    }
    add_audit(r);
    tx.commit();
    return true;
  }

  void add_login_token(const LoginToken& t) override {
    check_token_hash(__func__, t.hash);
    query(__func__, "INSERT INTO login_tokens(hash, user_id, generation, expires_at_ms) VALUES (?, ?, ?, ?)")
        .bind(t.hash).bind(t.user_id).bind(t.login_generation).bind(t.expires_at_ms).run();
  }

  std::optional<LoginToken> find_login_token(const std::string& hash) override {
    Query q = query(__func__, "SELECT " USER_COLUMNS ", t.generation, t.expires_at_ms FROM login_tokens t "
                              "JOIN users ON users.id = t.user_id WHERE t.hash = ?");
    q.bind(hash);
    return q.step() ? std::optional(read_login_token(q, hash)) : std::nullopt;
  }

  bool delete_login_token(const std::string& hash) override {
    query(__func__, "DELETE FROM login_tokens WHERE hash = ?").bind(hash).run();
    return sqlite3_changes(db()) > 0;
  }

  int64_t forget_login_tokens(int64_t before_ms) override {
    query(__func__, "DELETE FROM login_tokens WHERE expires_at_ms < ?").bind(before_ms).run();
    return sqlite3_changes(db());
  }

  AttemptCount count_attempts(const std::string& key, int64_t since_ms) override {
    Query q = query(__func__,
                    "SELECT COUNT(*), COALESCE(SUM(pending), 0), COALESCE(MIN(at_ms), 0), "
                    "COALESCE((SELECT until_ms FROM login_lockouts WHERE key = ?1), 0) "
                    "FROM login_attempts WHERE key = ?1 AND at_ms >= ?2");
    q.bind(key).bind(since_ms).step();
    return AttemptCount{q.int64(0), q.int64(1), q.int64(2), q.int64(3)};
  }

  int64_t add_attempt(const std::string& key, int64_t at_ms) override {
    check_attempt_key(__func__, key);
    query(__func__, "INSERT INTO login_attempts(key, at_ms, pending) VALUES (?, ?, 1)").bind(key).bind(at_ms).run();
    return sqlite3_last_insert_rowid(db());
  }

  void end_attempt(int64_t id, bool failed, int64_t at_ms) override {
    if (failed) query(__func__, "UPDATE login_attempts SET pending = 0, at_ms = ? WHERE id = ?").bind(at_ms).bind(id).run();
    else query(__func__, "DELETE FROM login_attempts WHERE id = ?").bind(id).run();
  }

  void reset_attempts(const std::string& key, int64_t locked_until_ms) override {
    Transaction tx(db(), __func__, Transaction::kWrite);
    query(__func__, "DELETE FROM login_attempts WHERE key = ? AND pending = 0").bind(key).run();
    if (locked_until_ms > 0) {
      query(__func__, "INSERT INTO login_lockouts(key, until_ms) VALUES (?, ?) "
                      "ON CONFLICT (key) DO UPDATE SET until_ms = excluded.until_ms")
          .bind(key).bind(locked_until_ms).run();
    } else {
      query(__func__, "DELETE FROM login_lockouts WHERE key = ?").bind(key).run();
    }
    tx.commit();
  }

  void forget_attempts(int64_t before_ms) override {
    Transaction tx(db(), __func__, Transaction::kWrite);
    query(__func__, "DELETE FROM login_attempts WHERE at_ms < ?").bind(before_ms).run();
    query(__func__, "DELETE FROM login_lockouts WHERE until_ms < ?").bind(before_ms).run();
    tx.commit();
  }

  std::optional<PupilHistory> history(int64_t pupil_id, const std::string& now) override {
    Transaction tx(db(), __func__, Transaction::kRead);  // one consistent snapshot
    std::optional<Pupil> p = pupil(__func__, pupil_id);
    if (!p) return std::nullopt;
    PupilHistory h;
    h.pupil = std::move(*p);
    h.sessions = sessions_of(__func__, pupil_id);
    {
      Query q = query(__func__, "SELECT " EXAM_ROWS " WHERE e.pupil_id = ? ORDER BY e.taken_at, e.id");
      q.bind(pupil_id);
      while (q.step()) h.exams.push_back(read_exam(q));
    }
    {
      // "worry_level > 0" spelled as in the partial index, so that the planner uses it. Counted
      // here: SQLite's GROUP BY sorts the faults in a temporary tree first (28 us, 21 so).
      Query q = query(__func__,
                      "SELECT e.kind FROM sessions s JOIN events e ON e.session_id = s.id "
                      "WHERE s.pupil_id = ? AND e.worry_level > 0");
      q.bind(pupil_id);
      while (q.step()) ++h.faults_by_kind[q.text(0)];
    }
    {
      Query q = query(__func__,
                      "SELECT id, issued_at, reevaluation_due, issued_by FROM licences "
                      "WHERE pupil_id = ? ORDER BY issued_at DESC, id DESC LIMIT 1");
      q.bind(pupil_id);
      if (q.step()) h.licence = LicenceRecord{q.int64(0), pupil_id, q.text(1), q.text(2), q.text(3)};
    }
    {
      Query q = query(__func__, "SELECT " CORRECTION_COLUMNS " FROM exam_corrections "
                                "WHERE exam_id IN (SELECT id FROM exams WHERE pupil_id = ?) ORDER BY id");
      q.bind(pupil_id);
      while (q.step()) h.corrections.push_back(read_correction(q));
    }
    h.trend = mark_trend(h.sessions);
    h.reevaluation_overdue = h.licence && h.licence->reevaluation_due < now;  // same form: string order is time order
    tx.commit();
    return h;
  }

 private:
  sqlite3* db() const { return db_.get(); }

  // The cached prepared statement for `sql` (prepared once per connection), for one use.
  // A statement is used by one Query at a time: do not nest two uses of the same SQL.
  Query query(const char* op, const char* sql) {
    auto it = statements_.find(sql);
    if (it == statements_.end()) {
      sqlite3_stmt* stmt = nullptr;
      if (sqlite3_prepare_v3(db(), sql, -1, SQLITE_PREPARE_PERSISTENT, &stmt, nullptr) != SQLITE_OK) {
        throw_db_error(db(), op);
      }
      it = statements_.emplace(sql, std::unique_ptr<sqlite3_stmt, StmtFinalizer>(stmt)).first;
    }
    return Query(db(), it->second.get(), op);
  }

  // Applies each pending migration in its own transaction.
  void migrate() {
    exec(db(), "migrate",
         "CREATE TABLE IF NOT EXISTS schema_migrations (version INTEGER PRIMARY KEY, applied_at TEXT NOT NULL)");
    const int latest = static_cast<int>(std::size(kMigrations));
    if (schema_version() > latest) {
      throw StoreError(StoreError::kIo, "migrate: database schema version " + std::to_string(schema_version()) +
                                            " is newer than this program's " + std::to_string(latest));
    }
    for (int version = schema_version() + 1; version <= latest; ++version) {
      Transaction tx(db(), "migrate", Transaction::kWrite);
      if (schema_version() >= version) continue;  // another connection applied it meanwhile
      exec(db(), "migrate", kMigrations[version - 1]);
      query("migrate", "INSERT INTO schema_migrations(version, applied_at) VALUES (?, ?)")
          .bind(version)
          .bind(now_iso8601())
          .run();
      tx.commit();
    }
  }

  // The rows `sql` counts with `where`'s values.
  int64_t count(const char* op, const std::string& sql, const Conditions& where) {
    Query q = query(op, sql.c_str());
    where.bind(q);
    q.step();
    return q.int64(0);
  }

  // A group's or a booking's instructor, if any, is staff of its school.
  void check_instructor(const char* op, int64_t school_id, std::optional<int64_t> user_id) {
    if (!user_id) return;
    const std::optional<User> u = get_user(*user_id);
    require(u.has_value(), StoreError::kNotFound, op, "no user " + std::to_string(*user_id));
    require(u->school_id == school_id && u->role != Role::kPupil, StoreError::kInvalid, op,
            "user " + std::to_string(*user_id) + " is not staff of the school");
  }

  std::optional<Pupil> pupil(const char* op, int64_t id) {
    Query q = query(op, "SELECT " PUPIL_COLUMNS " FROM pupils WHERE id = ?");
    q.bind(id);
    return q.step() ? std::optional(read_pupil(q)) : std::nullopt;
  }

  void require_school(const char* op, int64_t school_id) {
    Query q = query(op, "SELECT 1 FROM schools WHERE id = ?");
    q.bind(school_id);
    require(q.step(), StoreError::kNotFound, op, "no school " + std::to_string(school_id));
  }

  // The session, or kNotFound.
  Session require_session(const char* op, const std::string& public_id) {
    Query q = query(op, "SELECT " SESSION_COLUMNS " FROM " SESSIONS " WHERE public_id = ?");
    q.bind(public_id);
    require(q.step(), StoreError::kNotFound, op, "no session '" + public_id + "'");
    return read_session(q);
  }

  std::vector<Session> sessions_of(const char* op, int64_t pupil_id) {
    Query q = query(op, "SELECT " SESSION_COLUMNS " FROM " SESSIONS " WHERE pupil_id = ? ORDER BY created_at, id");
    q.bind(pupil_id);
    std::vector<Session> sessions;
    while (q.step()) sessions.push_back(read_session(q));
    return sessions;
  }

  int64_t insert_exam(const char* op, const ExamRecord& r, std::optional<int64_t> session_id) {
    Query q = query(op,
                    "INSERT INTO exams(pupil_id, kind, session_id, score, passed, examiner_id, taken_at, details) "
                    "VALUES (?, ?, ?, ?, ?, ?, ?, ?)");
    q.bind(r.pupil_id).bind(r.kind).bind(session_id).bind(r.score).bind(r.passed).bind(r.examiner_id);
    q.bind(r.taken_at.empty() ? now_iso8601() : r.taken_at).bind(r.details).run();
    return sqlite3_last_insert_rowid(db());
  }

  // Declared before the statements so that they are finalized before the connection closes.
  std::unique_ptr<sqlite3, DbCloser> db_;
  std::unordered_map<std::string, std::unique_ptr<sqlite3_stmt, StmtFinalizer>> statements_;
};

}  // namespace

std::unique_ptr<Store> Store::open_sqlite(const std::string& path) { return std::make_unique<SqliteStore>(path); }

}  // namespace forklift::store
