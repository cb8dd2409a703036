// The SQLite driver of the trainee store (sql_driver.h): one file, WAL, foreign keys, a busy
// timeout that lets several connections share it; SQLite's migrations and its dialect.
#include "forklift/store/store.h"

#include "common.h"
#include "sql_driver.h"

#include <sqlite3.h>
#include <sys/statvfs.h>

#include <chrono>
#include <filesystem>
#include <iterator>
#include <string_view>
#include <thread>
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
    // 6: exam records kept as written: the triggers named kept_* refuse any
    // change to an exam record, to an exam session once it is over (but for its first score: a
    // score may follow an abort), to its score, events and logs (the server's note
    // 'chain_refused' excepted), and to a finished theory exam paper; a correction is a new,
    // append-only record. Certificates issued with licences and their revocations, append-only,
    // and staff's full names, which certificates print.
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
    // 7: staff administration: accounts deactivated and their logins ended
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
    // 8: lists a school works with, groups and bookings: who started a
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
    // 9: the debrief: instructors' notes on a session and its sign-off, both
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
    // 13: the sessions that completed and passed, apart, by cab and by school in time order: the
    // lists filtered by that result read them alone (SESSION_PASSED_TERMS), where they worked
    // out the outcome of every session of the day (a cab's day of 10,000 sessions: 1.2 s).
    R"sql(
CREATE INDEX sessions_passed_by_cab ON sessions(cab_id, created_at) WHERE )sql" SESSION_PASSED_TERMS("") R"sql(;
CREATE INDEX sessions_passed_by_school ON sessions(school_id, created_at) WHERE )sql" SESSION_PASSED_TERMS("") R"sql(;
)sql",
    // 14: the language each person reads the pages and their words in (data/i18n/'s folder
    // names): staff on their account, pupils on their record (a pupil's login reads it there).
    R"sql(
ALTER TABLE users ADD COLUMN language TEXT NOT NULL DEFAULT 'en';
ALTER TABLE pupils ADD COLUMN language TEXT NOT NULL DEFAULT 'en';
)sql",
    // 15: each school's totals of pupils, sessions and exams, kept by triggers as rows come and
    // go, so that the whole school's lists show their total without counting 10 million rows
    // (1.2 s on SQLite, more on PostgreSQL).
    R"sql(
-- The passed sessions' indexes stay as 13 made them: with the reason in their keys (PostgreSQL's
-- 15) SQLite, planning without statistics, found them wider than the cab's index of every session
-- and read a cab's whole day for a page of its passed sessions (56 ms for 18,000 sessions).
-- The exams by kind and result in time order: counting a school's passed practical exams went
-- through every pupil's exams (56 ms at a million sessions).
CREATE INDEX exams_by_kind_result ON exams(kind, passed, taken_at);
CREATE TABLE school_totals (
  school_id INTEGER PRIMARY KEY REFERENCES schools(id),
  pupils INTEGER NOT NULL DEFAULT 0,
  sessions INTEGER NOT NULL DEFAULT 0,
  exams INTEGER NOT NULL DEFAULT 0
);
)sql" SCHOOL_TOTALS_FILL R"sql(
CREATE TRIGGER school_totals_school AFTER INSERT ON schools BEGIN
  INSERT INTO school_totals(school_id) VALUES (NEW.id);
END;
CREATE TRIGGER school_totals_pupil_in AFTER INSERT ON pupils BEGIN
  UPDATE school_totals SET pupils = pupils + 1 WHERE school_id = NEW.school_id;
END;
CREATE TRIGGER school_totals_pupil_out AFTER DELETE ON pupils BEGIN
  UPDATE school_totals SET pupils = pupils - 1 WHERE school_id = OLD.school_id;
END;
CREATE TRIGGER school_totals_session_in AFTER INSERT ON sessions BEGIN
  UPDATE school_totals SET sessions = sessions + 1 WHERE school_id = NEW.school_id;
END;
CREATE TRIGGER school_totals_session_out AFTER DELETE ON sessions BEGIN
  UPDATE school_totals SET sessions = sessions - 1 WHERE school_id = OLD.school_id;
END;
CREATE TRIGGER school_totals_exam_in AFTER INSERT ON exams BEGIN
  UPDATE school_totals SET exams = exams + 1 WHERE school_id = (SELECT school_id FROM pupils WHERE id = NEW.pupil_id);
END;
CREATE TRIGGER school_totals_exam_out AFTER DELETE ON exams BEGIN
  UPDATE school_totals SET exams = exams - 1 WHERE school_id = (SELECT school_id FROM pupils WHERE id = OLD.pupil_id);
END;
)sql",
    // 16: each session's outcome on its row, written when it settles (the store back-fills the
    // sessions before it), so that the lists filter by outcome and result on an index of their own
    // rather than working the outcome out row by row.
    OUTCOME_STORED(""),
    // 17: which server runs each open session, so that several servers on one store each ingest
    // and supervise their own sessions, and take over those of a server that has stopped (its
    // last sign of life in servers.seen_at older than the lease).
    SERVERS_MIGRATION,
    // 18: each pupil's faults by kind, kept by triggers as events come, so that the history reads
    // a few rows rather than every session's events (a third of the history's time on
    // PostgreSQL). The partial index that history() read them through goes.
    R"sql(
