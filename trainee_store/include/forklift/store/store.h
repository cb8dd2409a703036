// The trainee store: pupils, users and roles, cabs, sessions, events, scores, theory and practical
// exam records, licence records, session logs, theory papers, truck paths and the audit log of
// changes to pupils' records. One small interface per aggregate (accounts, logins, pupils, cabs,
// sessions, exams, licences, theory, the exam chain, audit), which Store brings together; two
// backends with the same schema versions (migrations applied at open) and the same behaviour:
// SQLite, the embedded default (one file, WAL, foreign keys), and PostgreSQL (libpq), for several
// servers sharing one database. Every SQL statement is written once (trainee_store/src/sql_store.cc);
// the backends differ in their drivers and in a dialect of a few fragments.
//
// Contract: every call is atomic. Bad arguments (unknown ids, empty names) throw StoreError with
// kind kInvalid or kNotFound (modes, session phases and outcomes are the session vocabulary's
// enums, named in SQL by name() and read back with parse<>()); a duplicate unique value
// (username, cab id), or a change to a record the schema keeps as written, throws kConflict; I/O
// or database failure throws kIo; a database that cannot be written or reached just now (a full
// disk, a read-only file system or server, a lost connection) throws StorageUnavailable, of kind kIo. Times are ISO-8601 UTC strings ("2026-11-23T10:30:00Z"). A Store
// object is used from one thread at a time; open one per thread (SQLite's busy timeout lets them
// share the file; each PostgreSQL Store is one connection).
// Exactly-once holds across Store objects and processes, on either backend: two servers sharing
// one database store an event, a score or a chain entry once (unique keys decide, not the caller).
// What PostgreSQL stores is UTF-8 text without NUL bytes: other text is refused (kInvalid).
// "synchronous=FULL" below is SQLite's; on PostgreSQL every commit is durable so (synchronous_commit).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <ctime>
#include <string>
#include <utility>
#include <vector>

#include "forklift/session/vocabulary.h"

namespace forklift::store {

class StoreError : public std::runtime_error {
 public:
  enum Kind { kInvalid, kNotFound, kConflict, kIo };
  StoreError(Kind kind, const std::string& what) : std::runtime_error(what), kind_(kind) {}
  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

// The database cannot be written or reached just now: its disk is full, it or its file system is
// read-only, its file cannot be opened or read, or the connection to the PostgreSQL server was
// lost. The call wrote nothing (every call is atomic); the same call succeeds again once there is
// room or the database is back. Of kind kIo, so code that tells kinds apart sees a database failure.
class StorageUnavailable : public StoreError {
 public:
  StorageUnavailable(const std::string& what, std::string reason) : StoreError(kIo, what), reason_(std::move(reason)) {}
  // Why, in words a school's administrator can act on ("the disk that holds the school's records is
  // full"), without the database's own text (what() has that, for the server's log).
  const std::string& reason() const { return reason_; }

