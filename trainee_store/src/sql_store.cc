// The trainee store written once, in SQL, over a driver (sql_driver.h): SQLite (sqlite_driver.cc)
// or PostgreSQL (postgres_driver.cc). Every statement of the store lives in this file, with
// SQLite's parameters; the dialect supplies the few fragments in which the two differ.
//
// Several servers may share one PostgreSQL database, so what SQLite gets from its one writer at a
// time is spelled out: every transaction that writes takes the database's write lock first
// (TxKind::kWrite), so reads inside it see the rows it replaces and two appends to the exam chain
// cannot interleave; single statements are atomic by themselves and exactly-once rests on unique
// keys (INSERT ... ON CONFLICT DO NOTHING) and guarded updates.
#include "forklift/store/store.h"

#include "common.h"
#include "rules.h"
#include "sql_driver.h"

#include <algorithm>
#include <iterator>
#include <regex>
#include <type_traits>
#include <utility>
#include <vector>

namespace forklift::store::detail {

namespace {

// Column lists shared by the statements that read whole rows (read_user and the like in
// common.h); a session's are the dialect's (Dialect::session_columns).
#define USER_COLUMNS "id, username, password_hash, role, school_id, pupil_id, full_name, active, login_generation"
#define PUPIL_COLUMNS "pupils.id, pupils.school_id, pupils.name, pupils.email, pupils.created_at, pupils.group_id"
#define AUDIT_COLUMNS "id, at, actor_user_id, actor, pupil_id, action, details"
#define STAFF_AUDIT_COLUMNS "id, at, actor_user_id, actor, user_id, action, details"
#define THEORY_ATTEMPT_COLUMNS \
  "id, pupil_id, seed, questions, started_at, started_by, exam_id, kind, deadline, finished_at, outcome, result"
#define CERTIFICATE_COLUMNS "id, number, pupil_id, licence_id, issued_at, issued_by, record, signature"
#define CORRECTION_COLUMNS "id, exam_id, corrected_by, at, reason, correction"
#define REVOCATION_COLUMNS "id, certificate_id, revoked_by, at, reason"
#define GROUP_COLUMNS \
  "g.id, g.school_id, g.name, g.instructor_id, g.created_at, (SELECT COUNT(*) FROM pupils p WHERE p.group_id = g.id)"
#define BOOKING_COLUMNS                                                                                          \
  "b.id, b.school_id, b.pupil_id, b.cab_id, b.starts_at, b.ends_at, b.scenario, b.mode, b.instructor_id, "       \
  "COALESCE(s.public_id, ''), b.created_at, p.name FROM bookings b JOIN pupils p ON p.id = b.pupil_id "          \
  "LEFT JOIN sessions s ON s.id = b.session_id"
#define EXAM_ROWS                                                                                           \
  "e.id, e.pupil_id, e.kind, s.public_id, e.score, e.passed, e.examiner_id, e.taken_at, e.details FROM exams e " \
  "LEFT JOIN sessions s ON s.id = e.session_id"

// session_outcome() in SQL, of a session whose phase, end reason and task-incomplete flag are the
// SQL expressions `state`, `reason` and `task_left` (true or false): written out from
// session_outcome() itself, phase by phase and reason by reason, so that the outcome the store
// keeps on the session row (migration 16) is the one the C++ rule gives.
std::string outcome_sql(const std::string& state, const std::string& reason, const std::string& task_left) {
  const auto outcome = [](SessionPhase phase, const std::string& why, bool task) {
    Session s;
    s.state = phase;
    s.reason = why;
    s.task_left_unfinished = task;
    return std::string("'") + name(session_outcome(s)) + "'";
  };
  // Every end reason's word, the evaluation's "parked", and last any other word (here, none).
  std::vector<std::string> reasons;
  for (int i = 0;; ++i) {
    const auto r = static_cast<EndReason>(i);
    if (parse<EndReason>(name(r)) != r) break;
    reasons.push_back(name(r));
  }
  reasons.push_back("parked");
  // One phase's outcome by its reason: a CASE over the reasons whose outcome is not the others'.
  const auto by_reason = [&](SessionPhase phase) {
    const auto of = [&](const std::string& why) {
      const std::string done = outcome(phase, why, false), left = outcome(phase, why, true);
      return done == left ? done : "CASE WHEN " + task_left + " THEN " + left + " ELSE " + done + " END";
    };
    const std::string other = of("");
    std::string cases;
    for (const std::string& why : reasons)
      if (const std::string o = of(why); o != other) cases += " WHEN '" + why + "' THEN " + o;
    return cases.empty() ? other : "CASE " + reason + cases + " ELSE " + other + " END";
  };
  std::string sql = "CASE " + state;
  for (int i = 0;; ++i) {
    const auto phase = static_cast<SessionPhase>(i);
    if (parse<SessionPhase>(name(phase)) != phase) break;
    sql += std::string(" WHEN '") + name(phase) + "' THEN " + by_reason(phase);
  }
  return sql + " END";
}

// A row of "c.seq, s.public_id, c.entry" (exam_chain c joined with its session s).
ChainEntry read_chain_entry(const Query& q) { return ChainEntry{q.int64(0), q.text(1), q.text(2)}; }

// A login token's row (?1 its hash) with its account, as read_login_token() reads it.
constexpr const char* kFindLoginToken =
    "SELECT " USER_COLUMNS ", t.generation, t.expires_at_ms FROM login_tokens t JOIN users ON users.id = t.user_id "
    "WHERE t.hash = ?1";

class SqlStore final : public Store {
 public:
  SqlStore(std::unique_ptr<Driver> driver, const Dialect& dialect)
      : driver_(std::move(driver)), d_(*driver_), dialect_(dialect) {
    migrate();
  }

  int schema_version() override {
    Transaction tx(d_, __func__, TxKind::kStatement);
    Query q(d_, __func__, "SELECT COALESCE(MAX(version), 0) FROM schema_migrations");
    q.step();
    const int version = static_cast<int>(q.int64(0));
    tx.commit();
    return version;
  }

  std::optional<std::string> storage_problem() override { return d_.storage_problem(); }

  std::vector<std::string> query_plans(const std::function<void()>& calls) override {
    std::vector<std::string> plans;
    d_.explain_into(&plans);
    try {
      calls();
    } catch (...) {
      d_.explain_into(nullptr);
      throw;
    }
    d_.explain_into(nullptr);
    return plans;
  }

  void batch(const std::function<void()>& writes) override {
    require(!d_.in_transaction(), StoreError::kInvalid, __func__, "batches do not nest");
    Durable durable(d_, __func__);  // the batch may hold exam results
    Transaction tx(d_, __func__, TxKind::kWrite);
    writes();
    tx.commit();
  }

  int64_t create_school(const std::string& name) override {
    require(!name.empty(), StoreError::kInvalid, __func__, "empty school name");
    return inserted(__func__, Query(d_, __func__, "INSERT INTO schools(name) VALUES (?1) RETURNING id").bind(name));
  }

  // The language column of users or pupils (migration 14), one row by id.
  std::string language_of(const std::string& table, const char* op, int64_t id) {
    Query q(d_, op, "SELECT language FROM " + table + " WHERE id = ?1");
    const auto found = first_row(op, q.bind(id), [](const Query& r) { return r.text(0); });
    require(found.has_value(), StoreError::kNotFound, op, "no " + table.substr(0, table.size() - 1) + " " + std::to_string(id));
    return *found;
  }
  void set_language(const std::string& table, const char* op, int64_t id, const std::string& language) {
    static const std::regex form("[A-Za-z0-9_-]{2,16}");
    require(std::regex_match(language, form), StoreError::kInvalid, op, "'" + language + "' is not a language's name");
    Transaction tx(d_, op, TxKind::kStatement);
    Query q(d_, op, "UPDATE " + table + " SET language = ?1 WHERE id = ?2");
    require(q.bind(language).bind(id).changes() > 0, StoreError::kNotFound, op,
            "no " + table.substr(0, table.size() - 1) + " " + std::to_string(id));
    tx.commit();
  }

  int64_t create_user(const std::string& username, const std::string& password_hash, Role role, int64_t school_id,
                      std::optional<int64_t> pupil_id, const std::string& full_name) override {
    check_username(__func__, username);
    Transaction tx(d_, __func__, TxKind::kStatement);
    Query q(d_, __func__, dialect_.insert_user);
    q.bind(username).bind(password_hash).bind(std::string(role_name(role))).bind(school_id).bind(pupil_id).bind(full_name);
    require(q.step(), StoreError::kConflict, __func__, "username '" + username + "' is taken");
    const int64_t id = q.int64(0);
    q.run();  // the insert is complete (and, outside a transaction, committed) when it has no more rows
    tx.commit();
    return id;
  }

  void set_user_full_name(int64_t id, const std::string& full_name) override {
    Transaction tx(d_, __func__, TxKind::kStatement);
    Query q(d_, __func__, "UPDATE users SET full_name = ?1 WHERE id = ?2");
    require(q.bind(full_name).bind(id).changes() > 0, StoreError::kNotFound, __func__, "no user " + std::to_string(id));
    tx.commit();
  }

  std::string user_language(int64_t id) override { return language_of("users", __func__, id); }
  void set_user_language(int64_t id, const std::string& language) override { set_language("users", __func__, id, language); }
  std::string pupil_language(int64_t id) override { return language_of("pupils", __func__, id); }
  void set_pupil_language(int64_t id, const std::string& language) override { set_language("pupils", __func__, id, language); }