DROP INDEX events_faults_by_session;
CREATE TABLE pupil_fault_counts (
  pupil_id INTEGER NOT NULL REFERENCES pupils(id),
  kind TEXT NOT NULL,
  count INTEGER NOT NULL,
  PRIMARY KEY (pupil_id, kind)
) WITHOUT ROWID;
)sql" PUPIL_FAULT_COUNTS_FILL R"sql(
CREATE TRIGGER pupil_fault_counts_in AFTER INSERT ON events WHEN NEW.worry_level > 0 BEGIN
  INSERT INTO pupil_fault_counts(pupil_id, kind, count) SELECT pupil_id, NEW.kind, 1 FROM sessions WHERE id = NEW.session_id
    ON CONFLICT (pupil_id, kind) DO UPDATE SET count = count + 1;
END;
CREATE TRIGGER pupil_fault_counts_out AFTER DELETE ON events WHEN OLD.worry_level > 0 BEGIN
  UPDATE pupil_fault_counts SET count = count - 1
    WHERE pupil_id = (SELECT pupil_id FROM sessions WHERE id = OLD.session_id) AND kind = OLD.kind;
END;
)sql",
    // 19: the pupil's school kept on the exam row, as on the session's (8), and the exams' indexes
    // by school: a school's passed practical exams were read through exams_by_kind_result with
    // each row's pupil looked up for the school (two lookups per exam counted: 21 ms p99 at a
    // million sessions, some 80 ms at 10 million); now counted from one index alone. The kept
    // records' trigger stands aside for the one fill, in the migration's transaction.
    R"sql(
ALTER TABLE exams ADD COLUMN school_id INTEGER REFERENCES schools(id);
DROP TRIGGER kept_exams_no_update;
UPDATE exams SET school_id = (SELECT school_id FROM pupils WHERE pupils.id = exams.pupil_id);
CREATE TRIGGER kept_exams_no_update BEFORE UPDATE ON exams
BEGIN
  SELECT RAISE(ABORT, 'exam records are kept as written: a correction is a new record');