 private:
  std::string reason_;
};

enum class Role { kAdmin, kInstructor, kExaminer, kPupil };
const char* role_name(Role role);                          // "admin", "instructor", "examiner", "pupil"
std::optional<Role> parse_role(const std::string& name);

// Usernames: with ASCII capitals read as small letters, 1 to kMaxUsernameLength of a-z, 0-9, '.',
// '_' and '-', and compared so. Nothing else (no spaces, control characters or letters that look
// like others), so that "admin ", "ADMIN" or "admin\n" never name a second account. The name as
// it is stored, or nullopt when it breaks the rule.
constexpr size_t kMaxUsernameLength = 64;
std::optional<std::string> canonical_username(const std::string& name);

struct User {
  int64_t id = 0;
  std::string username;
  std::string password_hash;  // opaque to the store (the server hashes)
  Role role = Role::kPupil;
  int64_t school_id = 0;
  std::optional<int64_t> pupil_id;  // set for role pupil: the pupil record this login is
  // The person's full name, as certificates print it (staff: examiners, supervisors, whoever
  // issues a licence); empty for accounts made before names were kept, and for pupils' logins
  // (their pupil record has the name).
  std::string full_name;
  // A deactivated account cannot log in and its tokens are refused.
  bool active = true;
  // Raised when the password is reset or the account deactivated: the server refuses a token
  // issued under an earlier one, so those logins end at once, on every server sharing the store.
  int64_t login_generation = 0;
};

// Which accounts list_users() returns: a school's staff (admins, instructors, examiners) and,
// when asked, its pupils' logins; of one role, active or not, when set.
struct UserFilter {
  int64_t school_id = 0;
  std::optional<Role> role;
  std::optional<bool> active;
  bool include_pupils = false;
};

// One page of accounts and how many match the filter in all.
struct UserPage {
  std::vector<User> users;
  int64_t total = 0;
};

struct School {
  int64_t id = 0;
  std::string name;
};

struct Pupil {
  int64_t id = 0;
  int64_t school_id = 0;
  std::string name;
  std::string email;  // may be empty
  std::string created_at;
  std::optional<int64_t> group_id;  // the group (course) the pupil is in, if any: at most one
};

// A course or group of pupils with the instructor who teaches it.
struct Group {
  int64_t id = 0;
  int64_t school_id = 0;
  std::string name;                     // unique in the school, capitals or not
  std::optional<int64_t> instructor_id;  // a user of the school
  std::string created_at;
  int64_t pupils = 0;  // how many pupils it has (as read)
};

struct Cab {
  std::string id;
  int64_t school_id = 0;
  std::string last_seen_at;  // empty if never seen
};

struct Session {
  int64_t id = 0;
  std::string public_id;  // the session id workers and DDS use, e.g. "s-000042"
  int64_t pupil_id = 0;
  std::string cab_id;
  std::string scenario;
  Mode mode = Mode::kTraining;
  SessionPhase state = SessionPhase::kStarting;
  std::string reason;     // an EndReason's name when its worker ended it; else the words of who ended it
  std::optional<int64_t> examiner_id;  // a user
  std::string created_at, ended_at;    // ended_at empty while open
  std::optional<double> mark;    // the evaluator's, as stored: mark_of() says whether it counts
  std::optional<bool> passed;
  // Its score counts a "task_incomplete" fault, as read by the store: for a session that ended when
  // its time ran out ("duration"), the one end whose outcome it decides; false for any other.
  bool task_left_unfinished = false;
  std::optional<int64_t> started_by;  // the user who started it (none for sessions from before it was kept)
};

// Lists a school works with: filtered and sorted in SQL, a page at a time with
// the total that match. Sort keys come from a fixed list (the store refuses others, kInvalid);
// ties are broken by id. Text filters are exact unless said otherwise; dates are ISO-8601 UTC
// strings compared as such ("2026-11-23" matches from the start of that day).
//
// A list's total: the whole school's pupils, sessions or exams (no filter but the school) are
// read from the totals the store keeps as rows come and go, exact and without counting; any other
// filter's rows are counted up to kCountedAtMost, and a page whose filter matches more says so
// (total_is_at_least: total is kCountedAtMost, and more match), so that no list's count reads
// millions of rows.
constexpr int64_t kCountedAtMost = 10000;
struct PupilFilter {
  int64_t school_id = 0;
  std::string search;                     // in the name or the email, capitals or not; empty: all
  std::optional<int64_t> group_id;        // 0: pupils in no group
  std::optional<int64_t> instructor_id;   // pupils of this instructor's groups
  std::optional<int64_t> first_for;       // an instructor: their groups' pupils first, then the rest
  std::string sort = "name";              // "name", "email", "created_at", "group"
  bool descending = false;
  // Keyset paging: the page after this pupil's row in the list's order (sort name, email or
  // created_at, without first_for; else kInvalid; kNotFound if no such pupil of the school), the
  // offset counted from there. Its cost does not grow with the page's place in the list, where an
  // offset's walks past every row before it (200,000 pupils: tens of milliseconds).
  std::optional<int64_t> after;
};
struct PupilPage {
  std::vector<Pupil> pupils;
  int64_t total = 0;
  bool total_is_at_least = false;  // more than total match (kCountedAtMost)
};

struct SessionFilter {
  int64_t school_id = 0;
  std::optional<int64_t> pupil_id;
  std::string search;                    // in the pupil's name or email, capitals or not
  std::string from, to;                  // created_at in [from, to); empty: open-ended
  std::string cab_id, scenario;          // exact; empty: any
  std::optional<Mode> mode;              // none: any
  std::optional<int64_t> instructor_id;  // started by this user
  std::optional<int64_t> group_id;       // of pupils in this group
  std::optional<Outcome> outcome;        // none: any
  std::string result;                    // "passed" (completed and passed), "not_passed" (over, and not so); empty: any
  std::string sort = "created_at";       // "created_at", "pupil", "cab", "scenario", "mode", "mark"
  bool descending = true;
  // Keyset paging, as PupilFilter's: the page after this session's row (its public id) in the
  // list's order (sorted by created_at, else kInvalid; kNotFound if no such session of the
  // school), the offset counted from there. Empty: none.
  std::string after;
};
// A session as a list shows it: with its pupil's name.
struct SessionRow {
  Session session;
  std::string pupil_name;
};
struct SessionPage {
  std::vector<SessionRow> sessions;
  int64_t total = 0;
  bool total_is_at_least = false;  // more than total match (kCountedAtMost)
};

struct ExamFilter {
  int64_t school_id = 0;
  std::optional<int64_t> pupil_id;
  std::string search;                   // in the pupil's name or email
  std::optional<ExamKind> kind;         // none: both
  std::string from, to;                 // taken_at in [from, to)
  std::optional<bool> passed;           // as recorded (a correction may say otherwise: the record's page shows it)
  std::optional<int64_t> examiner_id;
  std::optional<int64_t> group_id;
  std::string sort = "taken_at";        // "taken_at", "pupil", "kind", "score"
  bool descending = true;
  // Keyset paging, as PupilFilter's: the page after this exam record's row in the list's order
  // (sorted by taken_at, else kInvalid; kNotFound if no such exam of the school).
  std::optional<int64_t> after;
};

// What a session's end means, the one rule that the store's trend, the API,
// its exports and the pages follow. A session is "completed" when it ran its course: its task
// done ("task_complete", or "parked"), or the time it was given ran out ("duration") with no task
// left unfinished (the paper's manoeuvres, which have no task, end so). It is "timed_out" when
// its time ran out first: the scene's time limit ("time_limit"), or the time it was given with
// its task unfinished; "aborted" when an instructor stopped it; "stopped" when its worker was
// told to stop before its end ("signal": the server shut down); "failed" when the worker failed
// or ended it for any other reason (a crash, a hang, a numerical failure, a tip-over that ends a
// run); "open" until it ends. Only a completed session has a mark: the others have an outcome and
// no mark, and count in no chart or trend.
// The words are the session vocabulary's (forklift::Outcome, name() and parse<Outcome>()).
using Outcome = forklift::Outcome;
Outcome session_outcome(const Session& s);
// The session's mark as its record gives it: the evaluator's mark of a completed session, else none.
std::optional<double> mark_of(const Session& s);

struct EventRecord {
  std::string session_public_id;
  int64_t seq = 0;  // per session, from 1
  double sim_time_s = 0;
  std::string kind;
  int worry_level = 0;
  double x_m = 0, y_m = 0;
  std::string details;
};

struct ScoreRecord {
  std::string session_public_id;
  double mark = 0;
  bool passed = false;
  std::map<std::string, int> counts;  // faults by kind
  // For an exam session: its practical exam record's details (JSON text, opaque to the store: the
  // server's reasons for the result, the names and the course as they were); empty: "".
  std::string exam_details{};
};

struct ExamRecord {
  int64_t id = 0;
  int64_t pupil_id = 0;
  ExamKind kind = ExamKind::kPractical;
  std::optional<std::string> session_public_id;  // practical exams
  double score = 0;  // theory: fraction correct in [0, 1]; practical: the mark
  bool passed = false;
  std::optional<int64_t> examiner_id;
  std::string taken_at;
  std::string details;  // JSON text, free form (e.g. the theory answers)
};

// An exam record as a list shows it: with its pupil's name, and whether it has corrections.
struct ExamRow {
  ExamRecord exam;
  std::string pupil_name;
  int64_t corrections = 0;
};
struct ExamPage {
  std::vector<ExamRow> exams;
  int64_t total = 0;
  bool total_is_at_least = false;  // more than total match (kCountedAtMost)
};

// A cab booked for a pupil's session at a time. A cab is never booked twice at
// once: bookings of one cab do not overlap ([starts_at, ends_at) intervals).
struct Booking {
  int64_t id = 0;
  int64_t school_id = 0;
  int64_t pupil_id = 0;
  std::string cab_id;
  std::string starts_at, ends_at;  // ISO-8601 UTC, "YYYY-MM-DDTHH:MM:SSZ"; ends_at after starts_at
  std::string scenario;
  Mode mode = Mode::kTraining;
  std::optional<int64_t> instructor_id;
  std::string session_public_id;   // the session started from it; empty until then
  std::string created_at;
  std::string pupil_name;          // as read
};

// A correction of a finished exam record: a new record, never a change to the old one.
// Kept for ever (the schema refuses UPDATE and DELETE).
struct ExamCorrection {
  int64_t id = 0;
  int64_t exam_id = 0;
  int64_t corrected_by = 0;        // a user
  std::string at;                  // ISO-8601; empty when adding: now
  std::string reason;              // why; never empty
  std::string correction = "{}";   // a JSON object as text: the fields corrected and their new values
};

struct LicenceRecord {
  int64_t id = 0;
  int64_t pupil_id = 0;
  std::string issued_at;
  std::string reevaluation_due;  // issued_at + 3 years (OSHA 1910.178(l)(4))
  std::string issued_by;         // username
};

// A certificate, issued with a licence: its number, and the record the server
// signed (both JSON text, made and checked by the server, opaque to the store). Kept for ever.
struct CertificateRecord {
  int64_t id = 0;
  std::string number;  // unique; the store does not make it
  int64_t pupil_id = 0;
  int64_t licence_id = 0;
  std::string issued_at;
  std::optional<int64_t> issued_by;  // a user
  std::string record;     // what the certificate says, as signed
  std::string signature;  // the server's signature over it
};

// A certificate's revocation, at most one per certificate, kept for ever.
struct CertificateRevocation {
  int64_t id = 0;
  int64_t certificate_id = 0;
  int64_t revoked_by = 0;  // a user
  std::string at;          // ISO-8601; empty when adding: now
  std::string reason;      // never empty
};

// One point of a session's truck path, downsampled from the worker's TruckState (the server keeps
// about two a second). World frame: x, y on the floor, metres; yaw in radians, + turning left.
struct PathPoint {
  double sim_time_s = 0;
  double x_m = 0, y_m = 0;  // chassis CoG
  double yaw_rad = 0;
  double speed_m_s = 0;     // along the heading
  double lift_m = 0;        // fork lift
};

// A theory paper as handed out: the questions drawn (in order) from the bank with `seed` (and
// the pupil's earlier papers), kept as the server wrote them. Finished once: marked, or timed out.
// An exam paper (supervised) then names its ExamRecord in `exam_id`; a practice paper never has
// one (it never counts) and keeps its marking in `result`.
struct TheoryAttempt {
  int64_t id = 0;
  int64_t pupil_id = 0;
  int64_t seed = 0;                  // in [0, 2^53): exact in JSON
  std::string questions;             // JSON text, opaque to the store (the question ids and choice orders)
  std::string started_at;
  std::optional<int64_t> started_by;  // the user who handed the paper out: for an exam, its supervisor
  std::optional<int64_t> exam_id;     // an exam paper's record, once finished
  PaperKind kind = PaperKind::kExam;
  std::string deadline;               // ISO-8601 UTC, perhaps with milliseconds; empty: no time limit
  std::string finished_at;            // empty while open
  std::optional<PaperOutcome> outcome;  // none while open
  std::string result;                 // a practice paper's marking, JSON text opaque to the store
};

// An instructor's leave for a pupil to sit the theory exam again at once, whatever the school's
// waiting period and limit of attempts. Kept for ever.
struct TheoryUnlock {
  int64_t id = 0;
  int64_t pupil_id = 0;
  int64_t unlocked_by = 0;  // a user
  std::string at;           // ISO-8601; empty when adding: now
  std::string reason;       // may be empty
};

// Who made a change: a user, or a part of the platform writing on its own ("worker", "server").
struct Actor {
  std::optional<int64_t> user_id;  // none for automatic writes
  std::string name;                // the username, or "worker" / "server"
};

// One row of the audit log: a change to a pupil's record, who made it, and what changed.
struct AuditRecord {
  int64_t id = 0;
  std::string at;  // ISO-8601; empty when adding: now
  Actor actor;
  int64_t pupil_id = 0;
  std::string action;          // e.g. "pupil_created", "pupil_edited", "session_started"
  std::string details = "{}";  // a JSON object as text (an edit's before and after)
};

// One entry of the exam hash chain: JSON text made and checked by the server's evidence code
// (security/include/forklift/security/evidence.h), opaque to the store.
struct ChainEntry {
  int64_t seq = 0;  // from 1, without gaps
  std::string session_public_id;
  std::string entry;
};

// One row of the staff audit log: an administrator's change to an account (its creation, a full
// name, a password reset, a deactivation or reactivation), who made it and what changed. Kept
// apart from the pupils' audit log, whose every row is about a pupil's record.
struct StaffAuditRecord {
  int64_t id = 0;
  std::string at;  // ISO-8601; empty when adding: now
  Actor actor;
  int64_t user_id = 0;         // the account changed
  std::string action;          // e.g. "account_created", "password_reset", "account_deactivated"
  std::string details = "{}";  // a JSON object as text
};

// An instructor's note on a session, for the debrief. Kept for ever.
struct SessionNote {
  int64_t id = 0;
  std::string session_public_id;
  int64_t author_id = 0;  // a user
  std::string at;         // ISO-8601; empty when adding: now
  std::string text;       // never empty
};

// A session's sign-off: the instructor's word that its debrief is done. At most one per session,
// kept for ever; no note is added after it.
struct SessionSignOff {
  std::string session_public_id;
  int64_t signed_by = 0;  // a user
  std::string at;         // ISO-8601; empty when adding: now
  std::string comment;    // may be empty
};

// Which audit rows to list: one pupil's (pupil_id set), else every pupil's of one school
// (school_id set), else all.
struct AuditScope {
  std::optional<int64_t> pupil_id;
  std::optional<int64_t> school_id;
};

// A login's bearer token as the store keeps it: its SHA-256 (the server's to compute), never the
// token itself, so that a copy of the database logs no one in. Every server on the store honours
// it until it expires or is deleted (a logout), a restart included.
struct LoginToken {
  std::string hash;              // SHA-256 of the token, 64 lower-case hex digits
  int64_t user_id = 0;
  int64_t login_generation = 0;  // the account's User::login_generation at login
  int64_t expires_at_ms = 0;     // Unix time, milliseconds
  User user;                     // as read (find_login_token): the account as it is now
};

// One key's attempts (failed logins and the like, keyed by the server: a username, an address),
// as count_attempts() reads them.
struct AttemptCount {
  int64_t counted = 0;          // attempts made at or after the time asked, ended or not
  int64_t pending = 0;          // of those, not yet ended
  int64_t oldest_at_ms = 0;     // the oldest of those's time; 0: none
  int64_t locked_until_ms = 0;  // when the key's lockout ends; 0: none
};

// Everything about one pupil, aggregated by the store.
struct PupilHistory {
  Pupil pupil;
  std::vector<Session> sessions;  // oldest first
  std::vector<ExamRecord> exams;  // oldest first
  std::map<std::string, int> faults_by_kind;  // over all their sessions' events with worry_level > 0
  // Least-squares slope of mark per session over the marked training sessions (>= 2; mark_of():
  // exams are results, shown apart), else none.
  std::optional<double> trend;
  std::optional<LicenceRecord> licence;  // the latest
  bool reevaluation_overdue = false;     // licence.reevaluation_due before `now`
  std::vector<ExamCorrection> corrections;  // of the pupil's exams, oldest first
  std::vector<SessionNote> notes;           // the debrief notes on the pupil's sessions, oldest first
};

// Schools and their accounts: staff and pupils' logins.
class AccountStore {
 public:
  virtual ~AccountStore() = default;