  std::optional<School> get_school(int64_t id) override {
    Query q(d_, __func__, "SELECT id, name FROM schools WHERE id = ?1");
    return first_row(__func__, q.bind(id), [](const Query& r) { return School{r.int64(0), r.text(1)}; });
  }

  std::optional<User> find_user(const std::string& username) override {
    Query q(d_, __func__,
            "SELECT " USER_COLUMNS " FROM users WHERE " + dialect_.equal_folded("username", "?1") +
                " ORDER BY username = ?1 DESC, id LIMIT 1");
    return first_row(__func__, q.bind(username), read_user<Query>);
  }

  std::optional<User> get_user(int64_t id) override {
    Query q(d_, __func__, "SELECT " USER_COLUMNS " FROM users WHERE id = ?1");
    return first_row(__func__, q.bind(id), read_user<Query>);
  }

  UserPage list_users(const UserFilter& f, int limit, int offset) override {
    require(limit >= 0 && offset >= 0, StoreError::kInvalid, __func__, "negative limit or offset");
    Transaction tx(d_, __func__, TxKind::kRead);
    // ?1 school, ?2 pupils too, ?3 role or NULL, ?4 active or NULL.
#define USERS_WHERE                                                                                   \
  " FROM users WHERE school_id = ?1 AND (?2 OR role <> 'pupil') AND (CAST(?3 AS TEXT) IS NULL OR role = ?3) " \
  "AND (CAST(?4 AS BOOLEAN) IS NULL OR active = ?4)"
    const auto bind_filter = [&](Query& q) -> Query& {
      q.bind(f.school_id).bind(f.include_pupils);
      return q.bind(f.role ? std::optional<std::string>(role_name(*f.role)) : std::nullopt).bind(f.active);
    };
    UserPage page;
    {
      Query q(d_, __func__, "SELECT COUNT(*)" USERS_WHERE);
      bind_filter(q).step();
      page.total = q.int64(0);
    }
    Query q(d_, __func__,
            "SELECT " USER_COLUMNS USERS_WHERE " ORDER BY full_name = '', " + dialect_.folded("full_name") + ", " +
                dialect_.bytewise("username") + ", id LIMIT ?5 OFFSET ?6");
#undef USERS_WHERE
    bind_filter(q).bind(limit).bind(offset);
    while (q.step()) page.users.push_back(read_user(q));
    tx.commit();
    return page;
  }

  void set_user_password(int64_t id, const std::string& password_hash) override {
    Transaction tx(d_, __func__, TxKind::kStatement);
    Query q(d_, __func__, "UPDATE users SET password_hash = ?1, login_generation = login_generation + 1 WHERE id = ?2");
    require(q.bind(password_hash).bind(id).changes() > 0, StoreError::kNotFound, __func__, "no user " + std::to_string(id));
    tx.commit();
  }

  bool set_user_active(int64_t id, bool active) override {
    // The write lock: two admins deactivating each other one after the other, the second sees the first.
    Transaction tx(d_, __func__, TxKind::kWrite);
    const std::optional<User> u = get_user(id);
    require(u.has_value(), StoreError::kNotFound, __func__, "no user " + std::to_string(id));
    if (u->active == active) return false;
    if (!active && u->role == Role::kAdmin) {
      Query q(d_, __func__, "SELECT COUNT(*) FROM users WHERE school_id = ?1 AND role = 'admin' AND active = TRUE AND id <> ?2");
      q.bind(u->school_id).bind(id).step();
      check_deactivation(__func__, *u, q.int64(0));
    }
    Query(d_, __func__, "UPDATE users SET active = ?1, login_generation = login_generation + ?2 WHERE id = ?3")
        .bind(active).bind(active ? 0 : 1).bind(id).run();
    tx.commit();
    return true;
  }

  int64_t create_pupil(int64_t school_id, const std::string& name, const std::string& email) override {
    require(!name.empty(), StoreError::kInvalid, __func__, "empty pupil name");
    Query q(d_, __func__, "INSERT INTO pupils(school_id, name, email, created_at) VALUES (?1, ?2, ?3, ?4) RETURNING id");
    return inserted(__func__, q.bind(school_id).bind(name).bind(email).bind(now_iso8601()));
  }

  std::optional<Pupil> get_pupil(int64_t id) override {
    Transaction tx(d_, __func__, TxKind::kStatement);
    std::optional<Pupil> p = pupil(__func__, id);
    tx.commit();
    return p;
  }

  void update_pupil(int64_t id, const std::string& name, const std::string& email) override {
    require(!name.empty(), StoreError::kInvalid, __func__, "empty pupil name");
    Transaction tx(d_, __func__, TxKind::kStatement);
    Query q(d_, __func__, "UPDATE pupils SET name = ?1, email = ?2 WHERE id = ?3");
    require(q.bind(name).bind(email).bind(id).changes() > 0, StoreError::kNotFound, __func__,
            "no pupil " + std::to_string(id));
    tx.commit();
  }

  std::vector<Pupil> list_pupils(int64_t school_id, const std::string& search, int limit, int offset) override {
    require(limit >= 0 && offset >= 0, StoreError::kInvalid, __func__, "negative limit or offset");
    Transaction tx(d_, __func__, TxKind::kRead);
    require_school(__func__, school_id);
    Query q(d_, __func__,
            "SELECT " PUPIL_COLUMNS " FROM pupils WHERE school_id = ? AND " + dialect_.like_folded("name") +
                " ORDER BY " + dialect_.folded("name") + ", id LIMIT ? OFFSET ?");
    q.bind(school_id).bind(contains_pattern(search)).bind(limit).bind(offset);
    std::vector<Pupil> pupils;
    while (q.step()) pupils.push_back(read_pupil(q));
    tx.commit();
    return pupils;
  }

  PupilPage find_pupils(const PupilFilter& f, int limit, int offset) override {
    check_page(__func__, limit, offset);
    const std::string order =
        order_by(__func__,
                 {{"name", dialect_.folded("pupils.name")},
                  {"email", dialect_.folded("pupils.email")},
                  {"created_at", "pupils.created_at"},
                  {"group", dialect_.folded("COALESCE((SELECT g.name FROM pupil_groups g WHERE g.id = pupils.group_id), '')")}},
                 f.sort, f.descending, "pupils.id");
    Transaction tx(d_, __func__, TxKind::kRead);
    require_school(__func__, f.school_id);
    Conditions where;
    where.add("pupils.school_id = ?", {f.school_id});
    if (!f.search.empty()) {
      const std::string like = contains_pattern(f.search);
      where.add("(" + dialect_.like_folded("pupils.name") + " OR " + dialect_.like_folded("pupils.email") + ")", {like, like});
    }
    if (f.group_id == 0) where.add("pupils.group_id IS NULL");
    else if (f.group_id) where.add("pupils.group_id = ?", {*f.group_id});
    if (f.instructor_id)
      where.add("pupils.group_id IN (SELECT id FROM pupil_groups WHERE instructor_id = ?)", {*f.instructor_id});
    PupilPage page;
    list_total(__func__, page, f.search.empty() && !f.group_id && !f.instructor_id, "pupils", f.school_id, " FROM pupils" + where.sql(), where);
    Conditions bound = where;
    if (f.after) {
      // Keyset paging: the rows after the cursor's (its sort key, then id), found in the index
      // where an offset would walk past every row before them.
      require(!f.first_for && f.sort != "group", StoreError::kInvalid, __func__,
              "'after' pages a list sorted by name, email or when added, without an instructor's pupils first");
      const std::string key = f.sort == "name" ? dialect_.folded("pupils.name")
                              : f.sort == "email" ? dialect_.folded("pupils.email") : std::string("pupils.created_at");
      Query cursor(d_, __func__, "SELECT " + key + " FROM pupils WHERE pupils.id = ?1 AND pupils.school_id = ?2");
      require(cursor.bind(*f.after).bind(f.school_id).step(), StoreError::kNotFound, __func__,
              "no pupil " + std::to_string(*f.after) + " in the school");
      add_after(bound, key, "pupils.id", cursor.text(0), *f.after, f.descending);
    }
    // An instructor's own pupils first: a first sort key ahead of the one asked for.
    std::string sql = "SELECT " PUPIL_COLUMNS " FROM pupils" + bound.sql() + " ORDER BY ";
    if (f.first_for) {
      sql += "EXISTS (SELECT 1 FROM pupil_groups g WHERE g.id = pupils.group_id AND g.instructor_id = ?) DESC, ";
      bound.add_value(*f.first_for);
    }
    sql += order;
    Query q(d_, __func__, (sql + " LIMIT ? OFFSET ?").c_str());
    bound.bind(q);
    q.bind(limit).bind(offset);
    while (q.step()) page.pupils.push_back(read_pupil(q));
    tx.commit();
    return page;
  }