END;
DROP INDEX exams_by_kind_result;
DROP INDEX exams_by_time;
CREATE INDEX exams_by_school_kind_result ON exams(school_id, kind, passed, taken_at);
CREATE INDEX exams_by_school_time ON exams(school_id, taken_at);
-- An exam written without its pupil's school would be missing from the school's lists while
-- counted in its total: refused (one of no pupil is the foreign key's).
CREATE TRIGGER exams_school_is_the_pupils BEFORE INSERT ON exams
WHEN EXISTS (SELECT 1 FROM pupils WHERE id = NEW.pupil_id)
  AND NEW.school_id IS NOT (SELECT school_id FROM pupils WHERE id = NEW.pupil_id)
BEGIN
  SELECT RAISE(ABORT, 'an exam is of its pupil''s school');
END;
)sql",
    // 20: the school's sessions by outcome carry the result too, so that counting the passed ones
    // reads that index alone: it looked up each of up to 10,001 rows for its result (16 ms at 10
    // million sessions, 2.6 ms at 100,000).
    R"sql(
-- After the id, so that the order by time and id stays the index's own.
DROP INDEX sessions_by_school_outcome;
CREATE INDEX sessions_by_school_outcome ON sessions(school_id, outcome, created_at, id, passed);
-- Its statistics at once, where the store has any (an empty table gets none): without them the
-- planner took it for a narrow one and sorted every session of the school for the newest page
-- (56 ms at 100,000 sessions, 370 ms at a million).
ANALYZE sessions_by_school_outcome;
)sql",
};

// Read FROM sessions. The second column is NULL: read_session derives the public id from the id,
// as the schema does, without the schema's printf on every row. The one before last says whether
// the score notes the task left unfinished (TASK_LEFT_SQL: of the stored outcome, where it was
// joined from the task-incomplete scores' index).
constexpr const char* kSessionColumns =
    "sessions.id, NULL, sessions.pupil_id, sessions.cab_id, sessions.scenario, sessions.mode, "
    "sessions.state, sessions.reason, sessions.examiner_id, sessions.created_at, sessions.ended_at, sessions.mark, "
    "sessions.passed, " TASK_LEFT_SQL ", sessions.started_by";
constexpr const char* kSessions = "sessions";

// SQLite's dialect: NOCASE folds ASCII capitals only, as canonical_username() does, and LIKE
// ignores ASCII capitals by itself.
const Dialect kSqlite = {
    kMigrations,
    static_cast<int>(std::size(kMigrations)),
    [](const std::string& expr) { return expr + " COLLATE NOCASE"; },
    [](const std::string& column, const std::string& param) { return column + " = " + param + " COLLATE NOCASE"; },
    [](const std::string& column) { return column + " LIKE ? ESCAPE '\\'"; },
    [](const std::string& expr) { return expr; },
    kSessionColumns,
    kSessions,
    // CROSS JOIN fixes SQLite's join order: sessions first.
    "CROSS JOIN",
    "INSERT INTO users(username, password_hash, role, school_id, pupil_id, full_name) "
    "SELECT ?1, ?2, ?3, ?4, ?5, ?6 WHERE NOT EXISTS (SELECT 1 FROM users WHERE username = ?1 COLLATE NOCASE) RETURNING id",
    "INSERT INTO audit_log(at, actor_user_id, actor, pupil_id, action, details) "
    "SELECT ?1, ?2, ?3, s.pupil_id, 'session_scored', json_object('session', s.public_id, "
    "'mode', s.mode, 'mark', sc.mark, 'passed', json(CASE WHEN sc.passed THEN 'true' ELSE 'false' END), "
    "'counts', (SELECT json_group_object(kind, count) FROM score_counts WHERE session_id = s.id), "
    "'exam_id', (SELECT id FROM exams WHERE session_id = s.id)) "
    "FROM sessions s JOIN scores sc ON sc.session_id = s.id WHERE s.id = ?4",
    "SELECT json_object('session', ?1, 'from', ?2, 'to', ?3, 'reason', ?4)",
};

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

void run_sql(sqlite3* db, const char* op, const char* sql) {
  if (sqlite3_exec(db, sql, nullptr, nullptr, nullptr) != SQLITE_OK) throw_db_error(db, op);
}