  virtual int64_t create_school(const std::string& name) = 0;
  // `username` must be its own canonical_username() (else kInvalid); kConflict if a user's name
  // is the same but for capitals.
  virtual int64_t create_user(const std::string& username, const std::string& password_hash, Role role,
                              int64_t school_id, std::optional<int64_t> pupil_id = std::nullopt,
                              const std::string& full_name = "") = 0;
  // Sets a user's full name; kNotFound for an unknown user.
  virtual void set_user_full_name(int64_t id, const std::string& full_name) = 0;
  // The language a person reads the pages, their words and their certificates in: a folder name
  // of data/i18n/ ("en", "es"; the store checks only its form, 2 to 16 letters, digits, '-' or
  // '_', and the server that it has that language). Staff keep theirs on their account, pupils on
  // their record (a pupil's login reads it there); "en" until set. kNotFound for an unknown user
  // or pupil, kInvalid for a malformed language.
  virtual std::string user_language(int64_t user_id) = 0;
  virtual void set_user_language(int64_t user_id, const std::string& language) = 0;
  virtual std::string pupil_language(int64_t pupil_id) = 0;
  virtual void set_pupil_language(int64_t pupil_id, const std::string& language) = 0;
  virtual std::optional<School> get_school(int64_t id) = 0;
  // The user of that name, capitals or not. Of names stored before the rule that differ only in
  // capitals, the one spelled exactly so, else the oldest.
  virtual std::optional<User> find_user(const std::string& username) = 0;
  virtual std::optional<User> get_user(int64_t id) = 0;
  // The accounts `f` selects, by full name (capitals read as small letters; accounts without one
  // last), then username; with the total that match. kInvalid for a negative limit or offset.
  virtual UserPage list_users(const UserFilter& f, int limit, int offset) = 0;
  // Replaces an account's password hash and raises its login_generation; kNotFound for an
  // unknown user.
  virtual void set_user_password(int64_t id, const std::string& password_hash) = 0;
  // Deactivates an account (raising its login_generation) or reactivates it; returns whether it
  // changed. kNotFound for an unknown user; kConflict for the last active admin of its school
  // (checked in the same transaction, so two admins deactivating each other leave one).
  virtual bool set_user_active(int64_t id, bool active) = 0;
};

// What keeps a login on every server sharing the store: its tokens, and the attempts that limit
// failed ones.
class LoginStore {
 public:
  virtual ~LoginStore() = default;