  SessionPage find_sessions(const SessionFilter& f, int limit, int offset) override {
    check_page(__func__, limit, offset);
    check_result_filter(__func__, f);
    const std::string order = order_by(__func__,
                                       {{"created_at", "sessions.created_at"},
                                        {"pupil", dialect_.folded("p.name")},
                                        {"cab", dialect_.bytewise("sessions.cab_id")},
                                        {"scenario", dialect_.bytewise("sessions.scenario")},
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
      where.add("(" + dialect_.like_folded("p.name") + " OR " + dialect_.like_folded("p.email") + ")", {like, like});
    }
    if (!f.from.empty()) where.add("sessions.created_at >= ?", {f.from});
    if (!f.to.empty()) where.add("sessions.created_at < ?", {f.to});
    if (!f.cab_id.empty()) where.add("sessions.cab_id = ?", {f.cab_id});
    if (!f.scenario.empty()) where.add("sessions.scenario = ?", {f.scenario});
    if (f.mode) where.add("sessions.mode = ?", {std::string(name(*f.mode))});
    if (f.instructor_id) where.add("sessions.started_by = ?", {*f.instructor_id});
    if (f.group_id) where.add("p.group_id = ?", {*f.group_id});
    if (f.outcome) where.add("sessions.outcome = ?", {std::string(name(*f.outcome))});
    if (f.result == "passed") where.add(SESSION_COMPLETED_PASSED("sessions."));
    // Over, and not completed and passed (a completed session without a score among them).
    if (f.result == "not_passed")
      where.add("sessions.outcome <> 'open' AND (sessions.outcome <> 'completed' OR sessions.passed IS NOT TRUE)");
    const std::string from = " FROM sessions JOIN pupils p ON p.id = sessions.pupil_id" + where.sql();
    require(f.after.empty() || f.sort == "created_at", StoreError::kInvalid, __func__, "'after' pages a list sorted by created_at");
    Transaction tx(d_, __func__, TxKind::kRead);
    SessionPage page;
    // Counted without the pupils unless a filter needs them.
    const bool by_pupil = !f.search.empty() || f.group_id;
    const bool whole_school = !f.pupil_id && f.search.empty() && f.from.empty() && f.to.empty() && f.cab_id.empty() &&
                              f.scenario.empty() && !f.mode && !f.instructor_id && !f.group_id && !f.outcome && f.result.empty();
    list_total(__func__, page, whole_school, "sessions", f.school_id, by_pupil ? from : " FROM sessions" + where.sql(), where);
    Conditions bound = where;
    if (!f.after.empty()) {
      Query cursor(d_, __func__, "SELECT created_at, id FROM sessions WHERE public_id = ?1 AND school_id = ?2");
      require(cursor.bind(f.after).bind(f.school_id).step(), StoreError::kNotFound, __func__,
              "no session '" + f.after + "' in the school");
      add_after(bound, "sessions.created_at", "sessions.id", cursor.text(0), cursor.int64(1), f.descending);
    }
    // The page reads sessions first on SQLite (its CROSS JOIN fixes the join order): through the
    // index of their order or filter, it stops after a page; pupils first, it sorted every session
    // of the day (35 ms for a day of 10,000 sessions, 0.3 ms so). The count keeps the planner's order.
    Query q(d_, __func__, std::string("SELECT ") + dialect_.session_columns + ", p.name FROM " + dialect_.sessions_from + " " +
                              dialect_.session_page_join + " pupils p ON p.id = sessions.pupil_id" + bound.sql() + " ORDER BY " +
                              order + " LIMIT ? OFFSET ?");
    bound.bind(q);
    q.bind(limit).bind(offset);
    while (q.step()) page.sessions.push_back({read_session(q), q.text(15)});
    tx.commit();
    return page;
  }

  ExamPage find_exams(const ExamFilter& f, int limit, int offset) override {
    check_page(__func__, limit, offset);
    const std::string order = order_by(__func__,
                                       {{"taken_at", "e.taken_at"},
                                        {"pupil", dialect_.folded("p.name")},
                                        {"kind", "e.kind"},
                                        {"score", "e.score"}},
                                       f.sort, f.descending, "e.id");
    Conditions where;
    where.add("e.school_id = ?", {f.school_id});
    if (f.pupil_id) where.add("e.pupil_id = ?", {*f.pupil_id});
    if (!f.search.empty()) {
      const std::string like = contains_pattern(f.search);
      where.add("(" + dialect_.like_folded("p.name") + " OR " + dialect_.like_folded("p.email") + ")", {like, like});
    }
    if (f.kind) where.add("e.kind = ?", {std::string(name(*f.kind))});
    if (!f.from.empty()) where.add("e.taken_at >= ?", {f.from});
    if (!f.to.empty()) where.add("e.taken_at < ?", {f.to});
    if (f.passed) where.add(*f.passed ? "e.passed = TRUE" : "e.passed = FALSE");
    if (f.examiner_id) where.add("e.examiner_id = ?", {*f.examiner_id});
    if (f.group_id) where.add("p.group_id = ?", {*f.group_id});
    // Counted from the exams' indexes by school alone unless a filter is on the pupil's row.
    const bool by_pupil_row = !f.search.empty() || f.group_id;
    const std::string from = std::string(" FROM exams e") + (by_pupil_row ? " JOIN pupils p ON p.id = e.pupil_id" : "") + where.sql();
    // The page reads exams first (SQLite's CROSS JOIN) unless a filter picks pupils: with the
    // statistics of a store of 600,000 exams SQLite read every pupil's exams and sorted them all
    // for a page of 50 (1.2 s).
    const std::string page_join = " FROM exams e " + std::string(by_pupil_row ? "JOIN" : dialect_.session_page_join) +
                                  " pupils p ON p.id = e.pupil_id";
    require(!f.after || f.sort == "taken_at", StoreError::kInvalid, __func__, "'after' pages a list sorted by taken_at");
    Transaction tx(d_, __func__, TxKind::kRead);
    ExamPage page;
    const bool whole_school = !f.pupil_id && f.search.empty() && !f.kind && f.from.empty() && f.to.empty() && !f.passed &&
                              !f.examiner_id && !f.group_id;
    list_total(__func__, page, whole_school, "exams", f.school_id, from, where);
    Conditions bound = where;
    if (f.after) {
      Query cursor(d_, __func__, "SELECT taken_at FROM exams WHERE id = ?1 AND school_id = ?2");
      require(cursor.bind(*f.after).bind(f.school_id).step(), StoreError::kNotFound, __func__,
              "no exam " + std::to_string(*f.after) + " in the school");
      add_after(bound, "e.taken_at", "e.id", cursor.text(0), *f.after, f.descending);
    }
    // A practical exam's session looked up for the page's rows alone: joined, PostgreSQL's planner
    // hashed every session of the store to find the few the exams have.
    Query q(d_, __func__, ("SELECT e.id, e.pupil_id, e.kind, (SELECT s.public_id FROM sessions s WHERE s.id = e.session_id), e.score, e.passed, e.examiner_id, e.taken_at, "
                               "e.details, p.name, (SELECT COUNT(*) FROM exam_corrections c WHERE c.exam_id = e.id)" +
                               page_join + bound.sql() + " ORDER BY " + order + " LIMIT ? OFFSET ?")
                                  .c_str());
    bound.bind(q);
    q.bind(limit).bind(offset);
    while (q.step()) page.exams.push_back({read_exam(q), q.text(9), q.int64(10)});
    tx.commit();
    return page;
  }

  int64_t create_group(int64_t school_id, const std::string& name, std::optional<int64_t> instructor_id) override {
    require(!name.empty(), StoreError::kInvalid, __func__, "empty group name");
    Transaction tx(d_, __func__, TxKind::kWrite);
    require_school(__func__, school_id);
    check_instructor(__func__, school_id, instructor_id);
    Query q(d_, __func__,
            "INSERT INTO pupil_groups(school_id, name, instructor_id, created_at) VALUES (?1, ?2, ?3, ?4) RETURNING id");
    const int64_t id = q.bind(school_id).bind(name).bind(instructor_id).bind(now_iso8601()).returned_id();
    tx.commit();
    return id;
  }

  std::optional<Group> get_group(int64_t id) override {
    Query q(d_, __func__, "SELECT " GROUP_COLUMNS " FROM pupil_groups g WHERE g.id = ?1");
    return first_row(__func__, q.bind(id), read_group<Query>);
  }

  std::vector<Group> list_groups(int64_t school_id) override {
    Query q(d_, __func__, "SELECT " GROUP_COLUMNS " FROM pupil_groups g WHERE g.school_id = ?1 ORDER BY " + dialect_.folded("g.name") + ", g.id");
    return rows(__func__, q.bind(school_id), read_group<Query>);
  }

  void update_group(int64_t id, const std::string& name, std::optional<int64_t> instructor_id) override {
    require(!name.empty(), StoreError::kInvalid, __func__, "empty group name");
    Transaction tx(d_, __func__, TxKind::kWrite);
    const std::optional<Group> g = get_group(id);
    require(g.has_value(), StoreError::kNotFound, __func__, "no group " + std::to_string(id));
    check_instructor(__func__, g->school_id, instructor_id);
    Query(d_, __func__, "UPDATE pupil_groups SET name = ?1, instructor_id = ?2 WHERE id = ?3").bind(name).bind(instructor_id).bind(id).run();
    tx.commit();
  }

  void set_pupil_group(int64_t pupil_id, std::optional<int64_t> group_id) override {
    Transaction tx(d_, __func__, TxKind::kWrite);
    const std::optional<Pupil> p = pupil(__func__, pupil_id);
    require(p.has_value(), StoreError::kNotFound, __func__, "no pupil " + std::to_string(pupil_id));
    if (group_id) {
      const std::optional<Group> g = get_group(*group_id);
      require(g.has_value(), StoreError::kNotFound, __func__, "no group " + std::to_string(*group_id));
      require(g->school_id == p->school_id, StoreError::kInvalid, __func__, "group and pupil are of different schools");
    }
    Query(d_, __func__, "UPDATE pupils SET group_id = ?1 WHERE id = ?2").bind(group_id).bind(pupil_id).run();
    tx.commit();
  }

  int64_t create_booking(const Booking& b) override {
    check_booking(__func__, b);
    Transaction tx(d_, __func__, TxKind::kWrite);  // the check and the insert under one write lock
    const std::optional<Pupil> p = pupil(__func__, b.pupil_id);
    require(p.has_value(), StoreError::kNotFound, __func__, "no pupil " + std::to_string(b.pupil_id));
    check_instructor(__func__, p->school_id, b.instructor_id);
    {
      Query q(d_, __func__, "SELECT starts_at, ends_at FROM bookings WHERE cab_id = ?1 AND starts_at < ?2 AND ends_at > ?3 LIMIT 1");
      q.bind(b.cab_id).bind(b.ends_at).bind(b.starts_at);
      if (q.step())
        throw StoreError(StoreError::kConflict, std::string(__func__) + ": cab " + b.cab_id + " is booked from " + q.text(0) +
                                                    " to " + q.text(1));
    }
    Query ins(d_, __func__,
              "INSERT INTO bookings(school_id, pupil_id, cab_id, starts_at, ends_at, scenario, mode, instructor_id, created_at) "
              "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9) RETURNING id");
    ins.bind(p->school_id).bind(b.pupil_id).bind(b.cab_id).bind(b.starts_at).bind(b.ends_at).bind(b.scenario).bind(std::string(name(b.mode)));
    const int64_t id = ins.bind(b.instructor_id).bind(now_iso8601()).returned_id();
    tx.commit();
    return id;
  }

  std::optional<Booking> get_booking(int64_t id) override {
    Query q(d_, __func__, "SELECT " BOOKING_COLUMNS " WHERE b.id = ?1");
    return first_row(__func__, q.bind(id), read_booking<Query>);
  }

  std::vector<Booking> list_bookings(int64_t school_id, const std::string& from, const std::string& to) override {
    Query q(d_, __func__, "SELECT " BOOKING_COLUMNS " WHERE b.school_id = ?1 AND b.starts_at < ?2 AND b.ends_at > ?3 "
                              "ORDER BY " + dialect_.bytewise("b.cab_id") + ", b.starts_at, b.id");
    return rows(__func__, q.bind(school_id).bind(to).bind(from), read_booking<Query>);
  }

  void set_booking_session(int64_t booking_id, const std::string& session_public_id) override {
    Transaction tx(d_, __func__, TxKind::kWrite);
    const std::optional<Booking> b = get_booking(booking_id);
    require(b.has_value(), StoreError::kNotFound, __func__, "no booking " + std::to_string(booking_id));
    require(b->session_public_id.empty(), StoreError::kConflict, __func__, "booking " + std::to_string(booking_id) + " has its session");
    Query(d_, __func__, "UPDATE bookings SET session_id = (SELECT id FROM sessions WHERE public_id = ?1) WHERE id = ?2")
        .bind(session_public_id).bind(booking_id).run();
    require(get_booking(booking_id)->session_public_id == session_public_id, StoreError::kNotFound, __func__,
            "no session '" + session_public_id + "'");
    tx.commit();
  }

  void delete_booking(int64_t booking_id) override {
    Transaction tx(d_, __func__, TxKind::kWrite);
    const std::optional<Booking> b = get_booking(booking_id);
    require(b.has_value(), StoreError::kNotFound, __func__, "no booking " + std::to_string(booking_id));
    require(b->session_public_id.empty(), StoreError::kConflict, __func__, "booking " + std::to_string(booking_id) + " has started");
    Query(d_, __func__, "DELETE FROM bookings WHERE id = ?1").bind(booking_id).run();
    tx.commit();
  }

  void cab_seen(const std::string& cab_id, int64_t school_id, const std::string& now) override {
    require(!cab_id.empty(), StoreError::kInvalid, __func__, "empty cab id");
    Transaction tx(d_, __func__, TxKind::kStatement);
    // A known cab only refreshes last_seen_at; the same id announced by another school is a conflict.
    Query q(d_, __func__,
            "INSERT INTO cabs(id, school_id, last_seen_at) VALUES (?1, ?2, ?3) "
            "ON CONFLICT (id) DO UPDATE SET last_seen_at = excluded.last_seen_at "
            "WHERE cabs.school_id = excluded.school_id");
    require(q.bind(cab_id).bind(school_id).bind(now).changes() > 0, StoreError::kConflict, __func__,
            "cab " + cab_id + " belongs to another school");
    tx.commit();
  }

  std::vector<Cab> list_cabs(int64_t school_id) override {
    Transaction tx(d_, __func__, TxKind::kRead);
    require_school(__func__, school_id);
    Query q(d_, __func__, "SELECT id, school_id, last_seen_at FROM cabs WHERE school_id = ?1 ORDER BY id");
    q.bind(school_id);
    std::vector<Cab> cabs;
    while (q.step()) cabs.push_back(Cab{q.text(0), q.int64(1), q.text(2)});
    tx.commit();
    return cabs;
  }

  Session create_session(int64_t pupil_id, const std::string& cab_id, const std::string& scenario,
                         Mode mode, std::optional<int64_t> examiner_id, const std::string& now,
                         std::optional<int64_t> started_by, const std::string& server) override {
    check_new_session(__func__, cab_id, scenario);
    Transaction tx(d_, __func__, TxKind::kStatement);
    const std::optional<Pupil> of = pupil(__func__, pupil_id);
    require(of.has_value(), StoreError::kNotFound, __func__, "no pupil " + std::to_string(pupil_id));
    Query q(d_, __func__,
            // server_id named only when there is one: the statement as before it existed otherwise.
            std::string("INSERT INTO sessions(pupil_id, cab_id, scenario, mode, state, examiner_id, created_at, started_by, school_id") +
                (server.empty() ? ") VALUES (?1, ?2, ?3, ?4, 'starting', ?5, ?6, ?7, ?8)"
                                : ", server_id) VALUES (?1, ?2, ?3, ?4, 'starting', ?5, ?6, ?7, ?8, ?9)") +
                " RETURNING id, public_id");
    q.bind(pupil_id).bind(cab_id).bind(scenario).bind(std::string(name(mode))).bind(examiner_id).bind(now).bind(started_by).bind(of->school_id);
    if (!server.empty()) q.bind(server);
    q.step();
    Session s;
    s.id = q.int64(0);
    s.public_id = q.text(1);
    q.run();  // the insert is complete when it has no more rows
    s.pupil_id = pupil_id;
    s.cab_id = cab_id;
    s.scenario = scenario;
    s.mode = mode;
    s.state = SessionPhase::kStarting;
    s.examiner_id = examiner_id;
    s.created_at = now;
    s.started_by = started_by;
    tx.commit();
    return s;
  }

  std::optional<Session> get_session(const std::string& public_id) override {
    Transaction tx(d_, __func__, TxKind::kStatement);
    std::optional<Session> s = session(__func__, public_id);
    tx.commit();
    return s;
  }

  std::vector<Session> list_sessions_for_pupil(int64_t pupil_id) override {
    Transaction tx(d_, __func__, TxKind::kRead);
    require(pupil(__func__, pupil_id).has_value(), StoreError::kNotFound, __func__,
            "no pupil " + std::to_string(pupil_id));
    std::vector<Session> sessions = sessions_of(__func__, pupil_id);
    tx.commit();
    return sessions;
  }

  std::vector<Session> open_sessions() override {
    Query q(d_, __func__, std::string("SELECT ") + dialect_.session_columns + " FROM " + dialect_.sessions_from +
                              " WHERE state NOT IN ('ended', 'failed', 'aborted') ORDER BY id");
    return rows(__func__, q, read_session<Query>);
  }

  void server_alive(const std::string& server, const std::string& now) override {
    Query q(d_, __func__,
            "INSERT INTO servers(id, seen_at) VALUES (?1, ?2) ON CONFLICT (id) DO UPDATE SET seen_at = excluded.seen_at");
    changed(__func__, q.bind(server).bind(now));
  }

  std::vector<std::string> claim_sessions(const std::string& server, const std::string& stale_before, bool own,
                                          const std::string& only) override {
    Transaction tx(d_, __func__, TxKind::kStatement);
    // The open sessions' condition spelled as their index's. A server that never said it was
    // alive has no row: its sessions are taken too.
    Query q(d_, __func__,
            std::string("UPDATE sessions SET server_id = ?1 WHERE state NOT IN ('ended', 'failed', 'aborted') AND (server_id IS NULL OR ") +
                (own ? "server_id = ?1 OR " : "") +
                "(server_id <> ?1 AND server_id NOT IN (SELECT id FROM servers WHERE seen_at >= ?2)))" +
                (only.empty() ? "" : " AND public_id = ?3") + " RETURNING id");
    q.bind(server).bind(stale_before);
    if (!only.empty()) q.bind(only);
    std::vector<int64_t> ids;
    while (q.step()) ids.push_back(q.int64(0));
    q.run();
    std::sort(ids.begin(), ids.end());
    std::vector<std::string> taken;
    for (const int64_t id : ids) taken.push_back(session_public_id(id));
    tx.commit();
    return taken;
  }

  std::optional<std::string> session_server(const std::string& public_id) override {
    Transaction tx(d_, __func__, TxKind::kStatement);
    Query q(d_, __func__,
            "SELECT COALESCE(server_id, '') FROM sessions WHERE public_id = ?1 AND state NOT IN ('ended', 'failed', 'aborted')");
    q.bind(public_id);
    std::optional<std::string> server;
    if (q.step()) server = q.text(0);
    tx.commit();
    return server;
  }

  bool set_session_state(const std::string& public_id, SessionPhase state, const std::string& reason,
                         const std::string& now) override {
    Transaction tx(d_, __func__, TxKind::kStatement);
    // One statement, so that two writers cannot both move a session out of an open state: the
    // second one's guard is checked again once the first one's row is committed.
    // Its outcome with it, from the new phase and reason and the score's task flag (a score may
    // come first).
    static const std::string sql = "UPDATE sessions SET state = ?1, reason = ?2, ended_at = ?3, outcome = " +
                                   outcome_sql("CAST(?1 AS TEXT)", "CAST(?2 AS TEXT)", TASK_INCOMPLETE_SQL " IS NOT NULL") +
                                   " WHERE public_id = ?4 AND state NOT IN ('ended', 'failed', 'aborted')";
    Query q(d_, __func__, sql);
    const bool changed = q.bind(std::string(name(state))).bind(reason).bind(is_terminal(state) ? now : std::string()).bind(public_id).changes() > 0;
    if (!changed) require_session(__func__, public_id);  // kNotFound rather than false for an unknown session
    tx.commit();
    return changed;
  }

  bool add_event(const EventRecord& e) override {
    Transaction tx(d_, __func__, TxKind::kStatement);
    const int64_t session_id = require_session(__func__, e.session_public_id).id;
    Query q(d_, __func__,
            "INSERT INTO events(session_id, seq, sim_time_s, kind, worry_level, x_m, y_m, details) "
            "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8) ON CONFLICT (session_id, seq) DO NOTHING");
    q.bind(session_id).bind(e.seq).bind(e.sim_time_s).bind(e.kind).bind(e.worry_level).bind(e.x_m).bind(e.y_m);
    const bool added = q.bind(e.details).changes() > 0;
    tx.commit();
    return added;
  }

  std::vector<EventRecord> list_events(const std::string& session_public_id) override {
    Transaction tx(d_, __func__, TxKind::kRead);
    const int64_t session_id = require_session(__func__, session_public_id).id;
    Query q(d_, __func__,
            "SELECT seq, sim_time_s, kind, worry_level, x_m, y_m, details FROM events WHERE session_id = ?1 ORDER BY seq");
    q.bind(session_id);
    std::vector<EventRecord> events;
    while (q.step()) {
      events.push_back(EventRecord{session_public_id, q.int64(0), q.real(1), q.text(2), static_cast<int>(q.int64(3)),
                                   q.real(4), q.real(5), q.text(6)});
    }
    tx.commit();
    return events;
  }

  bool set_score(const ScoreRecord& s, const std::string& now) override {
    Durable durable(d_, __func__);
    Transaction tx(d_, __func__, TxKind::kWrite);
    const Session session = require_session(__func__, s.session_public_id);
    {
      // A second server's score for the session waits here for the first one's commit, then
      // finds it and changes nothing.
      Query q(d_, __func__, "INSERT INTO scores(session_id, mark, passed) VALUES (?1, ?2, ?3) ON CONFLICT (session_id) DO NOTHING");
      if (q.bind(session.id).bind(s.mark).bind(s.passed).changes() == 0) return false;  // the first score stands
    }
    for (const auto& [kind, count] : s.counts) {
      Query q(d_, __func__, "INSERT INTO score_counts(session_id, kind, count) VALUES (?1, ?2, ?3)");
      q.bind(session.id).bind(kind).bind(count).run();
    }
    // The outcome again: the score may note the task left unfinished of a session already ended.
    static const std::string update = "UPDATE sessions SET mark = ?1, passed = ?2, outcome = " +
                                      outcome_sql("sessions.state", "sessions.reason", TASK_INCOMPLETE_SQL " IS NOT NULL") +
                                      " WHERE id = ?3";
    Query(d_, __func__, update).bind(s.mark).bind(s.passed).bind(session.id).run();
    if (makes_practical_record(session)) insert_exam(__func__, practical_exam(session, s, now), session.id);
    tx.commit();
    return true;
  }

  std::optional<ScoreRecord> get_score(const std::string& session_public_id) override {
    Transaction tx(d_, __func__, TxKind::kRead);
    const std::optional<Session> session = this->session(__func__, session_public_id);
    if (!session) return std::nullopt;
    ScoreRecord score;
    {
      Query q(d_, __func__, "SELECT mark, passed FROM scores WHERE session_id = ?1");
      q.bind(session->id);
      if (!q.step()) return std::nullopt;
      score.session_public_id = session_public_id;
      score.mark = q.real(0);
      score.passed = q.int64(1) != 0;
    }
    Query q(d_, __func__, "SELECT kind, count FROM score_counts WHERE session_id = ?1");
    q.bind(session->id);
    while (q.step()) score.counts[q.text(0)] = static_cast<int>(q.int64(1));
    tx.commit();
    return score;
  }

  int64_t add_exam(const ExamRecord& r) override {
    Durable durable(d_, __func__);
    Transaction tx(d_, __func__, TxKind::kWrite);
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
    Query q(d_, __func__, "SELECT " EXAM_ROWS " WHERE e.id = ?1");
    return first_row(__func__, q.bind(id), read_exam<Query>);
  }

  int64_t add_exam_correction(const ExamCorrection& c) override {
    check_new_correction(__func__, c);
    Durable durable(d_, __func__);
    Query q(d_, __func__,
            "INSERT INTO exam_corrections(exam_id, corrected_by, at, reason, correction) VALUES (?1, ?2, ?3, ?4, ?5) "
            "RETURNING id");
    q.bind(c.exam_id).bind(c.corrected_by).bind(c.at.empty() ? now_iso8601() : c.at).bind(c.reason);
    return inserted(__func__, q.bind(c.correction));
  }

  std::vector<ExamCorrection> list_exam_corrections(int64_t exam_id) override {
    Query q(d_, __func__, "SELECT " CORRECTION_COLUMNS " FROM exam_corrections WHERE exam_id = ?1 ORDER BY id");
    return rows(__func__, q.bind(exam_id), read_correction<Query>);
  }

  int64_t create_theory_attempt(const TheoryAttempt& a) override {
    check_new_theory_attempt(__func__, a);
    Query q(d_, __func__,
            "INSERT INTO theory_attempts(pupil_id, seed, questions, started_at, started_by, kind, deadline) "
            "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7) RETURNING id");
    q.bind(a.pupil_id).bind(a.seed).bind(a.questions).bind(a.started_at.empty() ? now_iso8601() : a.started_at);
    return inserted(__func__, q.bind(a.started_by).bind(std::string(name(a.kind))).bind(a.deadline));
  }

  std::optional<TheoryAttempt> get_theory_attempt(int64_t id) override {
    Transaction tx(d_, __func__, TxKind::kStatement);
    std::optional<TheoryAttempt> a = attempt(__func__, id);
    tx.commit();
    return a;
  }

  int64_t finish_theory_attempt(int64_t attempt_id, const ExamRecord& r, PaperOutcome outcome) override {
    Durable durable(d_, __func__);
    Transaction tx(d_, __func__, TxKind::kWrite);
    const std::optional<TheoryAttempt> a = attempt(__func__, attempt_id);
    check_theory_finish(__func__, attempt_id, a, r);
    ExamRecord record = r;
    if (record.taken_at.empty()) record.taken_at = now_iso8601();
    const int64_t exam = insert_exam(__func__, record, std::nullopt);
    // The guard repeats the check above in the statement itself.
    Query q(d_, __func__,
            "UPDATE theory_attempts SET exam_id = ?1, outcome = ?2, finished_at = ?3 "
            "WHERE id = ?4 AND exam_id IS NULL AND finished_at = ''");
    require(q.bind(exam).bind(std::string(name(outcome))).bind(record.taken_at).bind(attempt_id).changes() > 0, StoreError::kConflict,
            __func__, "attempt " + std::to_string(attempt_id) + " was already finished");
    tx.commit();
    return exam;
  }

  void finish_practice_attempt(int64_t attempt_id, PaperOutcome outcome, const std::string& result,
                               const std::string& finished_at) override {
    Transaction tx(d_, __func__, TxKind::kWrite);
    const std::optional<TheoryAttempt> a = attempt(__func__, attempt_id);
    check_practice_finish(__func__, attempt_id, a);
    Query q(d_, __func__,
            "UPDATE theory_attempts SET outcome = ?1, result = ?2, finished_at = ?3 WHERE id = ?4 AND finished_at = ''");
    q.bind(std::string(name(outcome))).bind(result).bind(finished_at.empty() ? now_iso8601() : finished_at).bind(attempt_id);
    require(q.changes() > 0, StoreError::kConflict, __func__, "attempt " + std::to_string(attempt_id) + " was already finished");
    tx.commit();
  }

  std::vector<TheoryAttempt> list_theory_attempts(int64_t pupil_id) override {
    Query q(d_, __func__, "SELECT " THEORY_ATTEMPT_COLUMNS " FROM theory_attempts WHERE pupil_id = ?1 ORDER BY id");
    return rows(__func__, q.bind(pupil_id), read_theory_attempt<Query>);
  }

  std::vector<TheoryAttempt> open_theory_attempts() override {
    // "finished_at = ''" spelled as in the partial index, so that the planner uses it.
    Query q(d_, __func__, "SELECT " THEORY_ATTEMPT_COLUMNS " FROM theory_attempts "
                          "WHERE finished_at = '' AND deadline <> '' ORDER BY id");
    return rows(__func__, q, read_theory_attempt<Query>);
  }

  int64_t add_theory_unlock(const TheoryUnlock& u) override {
    Query q(d_, __func__, "INSERT INTO theory_unlocks(pupil_id, unlocked_by, at, reason) VALUES (?1, ?2, ?3, ?4) RETURNING id");
    return inserted(__func__, q.bind(u.pupil_id).bind(u.unlocked_by).bind(u.at.empty() ? now_iso8601() : u.at).bind(u.reason));
  }

  std::vector<TheoryUnlock> list_theory_unlocks(int64_t pupil_id) override {
    Query q(d_, __func__, "SELECT id, pupil_id, unlocked_by, at, reason FROM theory_unlocks WHERE pupil_id = ?1 ORDER BY id");
    return rows(__func__, q.bind(pupil_id),
                [](const Query& r) { return TheoryUnlock{r.int64(0), r.int64(1), r.int64(2), r.text(3), r.text(4)}; });
  }

  void add_path_points(const std::string& session_public_id, const std::vector<PathPoint>& points) override {
    if (points.empty()) return;
    Transaction tx(d_, __func__, TxKind::kWrite);  // one commit for the lot
    const int64_t session_id = require_session(__func__, session_public_id).id;
    for (const PathPoint& p : points) {
      Query q(d_, __func__,
              "INSERT INTO path_points(session_id, sim_time_s, x_m, y_m, yaw_rad, speed_m_s, lift_m) "
              "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7) ON CONFLICT (session_id, sim_time_s) DO NOTHING");
      q.bind(session_id).bind(p.sim_time_s).bind(p.x_m).bind(p.y_m).bind(p.yaw_rad).bind(p.speed_m_s).bind(p.lift_m).run();
    }
    tx.commit();
  }

  std::vector<PathPoint> list_path(const std::string& session_public_id) override {
    Transaction tx(d_, __func__, TxKind::kRead);
    const int64_t session_id = require_session(__func__, session_public_id).id;
    Query q(d_, __func__,
            "SELECT sim_time_s, x_m, y_m, yaw_rad, speed_m_s, lift_m FROM path_points WHERE session_id = ?1 ORDER BY sim_time_s");
    q.bind(session_id);
    std::vector<PathPoint> points;
    while (q.step()) points.push_back(PathPoint{q.real(0), q.real(1), q.real(2), q.real(3), q.real(4), q.real(5)});
    tx.commit();
    return points;
  }

  int64_t add_licence(int64_t pupil_id, const std::string& issued_at, const std::string& issued_by) override {
    require(!issued_by.empty(), StoreError::kInvalid, __func__, "empty issued_by");
    const std::string due = reevaluation_due(issued_at);
    Query q(d_, __func__,
            "INSERT INTO licences(pupil_id, issued_at, reevaluation_due, issued_by) VALUES (?1, ?2, ?3, ?4) RETURNING id");
    return inserted(__func__, q.bind(pupil_id).bind(issued_at).bind(due).bind(issued_by));
  }

  int64_t add_certificate(const CertificateRecord& c) override {
    check_new_certificate(__func__, c);
    Durable durable(d_, __func__);
    Transaction tx(d_, __func__, TxKind::kWrite);
    {
      Query q(d_, __func__, "SELECT pupil_id FROM licences WHERE id = ?1");
      q.bind(c.licence_id);
      check_certificate_licence(__func__, c, q.step() ? std::optional(q.int64(0)) : std::nullopt);
    }
    Query q(d_, __func__,
            "INSERT INTO certificates(number, pupil_id, licence_id, issued_at, issued_by, record, signature) "
            "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7) RETURNING id");
    q.bind(c.number).bind(c.pupil_id).bind(c.licence_id).bind(c.issued_at.empty() ? now_iso8601() : c.issued_at);
    const int64_t id = q.bind(c.issued_by).bind(c.record).bind(c.signature).returned_id();
    tx.commit();
    return id;
  }

  std::optional<CertificateRecord> find_certificate(const std::string& number) override {
    Query q(d_, __func__, "SELECT " CERTIFICATE_COLUMNS " FROM certificates WHERE number = ?1");
    return first_row(__func__, q.bind(number), read_certificate<Query>);
  }

  std::vector<CertificateRecord> list_certificates(int64_t pupil_id) override {
    Query q(d_, __func__, "SELECT " CERTIFICATE_COLUMNS " FROM certificates WHERE pupil_id = ?1 ORDER BY id");
    return rows(__func__, q.bind(pupil_id), read_certificate<Query>);
  }

  int64_t revoke_certificate(const CertificateRevocation& r) override {
    check_new_revocation(__func__, r);
    Durable durable(d_, __func__);
    // The unique key on certificate_id refuses a second revocation, even from another server.
    Query q(d_, __func__,
            "INSERT INTO certificate_revocations(certificate_id, revoked_by, at, reason) VALUES (?1, ?2, ?3, ?4) RETURNING id");
    return inserted(__func__, q.bind(r.certificate_id).bind(r.revoked_by).bind(r.at.empty() ? now_iso8601() : r.at).bind(r.reason));
  }

  std::optional<CertificateRevocation> certificate_revocation(int64_t certificate_id) override {
    Query q(d_, __func__, "SELECT " REVOCATION_COLUMNS " FROM certificate_revocations WHERE certificate_id = ?1");
    return first_row(__func__, q.bind(certificate_id), read_revocation<Query>);
  }

  void put_session_log(const std::string& session_public_id, const std::string& name, const std::string& text) override {
    require(!name.empty(), StoreError::kInvalid, __func__, "empty log name");
    Transaction tx(d_, __func__, TxKind::kStatement);
    const int64_t session_id = require_session(__func__, session_public_id).id;
    Query q(d_, __func__,
            "INSERT INTO session_logs(session_id, name, body) VALUES (?1, ?2, ?3) "
            "ON CONFLICT (session_id, name) DO UPDATE SET body = excluded.body "
            "WHERE session_logs.body IS DISTINCT FROM excluded.body");  // the same again (a second server settling it) is no write
    q.bind(session_id).bind(name).bind(text).run();
    tx.commit();
  }

  std::optional<std::string> get_session_log(const std::string& session_public_id, const std::string& name) override {
    Query q(d_, __func__,
            "SELECT l.body FROM session_logs l JOIN sessions s ON s.id = l.session_id WHERE s.public_id = ?1 AND l.name = ?2");
    return first_row(__func__, q.bind(session_public_id).bind(name), [](const Query& r) { return r.text(0); });
  }

  void append_chain_entry(const ChainEntry& e) override {
    // Under the write lock: of two servers appending at once, the second sees the first's entry
    // and is refused (kConflict), so the chain stays one chain. seq's primary key stands behind it.
    Transaction tx(d_, __func__, TxKind::kWrite);
    const int64_t session_id = require_session(__func__, e.session_public_id).id;
    const auto last = last_chain_entry();
    check_chain_append(__func__, e, last, get_chain_entry(e.session_public_id).has_value());
    Query(d_, __func__, "INSERT INTO exam_chain(seq, session_id, entry) VALUES (?1, ?2, ?3)")
        .bind(e.seq)
        .bind(session_id)
        .bind(e.entry)
        .run();
    tx.commit();
  }

  std::optional<ChainEntry> last_chain_entry() override {
    return one_chain_entry(__func__, "SELECT c.seq, s.public_id, c.entry FROM exam_chain c "
                                     "JOIN sessions s ON s.id = c.session_id ORDER BY c.seq DESC LIMIT 1",
                           std::nullopt);
  }

  std::optional<ChainEntry> get_chain_entry(const std::string& session_public_id) override {
    return one_chain_entry(__func__, "SELECT c.seq, s.public_id, c.entry FROM exam_chain c "
                                     "JOIN sessions s ON s.id = c.session_id WHERE s.public_id = ?1",
                           session_public_id);
  }

  std::vector<ChainEntry> list_chain() override {
    Query q(d_, __func__, "SELECT c.seq, s.public_id, c.entry FROM exam_chain c JOIN sessions s ON s.id = c.session_id ORDER BY c.seq");
    return rows(__func__, q, read_chain_entry);
  }

  int64_t count_chain_entries() override {
    Transaction tx(d_, __func__, TxKind::kStatement);
    Query q(d_, __func__, "SELECT COUNT(*) FROM exam_chain");
    q.step();
    const int64_t n = q.int64(0);
    tx.commit();
    return n;
  }

  std::vector<std::string> unchained_signed_exams() override {
    Query q(d_, __func__,
            "SELECT s.public_id FROM sessions s JOIN session_logs l ON l.session_id = s.id AND l.name = 'signature' "
            "LEFT JOIN exam_chain c ON c.session_id = s.id WHERE s.mode = 'exam' AND c.seq IS NULL ORDER BY s.id");
    return rows(__func__, q, [](const Query& r) { return r.text(0); });
  }

  int64_t add_audit(const AuditRecord& r) override {
    check_new_audit(__func__, r.actor, r.action);
    Query q(d_, __func__,
            "INSERT INTO audit_log(at, actor_user_id, actor, pupil_id, action, details) VALUES (?1, ?2, ?3, ?4, ?5, ?6) "
            "RETURNING id");
    q.bind(r.at.empty() ? now_iso8601() : r.at).bind(r.actor.user_id).bind(r.actor.name).bind(r.pupil_id);
    return inserted(__func__, q.bind(r.action).bind(r.details));
  }

  std::vector<AuditRecord> list_audit(const AuditScope& scope, int limit, int offset) override {
    require(limit >= 0 && offset >= 0, StoreError::kInvalid, __func__, "negative limit or offset");
    // One statement per scope, so that each reads its rows straight from an index.
    Query q(d_, __func__,
            scope.pupil_id    ? "SELECT " AUDIT_COLUMNS " FROM audit_log WHERE pupil_id = ?1 ORDER BY id DESC LIMIT ?2 OFFSET ?3"
            : scope.school_id ? "SELECT " AUDIT_COLUMNS " FROM audit_log WHERE pupil_id IN "
                                "(SELECT id FROM pupils WHERE school_id = ?1) ORDER BY id DESC LIMIT ?2 OFFSET ?3"
                              : "SELECT " AUDIT_COLUMNS " FROM audit_log ORDER BY id DESC LIMIT ?1 OFFSET ?2");
    if (scope.pupil_id || scope.school_id) q.bind(scope.pupil_id ? *scope.pupil_id : *scope.school_id);
    return rows(__func__, q.bind(limit).bind(offset), read_audit<Query>);
  }

  int64_t add_staff_audit(const StaffAuditRecord& r) override {
    check_new_audit(__func__, r.actor, r.action);
    Query q(d_, __func__,
            "INSERT INTO staff_audit_log(at, actor_user_id, actor, user_id, action, details) VALUES (?1, ?2, ?3, ?4, ?5, ?6) "
            "RETURNING id");
    q.bind(r.at.empty() ? now_iso8601() : r.at).bind(r.actor.user_id).bind(r.actor.name).bind(r.user_id);
    return inserted(__func__, q.bind(r.action).bind(r.details));
  }

  std::vector<StaffAuditRecord> list_staff_audit(int64_t school_id, std::optional<int64_t> user_id, int limit,
                                                 int offset) override {
    require(limit >= 0 && offset >= 0, StoreError::kInvalid, __func__, "negative limit or offset");
    Query q(d_, __func__,
            "SELECT " STAFF_AUDIT_COLUMNS " FROM staff_audit_log WHERE user_id IN (SELECT id FROM users WHERE school_id = ?1) "
            "AND (CAST(?2 AS BIGINT) IS NULL OR user_id = ?2) ORDER BY id DESC LIMIT ?3 OFFSET ?4");
    return rows(__func__, q.bind(school_id).bind(user_id).bind(limit).bind(offset), read_staff_audit<Query>);
  }

  int64_t add_session_note(const SessionNote& n) override {
    require(!n.text.empty(), StoreError::kInvalid, __func__, "empty note");
    // Under the write lock, so that no note slips in beside another server's sign-off.
    Transaction tx(d_, __func__, TxKind::kWrite);
    const int64_t session_id = require_session(__func__, n.session_public_id).id;
    Query signed_off(d_, __func__, "SELECT 1 FROM session_sign_offs WHERE session_id = ?1");
    require(!signed_off.bind(session_id).step(), StoreError::kConflict, __func__,
            "session " + n.session_public_id + " is signed off");
    Query q(d_, __func__, "INSERT INTO session_notes(session_id, author_user_id, at, text) VALUES (?1, ?2, ?3, ?4) RETURNING id");
    const int64_t id = inserted(__func__, q.bind(session_id).bind(n.author_id).bind(n.at.empty() ? now_iso8601() : n.at).bind(n.text));
    tx.commit();
    return id;
  }

  std::vector<SessionNote> list_session_notes(const std::string& session_public_id) override {
    Query q(d_, __func__, "SELECT n.id, s.public_id, n.author_user_id, n.at, n.text FROM session_notes n "
                          "JOIN sessions s ON s.id = n.session_id WHERE s.public_id = ?1 ORDER BY n.id");
    return rows(__func__, q.bind(session_public_id), read_session_note<Query>);
  }

  bool sign_off_session(const SessionSignOff& s) override {
    Transaction tx(d_, __func__, TxKind::kWrite);
    const int64_t session_id = require_session(__func__, s.session_public_id).id;
    Query q(d_, __func__, "INSERT INTO session_sign_offs(session_id, signed_by, at, comment) VALUES (?1, ?2, ?3, ?4) "
                          "ON CONFLICT (session_id) DO NOTHING");
    const bool added = q.bind(session_id).bind(s.signed_by).bind(s.at.empty() ? now_iso8601() : s.at).bind(s.comment).changes() > 0;
    tx.commit();
    return added;
  }

  std::optional<SessionSignOff> get_session_sign_off(const std::string& session_public_id) override {
    Query q(d_, __func__, "SELECT s.public_id, o.signed_by, o.at, o.comment FROM session_sign_offs o "
                          "JOIN sessions s ON s.id = o.session_id WHERE s.public_id = ?1");
    return first_row(__func__, q.bind(session_public_id), read_session_sign_off<Query>);
  }

  bool set_score_audited(const ScoreRecord& s, const std::string& now, const Actor& actor) override {
    Durable durable(d_, __func__);
    Transaction tx(d_, __func__, TxKind::kWrite);
    if (!set_score(s, now)) return false;
    const Session session = require_session(__func__, s.session_public_id);
    // The details from the rows just written, so that they say what was stored.
    Query q(d_, __func__, dialect_.insert_score_audit);
    q.bind(now).bind(actor.user_id).bind(actor.name).bind(session.id).run();
    tx.commit();
    return true;
  }

  bool set_session_state_audited(const std::string& public_id, SessionPhase state, const std::string& reason,
                                 const std::string& now, const Actor& actor) override {
    Transaction tx(d_, __func__, TxKind::kWrite);
    const Session before = require_session(__func__, public_id);
    if (!set_session_state(public_id, state, reason, now)) return false;
    AuditRecord r = state_audit(before, state, now, actor);
    {
      Query q(d_, __func__, dialect_.state_audit_details);
      q.bind(public_id).bind(std::string(name(before.state))).bind(std::string(name(state))).bind(reason).step();
      r.details = q.text(0);
    }
    add_audit(r);
    tx.commit();
    return true;
  }

  void add_login_token(const LoginToken& t) override {
    check_token_hash(__func__, t.hash);
    Transaction tx(d_, __func__, TxKind::kStatement);
    Query(d_, __func__, "INSERT INTO login_tokens(hash, user_id, generation, expires_at_ms) VALUES (?1, ?2, ?3, ?4)")
        .bind(t.hash).bind(t.user_id).bind(t.login_generation).bind(t.expires_at_ms).run();
    tx.commit();
  }

  std::optional<LoginToken> find_login_token(const std::string& hash) override {
    Query q(d_, __func__, kFindLoginToken);
    return first_row(__func__, q.bind(hash), [&](const Query& r) { return read_login_token(r, hash); });
  }

  bool delete_login_token(const std::string& hash) override {
    return changed(__func__, Query(d_, __func__, "DELETE FROM login_tokens WHERE hash = ?1").bind(hash)) > 0;
  }

  int64_t forget_login_tokens(int64_t before_ms) override {
    return changed(__func__, Query(d_, __func__, "DELETE FROM login_tokens WHERE expires_at_ms < ?1").bind(before_ms));
  }

  AttemptCount count_attempts(const std::string& key, int64_t since_ms) override {
    Query q(d_, __func__,
            "SELECT COUNT(*), COALESCE(SUM(CASE WHEN pending THEN 1 ELSE 0 END), 0), COALESCE(MIN(at_ms), 0), "
            "COALESCE((SELECT until_ms FROM login_lockouts WHERE key = ?1), 0) "
            "FROM login_attempts WHERE key = ?1 AND at_ms >= ?2");
    return *first_row(__func__, q.bind(key).bind(since_ms),
                      [](const Query& r) { return AttemptCount{r.int64(0), r.int64(1), r.int64(2), r.int64(3)}; });
  }

  int64_t add_attempt(const std::string& key, int64_t at_ms) override {
    check_attempt_key(__func__, key);
    return inserted(__func__, Query(d_, __func__, "INSERT INTO login_attempts(key, at_ms, pending) VALUES (?1, ?2, TRUE) RETURNING id")
                                  .bind(key).bind(at_ms));
  }

  void end_attempt(int64_t id, bool failed, int64_t at_ms) override {
    if (failed) changed(__func__, Query(d_, __func__, "UPDATE login_attempts SET pending = FALSE, at_ms = ?1 WHERE id = ?2").bind(at_ms).bind(id));
    else changed(__func__, Query(d_, __func__, "DELETE FROM login_attempts WHERE id = ?1").bind(id));
  }

  void reset_attempts(const std::string& key, int64_t locked_until_ms) override {
    Transaction tx(d_, __func__, TxKind::kWrite);
    Query(d_, __func__, "DELETE FROM login_attempts WHERE key = ?1 AND pending = FALSE").bind(key).run();
    if (locked_until_ms > 0) {
      Query(d_, __func__, "INSERT INTO login_lockouts(key, until_ms) VALUES (?1, ?2) "
                          "ON CONFLICT (key) DO UPDATE SET until_ms = excluded.until_ms")
          .bind(key).bind(locked_until_ms).run();
    } else {
      Query(d_, __func__, "DELETE FROM login_lockouts WHERE key = ?1").bind(key).run();
    }
    tx.commit();
  }

  void forget_attempts(int64_t before_ms) override {
    Transaction tx(d_, __func__, TxKind::kWrite);
    Query(d_, __func__, "DELETE FROM login_attempts WHERE at_ms < ?1").bind(before_ms).run();
    Query(d_, __func__, "DELETE FROM login_lockouts WHERE until_ms < ?1").bind(before_ms).run();
    tx.commit();
  }

  std::optional<PupilHistory> history(int64_t pupil_id, const std::string& now) override {
    std::optional<LoginToken> none;
    return history(pupil_id, now, "", none);
  }

  std::optional<PupilHistory> history(int64_t pupil_id, const std::string& now, const std::string& token_hash,
                                      std::optional<LoginToken>& token) override {
    // One consistent snapshot, and one round trip to a database a network away: every statement
    // is sent at once, the pupil's own and the login's among them, and its rows read after.
    Transaction tx(d_, __func__, TxKind::kRead);
    Query pupil_q(d_, __func__, "SELECT " PUPIL_COLUMNS " FROM pupils WHERE id = ?1");
    Query sessions_q(d_, __func__, sessions_of_sql());
    Query exams_q(d_, __func__, "SELECT " EXAM_ROWS " WHERE e.pupil_id = ?1 ORDER BY e.taken_at, e.id");
    Query faults_q(d_, __func__, "SELECT kind, count FROM pupil_fault_counts WHERE pupil_id = ?1 AND count > 0");
    Query licence_q(d_, __func__,
                    "SELECT id, issued_at, reevaluation_due, issued_by FROM licences "
                    "WHERE pupil_id = ?1 ORDER BY issued_at DESC, id DESC LIMIT 1");
    Query corrections_q(d_, __func__,
                        "SELECT " CORRECTION_COLUMNS " FROM exam_corrections "
                        "WHERE exam_id IN (SELECT id FROM exams WHERE pupil_id = ?1) ORDER BY id");
    Query notes_q(d_, __func__,
                  "SELECT n.id, s.public_id, n.author_user_id, n.at, n.text FROM sessions s "
                  "JOIN session_notes n ON n.session_id = s.id WHERE s.pupil_id = ?1 ORDER BY n.id");
    for (Query* q : {&pupil_q, &sessions_q, &exams_q, &faults_q, &licence_q, &corrections_q, &notes_q}) q->bind(pupil_id);
    token.reset();
    if (token_hash.empty()) {
      tx.run_last({&pupil_q, &sessions_q, &exams_q, &faults_q, &licence_q, &corrections_q, &notes_q});
    } else {
      Query token_q(d_, __func__, kFindLoginToken);
      tx.run_last({&token_q.bind(token_hash), &pupil_q, &sessions_q, &exams_q, &faults_q, &licence_q, &corrections_q, &notes_q});
      if (token_q.step()) token = read_login_token(token_q, token_hash);
    }
    if (!pupil_q.step()) return std::nullopt;
    PupilHistory h;
    h.pupil = read_pupil(pupil_q);
    while (sessions_q.step()) h.sessions.push_back(read_session(sessions_q));
    while (exams_q.step()) h.exams.push_back(read_exam(exams_q));
    while (faults_q.step()) h.faults_by_kind[faults_q.text(0)] = static_cast<int>(faults_q.int64(1));
    if (licence_q.step())
      h.licence = LicenceRecord{licence_q.int64(0), pupil_id, licence_q.text(1), licence_q.text(2), licence_q.text(3)};
    while (corrections_q.step()) h.corrections.push_back(read_correction(corrections_q));
    while (notes_q.step()) h.notes.push_back(read_session_note(notes_q));
    h.trend = mark_trend(h.sessions);
    h.reevaluation_overdue = h.licence && h.licence->reevaluation_due < now;  // same form: string order is time order
    tx.commit();
    return h;
  }

 private:
  // Applies each pending migration in its own transaction, one server at a time: a second
  // server starting meanwhile waits for the lock, then finds the work done.
  void migrate() {
    const int latest = dialect_.migration_count;
    for (;;) {
      Transaction tx(d_, "migrate", TxKind::kMigrate);
      d_.exec("migrate", "CREATE TABLE IF NOT EXISTS schema_migrations (version INTEGER PRIMARY KEY, applied_at TEXT NOT NULL)");
      const int version = schema_version();
      if (version > latest) {
        throw StoreError(StoreError::kIo, "migrate: database schema version " + std::to_string(version) +
                                              " is newer than this program's " + std::to_string(latest));
      }
      if (version == latest) return tx.commit();
      d_.exec("migrate", dialect_.migrations[version]);
      // The outcome of every session that is over, as session_outcome() gives it.
      if (version + 1 == kOutcomeStoredVersion)
        d_.exec("migrate", "UPDATE sessions SET outcome = " +
                               outcome_sql("state", "reason", TASK_INCOMPLETE_SQL " IS NOT NULL") +
                               " WHERE state IN ('ended', 'failed', 'aborted')");
      Query(d_, "migrate", "INSERT INTO schema_migrations(version, applied_at) VALUES (?1, ?2)")
          .bind(version + 1)
          .bind(now_iso8601())
          .run();
      tx.commit();
    }
  }

  // The id an INSERT ... RETURNING id gave, the statement being the whole call.
  int64_t inserted(const char* op, Query& q) {
    Transaction tx(d_, op, TxKind::kStatement);
    const int64_t id = q.returned_id();
    tx.commit();
    return id;
  }
  int64_t inserted(const char* op, Query&& q) { return inserted(op, q); }

  // The rows an UPDATE or DELETE changed, the statement being the whole call.
  int64_t changed(const char* op, Query& q) {
    Transaction tx(d_, op, TxKind::kStatement);
    const int64_t n = q.changes();
    tx.commit();
    return n;
  }

  // The rows of `q`, each read by `read`, the statement being the whole call.
  template <class Read, class Row = std::invoke_result_t<Read&, const Query&>>
  std::vector<Row> rows(const char* op, Query& q, Read read) {
    Transaction tx(d_, op, TxKind::kStatement);
    std::vector<Row> out;
    while (q.step()) out.push_back(read(q));
    tx.commit();
    return out;
  }
  // The first row of `q` read by `read`, if it has one, the statement being the whole call.
  template <class Read, class Row = std::invoke_result_t<Read&, const Query&>>
  std::optional<Row> first_row(const char* op, Query& q, Read read) {
    Transaction tx(d_, op, TxKind::kStatement);
    std::optional<Row> out;
    if (q.step()) out = read(q);
    tx.commit();
    return out;
  }

  // A list's total (store.h, kCountedAtMost): the school's kept total in `column` of
  // school_totals for the `whole_school`, else the rows of `from` (a FROM and WHERE with `?` for
  // `where`'s values) counted up to one more than kCountedAtMost.
  template <class Page>
  void list_total(const char* op, Page& page, bool whole_school, const char* column, int64_t school_id,
                  const std::string& from, const Conditions& where) {
    if (whole_school) {
      Query q(d_, op, std::string("SELECT ") + column + " FROM school_totals WHERE school_id = ?1");
      page.total = q.bind(school_id).step() ? q.int64(0) : 0;
      return;
    }
    Query q(d_, op, "SELECT COUNT(*) FROM (SELECT 1" + from + " LIMIT " + std::to_string(kCountedAtMost + 1) + ") counted");
    where.bind(q);
    q.step();
    page.total = std::min(q.int64(0), kCountedAtMost);
    page.total_is_at_least = q.int64(0) > kCountedAtMost;
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
    Query q(d_, op, "SELECT " PUPIL_COLUMNS " FROM pupils WHERE id = ?1");
    q.bind(id);
    return q.step() ? std::optional(read_pupil(q)) : std::nullopt;
  }

  std::optional<Session> session(const char* op, const std::string& public_id) {
    Query q(d_, op, std::string("SELECT ") + dialect_.session_columns + " FROM " + dialect_.sessions_from + " WHERE public_id = ?");
    q.bind(public_id);
    return q.step() ? std::optional(read_session(q)) : std::nullopt;
  }

  std::optional<TheoryAttempt> attempt(const char* op, int64_t id) {
    Query q(d_, op, "SELECT " THEORY_ATTEMPT_COLUMNS " FROM theory_attempts WHERE id = ?1");
    q.bind(id);
    return q.step() ? std::optional(read_theory_attempt(q)) : std::nullopt;
  }

  void require_school(const char* op, int64_t school_id) {
    Query q(d_, op, "SELECT 1 FROM schools WHERE id = ?1");
    q.bind(school_id);
    require(q.step(), StoreError::kNotFound, op, "no school " + std::to_string(school_id));
  }

  // The session, or kNotFound.
  Session require_session(const char* op, const std::string& public_id) {
    std::optional<Session> s = session(op, public_id);
    require(s.has_value(), StoreError::kNotFound, op, "no session '" + public_id + "'");
    return std::move(*s);
  }

  // A pupil's (?1) sessions in the order they were made.
  std::string sessions_of_sql() const {
    return std::string("SELECT ") + dialect_.session_columns + " FROM " + dialect_.sessions_from +
           " WHERE pupil_id = ?1 ORDER BY created_at, id";
  }

  std::vector<Session> sessions_of(const char* op, int64_t pupil_id) {
    Query q(d_, op, sessions_of_sql());
    q.bind(pupil_id);
    std::vector<Session> sessions;
    while (q.step()) sessions.push_back(read_session(q));
    return sessions;
  }

  int64_t insert_exam(const char* op, const ExamRecord& r, std::optional<int64_t> session_id) {
    Query q(d_, op,
            "INSERT INTO exams(pupil_id, kind, session_id, score, passed, examiner_id, taken_at, details, school_id) "
            "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, (SELECT school_id FROM pupils WHERE id = ?1)) RETURNING id");
    q.bind(r.pupil_id).bind(std::string(name(r.kind))).bind(session_id).bind(r.score).bind(r.passed).bind(r.examiner_id);
    return q.bind(r.taken_at.empty() ? now_iso8601() : r.taken_at).bind(r.details).returned_id();
  }

  std::optional<ChainEntry> one_chain_entry(const char* op, const char* sql, const std::optional<std::string>& session) {
    Query q(d_, op, sql);
    if (session) q.bind(*session);
    return first_row(op, q, read_chain_entry);
  }

  std::unique_ptr<Driver> driver_;
  Driver& d_;
  const Dialect& dialect_;
};

}  // namespace

std::unique_ptr<Store> make_sql_store(std::unique_ptr<Driver> driver, const Dialect& dialect) {
  return std::make_unique<SqlStore>(std::move(driver), dialect);
}

}  // namespace forklift::store::detail