struct DbCloser {
  void operator()(sqlite3* db) const { sqlite3_close_v2(db); }
};
struct StmtFinalizer {
  void operator()(sqlite3_stmt* s) const { sqlite3_finalize(s); }
};

class SqliteStatement final : public Statement {
 public:
  // `plans`: the driver's Driver::explain_into, read when the statement first steps.
  SqliteStatement(sqlite3* db, sqlite3_stmt* stmt, std::vector<std::string>* const& plans)
      : db_(db), stmt_(stmt), plans_(plans) {}

  // For one use by `op`.
  SqliteStatement& use(const char* op) {
    op_ = op;
    return *this;
  }

  void bind_null() override { check(sqlite3_bind_null(stmt(), ++param_)); }
  void bind_int64(int64_t v) override { check(sqlite3_bind_int64(stmt(), ++param_, v)); }
  void bind_double(double v) override { check(sqlite3_bind_double(stmt(), ++param_, v)); }
  void bind_bool(bool v) override { bind_int64(v ? 1 : 0); }
  void bind_text(const std::string& v) override {
    check(sqlite3_bind_text(stmt(), ++param_, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
  }

  bool step() override {
    if (plans_ && !sqlite3_stmt_busy(stmt())) explain();
    const int rc = sqlite3_step(stmt());
    if (rc == SQLITE_ROW) return true;
    if (rc != SQLITE_DONE) throw_db_error(db_, op_);
    return false;
  }
  int64_t changes() override {
    while (step()) {
    }
    return sqlite3_changes(db_);
  }

  int64_t int64(int col) const override { return sqlite3_column_int64(stmt(), col); }
  double real(int col) const override { return sqlite3_column_double(stmt(), col); }
  std::string text(int col) const override {
    const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(stmt(), col));
    return p ? std::string(p, static_cast<size_t>(sqlite3_column_bytes(stmt(), col))) : std::string();
  }
  bool is_null(int col) const override { return sqlite3_column_type(stmt(), col) == SQLITE_NULL; }

  void reset() override {
    sqlite3_reset(stmt());
    sqlite3_clear_bindings(stmt());
    param_ = 0;
  }

 private:
  sqlite3_stmt* stmt() const { return stmt_.get(); }
  void check(int rc) {
    if (rc != SQLITE_OK) throw_db_error(db_, op_);
  }
  // The statement and its plan, the values bound written in (EXPLAIN QUERY PLAN: one line per
  // step, "SCAN t" or "SEARCH t USING INDEX i (...)").
  void explain() {
    std::unique_ptr<char, decltype(&sqlite3_free)> sql(sqlite3_expanded_sql(stmt()), &sqlite3_free);
    if (!sql) return;
    const std::string query = std::string("EXPLAIN QUERY PLAN ") + sql.get();
    sqlite3_stmt* e = nullptr;
    if (sqlite3_prepare_v2(db_, query.c_str(), -1, &e, nullptr) != SQLITE_OK) throw_db_error(db_, op_);
    std::unique_ptr<sqlite3_stmt, StmtFinalizer> plan(e);
    std::string text = sqlite3_sql(stmt());
    while (sqlite3_step(e) == SQLITE_ROW) text += std::string("\n") + reinterpret_cast<const char*>(sqlite3_column_text(e, 3));
    plans_->push_back(text);
  }

  sqlite3* db_;
  std::unique_ptr<sqlite3_stmt, StmtFinalizer> stmt_;
  std::vector<std::string>* const& plans_;
  const char* op_ = "";
  int param_ = 0;
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

class SqliteDriver final : public Driver {
 public:
  explicit SqliteDriver(const std::string& path) {
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
    // While another connection migrates a new file (still in rollback mode), SQLite answers
    // "locked" at once rather than wait, as waiting could deadlock: try again within the timeout.
    for (int tries = 0;; ++tries) {
      const int wal = sqlite3_exec(db, "PRAGMA journal_mode=WAL", nullptr, nullptr, nullptr);
      if (wal == SQLITE_OK) break;
      if ((wal & 0xff) != SQLITE_BUSY || tries == 5000) throw_db_error(db, "open");
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    run_sql(db, "open", "PRAGMA foreign_keys=ON");
    // In WAL mode NORMAL loses at most the last commits on power loss, never consistency.
    run_sql(db, "open", "PRAGMA synchronous=NORMAL");
    // Read pages through a memory map instead of one pread each: a history() on a large store
    // touches a few hundred scattered pages (10,000 pupils x 50 sessions x 20 events: 590 us per
    // call with pread, 270 with mmap).
    run_sql(db, "open", "PRAGMA mmap_size=1073741824");
    // A statement inside a batch that fires a trigger (the school's totals) keeps a statement
    // journal, to undo itself alone: in memory, not a temporary file written page by page.
    run_sql(db, "open", "PRAGMA temp_store=MEMORY");
  }

  // The cached prepared statement for `sql` (prepared once per connection).
  Statement& prepare(const char* op, const std::string& sql) override {
    auto it = statements_.find(sql);
    if (it == statements_.end()) {
      sqlite3_stmt* stmt = nullptr;
      if (sqlite3_prepare_v3(db(), sql.c_str(), static_cast<int>(sql.size()), SQLITE_PREPARE_PERSISTENT, &stmt,
                             nullptr) != SQLITE_OK) {
        throw_db_error(db(), op);
      }
      it = statements_.emplace(sql, std::make_unique<SqliteStatement>(db(), stmt, plans_)).first;
    }
    return it->second->use(op);
  }

  void exec(const char* op, const std::string& sql) override { run_sql(db(), op, sql.c_str()); }

  void explain_into(std::vector<std::string>* plans) override { plans_ = plans; }

  bool in_transaction() override { return !sqlite3_get_autocommit(db()); }

  // A single statement is atomic by itself, in a transaction or not: nothing to begin. Writers
  // BEGIN IMMEDIATE: they take the write lock up front (waiting on the busy timeout) rather than
  // fail when upgrading a read.
  TxState begin(const char* op, TxKind kind) override {
    TxState tx;
    if (kind == TxKind::kStatement) return tx;
    tx.nested = in_transaction();
    run_sql(db(), op, tx.nested ? "SAVEPOINT op" : kind == TxKind::kRead ? "BEGIN" : "BEGIN IMMEDIATE");
    tx.open = true;
    return tx;
  }
  void commit(const char* op, TxState& tx) override {
    if (!tx.open) return;
    run_sql(db(), op, tx.nested ? "RELEASE op" : "COMMIT");
    tx.open = false;
  }
  void end(TxState& tx) noexcept override {
    if (!tx.open) return;
    tx.open = false;
    sqlite3_exec(db(), tx.nested ? "ROLLBACK TO op; RELEASE op" : "ROLLBACK", nullptr, nullptr, nullptr);
  }

  // synchronous cannot change inside a transaction: Durable encloses it.
  bool durable_begin(const char* op) override {
    run_sql(db(), op, "PRAGMA synchronous=FULL");
    return true;
  }
  void durable_end() noexcept override { sqlite3_exec(db(), "PRAGMA synchronous=NORMAL", nullptr, nullptr, nullptr); }


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

 private:
  sqlite3* db() const { return db_.get(); }

  // Declared before the statements so that they are finalized before the connection closes.
  std::unique_ptr<sqlite3, DbCloser> db_;
  std::vector<std::string>* plans_ = nullptr;  // explain_into's; the statements read it
  std::unordered_map<std::string, std::unique_ptr<SqliteStatement>> statements_;
};

}  // namespace

std::unique_ptr<Store> Store::open_sqlite(const std::string& path) {
  return make_sql_store(std::make_unique<SqliteDriver>(path), kSqlite);
}

}  // namespace forklift::store