  // Logins' tokens, shared by every server on the store. add_login_token: kInvalid for a hash that
  // is not 64 lower-case hex digits, kNotFound for an unknown user, kConflict for a hash stored
  // already. find_login_token: the token of that hash with its account as it is now, or nullopt
  // (never stored, deleted, or forgotten). delete_login_token (a logout): whether there was one.
  // forget_login_tokens: deletes those that expired before `before_ms`; how many.
  virtual void add_login_token(const LoginToken& t) = 0;
  virtual std::optional<LoginToken> find_login_token(const std::string& hash) = 0;
  virtual bool delete_login_token(const std::string& hash) = 0;
  virtual int64_t forget_login_tokens(int64_t before_ms) = 0;

  // Attempts under a key (the server's throttle of failed logins), shared by every server on the
  // store; times are Unix milliseconds. The server's policy runs them in one batch(), so that two
  // servers counting at once count one after the other.
  // count_attempts: the key's attempts made at or after `since_ms`, and its lockout.
  virtual AttemptCount count_attempts(const std::string& key, int64_t since_ms) = 0;
  // A new attempt on `key` (kInvalid if empty) made at `at_ms`, pending until it ends; its id.
  virtual int64_t add_attempt(const std::string& key, int64_t at_ms) = 0;
  // Ends an attempt: a failure stays counted, made at `at_ms`; a success is deleted. Nothing for
  // an id that is not stored (forgotten meanwhile).
  virtual void end_attempt(int64_t id, bool failed, int64_t at_ms) = 0;
  // Forgets `key`'s ended attempts (pending ones stay) and locks it out until `locked_until_ms`
  // (0: not at all).
  virtual void reset_attempts(const std::string& key, int64_t locked_until_ms) = 0;
  // Deletes the attempts made before `before_ms`, ended or not (a server that stopped mid-check
  // leaves its attempt pending), and the lockouts that ended before it.
  virtual void forget_attempts(int64_t before_ms) = 0;
};

// Pupils, their groups (courses) and their whole history.
class PupilStore {
 public:
  virtual ~PupilStore() = default;

  virtual int64_t create_pupil(int64_t school_id, const std::string& name, const std::string& email) = 0;
  virtual std::optional<Pupil> get_pupil(int64_t id) = 0;
  // Replaces a pupil's name and email; kNotFound for an unknown pupil, kInvalid for an empty name.
  virtual void update_pupil(int64_t id, const std::string& name, const std::string& email) = 0;
  // Pupils of a school whose name contains `search` (case-insensitive; empty: all), by name.
  virtual std::vector<Pupil> list_pupils(int64_t school_id, const std::string& search, int limit, int offset) = 0;
  // The lists a school works with (PupilFilter and the like), filtered, sorted and paged: kInvalid
  // for an unknown sort key or result, or a negative limit or offset.
  virtual PupilPage find_pupils(const PupilFilter& f, int limit, int offset) = 0;

  // Groups: kInvalid for an empty name, kConflict for a name the school has (capitals or not),
  // kNotFound for an unknown school, group or instructor.
  virtual int64_t create_group(int64_t school_id, const std::string& name, std::optional<int64_t> instructor_id) = 0;
  virtual std::optional<Group> get_group(int64_t id) = 0;
  virtual std::vector<Group> list_groups(int64_t school_id) = 0;  // by name
  virtual void update_group(int64_t id, const std::string& name, std::optional<int64_t> instructor_id) = 0;
  // Moves a pupil into a group (of the pupil's school, else kInvalid), or out of any (nullopt).
  virtual void set_pupil_group(int64_t pupil_id, std::optional<int64_t> group_id) = 0;

  // PupilHistory for `pupil_id`, with overdue computed against `now`; nullopt if no such pupil.
  virtual std::optional<PupilHistory> history(int64_t pupil_id, const std::string& now) = 0;
  // The same, and the login token of `token_hash` as find_login_token() reads it (into `token`),
  // from the same snapshot in the same trip to the database: a request's login and its page,
  // where each was a round trip of its own to PostgreSQL. An empty hash looks up no token.
  virtual std::optional<PupilHistory> history(int64_t pupil_id, const std::string& now, const std::string& token_hash,
                                              std::optional<LoginToken>& token) = 0;
};

// Cabs, as they announce themselves, and their bookings.
class CabStore {
 public:
  virtual ~CabStore() = default;

  // A cab announced itself (inserted if new, last_seen_at set to now).
  virtual void cab_seen(const std::string& cab_id, int64_t school_id, const std::string& now) = 0;
  virtual std::vector<Cab> list_cabs(int64_t school_id) = 0;

  // Bookings: kConflict when the cab is booked at an overlapping time, kInvalid for a booking that
  // ends before it starts, kNotFound for an unknown pupil or instructor.
  virtual int64_t create_booking(const Booking& b) = 0;
  virtual std::optional<Booking> get_booking(int64_t id) = 0;
  // A school's bookings that overlap [from, to), by cab and start.
  virtual std::vector<Booking> list_bookings(int64_t school_id, const std::string& from, const std::string& to) = 0;
  // Records the session started from a booking, once (kConflict if it has one).
  virtual void set_booking_session(int64_t booking_id, const std::string& session_public_id) = 0;
  virtual void delete_booking(int64_t booking_id) = 0;  // kNotFound; kConflict once a session started from it
};

// Sessions: their life, events, score, truck path and logs, and their debrief.
class SessionStore {
 public:
  virtual ~SessionStore() = default;

  // New session in state "starting"; public_id assigned by the store ("s-" + zero-padded id).
  // A cab has at most one open session (not ended, failed or aborted): kConflict if it has one,
  // decided by a unique index, so that of two servers starting a session on one cab at once one
  // fails. (Schema 11 failed the older of any open sessions that shared a cab before it.)
  // `server` names the server that runs it (claim_sessions); empty: none yet.
  virtual Session create_session(int64_t pupil_id, const std::string& cab_id, const std::string& scenario,
                                 Mode mode, std::optional<int64_t> examiner_id, const std::string& now,
                                 std::optional<int64_t> started_by = std::nullopt, const std::string& server = "") = 0;
  virtual std::optional<Session> get_session(const std::string& public_id) = 0;
  virtual std::vector<Session> list_sessions_for_pupil(int64_t pupil_id) = 0;
  // Sessions not yet ended, failed or aborted (a restarted server resumes supervising these).
  virtual std::vector<Session> open_sessions() = 0;

  // Which server runs each open session, when several share the store: the one that started it,
  // until its signs of life stop, when another takes it over. A server says it is alive (at its
  // wall-clock `now`) every few seconds.
  virtual void server_alive(const std::string& server, const std::string& now) = 0;
  // Takes for `server` the open sessions that no server runs (started before servers were named)
  // and those whose server's last sign of life is older than `stale_before` (its lease ran out);
  // with `own`, its own as well; with `only`, that session alone. One statement, so that of two
  // servers taking over from a third, each session goes to one. Returns their public ids, oldest first.
  virtual std::vector<std::string> claim_sessions(const std::string& server, const std::string& stale_before, bool own,
                                                  const std::string& only = "") = 0;
  // The server that runs an open session: empty if none, nullopt if no such open session.
  virtual std::optional<std::string> session_server(const std::string& public_id) = 0;
  // Moves a session to `state`. A session that is ended, failed or aborted never changes again:
  // the call then returns false and changes nothing. Sets ended_at for those three states.
  virtual bool set_session_state(const std::string& public_id, SessionPhase state, const std::string& reason,
                                 const std::string& now) = 0;

  // Exactly once: a second event with the same (session, seq) is ignored and returns false.
  virtual bool add_event(const EventRecord& e) = 0;
  virtual std::vector<EventRecord> list_events(const std::string& session_public_id) = 0;
  // Exactly once per session: the first score is kept, later ones return false. Also sets the
  // session's mark and passed, and, for an exam session, adds its practical exam record. Written
  // with synchronous=FULL (an exam result must survive a power cut).
  virtual bool set_score(const ScoreRecord& s, const std::string& now) = 0;
  virtual std::optional<ScoreRecord> get_score(const std::string& session_public_id) = 0;

  // As find_pupils, of sessions.
  virtual SessionPage find_sessions(const SessionFilter& f, int limit, int offset) = 0;

  // Appends points to a session's truck path; a point at a sim time already stored is ignored
  // (a restarted ingest may see the same state twice). kNotFound for an unknown session.
  virtual void add_path_points(const std::string& session_public_id, const std::vector<PathPoint>& points) = 0;
  // The session's path in sim-time order (empty if none was stored); kNotFound for an unknown session.
  virtual std::vector<PathPoint> list_path(const std::string& session_public_id) = 0;

  // The session's control log and session log, stored as text; replaced by a later put, but for
  // an exam that is over, whose logs are kept as they are (the schema refuses a changed body; the
  // server's note "chain_refused" excepted).
  virtual void put_session_log(const std::string& session_public_id, const std::string& name, const std::string& text) = 0;
  virtual std::optional<std::string> get_session_log(const std::string& session_public_id, const std::string& name) = 0;

  // The debrief's notes and sign-off, append-only (the schema refuses UPDATE and DELETE).
  // add_session_note: id ignored; kNotFound for an unknown session or user, kInvalid for empty
  // text, kConflict once the session is signed off. Returns its id.
  virtual int64_t add_session_note(const SessionNote& n) = 0;
  virtual std::vector<SessionNote> list_session_notes(const std::string& session_public_id) = 0;  // oldest first
  // Signs a session off exactly once: false (and nothing written) if it was signed off already.
  // kNotFound for an unknown session or user.
  virtual bool sign_off_session(const SessionSignOff& s) = 0;
  virtual std::optional<SessionSignOff> get_session_sign_off(const std::string& session_public_id) = 0;

  // set_score and set_session_state with their audit row ("session_scored"; "session_<state>",
  // with the state before and after) in one transaction, for writers outside the HTTP API (the
  // DDS ingest: actor {nullopt, "worker"}). The row is written only when the call changes
  // something; the return value is the plain call's.
  virtual bool set_score_audited(const ScoreRecord& s, const std::string& now, const Actor& actor) = 0;
  virtual bool set_session_state_audited(const std::string& public_id, SessionPhase state,
                                         const std::string& reason, const std::string& now, const Actor& actor) = 0;
};

// Exam records, kept as written, and their corrections.
class ExamStore {
 public:
  virtual ~ExamStore() = default;

  // Exam records are written once and kept as written: the schema refuses UPDATE and DELETE on
  // them, on an exam session once it is over (but for its first score), on its scores, events and
  // logs, and on a finished theory paper; a correction is a new record (add_exam_correction).
  virtual int64_t add_exam(const ExamRecord& r) = 0;  // id ignored; synchronous=FULL
  virtual std::optional<ExamRecord> get_exam(int64_t id) = 0;  // nullopt if no such exam
  // Adds a correction (id ignored); kNotFound for an unknown exam or user, kInvalid for an empty
  // reason or a correction that is not a JSON object. synchronous=FULL. Returns its id.
  virtual int64_t add_exam_correction(const ExamCorrection& c) = 0;
  virtual std::vector<ExamCorrection> list_exam_corrections(int64_t exam_id) = 0;  // oldest first

  // As find_pupils, of exam records.
  virtual ExamPage find_exams(const ExamFilter& f, int limit, int offset) = 0;
};

// Licences and the certificates issued with them.
class LicenceStore {
 public:
  virtual ~LicenceStore() = default;

  // A licence issued to a pupil, due its re-evaluation three years on (OSHA 1910.178(l)(4)).
  virtual int64_t add_licence(int64_t pupil_id, const std::string& issued_at, const std::string& issued_by) = 0;

  // Certificates, append-only like their revocations. add_certificate: id ignored; kConflict for
  // a number taken or a licence that has one; kNotFound for an unknown pupil, licence or user;
  // kInvalid for a licence of another pupil or an empty number. synchronous=FULL.
  virtual int64_t add_certificate(const CertificateRecord& c) = 0;
  virtual std::optional<CertificateRecord> find_certificate(const std::string& number) = 0;
  virtual std::vector<CertificateRecord> list_certificates(int64_t pupil_id) = 0;  // oldest first
  // kConflict if the certificate is revoked already; kNotFound for an unknown one or user;
  // kInvalid for an empty reason. Returns its id.
  virtual int64_t revoke_certificate(const CertificateRevocation& r) = 0;
  virtual std::optional<CertificateRevocation> certificate_revocation(int64_t certificate_id) = 0;
};

// Theory papers handed out, finished once, and instructors' unlocks of further attempts.
class TheoryStore {
 public:
  virtual ~TheoryStore() = default;

  // A theory paper handed out (id ignored; exam_id, finished_at, outcome and result must be empty;
  // kNotFound for an unknown pupil or user). Returns its id.
  virtual int64_t create_theory_attempt(const TheoryAttempt& a) = 0;
  virtual std::optional<TheoryAttempt> get_theory_attempt(int64_t id) = 0;
  // Finishes an exam paper exactly once: adds `r` (a theory record of the attempt's pupil) as its
  // exam record and links it, with `outcome` and finished_at = r.taken_at, in one transaction
  // written with synchronous=FULL. kNotFound for an unknown attempt, kInvalid if the attempt is a
  // practice paper or `r` is not a theory record of its pupil, kConflict if it was finished
  // already. Returns the exam record's id.
  virtual int64_t finish_theory_attempt(int64_t attempt_id, const ExamRecord& r,
                                        PaperOutcome outcome = PaperOutcome::kMarked) = 0;
  // Finishes a practice paper exactly once, keeping its marking (`result`, JSON text). kNotFound
  // for an unknown attempt, kInvalid for an exam paper, kConflict if it was finished already.
  virtual void finish_practice_attempt(int64_t attempt_id, PaperOutcome outcome, const std::string& result,
                                       const std::string& finished_at) = 0;
  // A pupil's papers, exams and practice alike, oldest first.
  virtual std::vector<TheoryAttempt> list_theory_attempts(int64_t pupil_id) = 0;
  // Every paper not yet finished that has a deadline, oldest first (the server ends those whose
  // time is up).
  virtual std::vector<TheoryAttempt> open_theory_attempts() = 0;
  // Adds an unlock (id ignored); kNotFound for an unknown pupil or user. Returns its id.
  virtual int64_t add_theory_unlock(const TheoryUnlock& u) = 0;
  virtual std::vector<TheoryUnlock> list_theory_unlocks(int64_t pupil_id) = 0;  // oldest first
};

// The exam hash chain.
class ChainStore {
 public:
  virtual ~ChainStore() = default;

  // The exam hash chain, append-only (the schema refuses UPDATE and DELETE). kConflict unless
  // seq follows the last entry's and the session has none yet; kNotFound for an unknown session.
  virtual void append_chain_entry(const ChainEntry& e) = 0;
  virtual std::optional<ChainEntry> last_chain_entry() = 0;
  virtual std::optional<ChainEntry> get_chain_entry(const std::string& session_public_id) = 0;
  virtual std::vector<ChainEntry> list_chain() = 0;  // in order
  // How many entries the chain holds: the last entry's seq unless rows were deleted around the
  // schema's triggers (a gap).
  virtual int64_t count_chain_entries() = 0;
  // Exam sessions with a signed log ("signature" session log) but no chain entry yet, oldest
  // first: a server that stopped between a worker's exit and the chaining picks them up again.
  virtual std::vector<std::string> unchained_signed_exams() = 0;
};

// The audit logs of changes to pupils' records and to staff accounts.
class AuditStore {
 public:
  virtual ~AuditStore() = default;

  // The audit log, append-only: the schema itself refuses UPDATE and DELETE on it. Add a row in
  // the same batch() as the change it records, so that both commit or neither. kNotFound for an
  // unknown pupil or actor user; kInvalid for an empty actor name or action, or details that are
  // not a JSON object. Returns the row's id.
  virtual int64_t add_audit(const AuditRecord& r) = 0;
  // Rows in `scope`, newest first.
  virtual std::vector<AuditRecord> list_audit(const AuditScope& scope, int limit, int offset) = 0;

  // The staff audit log, append-only as the audit log is, and added to the same way (in the batch
  // of the change). kNotFound for an unknown account or actor user; kInvalid as add_audit.
  virtual int64_t add_staff_audit(const StaffAuditRecord& r) = 0;
  // Rows about the accounts of `school_id` (only `user_id`'s when set), newest first.
  virtual std::vector<StaffAuditRecord> list_staff_audit(int64_t school_id, std::optional<int64_t> user_id, int limit,
                                                         int offset) = 0;
};

// The whole store: each aggregate's interface above, and what concerns the database as a whole.
// A part of the server that touches some aggregates only can take their interfaces (a Store is
// each of them).
class Store : public AccountStore,
              public LoginStore,
              public PupilStore,
              public CabStore,
              public SessionStore,
              public ExamStore,
              public LicenceStore,
              public TheoryStore,
              public ChainStore,
              public AuditStore {
 public:
  // Opens the store at `location`: a PostgreSQL connection URI ("postgresql://" or "postgres://",
  // is_postgresql_location) opens PostgreSQL, anything else is an SQLite file's path.
  static std::unique_ptr<Store> open(const std::string& location);
  // Opens (creating if need be) an SQLite database and applies pending migrations.
  static std::unique_ptr<Store> open_sqlite(const std::string& path);
  // Connects to a PostgreSQL database (a libpq connection URI or "key=value" string; the
  // password best comes from ~/.pgpass or PGPASSWORD, not the URI) and applies pending
  // migrations, one server at a time. The database must exist; the tables are made in it.
  // kIo if it cannot connect, naming the location without its password.
  static std::unique_ptr<Store> open_postgresql(const std::string& conninfo);
  virtual ~Store() = default;

  virtual int schema_version() = 0;

  // Why the store could not write just now, as StorageUnavailable::reason() words it, or nullopt
  // when it sees nothing wrong; writes nothing. SQLite looks at the database's file system (read
  // only, or out of room); PostgreSQL asks its server (reachable, and not read-only). A full disk
  // on the PostgreSQL server shows only when a write fails.
  virtual std::optional<std::string> storage_problem() = 0;

  // The plans of the statements that `calls` run on this store, which run as usual: one text each,
  // the statement's SQL and, after a line break, its plan as the database gives it (EXPLAIN on
  // PostgreSQL, EXPLAIN QUERY PLAN on SQLite, with the values bound). For the tests that keep every
  // list on an index, and for an administrator asking why a page is slow.
  virtual std::vector<std::string> query_plans(const std::function<void()>& calls) = 0;

  // Runs `writes` (calls on this Store) as one transaction: all of them or, if it throws, none
  // (the exception propagates). For imports and bulk loads: one commit instead of one per row.
  // Batches do not nest (kInvalid).
  virtual void batch(const std::function<void()>& writes) = 0;
};

// Whether `location` names a PostgreSQL database ("postgresql://..." or "postgres://...").
bool is_postgresql_location(const std::string& location);
// `location` fit to print: a PostgreSQL URI's password (user:password@, password=...) as "***".
std::string printable_location(const std::string& location);

// ISO-8601 UTC time of the system clock, and the same time `years` or `months` (either may be
// negative) after an ISO time, on the month's last day when the month has not its day.
std::string now_iso8601();
// A time as the store writes times, "YYYY-MM-DDTHH:MM:SSZ" (UTC).
std::string iso8601_of(std::time_t t);
std::string add_years_iso8601(const std::string& iso, int years);
std::string add_months_iso8601(const std::string& iso, int months);

}  // namespace forklift::store
