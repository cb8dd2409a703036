// The store's contract, once for each backend: every test case below runs against SQLite (a file
// in the test's temporary folder) and against PostgreSQL (a database on a server this test process
// starts itself, support/postgres.h), as StoreTest.<Case>/sqlite and StoreTest.<Case>/postgresql.
#include "forklift/store/store.h"

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <atomic>
#include <cctype>
#include <cstdio>
#include <latch>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "forklift/security/evidence.h"
#include "store_generator.h"
#include "support/postgres.h"

namespace fs = forklift::store;
using forklift::Mode;
using forklift::Outcome;
using forklift::SessionPhase;

namespace {

// Runs `sql` on a separate raw connection to `path` and returns the first column of each row.
std::vector<std::string> SqliteQuery(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  sqlite3_stmt* stmt = nullptr;
  std::vector<std::string> rows;
  if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK &&
      sqlite3_prepare_v2(db, sql.c_str(), -1, &stmt, nullptr) == SQLITE_OK) {
    int rc;
    while ((rc = sqlite3_step(stmt)) == SQLITE_ROW) {
      const auto* text = reinterpret_cast<const char*>(sqlite3_column_text(stmt, 0));
      rows.emplace_back(text ? text : "");
    }
    if (rc != SQLITE_DONE) ADD_FAILURE() << sql << ": " << sqlite3_errmsg(db);
  } else {
    ADD_FAILURE() << sql << ": " << sqlite3_errmsg(db);
  }
  sqlite3_finalize(stmt);
  sqlite3_close(db);
  return rows;
}

// Runs `sql` on a separate writable raw connection to `path`; returns SQLite's error message, or
// "" if it succeeded.
std::string SqliteExec(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  std::string error;
  if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK) {
    error = sqlite3_errmsg(db);
  } else {
    sqlite3_busy_timeout(db, 5000);
    char* message = nullptr;
    if (sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &message) != SQLITE_OK) error = message ? message : "failed";
    sqlite3_free(message);
  }
  sqlite3_close(db);
  return error;
}

// Calls `f` and returns the kind of StoreError it throws; fails the test if it throws nothing.
template <class F>
std::optional<fs::StoreError::Kind> ErrorKind(F f) {
  try {
    f();
  } catch (const fs::StoreError& e) {
    return e.kind();
  }
  ADD_FAILURE() << "no StoreError thrown";
  return std::nullopt;
}

enum class Backend { kSqlite, kPostgresql };
const char* Name(Backend b) { return b == Backend::kSqlite ? "sqlite" : "postgresql"; }
void PrintTo(Backend b, std::ostream* os) { *os << Name(b); }  // the value in ctest's names

// This process's PostgreSQL server, started on first use (support/postgres.h) and stopped at exit.
// If it cannot start, every PostgreSQL case fails saying why.
forklift::test::PostgresServer& Postgres() {
  static std::string failure;
  static const std::unique_ptr<forklift::test::PostgresServer> server = []() -> std::unique_ptr<forklift::test::PostgresServer> {
    try {
      return std::make_unique<forklift::test::PostgresServer>(
          ::testing::TempDir() + "/postgresql-" + std::to_string(getpid()), false);
    } catch (const std::exception& e) {
      failure = e.what();
      return nullptr;
    }
  }();
  if (!server) throw std::runtime_error(failure);
  return *server;
}

// Lower-case letters, digits and '_' of `name` (a test's name made a file or database name).
std::string Plain(const std::string& name) {
  std::string out;
  for (char c : name) out += std::isalnum(static_cast<unsigned char>(c)) ? static_cast<char>(std::tolower(c)) : '_';
  return out;
}

class StoreTest : public ::testing::TestWithParam<Backend> {
 protected:
  void SetUp() override {
    location_ = FreshLocation("");
    store_ = Open();
    school_ = store_->create_school("Depot school");
  }
  // A PostgreSQL database stays until the server's folder goes at exit: ctest runs each case in a
  // process of its own, so dropping it would only cost time.
  void TearDown() override {
    store_.reset();
    if (sqlite())
      for (const std::string& l : made_)
        for (const char* suffix : {"", "-wal", "-shm"}) std::remove((l + suffix).c_str());
  }

  bool sqlite() const { return GetParam() == Backend::kSqlite; }
  // A database of this test's own that nothing has opened yet: a new SQLite file, or a new
  // PostgreSQL database. `suffix` tells a test's second one from its first.
  std::string FreshLocation(const std::string& suffix) {
    const std::string name = Plain(::testing::UnitTest::GetInstance()->current_test_info()->name()) + suffix;
    if (sqlite()) {
      const std::string path = ::testing::TempDir() + "forklift_store_" + name + "_" + std::to_string(getpid()) + ".db";
      for (const char* end : {"", "-wal", "-shm"}) std::remove((path + end).c_str());
      made_.push_back(path);
      return path;
    }
    try {
      const std::string db = name.substr(0, 63);  // PostgreSQL's longest name
      Postgres().drop_database(db);
      made_.push_back(Postgres().create_database(db));
      return made_.back();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "PostgreSQL could not be started for this test: " << e.what();
      throw;
    }
  }
  // Another Store on the test's database, as a second thread or a second server opens it.
  std::unique_ptr<fs::Store> Open() { return fs::Store::open(location_); }

  // Runs `sql` on a separate raw connection to the test's database and returns the first column
  // of each row.
  std::vector<std::string> RawQuery(const std::string& sql) {
    if (sqlite()) return SqliteQuery(location_, sql);
    std::vector<std::string> rows;
    const std::string error = Postgres().exec(Database(), sql, &rows);
    if (!error.empty()) ADD_FAILURE() << sql << ": " << error;
    return rows;
  }
  // Runs `sql` on a separate raw connection; returns the database's error message, or "" if it
  // succeeded.
  std::string RawExec(const std::string& sql) { return sqlite() ? SqliteExec(location_, sql) : Postgres().exec(Database(), sql); }
  // The statement of this test's backend, where their dialects differ.
  const char* Sql(const char* sqlite_sql, const char* postgres_sql) const { return sqlite() ? sqlite_sql : postgres_sql; }

  int64_t NewPupil(const std::string& name) { return store_->create_pupil(school_, name, ""); }
  fs::ExamRecord TheoryRecord(int64_t pupil, double score, bool passed, const std::string& taken_at = "") {
    fs::ExamRecord r;
    r.pupil_id = pupil;
    r.kind = forklift::ExamKind::kTheory;
    r.score = score;
    r.passed = passed;
    r.taken_at = taken_at;
    return r;
  }
  // Later migrations go first: a test that goes back to an older schema must come forward through them.
  std::string DropMigration14() {
    return DropMigration15() + "ALTER TABLE users DROP COLUMN language; ALTER TABLE pupils DROP COLUMN language; DELETE FROM schema_migrations WHERE version >= 14; ";
  }
  std::string DropMigration20() {
    // The index as 16 made it (PostgreSQL's with the id).
    return std::string("DROP INDEX sessions_by_school_outcome; CREATE INDEX sessions_by_school_outcome ON sessions(school_id, outcome, created_at") +
           (sqlite() ? "); " : ", id); ") + "DELETE FROM schema_migrations WHERE version >= 20; ";
  }
  std::string DropMigration19() {
    // The exams' indexes as 15 and 8 left them (PostgreSQL's with the id as 15 made it).
    return DropMigration20() + (sqlite() ? "DROP TRIGGER exams_school_is_the_pupils; "
                                         : "DROP TRIGGER exams_school_is_the_pupils ON exams; DROP FUNCTION exam_school_is_the_pupils; ") +
           "DROP INDEX exams_by_school_kind_result; DROP INDEX exams_by_school_time; ALTER TABLE exams DROP COLUMN school_id; " +
           (sqlite() ? "CREATE INDEX exams_by_kind_result ON exams(kind, passed, taken_at); "
                     : "CREATE INDEX exams_by_kind_result ON exams(kind, passed, taken_at, id); ") +
           "CREATE INDEX exams_by_time ON exams(taken_at); DELETE FROM schema_migrations WHERE version >= 19; ";
  }
  std::string DropMigration18() {
    return DropMigration19() +
           (sqlite() ? "DROP TRIGGER pupil_fault_counts_in; DROP TRIGGER pupil_fault_counts_out; "
                     : "DROP TRIGGER pupil_fault_counts_in ON events; DROP TRIGGER pupil_fault_counts_out ON events; "
                       "DROP FUNCTION pupil_fault_counts_count; ") +
           "DROP TABLE pupil_fault_counts; "
           "CREATE INDEX events_faults_by_session ON events(session_id, worry_level, kind) WHERE worry_level > 0; "
           "DELETE FROM schema_migrations WHERE version >= 18; ";
  }
  std::string DropMigration17() {
    return DropMigration18() + "ALTER TABLE sessions DROP COLUMN server_id; DROP TABLE servers; DELETE FROM schema_migrations WHERE version >= 17; ";
  }
  std::string DropMigration16() {
    // The passed sessions' indexes as 15 left them (13's on SQLite).
    const std::string passed = " WHERE state = 'ended' AND passed = TRUE AND reason IN ('task_complete', 'parked', 'duration'); ";
    const std::string key = sqlite() ? "created_at)" : "created_at, id, reason)";
    return DropMigration17() + "DROP INDEX sessions_by_school_outcome; DROP INDEX sessions_passed_by_cab; DROP INDEX sessions_passed_by_school; "
           "CREATE INDEX sessions_passed_by_cab ON sessions(cab_id, " + key + passed +
           "CREATE INDEX sessions_passed_by_school ON sessions(school_id, " + key + passed +
           "ALTER TABLE sessions DROP COLUMN outcome; DELETE FROM schema_migrations WHERE version >= 16; ";
  }
  std::string DropMigration15() {
    std::string sql = DropMigration16();
    for (const char* t : {"school_totals_school ON schools", "school_totals_pupil_in ON pupils", "school_totals_pupil_out ON pupils",
                          "school_totals_session_in ON sessions", "school_totals_session_out ON sessions",
                          "school_totals_exam_in ON exams", "school_totals_exam_out ON exams"}) {
      const std::string name(t);
      sql += "DROP TRIGGER " + (sqlite() ? name.substr(0, name.find(' ')) : name) + "; ";
    }
    if (!sqlite()) sql += "DROP FUNCTION school_totals_count; ";
    sql += "DROP INDEX exams_by_kind_result; ";
    // Migration 13's indexes as it made them (SQLite's 15 leaves them).
    if (!sqlite())
      sql += "DROP INDEX sessions_passed_by_cab; DROP INDEX sessions_passed_by_school; "
             "CREATE INDEX sessions_passed_by_cab ON sessions(cab_id, created_at, id) WHERE state = 'ended' AND passed = TRUE AND reason IN ('task_complete', 'parked', 'duration'); "
             "CREATE INDEX sessions_passed_by_school ON sessions(school_id, created_at, id) WHERE state = 'ended' AND passed = TRUE AND reason IN ('task_complete', 'parked', 'duration'); ";
    return sql + "DROP TABLE school_totals; DELETE FROM schema_migrations WHERE version >= 15; ";
  }
  std::string DropMigration13() {
    return DropMigration14() + "DROP INDEX sessions_passed_by_cab; DROP INDEX sessions_passed_by_school; DELETE FROM schema_migrations WHERE version >= 13; ";
  }
  std::string DropMigration12() {
    return DropMigration13() + "DROP TABLE login_lockouts; DROP TABLE login_attempts; DROP TABLE login_tokens; DELETE FROM schema_migrations WHERE version >= 12; ";
  }
  std::string DropMigration11() {
    return DropMigration12() + "DROP INDEX sessions_one_open_per_cab; DELETE FROM schema_migrations WHERE version >= 11; ";
  }
  std::string DropMigration10() {
    return DropMigration11() + "DROP INDEX score_counts_task_incomplete; DELETE FROM schema_migrations WHERE version >= 10; ";
  }
  std::string DropMigration9() {
    return DropMigration10() + "DROP TABLE session_notes; DROP TABLE session_sign_offs; DELETE FROM schema_migrations WHERE version >= 9; ";
  }
  // SQL that takes migration 8 back out (lists, groups and bookings: their tables, indexes and
  // columns), as a program from before it left the file.
  std::string DropMigration8() {
    return DropMigration9() + "DROP TABLE bookings; DROP INDEX pupils_by_group; ALTER TABLE pupils DROP COLUMN group_id; DROP TABLE pupil_groups; "
           "DROP INDEX pupils_by_school_email; DROP INDEX exams_by_time; DROP INDEX sessions_by_starter; "
           "DROP INDEX sessions_by_cab; DROP INDEX sessions_by_time; ALTER TABLE sessions DROP COLUMN started_by; "
           "DROP INDEX sessions_by_school_time; ALTER TABLE sessions DROP COLUMN school_id; "
           "DELETE FROM schema_migrations WHERE version >= 8; ";
  }
  // SQL that takes migration 7 back out of the database (staff administration: its table, index
  // and columns), as a program from before it left the file.
  std::string DropMigration7() {
    return DropMigration8() + "DROP TABLE staff_audit_log; DROP INDEX users_by_school_name; ALTER TABLE users DROP COLUMN active; "
           "ALTER TABLE users DROP COLUMN login_generation; DELETE FROM schema_migrations WHERE version >= 7; ";
  }
  // SQL that takes migrations 6 and on back out of the database (their triggers, functions,
  // tables and columns), as a program from before them left the file.
  std::string DropMigration6() {
    std::string sql = DropMigration7();
    if (sqlite()) {
      for (const std::string& t : RawQuery("SELECT name FROM sqlite_master WHERE type = 'trigger' AND name LIKE 'kept_%'"))
        sql += "DROP TRIGGER " + t + "; ";
    } else {
      for (const std::string& t : RawQuery("SELECT tgname || ' ON ' || tgrelid::regclass FROM pg_trigger WHERE tgname LIKE 'kept\\_%'"))
        sql += "DROP TRIGGER " + t + "; ";
    }
    sql += "DROP TABLE certificate_revocations; DROP TABLE certificates; DROP TABLE exam_corrections; ";
    if (!sqlite()) sql += "DROP FUNCTION refuse_kept_edit, refuse_kept_truncate, is_kept_exam_session; ";
    return sql + "ALTER TABLE users DROP COLUMN full_name; DELETE FROM schema_migrations WHERE version >= 6; ";
  }
  // A new open session, on a cab of its own ("cab1", "cab2", ...: a cab has one open session).
  fs::Session NewSession(int64_t pupil, Mode mode = Mode::kTraining,
                         const std::string& now = "2026-01-01T10:00:00Z",
                         std::optional<int64_t> examiner = std::nullopt) {
    return store_->create_session(pupil, "cab" + std::to_string(++cabs_used_), "manoeuvre_4", mode, examiner, now);
  }
  // A session of `pupil` on `cab` at `now`, started by `by`, ended with `reason` and, when given, a mark.
  std::string EndedSession(int64_t pupil, const std::string& cab, const std::string& scenario, const std::string& now,
                           std::optional<int64_t> by, const std::string& reason, std::optional<double> mark = std::nullopt,
                           bool passed = true) {
    const std::string id = store_->create_session(pupil, cab, scenario, Mode::kTraining, std::nullopt, now, by).public_id;
    if (mark) store_->set_score({id, *mark, passed, {}}, now);
    store_->set_session_state(id, SessionPhase::kEnded, reason, now);
    return id;
  }
  fs::EventRecord MakeEvent(const std::string& session, int64_t seq, const std::string& kind, int worry) {
    return fs::EventRecord{session, seq, 0.1 * static_cast<double>(seq), kind, worry, 1.0, 2.0, "{}"};
  }

  std::string location_;  // the SQLite file, or the PostgreSQL database's URI
  std::unique_ptr<fs::Store> store_;
  int64_t school_ = 0;
  int cabs_used_ = 0;

 private:
  std::string Database() const { return location_.substr(location_.rfind('/') + 1); }
  std::vector<std::string> made_;
};

// ---------------------------------------------------------------- lists, groups and bookings

TEST_P(StoreTest, PupilsAreFoundByNameOrEmailSortedAndPagedWithTheTotal) {
  const int64_t ann = store_->create_pupil(school_, "Ann Archer", "ann@depot.example");
  const int64_t bob = store_->create_pupil(school_, "bob Baker", "BOB@yard.example");
  const int64_t cy = store_->create_pupil(school_, "Cy Cole", "cy@depot.example");
  store_->create_pupil(store_->create_school("Other"), "Ann Elsewhere", "ann@depot.example");
  auto ids = [&](const fs::PupilFilter& f, int limit = 100, int offset = 0) {
    std::vector<int64_t> out;
    for (const auto& p : store_->find_pupils(f, limit, offset).pupils) out.push_back(p.id);
    return out;
  };
  using V = std::vector<int64_t>;
  fs::PupilFilter f;
  f.school_id = school_;
  EXPECT_EQ(ids(f), (V{ann, bob, cy}));  // by name, capitals read as small letters
  f.search = "DEPOT";                     // in the email, whatever its capitals
  EXPECT_EQ(ids(f), (V{ann, cy}));
  EXPECT_EQ(store_->find_pupils(f, 1, 1).total, 2);
  EXPECT_EQ(ids(f, 1, 1), V{cy});
  f.search = "bob@";
  EXPECT_EQ(ids(f), V{bob});
  f.search = "";
  f.sort = "email";
  f.descending = true;
  EXPECT_EQ(ids(f), (V{cy, bob, ann}));
  f.sort = "password";
  EXPECT_EQ(ErrorKind([&] { store_->find_pupils(f, 10, 0); }), fs::StoreError::kInvalid);
  f.sort = "name";
  EXPECT_EQ(ErrorKind([&] { store_->find_pupils(f, -1, 0); }), fs::StoreError::kInvalid);
}

// Keyset paging (PupilFilter::after) gives the pages offset paging gives, in either order and by
// each key it serves, names that differ only in capitals and ties broken by id included; the
// whole school's total is the kept one, and stays right as pupils come and go.
TEST_P(StoreTest, PupilsArePagedAfterARowAsByOffset) {
  const char* names[] = {"eve", "Ann", "ann", "Bob", "cy", "Dan", "ann", "Eve", "bob"};
  std::vector<int64_t> made;
  for (int i = 0; i < 9; ++i) made.push_back(store_->create_pupil(school_, names[i], "p" + std::to_string(8 - i) + "@x.example"));
  for (const char* sort : {"name", "email", "created_at"}) {
    for (const bool descending : {false, true}) {
      fs::PupilFilter f;
      f.school_id = school_;
      f.sort = sort;
      f.descending = descending;
      std::vector<int64_t> by_offset, by_keyset;
      for (int offset = 0; offset < 9; offset += 2)
        for (const auto& p : store_->find_pupils(f, 2, offset).pupils) by_offset.push_back(p.id);
      for (;;) {
        const fs::PupilPage page = store_->find_pupils(f, 2, 0);
        EXPECT_EQ(page.total, 9);
        EXPECT_FALSE(page.total_is_at_least);
        for (const auto& p : page.pupils) by_keyset.push_back(p.id);
        if (page.pupils.size() < 2) break;
        f.after = page.pupils.back().id;
      }
      EXPECT_EQ(by_keyset, by_offset) << sort << (descending ? " desc" : " asc");
      EXPECT_EQ(by_offset.size(), 9u);
    }
  }
  fs::PupilFilter f;
  f.school_id = school_;
  f.after = made[3];
  EXPECT_EQ(store_->find_pupils(f, 1, 1).pupils.at(0).name, "cy");  // Bob, bob, cy: the offset counts from the row after
  f.after = 999999;
  EXPECT_EQ(ErrorKind([&] { store_->find_pupils(f, 2, 0); }), fs::StoreError::kNotFound);
  f.after = made[0];
  f.first_for = 1;
  EXPECT_EQ(ErrorKind([&] { store_->find_pupils(f, 2, 0); }), fs::StoreError::kInvalid);
  ASSERT_EQ(RawExec("DELETE FROM pupils WHERE id = " + std::to_string(made[0])), "");
  fs::PupilFilter all;
  all.school_id = school_;
  EXPECT_EQ(store_->find_pupils(all, 1, 0).total, 8);
}

// The sessions' and the exams' lists paged after a row (SessionFilter::after, ExamFilter::after)
// give the pages offset paging gives, in either order, ties of time broken by id.
TEST_P(StoreTest, SessionsAndExamsArePagedAfterARowAsByOffset) {
  const int64_t pupil = NewPupil("Ann");
  for (int i = 0; i < 9; ++i) {
    const std::string at = "2026-03-0" + std::to_string(1 + i / 3) + "T09:00:00Z";  // three at each time
    const fs::Session s = store_->create_session(pupil, "cab" + std::to_string(i), "manoeuvre_4", Mode::kTraining, std::nullopt, at);
    store_->set_session_state(s.public_id, SessionPhase::kEnded, "task_complete", at);
    store_->add_exam(TheoryRecord(pupil, 0.1 * i, i % 2 == 0, at));
  }
  for (const bool descending : {false, true}) {
    fs::SessionFilter sf;
    sf.school_id = school_;
    sf.descending = descending;
    fs::ExamFilter ef;
    ef.school_id = school_;
    ef.descending = descending;
    std::vector<std::string> sessions_by_offset, sessions_by_keyset;
    std::vector<int64_t> exams_by_offset, exams_by_keyset;
    for (int offset = 0; offset < 9; offset += 2) {
      for (const auto& r : store_->find_sessions(sf, 2, offset).sessions) sessions_by_offset.push_back(r.session.public_id);
      for (const auto& r : store_->find_exams(ef, 2, offset).exams) exams_by_offset.push_back(r.exam.id);
    }
    for (;;) {
      const fs::SessionPage page = store_->find_sessions(sf, 2, 0);
      for (const auto& r : page.sessions) sessions_by_keyset.push_back(r.session.public_id);
      if (page.sessions.size() < 2) break;
      sf.after = page.sessions.back().session.public_id;
    }
    for (;;) {
      const fs::ExamPage page = store_->find_exams(ef, 2, 0);
      EXPECT_EQ(page.total, 9);
      for (const auto& r : page.exams) exams_by_keyset.push_back(r.exam.id);
      if (page.exams.size() < 2) break;
      ef.after = page.exams.back().exam.id;
    }
    EXPECT_EQ(sessions_by_keyset, sessions_by_offset) << (descending ? "desc" : "asc");
    EXPECT_EQ(exams_by_keyset, exams_by_offset) << (descending ? "desc" : "asc");
    EXPECT_EQ(sessions_by_offset.size(), 9u);
    EXPECT_EQ(exams_by_offset.size(), 9u);
  }
  fs::SessionFilter sf;
  sf.school_id = school_;
  sf.after = "s-999999";
  EXPECT_EQ(ErrorKind([&] { store_->find_sessions(sf, 2, 0); }), fs::StoreError::kNotFound);
  sf.after = "s-000001";
  sf.sort = "cab";
  EXPECT_EQ(ErrorKind([&] { store_->find_sessions(sf, 2, 0); }), fs::StoreError::kInvalid);
  fs::ExamFilter ef;
  ef.school_id = school_;
  ef.after = 999999;
  EXPECT_EQ(ErrorKind([&] { store_->find_exams(ef, 2, 0); }), fs::StoreError::kNotFound);
}

TEST_P(StoreTest, GroupsHaveAnInstructorAndPupilsAndFilterTheLists) {
  const int64_t ines = store_->create_user("ines", "h", fs::Role::kInstructor, school_, std::nullopt, "Ines Instructor");
  const int64_t ivan = store_->create_user("ivan", "h", fs::Role::kInstructor, school_, std::nullopt, "Ivan Instructor");
  const int64_t morning = store_->create_group(school_, "Morning course", ines);
  const int64_t evening = store_->create_group(school_, "Evening course", ivan);
  EXPECT_EQ(ErrorKind([&] { store_->create_group(school_, "MORNING course", ines); }), fs::StoreError::kConflict);
  EXPECT_EQ(ErrorKind([&] { store_->create_group(school_, "", ines); }), fs::StoreError::kInvalid);
  const int64_t pupil_user = store_->create_user("pia", "h", fs::Role::kPupil, school_, NewPupil("Pia"));
  EXPECT_EQ(ErrorKind([&] { store_->create_group(school_, "Pupils teach", pupil_user); }), fs::StoreError::kInvalid);

  const int64_t ann = NewPupil("Ann"), bob = NewPupil("Bob"), cy = NewPupil("Cy");
  store_->set_pupil_group(ann, evening);
  store_->set_pupil_group(bob, morning);
  store_->set_pupil_group(cy, morning);
  store_->set_pupil_group(cy, std::nullopt);  // out again: in at most one group
  EXPECT_EQ(store_->get_pupil(bob)->group_id, morning);
  EXPECT_FALSE(store_->get_pupil(cy)->group_id.has_value());
  const int64_t elsewhere = store_->create_group(store_->create_school("Other"), "Morning course", std::nullopt);
  EXPECT_EQ(ErrorKind([&] { store_->set_pupil_group(ann, elsewhere); }), fs::StoreError::kInvalid);

  const auto groups = store_->list_groups(school_);
  ASSERT_EQ(groups.size(), 2u);
  EXPECT_EQ(groups[0].name, "Evening course");  // by name
  EXPECT_EQ(groups[1].pupils, 1);
  EXPECT_EQ(groups[1].instructor_id, ines);
  store_->update_group(morning, "Morning course A", ivan);
  EXPECT_EQ(store_->get_group(morning)->name, "Morning course A");
  EXPECT_EQ(store_->get_group(morning)->instructor_id, ivan);
  store_->update_group(morning, "Morning course", ines);

  auto names = [&](const fs::PupilFilter& f) {
    std::vector<std::string> out;
    for (const auto& p : store_->find_pupils(f, 100, 0).pupils) out.push_back(p.name);
    return out;
  };
  using V = std::vector<std::string>;
  fs::PupilFilter f;
  f.school_id = school_;
  f.group_id = morning;
  EXPECT_EQ(names(f), V{"Bob"});
  f.group_id = 0;  // in no group
  EXPECT_EQ(names(f), (V{"Cy", "Pia"}));
  f.group_id.reset();
  f.instructor_id = ivan;
  EXPECT_EQ(names(f), V{"Ann"});
  f.instructor_id.reset();
  f.first_for = ines;  // Ines's pupils first, then the rest by name
  EXPECT_EQ(names(f), (V{"Bob", "Ann", "Cy", "Pia"}));
  f.first_for.reset();
  f.sort = "group";
  EXPECT_EQ(names(f), (V{"Pia", "Cy", "Ann", "Bob"}));  // no group (ties by id), Evening, Morning
}

TEST_P(StoreTest, SessionsAreFoundByDateCabScenarioInstructorOutcomeAndResult) {
  const int64_t ines = store_->create_user("ines", "h", fs::Role::kInstructor, school_, std::nullopt, "Ines Instructor");
  const int64_t ann = store_->create_pupil(school_, "Ann", "ann@depot.example"), bob = NewPupil("Bob");
  const int64_t group = store_->create_group(school_, "Morning", ines);
  store_->set_pupil_group(bob, group);
  const std::string a1 = EndedSession(ann, "cab1", "manoeuvre_4", "2026-11-23T08:00:00Z", ines, "task_complete", 82.5, true);
  const std::string a2 = EndedSession(ann, "cab2", "manoeuvre_4", "2026-11-23T09:00:00Z", std::nullopt, "time_limit");
  const std::string b1 = EndedSession(bob, "cab1", "yard_drive", "2026-11-23T10:00:00Z", ines, "task_complete", 40, false);
  const std::string b2 = EndedSession(bob, "cab1", "manoeuvre_4", "2026-11-24T08:00:00Z", ines, "signal");
  const std::string open = store_->create_session(bob, "cab2", "yard_drive", Mode::kTraining, std::nullopt, "2026-11-24T09:00:00Z", ines).public_id;
  store_->create_session(store_->create_pupil(store_->create_school("Other"), "Zed", ""), "cab1", "yard_drive", Mode::kTraining,
                         std::nullopt, "2026-11-23T08:30:00Z");

  auto ids = [&](fs::SessionFilter f) {
    f.school_id = school_;
    std::vector<std::string> out;
    for (const auto& r : store_->find_sessions(f, 100, 0).sessions) out.push_back(r.session.public_id);
    return out;
  };
  using V = std::vector<std::string>;
  EXPECT_EQ(ids({}), (V{open, b2, b1, a2, a1}));  // newest first; not another school's
  fs::SessionFilter day;
  day.from = "2026-11-23T00:00:00Z";
  day.to = "2026-11-24T00:00:00Z";
  EXPECT_EQ(ids(day), (V{b1, a2, a1}));
  fs::SessionFilter f = day;
  f.cab_id = "cab1";
  EXPECT_EQ(ids(f), (V{b1, a1}));
  f.scenario = "yard_drive";
  EXPECT_EQ(ids(f), V{b1});
  f = {};
  f.instructor_id = ines;
  f.descending = false;
  EXPECT_EQ(ids(f), (V{a1, b1, b2, open}));
  f = {};
  f.group_id = group;
  f.outcome = Outcome::kStopped;
  EXPECT_EQ(ids(f), V{b2});
  f = {};
  f.outcome = Outcome::kOpen;
  EXPECT_EQ(ids(f), V{open});
  f = {};
  f.result = "passed";
  EXPECT_EQ(ids(f), V{a1});
  f.result = "not_passed";
  EXPECT_EQ(ids(f), (V{b2, b1, a2}));
  f = {};
  f.search = "DEPOT";
  EXPECT_EQ(ids(f), (V{a2, a1}));
  f = {};
  f.sort = "mark";  // unmarked lowest
  EXPECT_EQ(ids(f).front(), a1);
  f.sort = "pupil";
  f.descending = false;
  EXPECT_EQ(ids(f).front(), a1);

  fs::SessionFilter page;
  page.school_id = school_;
  const fs::SessionPage p = store_->find_sessions(page, 2, 1);
  EXPECT_EQ(p.total, 5);
  ASSERT_EQ(p.sessions.size(), 2u);
  EXPECT_EQ(p.sessions[0].session.public_id, b2);
  EXPECT_EQ(p.sessions[0].pupil_name, "Bob");
  EXPECT_EQ(p.sessions[0].session.started_by, ines);
  page.sort = "password";
  EXPECT_EQ(ErrorKind([&] { store_->find_sessions(page, 10, 0); }), fs::StoreError::kInvalid);
  page.sort = "created_at";
  page.result = "won";
  EXPECT_EQ(ErrorKind([&] { store_->find_sessions(page, 10, 0); }), fs::StoreError::kInvalid);
}

TEST_P(StoreTest, ExamsAreFoundByKindDateAndResultWithTheirCorrections) {
  const int64_t ann = NewPupil("Ann"), bob = NewPupil("Bob");
  const int64_t erin = store_->create_user("erin", "h", fs::Role::kExaminer, school_, std::nullopt, "Erin Examiner");
  const int64_t t1 = store_->add_exam(TheoryRecord(ann, 0.9, true, "2026-11-23T08:00:00Z"));
  const int64_t t2 = store_->add_exam(TheoryRecord(bob, 0.5, false, "2026-11-24T08:00:00Z"));
  fs::ExamRecord practical;
  practical.pupil_id = bob;
  practical.kind = forklift::ExamKind::kPractical;
  practical.score = 71.25;
  practical.passed = true;
  practical.examiner_id = erin;
  practical.taken_at = "2026-11-24T10:00:00Z";
  const int64_t p1 = store_->add_exam(practical);
  store_->add_exam_correction({0, t2, erin, "", "marked again", R"({"passed": true})"});

  auto ids = [&](fs::ExamFilter f) {
    f.school_id = school_;
    std::vector<int64_t> out;
    for (const auto& r : store_->find_exams(f, 100, 0).exams) out.push_back(r.exam.id);
    return out;
  };
  using V = std::vector<int64_t>;
  EXPECT_EQ(ids({}), (V{p1, t2, t1}));
  fs::ExamFilter f;
  f.kind = forklift::ExamKind::kTheory;
  EXPECT_EQ(ids(f), (V{t2, t1}));
  f.passed = false;
  EXPECT_EQ(ids(f), V{t2});
  f = {};
  f.from = "2026-11-24T00:00:00Z";
  f.examiner_id = erin;
  EXPECT_EQ(ids(f), V{p1});
  f = {};
  f.sort = "score";
  f.descending = false;
  EXPECT_EQ(ids(f), (V{t2, t1, p1}));
  fs::ExamFilter all;
  all.school_id = school_;
  const fs::ExamPage page = store_->find_exams(all, 1, 1);
  EXPECT_EQ(page.total, 3);
  ASSERT_EQ(page.exams.size(), 1u);
  EXPECT_EQ(page.exams[0].pupil_name, "Bob");
  EXPECT_EQ(page.exams[0].corrections, 1);
}

// A school's exams are listed from the school kept on each exam's row: another school's are never
// among them, by kind and result or all of them, with their totals; the same after the upgrade
// that keeps the school there (schema 19) filled it in for the exams before it, which still
// refuse any change afterwards; an exam written without its pupil's school is refused.
TEST_P(StoreTest, ASchoolsExamsAreItsOwnAsBeforeTheUpgradeThatKeepsTheSchoolOnThem) {
  const int64_t other_school = store_->create_school("Other school");
  const int64_t ann = NewPupil("Ann"), zoe = store_->create_pupil(other_school, "Zoe", "");
  fs::ExamRecord practical;
  practical.kind = forklift::ExamKind::kPractical;
  practical.score = 90;
  practical.passed = true;
  std::vector<int64_t> ours, theirs;
  for (int i = 0; i < 6; ++i) {
    practical.pupil_id = i % 2 ? zoe : ann;
    practical.taken_at = "2026-11-2" + std::to_string(i) + "T10:00:00Z";
    practical.passed = i < 4;
    (i % 2 ? theirs : ours).push_back(store_->add_exam(practical));
  }
  (void)store_->add_exam(TheoryRecord(zoe, 0.9, true, "2026-11-27T08:00:00Z"));
  const int64_t ann_theory = store_->add_exam(TheoryRecord(ann, 0.9, true, "2026-11-28T08:00:00Z"));
  const auto listed = [&](int64_t school, bool practical_passed) {
    fs::ExamFilter f;
    f.school_id = school;
    if (practical_passed) {
      f.kind = forklift::ExamKind::kPractical;
      f.passed = true;
    }
    const fs::ExamPage page = store_->find_exams(f, 100, 0);
    std::vector<int64_t> ids;
    for (const auto& r : page.exams) ids.push_back(r.exam.id);
    EXPECT_EQ(page.total, static_cast<int64_t>(ids.size()));
    return ids;
  };
  using V = std::vector<int64_t>;
  const auto check = [&](const char* when) {
    EXPECT_EQ(listed(school_, false), (V{ann_theory, ours[2], ours[1], ours[0]})) << when;
    EXPECT_EQ(listed(school_, true), (V{ours[1], ours[0]})) << when;
    EXPECT_EQ(listed(other_school, true), (V{theirs[1], theirs[0]})) << when;
    EXPECT_EQ(listed(other_school, false).size(), 4u) << when;
  };
  check("as written");
  store_.reset();
  ASSERT_EQ(RawExec(DropMigration19()), "");  // schema 18, as an older program left it
  store_ = Open();
  check("filled in by the upgrade");
  EXPECT_NE(RawExec("UPDATE exams SET score = 1"), "");
  EXPECT_NE(RawExec("DELETE FROM exams"), "");
  // Written past the store, an exam without its pupil's school is refused: the lists would miss it.
  const std::string exam = "INSERT INTO exams(pupil_id, kind, score, passed, taken_at, school_id) VALUES (" + std::to_string(ann) +
                           ", 'theory', 0.5, FALSE, '2026-11-29T08:00:00Z', ";
  EXPECT_NE(RawExec(exam + "NULL)"), "");
  EXPECT_NE(RawExec(exam + std::to_string(other_school) + ")"), "");
  EXPECT_EQ(RawExec(exam + std::to_string(school_) + ")"), "");
}

TEST_P(StoreTest, ACabIsNeverBookedTwiceAtOnce) {
  const int64_t ines = store_->create_user("ines", "h", fs::Role::kInstructor, school_, std::nullopt, "Ines Instructor");
  const int64_t ann = NewPupil("Ann"), bob = NewPupil("Bob");
  fs::Booking b;
  b.pupil_id = ann;
  b.cab_id = "cab1";
  b.starts_at = "2026-11-23T09:00:00Z";
  b.ends_at = "2026-11-23T10:00:00Z";
  b.scenario = "manoeuvre_4";
  b.instructor_id = ines;
  const int64_t first = store_->create_booking(b);
  fs::Booking overlap = b;
  overlap.pupil_id = bob;
  overlap.starts_at = "2026-11-23T09:30:00Z";
  overlap.ends_at = "2026-11-23T10:30:00Z";
  EXPECT_EQ(ErrorKind([&] { store_->create_booking(overlap); }), fs::StoreError::kConflict);
  overlap.starts_at = "2026-11-23T08:00:00Z";  // around it
  overlap.ends_at = "2026-11-23T11:00:00Z";
  EXPECT_EQ(ErrorKind([&] { store_->create_booking(overlap); }), fs::StoreError::kConflict);
  fs::Booking after = overlap;
  after.starts_at = "2026-11-23T10:00:00Z";  // back to back is not double
  after.ends_at = "2026-11-23T10:30:00Z";
  const int64_t second = store_->create_booking(after);
  fs::Booking other_cab = overlap;
  other_cab.cab_id = "cab2";
  const int64_t third = store_->create_booking(other_cab);
  fs::Booking backwards = b;
  backwards.cab_id = "cab3";
  backwards.ends_at = b.starts_at;
  EXPECT_EQ(ErrorKind([&] { store_->create_booking(backwards); }), fs::StoreError::kInvalid);

  const auto day = store_->list_bookings(school_, "2026-11-23T00:00:00Z", "2026-11-24T00:00:00Z");
  ASSERT_EQ(day.size(), 3u);
  EXPECT_EQ(day[0].id, first);  // by cab, then time
  EXPECT_EQ(day[1].id, second);
  EXPECT_EQ(day[2].id, third);
  EXPECT_EQ(day[0].pupil_name, "Ann");
  EXPECT_EQ(day[0].school_id, school_);
  EXPECT_TRUE(store_->list_bookings(school_, "2026-11-24T00:00:00Z", "2026-11-25T00:00:00Z").empty());

  const std::string s = NewSession(ann).public_id;
  store_->set_booking_session(first, s);
  EXPECT_EQ(store_->get_booking(first)->session_public_id, s);
  EXPECT_EQ(ErrorKind([&] { store_->set_booking_session(first, s); }), fs::StoreError::kConflict);
  EXPECT_EQ(ErrorKind([&] { store_->delete_booking(first); }), fs::StoreError::kConflict);
  store_->delete_booking(second);
  EXPECT_FALSE(store_->get_booking(second).has_value());
  EXPECT_EQ(ErrorKind([&] { store_->delete_booking(second); }), fs::StoreError::kNotFound);
}

INSTANTIATE_TEST_SUITE_P(, StoreTest, ::testing::Values(Backend::kSqlite, Backend::kPostgresql),
                         [](const ::testing::TestParamInfo<Backend>& info) { return std::string(Name(info.param)); });

TEST_P(StoreTest, MigrationsAreAppliedOnceAndReopeningKeepsData) {
  const int version = store_->schema_version();
  EXPECT_GE(version, 1);
  const int64_t pupil = NewPupil("Ann");
  const auto applied = RawQuery("SELECT version || ' ' || applied_at FROM schema_migrations ORDER BY version");
  ASSERT_EQ(applied.size(), static_cast<size_t>(version));

  store_.reset();
  store_ = Open();
  EXPECT_EQ(store_->schema_version(), version);
  ASSERT_TRUE(store_->get_pupil(pupil).has_value());
  EXPECT_EQ(store_->get_pupil(pupil)->name, "Ann");
  // Same rows, same applied_at: nothing was applied again.
  EXPECT_EQ(RawQuery("SELECT version || ' ' || applied_at FROM schema_migrations ORDER BY version"), applied);
}

TEST_P(StoreTest, WalModeAndForeignKeysAreOn) {
  if (sqlite()) {
    // journal_mode=WAL is a property of the file, visible to any connection.
    EXPECT_EQ(RawQuery("PRAGMA journal_mode"), std::vector<std::string>{"wal"});
    EXPECT_FALSE(RawQuery("SELECT \"table\" FROM pragma_foreign_key_list('sessions')").empty());
  } else {
    // PostgreSQL has no journal mode to set (its WAL is always on) and always enforces the
    // foreign keys its schema declares.
    EXPECT_FALSE(RawQuery("SELECT conname FROM pg_constraint WHERE conrelid = 'sessions'::regclass AND contype = 'f'").empty());
  }
  // foreign_keys is per connection: only the store's own enforcement shows it. create_pupil does
  // not look the school up itself, so only the foreign key can refuse an unknown one.
  EXPECT_EQ(ErrorKind([&] { store_->create_pupil(school_ + 999, "Nobody", ""); }), fs::StoreError::kNotFound);
  EXPECT_EQ(ErrorKind([&] { store_->create_user("ghost", "h", fs::Role::kPupil, school_, 12345); }),
            fs::StoreError::kNotFound);
  if (sqlite()) {
    EXPECT_TRUE(RawQuery("PRAGMA foreign_key_check").empty());
  }
}

TEST_P(StoreTest, UsersAreUniqueAndRoundTrip) {
  const int64_t pupil = NewPupil("Ann");
  const int64_t id = store_->create_user("ann", "hash1", fs::Role::kPupil, school_, pupil);
  EXPECT_EQ(ErrorKind([&] { store_->create_user("ann", "hash2", fs::Role::kAdmin, school_); }),
            fs::StoreError::kConflict);
  EXPECT_EQ(ErrorKind([&] { store_->create_user("", "hash", fs::Role::kAdmin, school_); }), fs::StoreError::kInvalid);
  EXPECT_EQ(ErrorKind([&] { store_->create_pupil(school_, "", ""); }), fs::StoreError::kInvalid);

  const auto user = store_->find_user("ann");
  ASSERT_TRUE(user.has_value());
  EXPECT_EQ(user->id, id);
  EXPECT_EQ(user->password_hash, "hash1");
  EXPECT_EQ(user->role, fs::Role::kPupil);
  EXPECT_EQ(user->pupil_id, pupil);
  EXPECT_EQ(store_->get_user(id)->username, "ann");
  EXPECT_FALSE(store_->find_user("bob").has_value());

  for (fs::Role r : {fs::Role::kAdmin, fs::Role::kInstructor, fs::Role::kExaminer, fs::Role::kPupil}) {
    EXPECT_EQ(fs::parse_role(fs::role_name(r)), r);
  }
  EXPECT_FALSE(fs::parse_role("janitor").has_value());
}

// Usernames: capitals read as small letters, a-z 0-9 . _ - only, 1-64; unique and found so.
TEST_P(StoreTest, UsernamesAreStoredLowerCaseUniqueAndFoundWhateverTheirCapitals) {
  EXPECT_EQ(fs::canonical_username("Ann.Lee-2_b"), "ann.lee-2_b");
  for (const std::string bad : {"", "ann ", " ann", "an n", "ann\n", "ann\t", "ann\x7f", "\xd0\xb0nn", "ann\xc2\xa0", "ann@school"})
    EXPECT_FALSE(fs::canonical_username(bad).has_value()) << bad;
  EXPECT_TRUE(fs::canonical_username(std::string(64, 'a')).has_value());
  EXPECT_FALSE(fs::canonical_username(std::string(65, 'a')).has_value());

  const int64_t ann = store_->create_user("ann", "h", fs::Role::kInstructor, school_);
  EXPECT_EQ(ErrorKind([&] { store_->create_user("Ann", "h", fs::Role::kAdmin, school_); }), fs::StoreError::kInvalid);  // not canonical
  EXPECT_EQ(store_->find_user("ANN")->id, ann);
  EXPECT_FALSE(store_->find_user("ann ").has_value());
  // A name stored before the rule keeps its capitals, is found without them and blocks a copy.
  ASSERT_EQ(RawExec("INSERT INTO users(username, password_hash, role, school_id) VALUES ('Bob', 'h', 'admin', " +
                               std::to_string(school_) + ")"),
            "");
  EXPECT_EQ(store_->find_user("bob")->username, "Bob");
  EXPECT_EQ(ErrorKind([&] { store_->create_user("bob", "h", fs::Role::kAdmin, school_); }), fs::StoreError::kConflict);
}

TEST_P(StoreTest, CreateSessionValidatesAndAssignsPublicId) {
  const int64_t pupil = NewPupil("Ann");
  EXPECT_EQ(ErrorKind([&] { NewSession(pupil + 999); }), fs::StoreError::kNotFound);
  EXPECT_EQ(ErrorKind([&] { store_->create_session(pupil, "", "m4", Mode::kTraining, std::nullopt, "t"); }),
            fs::StoreError::kInvalid);
  EXPECT_EQ(ErrorKind([&] { store_->create_session(pupil, "cab1", "", Mode::kTraining, std::nullopt, "t"); }),
            fs::StoreError::kInvalid);

  const fs::Session s = NewSession(pupil);
  EXPECT_EQ(s.public_id, "s-000001");
  EXPECT_EQ(s.state, SessionPhase::kStarting);
  const auto stored = store_->get_session("s-000001");
  ASSERT_TRUE(stored.has_value());
  EXPECT_EQ(stored->pupil_id, pupil);
  EXPECT_EQ(stored->cab_id, s.cab_id);
  EXPECT_EQ(stored->mode, Mode::kTraining);
  EXPECT_EQ(stored->state, SessionPhase::kStarting);
  EXPECT_TRUE(stored->ended_at.empty());
  EXPECT_FALSE(stored->mark.has_value());
  EXPECT_EQ(NewSession(pupil).public_id, "s-000002");
}

// SQLite's reads derive a session's public id from its id rather than read the schema's virtual
// column (common.h: session_public_id); the two agree, past six digits too, in both backends.
TEST_P(StoreTest, PublicIdsAreDerivedAsTheSchemaDerivesThem) {
  const int64_t pupil = NewPupil("Ann");
  const std::string first = NewSession(pupil).public_id;
  for (const char* id : {"999999", "1000000", "1234567"}) {
    ASSERT_EQ(RawExec(std::string("INSERT INTO sessions(id, pupil_id, cab_id, scenario, mode, state, created_at) VALUES (") +
                      id + ", " + std::to_string(pupil) + ", 'cab1', 'manoeuvre_4', 'training', 'ended', '2026-01-02T10:00:00Z')"),
              "");
  }
  const std::vector<std::string> schema = RawQuery("SELECT public_id FROM sessions WHERE pupil_id = " + std::to_string(pupil) + " ORDER BY id");
  EXPECT_EQ(schema, (std::vector<std::string>{first, "s-999999", "s-1000000", "s-1234567"}));
  std::vector<std::string> read;
  for (const fs::Session& s : store_->list_sessions_for_pupil(pupil)) read.push_back(s.public_id);
  EXPECT_EQ(read, schema);
  for (const std::string& public_id : schema) {
    const auto s = store_->get_session(public_id);  // found by the schema's column, read back as derived
    ASSERT_TRUE(s.has_value()) << public_id;
    EXPECT_EQ(s->public_id, public_id);
  }
}

TEST_P(StoreTest, EventsAreStoredExactlyOnce) {
  const std::string s = NewSession(NewPupil("Ann")).public_id;
  EXPECT_TRUE(store_->add_event(MakeEvent(s, 1, "overspeed", 2)));
  EXPECT_TRUE(store_->add_event(MakeEvent(s, 2, "collision", 3)));
  EXPECT_FALSE(store_->add_event(MakeEvent(s, 1, "something else", 1)));  // a redelivery
  const auto events = store_->list_events(s);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].seq, 1);
  EXPECT_EQ(events[0].kind, "overspeed");  // the first one kept
  EXPECT_EQ(events[0].worry_level, 2);
  EXPECT_DOUBLE_EQ(events[0].y_m, 2.0);
  EXPECT_EQ(events[1].kind, "collision");
  EXPECT_EQ(ErrorKind([&] { store_->add_event(MakeEvent("s-999999", 1, "x", 1)); }), fs::StoreError::kNotFound);
}

TEST_P(StoreTest, ScoreIsKeptOnceAndSetsTheMark) {
  const int64_t pupil = NewPupil("Ann");
  const std::string s = NewSession(pupil).public_id;
  EXPECT_TRUE(store_->set_score(fs::ScoreRecord{s, 72.5, true, {{"overspeed", 2}, {"collision", 1}}}, "t1"));
  EXPECT_FALSE(store_->set_score(fs::ScoreRecord{s, 10, false, {}}, "t2"));
  const auto score = store_->get_score(s);
  ASSERT_TRUE(score.has_value());
  EXPECT_DOUBLE_EQ(score->mark, 72.5);
  EXPECT_TRUE(score->passed);
  EXPECT_EQ(score->counts, (std::map<std::string, int>{{"collision", 1}, {"overspeed", 2}}));
  const auto session = store_->get_session(s);
  EXPECT_EQ(session->mark, 72.5);
  EXPECT_EQ(session->passed, true);
  EXPECT_TRUE(store_->history(pupil, "t3")->exams.empty());  // a training session is no exam
  EXPECT_EQ(ErrorKind([&] { store_->set_score(fs::ScoreRecord{"s-999999", 1, true, {}}, "t"); }),
            fs::StoreError::kNotFound);
}

TEST_P(StoreTest, ExamSessionScoreAddsPracticalExam) {
  const int64_t pupil = NewPupil("Ann");
  const int64_t examiner = store_->create_user("eve", "h", fs::Role::kExaminer, school_);
  const std::string s = NewSession(pupil, Mode::kExam, "2026-01-01T10:00:00Z", examiner).public_id;
  ASSERT_TRUE(store_->set_score(fs::ScoreRecord{s, 81, true, {}}, "2026-01-01T10:30:00Z"));
  ASSERT_FALSE(store_->set_score(fs::ScoreRecord{s, 20, false, {}}, "2026-01-01T10:40:00Z"));
  const auto exams = store_->history(pupil, "2026-01-02T00:00:00Z")->exams;
  ASSERT_EQ(exams.size(), 1u);
  EXPECT_EQ(exams[0].kind, forklift::ExamKind::kPractical);
  EXPECT_EQ(exams[0].session_public_id, s);
  EXPECT_DOUBLE_EQ(exams[0].score, 81);
  EXPECT_TRUE(exams[0].passed);
  EXPECT_EQ(exams[0].examiner_id, examiner);
  EXPECT_EQ(exams[0].taken_at, "2026-01-01T10:30:00Z");
}

TEST_P(StoreTest, TheoryExamsAreValidated) {
  const int64_t pupil = NewPupil("Ann");
  fs::ExamRecord r;
  r.pupil_id = pupil;
  r.kind = forklift::ExamKind::kTheory;
  r.score = 0.9;
  r.passed = true;
  r.taken_at = "2026-02-01T09:00:00Z";
  r.details = R"({"answers":[1,2,3]})";
  const int64_t id = store_->add_exam(r);
  const auto exams = store_->history(pupil, "2026-03-01T00:00:00Z")->exams;
  ASSERT_EQ(exams.size(), 1u);
  EXPECT_EQ(exams[0].id, id);
  EXPECT_EQ(exams[0].details, r.details);
  EXPECT_FALSE(exams[0].session_public_id.has_value());

  r.pupil_id = pupil + 999;
  EXPECT_EQ(ErrorKind([&] { store_->add_exam(r); }), fs::StoreError::kNotFound);
}

TEST_P(StoreTest, TerminalStatesNeverChange) {
  const int64_t pupil = NewPupil("Ann");
  const std::string s = NewSession(pupil).public_id;
  const std::string other = NewSession(pupil).public_id;
  EXPECT_EQ(ErrorKind([&] { store_->set_session_state("s-999999", SessionPhase::kRunning, "", "t"); }),
            fs::StoreError::kNotFound);

  EXPECT_TRUE(store_->set_session_state(s, SessionPhase::kRunning, "", "2026-01-01T10:01:00Z"));
  EXPECT_TRUE(store_->get_session(s)->ended_at.empty());
  EXPECT_TRUE(store_->set_session_state(s, SessionPhase::kEnded, "finished", "2026-01-01T10:20:00Z"));
  EXPECT_FALSE(store_->set_session_state(s, SessionPhase::kRunning, "again", "2026-01-01T10:30:00Z"));
  EXPECT_FALSE(store_->set_session_state(s, SessionPhase::kAborted, "late", "2026-01-01T10:31:00Z"));
  const auto ended = store_->get_session(s);
  EXPECT_EQ(ended->state, SessionPhase::kEnded);
  EXPECT_EQ(ended->reason, "finished");
  EXPECT_EQ(ended->ended_at, "2026-01-01T10:20:00Z");

  const auto open = store_->open_sessions();
  ASSERT_EQ(open.size(), 1u);
  EXPECT_EQ(open[0].public_id, other);
  EXPECT_TRUE(store_->set_session_state(other, SessionPhase::kFailed, "worker died", "t"));
  EXPECT_FALSE(store_->set_session_state(other, SessionPhase::kEnded, "", "t"));
  EXPECT_TRUE(store_->open_sessions().empty());
}

TEST_P(StoreTest, ListPupilsSearchIsCaseInsensitiveAndLiteral) {
  for (const char* name : {"bob JONES", "Alice Jonesy", "carol 100%", "Dan 1005", "Eve_Y", "EveXY"}) NewPupil(name);
  const int64_t other_school = store_->create_school("Other");
  store_->create_pupil(other_school, "Zed Jones", "");

  auto names = [&](const std::string& search, int limit = 100, int offset = 0) {
    std::vector<std::string> out;
    for (const auto& p : store_->list_pupils(school_, search, limit, offset)) out.push_back(p.name);
    return out;
  };
  using V = std::vector<std::string>;
  EXPECT_EQ(names("jones"), (V{"Alice Jonesy", "bob JONES"}));  // by name, ignoring case
  EXPECT_EQ(names("100%"), V{"carol 100%"});                     // % is literal
  EXPECT_EQ(names("e_"), V{"Eve_Y"});                            // _ is literal
  EXPECT_EQ(names(""), (V{"Alice Jonesy", "bob JONES", "carol 100%", "Dan 1005", "Eve_Y", "EveXY"}));
  EXPECT_EQ(names("", 2, 1), (V{"bob JONES", "carol 100%"}));
  EXPECT_EQ(ErrorKind([&] { store_->list_pupils(school_ + 999, "", 10, 0); }), fs::StoreError::kNotFound);
}

TEST_P(StoreTest, CabsAreUpsertedPerSchool) {
  store_->cab_seen("cab1", school_, "2026-01-01T08:00:00Z");
  store_->cab_seen("cab1", school_, "2026-01-01T09:00:00Z");
  const auto cabs = store_->list_cabs(school_);
  ASSERT_EQ(cabs.size(), 1u);
  EXPECT_EQ(cabs[0].last_seen_at, "2026-01-01T09:00:00Z");
  const int64_t other = store_->create_school("Other");
  EXPECT_EQ(ErrorKind([&] { store_->cab_seen("cab1", other, "t"); }), fs::StoreError::kConflict);
}

TEST_P(StoreTest, SessionLogsAreReplaced) {
  const std::string s = NewSession(NewPupil("Ann")).public_id;
  EXPECT_FALSE(store_->get_session_log(s, "control").has_value());
  store_->put_session_log(s, "control", "v1");
  store_->put_session_log(s, "control", "v2");
  EXPECT_EQ(store_->get_session_log(s, "control"), "v2");
  EXPECT_EQ(ErrorKind([&] { store_->put_session_log("s-999999", "control", "x"); }), fs::StoreError::kNotFound);
}

TEST_P(StoreTest, HistoryAggregatesFaultsTrendAndLicence) {
  const int64_t pupil = NewPupil("Ann");
  const int64_t other = NewPupil("Bob");
  const std::string s1 = NewSession(pupil, Mode::kTraining, "2026-01-01T10:00:00Z").public_id;
  const std::string aborted = NewSession(pupil, Mode::kTraining, "2026-01-02T10:00:00Z").public_id;
  const std::string s2 = NewSession(pupil, Mode::kTraining, "2026-01-03T10:00:00Z").public_id;
  const std::string s3 = NewSession(pupil, Mode::kTraining, "2026-01-04T10:00:00Z").public_id;
  const std::string bobs = NewSession(other).public_id;
  store_->add_event(MakeEvent(s1, 1, "overspeed", 2));
  store_->add_event(MakeEvent(s1, 2, "overspeed", 1));
  store_->add_event(MakeEvent(s1, 3, "horn", 0));  // worry 0: not a fault
  store_->add_event(MakeEvent(s2, 1, "overspeed", 3));
  store_->add_event(MakeEvent(s2, 2, "collision", 3));
  store_->add_event(MakeEvent(bobs, 1, "collision", 3));  // someone else's
  store_->add_event(MakeEvent(s2, 2, "collision", 3));  // heard twice: counted once
  store_->set_session_state(aborted, SessionPhase::kAborted, "cab lost", "2026-01-02T10:05:00Z");
  // The worker's score follows an abort: an aborted session keeps it, and has no mark.
  store_->set_score(fs::ScoreRecord{aborted, 95, true, {}}, "t");
  store_->set_score(fs::ScoreRecord{s1, 50, false, {}}, "t");
  store_->set_score(fs::ScoreRecord{s2, 60, false, {}}, "t");
  store_->set_score(fs::ScoreRecord{s3, 70, true, {}}, "t");
  for (const std::string& s : {s1, s2, s3}) store_->set_session_state(s, SessionPhase::kEnded, "task_complete", "t");
  store_->add_licence(pupil, "2021-05-01T12:00:00Z", "inspector");
  const int64_t latest = store_->add_licence(pupil, "2022-05-01T12:00:00Z", "inspector");

  const auto h = store_->history(pupil, "2026-01-05T00:00:00Z");
  ASSERT_TRUE(h.has_value());
  EXPECT_EQ(h->pupil.name, "Ann");
  ASSERT_EQ(h->sessions.size(), 4u);
  EXPECT_EQ(h->sessions.front().public_id, s1);
  EXPECT_EQ(h->sessions.back().public_id, s3);
  EXPECT_EQ(h->faults_by_kind, (std::map<std::string, int>{{"collision", 1}, {"overspeed", 3}}));
  ASSERT_TRUE(h->trend.has_value());
  EXPECT_NEAR(*h->trend, 10.0, 1e-9);  // 50, 60, 70 over the marked sessions, not the aborted one's 95
  ASSERT_TRUE(h->licence.has_value());
  EXPECT_EQ(h->licence->id, latest);
  EXPECT_EQ(h->licence->reevaluation_due, "2025-05-01T12:00:00Z");
  EXPECT_TRUE(h->reevaluation_overdue);

  EXPECT_FALSE(store_->history(pupil, "2025-04-30T23:59:59Z")->reevaluation_overdue);
  const auto bob = store_->history(other, "2026-01-05T00:00:00Z");
  EXPECT_FALSE(bob->trend.has_value());
  EXPECT_FALSE(bob->licence.has_value());
  EXPECT_FALSE(bob->reevaluation_overdue);
  EXPECT_FALSE(store_->history(pupil + 999, "t").has_value());
}

TEST_P(StoreTest, BatchIsAllOrNothingAndACallFailingInsideItUndoesOnlyItself) {
  // A failing batch leaves nothing behind.
  EXPECT_THROW(store_->batch([&] {
    store_->create_pupil(school_, "Ann", "");
    store_->create_pupil(school_, "Bob", "");
    throw std::runtime_error("import aborted");
  }), std::runtime_error);
  EXPECT_TRUE(store_->list_pupils(school_, "", 10, 0).empty());

  // A refused call inside a batch is undone alone; the batch's other writes commit.
  store_->batch([&] {
    store_->create_user("carol", "h", fs::Role::kInstructor, school_);
    EXPECT_EQ(ErrorKind([&] { store_->create_user("carol", "h2", fs::Role::kAdmin, school_); }),
              fs::StoreError::kConflict);
    store_->create_pupil(school_, "Dan", "");
  });
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM users WHERE username = 'carol'"), std::vector<std::string>{"1"});
  EXPECT_EQ(store_->list_pupils(school_, "", 10, 0).size(), 1u);
  EXPECT_EQ(ErrorKind([&] { store_->batch([&] { store_->batch([] {}); }); }), fs::StoreError::kInvalid);
}

// A call the database itself refuses (a foreign key, a check) inside a batch undoes only itself:
// the batch goes on and commits the rest (PostgreSQL would otherwise refuse the rest of it).
TEST_P(StoreTest, ACallTheDatabaseRefusesInsideABatchUndoesOnlyItself) {
  store_->batch([&] {
    store_->create_pupil(school_, "Ann", "");
    EXPECT_EQ(ErrorKind([&] { store_->create_pupil(school_ + 999, "Nobody", ""); }), fs::StoreError::kNotFound);
    fs::AuditRecord bad;
    bad.actor = {std::nullopt, "server"};
    bad.pupil_id = store_->list_pupils(school_, "Ann", 1, 0).at(0).id;
    bad.action = "pupil_created";
    bad.details = "not json";
    EXPECT_EQ(ErrorKind([&] { store_->add_audit(bad); }), fs::StoreError::kInvalid);
    EXPECT_EQ(ErrorKind([&] { store_->batch([] {}); }), fs::StoreError::kInvalid);
    store_->create_pupil(school_, "Bob", "");
  });
  std::vector<std::string> names;
  for (const auto& p : store_->list_pupils(school_, "", 10, 0)) names.push_back(p.name);
  EXPECT_EQ(names, (std::vector<std::string>{"Ann", "Bob"}));
  EXPECT_TRUE(store_->list_audit({}, 10, 0).empty());
  // And a batch in which nothing reached the database commits nothing, and the store goes on.
  store_->batch([] {});
  EXPECT_EQ(ErrorKind([&] { store_->batch([&] { store_->update_pupil(12345, "Nobody", ""); }); }), fs::StoreError::kNotFound);
  EXPECT_EQ(store_->list_pupils(school_, "", 10, 0).size(), 2u);
}

TEST(StoreTimeTest, AddYearsMonthsAndNow) {
  EXPECT_EQ(fs::add_years_iso8601("2024-02-29T08:00:00Z", 3), "2027-02-28T08:00:00Z");
  EXPECT_EQ(fs::add_years_iso8601("2024-02-29T08:00:00Z", 4), "2028-02-29T08:00:00Z");
  EXPECT_EQ(fs::add_years_iso8601("2026-11-23T10:30:00Z", 3), "2029-11-23T10:30:00Z");
  for (const char* bad : {"", "2026-11-23", "2026-13-01T00:00:00Z", "2025-02-29T00:00:00Z", "2026-11-23T25:00:00Z",
                          "2026-11-23 10:30:00Z", "2026-11-23T10:30:00"}) {
    EXPECT_EQ(ErrorKind([&] { fs::add_years_iso8601(bad, 3); }), fs::StoreError::kInvalid) << bad;
  }
  // Months, forward and back, across a year's end, onto a month without the day.
  EXPECT_EQ(fs::add_months_iso8601("2026-11-23T10:30:00Z", 2), "2027-01-23T10:30:00Z");
  EXPECT_EQ(fs::add_months_iso8601("2027-01-23T10:30:00Z", -12), "2026-01-23T10:30:00Z");
  EXPECT_EQ(fs::add_months_iso8601("2026-03-31T00:00:00Z", -1), "2026-02-28T00:00:00Z");
  EXPECT_EQ(fs::add_months_iso8601("2026-01-15T00:00:00Z", -13), "2024-12-15T00:00:00Z");
  const std::string now = fs::now_iso8601();
  EXPECT_TRUE(std::regex_match(now, std::regex(R"(\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}Z)"))) << now;
  EXPECT_NO_THROW(fs::add_years_iso8601(now, 3));
}

TEST_P(StoreTest, TwoStoresOnOneFileSeeEachOthersWrites) {
  auto second = Open();
  const int64_t pupil = NewPupil("Ann");
  ASSERT_TRUE(second->get_pupil(pupil).has_value());
  const std::string s = second->create_session(pupil, "cab1", "m4", Mode::kTraining, std::nullopt, "t").public_id;
  ASSERT_TRUE(store_->get_session(s).has_value());

  // Two threads writing at once, one store each: SQLite's busy timeout serialises them,
  // PostgreSQL takes both at once.
  constexpr int kPerThread = 300;
  auto write = [&](fs::Store* store, int first) {
    for (int i = 0; i < kPerThread; ++i) store->add_event(MakeEvent(s, first + i, "overspeed", 1));
  };
  std::thread a(write, store_.get(), 1);
  std::thread b(write, second.get(), 1 + kPerThread);
  a.join();
  b.join();
  EXPECT_EQ(store_->list_events(s).size(), 2u * kPerThread);
  EXPECT_EQ(second->history(pupil, "t")->faults_by_kind.at("overspeed"), 2 * kPerThread);
}

// Each write through the API is its own commit (some 80 us here), so the store is kept to
// 20,000 sessions; the benchmark times history() on 500,000.
TEST_P(StoreTest, HistoryOnALargeStore) {
  constexpr int kPupils = 400, kSessions = 50;
  int64_t probe = 0;
  for (int p = 0; p < kPupils; ++p) {
    const int64_t pupil = NewPupil("Pupil " + std::to_string(p));
    if (p == kPupils / 2) probe = pupil;
    for (int i = 0; i < kSessions; ++i) {
      const std::string s = NewSession(pupil, Mode::kTraining, "2026-01-01T10:00:" + std::to_string(10 + i) + "Z").public_id;
      if (pupil == probe) store_->add_event(MakeEvent(s, 1, "overspeed", 1));
    }
  }
  const auto h = store_->history(probe, "2026-02-01T00:00:00Z");
  ASSERT_TRUE(h.has_value());
  EXPECT_EQ(h->sessions.size(), static_cast<size_t>(kSessions));
  EXPECT_EQ(h->faults_by_kind.at("overspeed"), kSessions);
}

// Every list reads the sessions and the exams through an index, never the whole table: its plan, as the database
// gives it (EXPLAIN on PostgreSQL, EXPLAIN QUERY PLAN on SQLite), at a generated store of 100,000
// sessions of two schools (bench/store_generator.h: each 1,020 pupils over two years on 4 cabs, with
// their results, practical and theory exams, the two schools' rows interleaved), filled in a few seconds, with the statistics ANALYZE makes as
// autovacuum (PostgreSQL) and the server's optimize (SQLite) do; at 10 million sessions
// (forklift-bench-store --explain) the plans are the same. A list whose plan reads the whole
// table of sessions or exams is named with its plan; so is one that hashes every task-incomplete score of the store
// for a page (PostgreSQL's hashed SubPlan, which grows with the store).
TEST_P(StoreTest, EveryListReadsTheSessionsThroughAnIndex) {
  const forklift::bench::GeneratedStore g = forklift::bench::generate_sessions(location_, 100000, false, 50000);
  ASSERT_EQ(g.schools, 2);
  ASSERT_EQ(g.sessions, 50000);
  const int64_t school = g.school_id, some_pupil = g.pupil_id(g.pupils / 2);
  const auto day = [&](int d, fs::SessionFilter f) {
    f.from = forklift::bench::generated_day(d) + "T00:00:00Z";
    f.to = forklift::bench::generated_day(d + 1) + "T00:00:00Z";
    return f;
  };

  // Rows deep in the lists, for their next pages by keyset.
  fs::SessionFilter school_sessions;
  school_sessions.school_id = school;
  const std::string deep_session = store_->find_sessions(school_sessions, 1, 20000).sessions.at(0).session.public_id;
  fs::ExamFilter school_exams;
  school_exams.school_id = school;
  const int64_t deep_exam = store_->find_exams(school_exams, 1, static_cast<int>(g.exams / 2)).exams.at(0).exam.id;
  const auto lists = [&] {
    fs::PupilFilter pupils;
    pupils.school_id = school;
    store_->find_pupils(pupils, 50, 0);
    store_->find_pupils(pupils, 50, 1000);
    store_->list_pupils(school, "", 50, 0);
    fs::SessionFilter newest;
    newest.school_id = school;
    store_->find_sessions(newest, 50, 0);
    const fs::SessionFilter a_day = day(300, newest);
    store_->find_sessions(a_day, 50, 0);
    fs::SessionFilter cab_day_passed = a_day;
    cab_day_passed.cab_id = "cab2";
    cab_day_passed.result = "passed";
    store_->find_sessions(cab_day_passed, 50, 0);
    fs::SessionFilter cab_not_passed = cab_day_passed;
    cab_not_passed.result = "not_passed";
    store_->find_sessions(cab_not_passed, 50, 0);
    fs::SessionFilter day_timed_out = a_day;
    day_timed_out.outcome = Outcome::kTimedOut;
    store_->find_sessions(day_timed_out, 50, 0);
    fs::SessionFilter cab_day_stopped = cab_day_passed;
    cab_day_stopped.result.clear();
    cab_day_stopped.outcome = Outcome::kStopped;
    store_->find_sessions(cab_day_stopped, 50, 0);
    fs::SessionFilter passed = newest;
    passed.result = "passed";
    store_->find_sessions(passed, 50, 0);
    fs::SessionFilter timed_out = newest;
    timed_out.outcome = Outcome::kTimedOut;
    store_->find_sessions(timed_out, 50, 0);
    fs::SessionFilter pupil = newest;
    pupil.pupil_id = some_pupil;
    store_->find_sessions(pupil, 50, 0);
    fs::ExamFilter exams;
    exams.school_id = school;
    store_->find_exams(exams, 50, 0);
    fs::SessionFilter sessions_after = newest;
    sessions_after.after = deep_session;
    store_->find_sessions(sessions_after, 50, 0);
    fs::ExamFilter exams_after = exams;
    exams_after.after = deep_exam;
    store_->find_exams(exams_after, 50, 0);
    fs::ExamFilter practical_passed = exams;
    practical_passed.kind = forklift::ExamKind::kPractical;
    practical_passed.passed = true;
    store_->find_exams(practical_passed, 50, 0);
    store_->history(some_pupil, "2026-12-01T00:00:00Z");
  };
  // The whole school's totals are the kept ones; a filter that matches more than the store counts says so.
  fs::SessionFilter all;
  all.school_id = school;
  EXPECT_EQ(store_->find_sessions(all, 1, 0).total, 50000);
  EXPECT_FALSE(store_->find_sessions(all, 1, 0).total_is_at_least);
  fs::ExamFilter every_exam;
  every_exam.school_id = school;
  EXPECT_EQ(store_->find_exams(every_exam, 1, 0).total, g.exams);
  all.result = "passed";
  const fs::SessionPage passed_page = store_->find_sessions(all, 1, 0);
  EXPECT_EQ(passed_page.total, fs::kCountedAtMost);
  EXPECT_TRUE(passed_page.total_is_at_least);
  EXPECT_EQ(RawQuery("SELECT sessions FROM school_totals WHERE school_id = " + std::to_string(school)), std::vector<std::string>{"50000"});

  lists();  // PostgreSQL's plans for a prepared statement settle over its first runs: asked after
  const std::vector<std::string> plans = store_->query_plans(lists);
  ASSERT_GE(plans.size(), 12u);  // every list's count and page, and the history's statements
  int sessions_read = 0, exams_read = 0;
  for (const std::string& plan : plans) {
    const std::string sql = plan.substr(0, plan.find('\n'));
    const bool of_exams = sql.find("FROM exams e") != std::string::npos;
    if (sql.find("sessions") == std::string::npos && !of_exams) continue;
    sessions_read += sql.find("sessions") != std::string::npos;
    exams_read += of_exams;
    // A table scan: "Seq Scan on sessions" (PostgreSQL), "SCAN sessions" with no index (SQLite);
    // the same of the exams, "e" in the statements that read them.
    std::istringstream lines(plan.substr(sql.size()));
    for (std::string line; std::getline(lines, line);) {
      std::istringstream words(line);
      std::string word, scanned;
      while (words >> word && word != "SCAN") {}
      words >> scanned;
      const bool scan = sqlite() ? (scanned == "sessions" || scanned == "exams" || (of_exams && scanned == "e")) &&
                                       line.find("INDEX") == std::string::npos
                                 : line.find("Seq Scan on sessions") != std::string::npos ||
                                       line.find("Seq Scan on exams ") != std::string::npos;
      EXPECT_FALSE(scan) << "a table scan of the sessions or the exams:\n" << plan;
      EXPECT_EQ(line.find("hashed SubPlan"), std::string::npos) << "a hash of the whole store's rows:\n" << plan;
    }
  }
  EXPECT_GE(sessions_read, 18);
  EXPECT_GE(exams_read, 5);  // the exams lists' pages, the count of a filtered one, the history's exams
}

// The generated region (bench/store_generator.h): its schools share the sessions out, their rows
// interleaved as their days bring them, and each school's lists hold its own rows alone, at the
// ids the generator says.
TEST_P(StoreTest, AGeneratedRegionsSchoolsEachListTheirOwnRows) {
  const forklift::bench::GeneratedStore g = forklift::bench::generate_sessions(location_, 3001, false, 1000);
  ASSERT_EQ(g.schools, 4);
  EXPECT_EQ(g.all_sessions, 3001);
  EXPECT_EQ(g.sessions, 751);  // 3001 shared by 4: the first school has the one left over
  const std::string stride = std::to_string(g.schools), school = std::to_string(g.school_id);
  // Interleaved: the first sessions are one of each school's, in turn.
  EXPECT_EQ(RawQuery("SELECT COUNT(DISTINCT school_id) FROM sessions WHERE id <= 4"), std::vector<std::string>{"4"});
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM sessions"), std::vector<std::string>{"3001"});
  // The school's rows are at the ids the generator gives, and no other school's are.
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM sessions WHERE school_id = " + school + " AND (id - " +
                     std::to_string(g.first_session_id) + ") % " + stride + " = 0 AND id <= " + std::to_string(g.session_id(g.sessions - 1))),
            std::vector<std::string>{std::to_string(g.sessions)});
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM pupils WHERE school_id = " + school + " AND (id - " + std::to_string(g.first_pupil_id) +
                     ") % " + stride + " = 0 AND id <= " + std::to_string(g.pupil_id(g.pupils - 1))),
            std::vector<std::string>{std::to_string(g.pupils)});
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM exams WHERE school_id = " + school + " AND (id - " + std::to_string(g.first_exam_id) +
                     ") % " + stride + " = 0 AND id <= " + std::to_string(g.exam_id(g.exams - 1))),
            std::vector<std::string>{std::to_string(g.exams)});

  fs::SessionFilter sessions;
  sessions.school_id = g.school_id;
  const fs::SessionPage page = store_->find_sessions(sessions, 50, 0);
  EXPECT_EQ(page.total, g.sessions);
  ASSERT_EQ(page.sessions.size(), 50u);
  for (const auto& row : page.sessions) EXPECT_EQ((row.session.pupil_id - g.first_pupil_id) % g.schools, 0) << row.session.public_id;
  fs::PupilFilter pupils;
  pupils.school_id = g.school_id;
  EXPECT_EQ(store_->find_pupils(pupils, 50, 0).total, g.pupils);
  fs::ExamFilter exams;
  exams.school_id = g.school_id;
  EXPECT_EQ(store_->find_exams(exams, 50, 0).total, g.exams);
  // A pupil's history is their own 50 sessions, with their theory exam.
  const auto h = store_->history(g.pupil_id(g.pupils / 2), "2027-01-01T00:00:00Z");
  ASSERT_TRUE(h);
  EXPECT_EQ(h->sessions.size(), 50u);
  for (const auto& s : h->sessions) EXPECT_EQ(s.pupil_id, g.pupil_id(g.pupils / 2));
  EXPECT_FALSE(h->exams.empty());
  // Another school's session is no cursor in this school's list.
  sessions.after = "s-000002";
  EXPECT_THROW(store_->find_sessions(sessions, 50, 0), fs::StoreError);
}

// A store with its planner's statistics keeps them through the upgrade that widened the school's
// sessions by outcome (schema 20): without them SQLite took the new index for a narrow one and
// sorted every session of the school for the newest page (370 ms at a million sessions). The
// newest page is read in an index's order, sorting nothing, before the upgrade and after it.
TEST_P(StoreTest, TheNewestSessionsAreReadInAnIndexsOrderAfterTheUpgradeThatWidenedOne) {
  const forklift::bench::GeneratedStore g = forklift::bench::generate_sessions(location_, 5000);
  fs::SessionFilter newest;
  newest.school_id = g.school_id;
  const auto sorting_plan = [&] {
    store_->find_sessions(newest, 50, 0);  // PostgreSQL's plan of a prepared statement settles over its first runs
    for (const std::string& plan : store_->query_plans([&] { store_->find_sessions(newest, 50, 0); }))
      if (plan.find("FROM sessions") != std::string::npos &&
          (plan.find("TEMP B-TREE FOR ORDER BY") != std::string::npos || plan.find("Sort Key") != std::string::npos))
        return plan;
    return std::string();
  };
  EXPECT_EQ(sorting_plan(), "") << "as generated";
  store_.reset();
  ASSERT_EQ(RawExec(DropMigration20()), "");  // schema 19, as an older program left it
  store_ = Open();
  EXPECT_EQ(sorting_plan(), "") << "after the upgrade";
}

// The outcome kept on a session's row (the lists' filter by outcome and result) is
// session_outcome()'s, however the session ended, whether its score came before its end or after,
// as written when it settles and as back-filled by the upgrade that stored it (schema 16): the
// cab leaving ("cab_gone") is "stopped" in both, as the rule says, not "failed".
TEST_P(StoreTest, TheStoredOutcomeIsTheOutcomeRulesOnEveryEnd) {
  const int64_t pupil = NewPupil("Ann");
  std::vector<std::string> reasons = {"parked", "", "worker exited"};
  for (int i = 0; forklift::parse<forklift::EndReason>(forklift::name(static_cast<forklift::EndReason>(i))); ++i)
    reasons.push_back(forklift::name(static_cast<forklift::EndReason>(i)));
  std::map<std::string, Outcome> expected;  // by session
  int cab = 0;
  for (const SessionPhase phase : {SessionPhase::kRunning, SessionPhase::kEnded, SessionPhase::kFailed, SessionPhase::kAborted})
    for (const std::string& reason : reasons)
      for (const bool task_left : {false, true}) {
        const fs::Session s = store_->create_session(pupil, "cab" + std::to_string(++cab), "manoeuvre_4", Mode::kTraining,
                                                     std::nullopt, "2026-03-01T09:00:00Z");
        fs::ScoreRecord score{s.public_id, 80, true, {}};
        if (task_left) score.counts["task_incomplete"] = 1;
        // The score before the end for every other session, after it for the rest.
        if (cab % 2) store_->set_score(score, "2026-03-01T09:20:00Z");
        store_->set_session_state(s.public_id, phase, reason, "2026-03-01T09:20:00Z");
        if (cab % 2 == 0) store_->set_score(score, "2026-03-01T09:20:00Z");
        expected[s.public_id] = fs::session_outcome(*store_->get_session(s.public_id));
      }
  const auto check = [&](const char* when) {
    std::map<std::string, Outcome> listed;
    fs::SessionFilter f;
    f.school_id = school_;
    f.pupil_id = pupil;
    for (int i = 0; forklift::parse<Outcome>(forklift::name(static_cast<Outcome>(i))); ++i) {
      f.outcome = static_cast<Outcome>(i);
      for (const fs::SessionRow& r : store_->find_sessions(f, 500, 0).sessions) listed[r.session.public_id] = *f.outcome;
    }
    EXPECT_EQ(listed, expected) << when;
  };
  check("as written");
  const fs::Session gone = store_->create_session(pupil, "cabX", "manoeuvre_4", Mode::kTraining, std::nullopt, "2026-03-01T10:00:00Z");
  store_->set_session_state(gone.public_id, SessionPhase::kEnded, "cab_gone", "2026-03-01T10:05:00Z");
  EXPECT_EQ(fs::session_outcome(*store_->get_session(gone.public_id)), Outcome::kStopped);
  expected[gone.public_id] = Outcome::kStopped;
  check("the cab gone");
  store_.reset();
  ASSERT_EQ(RawExec(DropMigration16()), "");  // schema 15, as an older program left it
  store_ = Open();
  check("back-filled by the upgrade");
}

// The history's fault counts are kept per pupil as events come (migration 18); a store from before
// them has its counts filled by the upgrade, and counts on from there.
TEST_P(StoreTest, TheFaultCountsOfAStoreFromBeforeThemAreFilledByTheUpgrade) {
  const int64_t ann = NewPupil("Ann"), bob = NewPupil("Bob");
  const std::string a1 = NewSession(ann).public_id, b1 = NewSession(bob).public_id;
  store_->add_event(MakeEvent(a1, 1, "overspeed", 2));
  store_->add_event(MakeEvent(a1, 2, "overspeed", 1));
  store_->add_event(MakeEvent(a1, 3, "horn", 0));
  store_->add_event(MakeEvent(b1, 1, "collision", 3));
  store_.reset();
  ASSERT_EQ(RawExec(DropMigration18()), "");  // schema 17, as an older program left it
  store_ = Open();
  EXPECT_EQ(store_->history(ann, "t")->faults_by_kind, (std::map<std::string, int>{{"overspeed", 2}}));
  EXPECT_EQ(store_->history(bob, "t")->faults_by_kind, (std::map<std::string, int>{{"collision", 1}}));
  store_->add_event(MakeEvent(a1, 4, "collision", 3));
  store_->add_event(MakeEvent(a1, 4, "collision", 3));  // heard twice
  EXPECT_EQ(store_->history(ann, "t")->faults_by_kind, (std::map<std::string, int>{{"collision", 1}, {"overspeed", 2}}));
  EXPECT_EQ(store_->history(bob, "t")->faults_by_kind, (std::map<std::string, int>{{"collision", 1}}));
}

// Two servers on one database (two Store objects: two connections) ingest the same 200 sessions'
// events, scores and ends at once, as two servers that both hear every worker over DDS would, and
// both chain each exam as the server does (chain_exam: read the last entry, append after it,
// start again if the other server came first). Nothing is lost, nothing doubled, and the exam
// chain is one chain that verifies.
TEST_P(StoreTest, TwoServersIngestTheSameSessionsExactlyOnce) {
  constexpr int kSessions = 200, kEvents = 10;
  const int64_t pupil = NewPupil("Ann");
  const int64_t examiner = store_->create_user("eve", "h", fs::Role::kExaminer, school_);
  std::vector<fs::Session> sessions;
  for (int i = 0; i < kSessions; ++i)
    sessions.push_back(i % 2 ? NewSession(pupil, Mode::kExam, "2026-01-01T10:00:00Z", examiner) : NewSession(pupil));
  const fs::Actor worker{std::nullopt, "worker"};

  struct Tally {
    int events = 0, scores = 0, ends = 0, chained = 0, chain_retries = 0;
    std::string error;
  };
  auto chain_exam = [](fs::Store& db, const fs::Session& s, Tally& t) {
    for (;;) {
      if (db.get_chain_entry(s.public_id)) return;  // the other server chained it
      const auto last = db.last_chain_entry();
      const int64_t seq = last ? last->seq + 1 : 1;
      const std::string prev = last ? nlohmann::json::parse(last->entry).at("entry_hash").get<std::string>() : std::string(64, '0');
      const nlohmann::json record = {{"session", s.public_id}, {"cab", s.cab_id}, {"mode", forklift::name(s.mode)}};
      const nlohmann::json entry =
          forklift::security::make_chain_entry(seq, prev, record, forklift::security::sha256_hex(s.public_id), "", "", "");
      try {
        db.append_chain_entry({seq, s.public_id, entry.dump()});
        ++t.chained;
        return;
      } catch (const fs::StoreError& e) {
        if (e.kind() != fs::StoreError::kConflict) throw;
        ++t.chain_retries;  // the other server appended first: read the chain again
      }
    }
  };
  std::latch go(2);
  auto server = [&](fs::Store* db, Tally* t) {
    try {
      go.arrive_and_wait();
      for (int i = 0; i < kSessions; ++i) {
        const fs::Session& s = sessions[i];
        for (int seq = 1; seq <= kEvents; ++seq)
          t->events += db->add_event(MakeEvent(s.public_id, seq, seq % 2 ? "overspeed" : "collision", seq % 3));
        t->scores += db->set_score_audited({s.public_id, 40.0 + i / 4.0, i % 3 != 0, {{"overspeed", 5}, {"collision", 5}}},
                                           "2026-01-01T10:30:00Z", worker);
        t->ends += db->set_session_state_audited(s.public_id, SessionPhase::kEnded, "duration", "2026-01-01T10:30:00Z", worker);
        if (s.mode == Mode::kExam) chain_exam(*db, s, *t);
      }
    } catch (const std::exception& e) {
      t->error = e.what();
    }
  };
  auto second = Open();
  Tally a, b;
  std::thread ta(server, store_.get(), &a), tb(server, second.get(), &b);
  ta.join();
  tb.join();
  ASSERT_EQ(a.error, "");
  ASSERT_EQ(b.error, "");

  // Each item was stored by exactly one of the two, whichever came first.
  EXPECT_EQ(a.events + b.events, kSessions * kEvents);
  EXPECT_EQ(a.scores + b.scores, kSessions);
  EXPECT_EQ(a.ends + b.ends, kSessions);
  EXPECT_EQ(a.chained + b.chained, kSessions / 2);
  std::printf("server A stored %d events, %d scores, %d chain entries; B %d, %d, %d; %d chain appends started again\n",
              a.events, a.scores, a.chained, b.events, b.scores, b.chained, a.chain_retries + b.chain_retries);
  for (const fs::Session& s : sessions) {
    const auto events = store_->list_events(s.public_id);
    ASSERT_EQ(events.size(), static_cast<size_t>(kEvents)) << s.public_id;
    for (int seq = 1; seq <= kEvents; ++seq) EXPECT_EQ(events[seq - 1].seq, seq) << s.public_id;
    EXPECT_EQ(store_->get_score(s.public_id)->counts.at("overspeed"), 5);
    EXPECT_EQ(store_->get_session(s.public_id)->state, SessionPhase::kEnded);
  }
  const auto h = store_->history(pupil, "2026-02-01T00:00:00Z");
  EXPECT_EQ(h->sessions.size(), static_cast<size_t>(kSessions));
  EXPECT_EQ(h->exams.size(), static_cast<size_t>(kSessions / 2));  // one practical exam record per exam session
  std::set<std::string> examined;
  for (const auto& e : h->exams) examined.insert(e.session_public_id.value_or(""));
  EXPECT_EQ(examined.size(), static_cast<size_t>(kSessions / 2));
  // Faults counted once: each session's events of worry > 0, by kind.
  int overspeed = 0, collision = 0;
  for (int seq = 1; seq <= kEvents; ++seq)
    if (seq % 3 > 0) ++(seq % 2 ? overspeed : collision);
  EXPECT_EQ(h->faults_by_kind.at("overspeed"), overspeed * kSessions);
  EXPECT_EQ(h->faults_by_kind.at("collision"), collision * kSessions);
  std::map<std::string, int> actions;
  for (const auto& r : store_->list_audit({pupil, std::nullopt}, 10 * kSessions, 0)) ++actions[r.action];
  EXPECT_EQ(actions, (std::map<std::string, int>{{"session_ended", kSessions}, {"session_scored", kSessions}}));

  // One chain: every exam once, seqs 1..n, each entry linked to the one before, the head anchored.
  const auto entries = store_->list_chain();
  ASSERT_EQ(entries.size(), static_cast<size_t>(kSessions / 2));
  EXPECT_EQ(store_->count_chain_entries(), kSessions / 2);
  nlohmann::json chain = nlohmann::json::array();
  std::set<std::string> chained;
  for (const auto& e : entries) {
    chain.push_back(nlohmann::json::parse(e.entry));
    chained.insert(e.session_public_id);
  }
  EXPECT_EQ(chained, examined);
  const nlohmann::json anchor = {{"head", forklift::security::chain_anchor_line(chain.back())}};
  const auto report = forklift::security::verify_chain(chain, anchor, "");
  EXPECT_TRUE(report.ok) << ::testing::PrintToString(report.problems);
}

// Two servers starting at once on a new database: the schema is made once, and both work.
TEST_P(StoreTest, TwoStoresOpeningANewDatabaseAtOnceMigrateItOnce) {
  const std::string fresh = FreshLocation("_new");
  std::latch go(2);
  std::unique_ptr<fs::Store> first, second;
  std::string errors;
  std::mutex mu;
  auto open = [&](std::unique_ptr<fs::Store>* out) {
    go.arrive_and_wait();
    try {
      *out = fs::Store::open(fresh);
    } catch (const std::exception& e) {
      std::lock_guard<std::mutex> lock(mu);
      errors += e.what();
    }
  };
  std::thread a(open, &first), b(open, &second);
  a.join();
  b.join();
  ASSERT_EQ(errors, "");
  EXPECT_EQ(first->schema_version(), store_->schema_version());
  EXPECT_EQ(second->schema_version(), store_->schema_version());
  const int64_t school = first->create_school("Second school");
  EXPECT_EQ(second->list_pupils(school, "", 10, 0).size(), 0u);
  const auto versions = sqlite() ? SqliteQuery(fresh, "SELECT version FROM schema_migrations ORDER BY version")
                                 : [&] {
                                     std::vector<std::string> rows;
                                     Postgres().exec(fresh.substr(fresh.rfind('/') + 1),
                                                     "SELECT version FROM schema_migrations ORDER BY version", &rows);
                                     return rows;
                                   }();
  EXPECT_EQ(versions.size(), static_cast<size_t>(store_->schema_version()));
}

// What PostgreSQL cannot keep, it refuses as bad input rather than cut short: text with a NUL
// byte. SQLite keeps it whole.
TEST_P(StoreTest, TextWithANulByteIsKeptWholeOrRefused) {
  const std::string s = NewSession(NewPupil("Ann")).public_id;
  const std::string details = std::string("{\"a\":1}\0tail", 12);
  fs::EventRecord e = MakeEvent(s, 1, "overspeed", 1);
  e.details = details;
  if (sqlite()) {
    EXPECT_TRUE(store_->add_event(e));
    EXPECT_EQ(store_->list_events(s).at(0).details, details);
  } else {
    EXPECT_EQ(ErrorKind([&] { store_->add_event(e); }), fs::StoreError::kInvalid);
    EXPECT_TRUE(store_->list_events(s).empty());
  }
}

// A store whose connection the database dropped (a restarted server, an administrator) fails the
// call under way as I/O and connects again for the next one. SQLite has no connection to lose.
TEST_P(StoreTest, APostgresqlConnectionDroppedByTheServerIsMadeAgain) {
  if (sqlite()) return;  // nothing to drop: a file
  const int64_t pupil = NewPupil("Ann");
  ASSERT_EQ(RawExec("SELECT pg_terminate_backend(pid, 10000) FROM pg_stat_activity "
                    "WHERE application_name = 'forklift' AND datname = current_database()"),
            "");
  try {
    store_->get_pupil(pupil);
    ADD_FAILURE() << "a dropped connection was not noticed";
  } catch (const fs::StorageUnavailable& e) {  // of kind kIo, with the reason in words
    EXPECT_EQ(e.kind(), fs::StoreError::kIo);
    EXPECT_NE(e.reason().find("connection"), std::string::npos) << e.reason();
  }
  ASSERT_TRUE(store_->get_pupil(pupil).has_value());
  EXPECT_EQ(store_->get_pupil(pupil)->name, "Ann");
  store_->batch([&] { store_->update_pupil(pupil, "Ann Driver", ""); });  // statements prepared again
  EXPECT_EQ(store_->get_pupil(pupil)->name, "Ann Driver");
}

// A read-only PostgreSQL database (a standby, or one set so) is StorageUnavailable with the
// reason, at open (the migrations' look) as at a write; SQLite's full and read-only disks are real
// mounts under a running server in tests/server/storage_test.cc.
TEST_P(StoreTest, AReadOnlyPostgresqlDatabaseIsStorageUnavailableWithTheReason) {
  if (sqlite()) GTEST_SKIP() << "SQLite's read-only and full disks are tested with real mounts in storage_test";
  EXPECT_EQ(store_->storage_problem(), std::nullopt);
  const std::string db = location_.substr(location_.rfind('/') + 1);
  // Through the server's maintenance database: once set, the test's own refuses the ALTER too.
  ASSERT_EQ(Postgres().exec("postgres", "ALTER DATABASE \"" + db + "\" SET default_transaction_read_only = on"), "");
  try {
    Open()->create_school("Read-only school");
    ADD_FAILURE() << "a read-only database took a write";
  } catch (const fs::StorageUnavailable& e) {
    EXPECT_NE(e.reason().find("read-only"), std::string::npos) << e.reason();
  }
  ASSERT_EQ(Postgres().exec("postgres", "ALTER DATABASE \"" + db + "\" RESET default_transaction_read_only"), "");
  auto again = Open();
  EXPECT_EQ(again->storage_problem(), std::nullopt);
  EXPECT_GT(again->create_school("Writable again"), 0);
}

TEST(StoreLocationTest, PostgresqlUrisOpenPostgresqlAndNeverPrintTheirPassword) {
  EXPECT_TRUE(fs::is_postgresql_location("postgresql://forklift@db.school.lan/forklift"));
  EXPECT_TRUE(fs::is_postgresql_location("postgres://db/forklift"));
  EXPECT_FALSE(fs::is_postgresql_location("school.db"));
  EXPECT_FALSE(fs::is_postgresql_location("/var/lib/forklift/postgresql://x.db"));
  EXPECT_EQ(fs::printable_location("school.db"), "school.db");
  EXPECT_EQ(fs::printable_location("postgresql://ann:s3cret@db:5432/forklift?sslmode=require"),
            "postgresql://ann:***@db:5432/forklift?sslmode=require");
  EXPECT_EQ(fs::printable_location("postgresql://ann@db/forklift?password=s3cret&sslmode=require"),
            "postgresql://ann@db/forklift?password=***&sslmode=require");
  EXPECT_EQ(fs::printable_location("postgresql://db/forklift"), "postgresql://db/forklift");

  // Nothing listens on this port: the error says where, without the password.
  const std::string port = std::to_string(forklift::test::free_port());
  const std::string where = "postgresql://forklift:s3cret@127.0.0.1:" + port + "/forklift?connect_timeout=5";
  try {
    fs::Store::open(where);
    ADD_FAILURE() << "opened a database nobody serves";
  } catch (const fs::StoreError& e) {
    EXPECT_EQ(e.kind(), fs::StoreError::kIo);
    EXPECT_EQ(std::string(e.what()).find("s3cret"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("forklift:***@127.0.0.1"), std::string::npos) << e.what();
  }
  // Nor in the "key=value" form.
  try {
    fs::Store::open_postgresql("host=127.0.0.1 port=" + port + " dbname=forklift user=forklift password=s3cret connect_timeout=5");
    ADD_FAILURE() << "opened a database nobody serves";
  } catch (const fs::StoreError& e) {
    EXPECT_EQ(e.kind(), fs::StoreError::kIo);
    EXPECT_EQ(std::string(e.what()).find("s3cret"), std::string::npos) << e.what();
  }
}

}  // namespace

TEST_P(StoreTest, TheoryAttemptIsMarkedExactlyOnce) {
  const int64_t pupil = NewPupil("Ann");
  const int64_t other = NewPupil("Ben");
  fs::TheoryAttempt a;
  a.pupil_id = pupil;
  a.seed = 12345;
  a.questions = R"(["q01","q07"])";
  a.started_at = "2026-02-01T09:00:00Z";
  const int64_t id = store_->create_theory_attempt(a);
  const auto got = store_->get_theory_attempt(id);
  ASSERT_TRUE(got.has_value());
  EXPECT_EQ(got->pupil_id, pupil);
  EXPECT_EQ(got->seed, 12345);
  EXPECT_EQ(got->questions, a.questions);
  EXPECT_EQ(got->started_at, a.started_at);
  EXPECT_FALSE(got->exam_id.has_value());
  EXPECT_FALSE(store_->get_theory_attempt(id + 99).has_value());

  fs::ExamRecord r;
  r.pupil_id = other;  // not the attempt's pupil
  r.kind = forklift::ExamKind::kTheory;
  r.score = 0.8;
  r.passed = true;
  r.taken_at = "2026-02-01T09:20:00Z";
  r.details = R"({"attempt":1})";
  EXPECT_EQ(ErrorKind([&] { store_->finish_theory_attempt(id, r); }), fs::StoreError::kInvalid);
  r.pupil_id = pupil;
  r.kind = forklift::ExamKind::kPractical;
  EXPECT_EQ(ErrorKind([&] { store_->finish_theory_attempt(id, r); }), fs::StoreError::kInvalid);
  r.kind = forklift::ExamKind::kTheory;
  EXPECT_EQ(ErrorKind([&] { store_->finish_theory_attempt(id + 99, r); }), fs::StoreError::kNotFound);
  const int64_t exam = store_->finish_theory_attempt(id, r);
  EXPECT_EQ(store_->get_theory_attempt(id)->exam_id, exam);
  const auto e = store_->get_exam(exam);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->kind, forklift::ExamKind::kTheory);
  EXPECT_EQ(e->pupil_id, pupil);
  EXPECT_DOUBLE_EQ(e->score, 0.8);
  EXPECT_EQ(e->details, r.details);
  EXPECT_FALSE(store_->get_exam(exam + 99).has_value());
  // A second marking is refused and adds no record; the failed tries above added none either.
  EXPECT_EQ(ErrorKind([&] { store_->finish_theory_attempt(id, r); }), fs::StoreError::kConflict);
  EXPECT_EQ(store_->history(pupil, "2026-03-01T00:00:00Z")->exams.size(), 1u);
  EXPECT_TRUE(store_->history(other, "2026-03-01T00:00:00Z")->exams.empty());

  a.pupil_id = pupil + 999;
  EXPECT_EQ(ErrorKind([&] { store_->create_theory_attempt(a); }), fs::StoreError::kNotFound);
  a.pupil_id = pupil;
  a.seed = -1;
  EXPECT_EQ(ErrorKind([&] { store_->create_theory_attempt(a); }), fs::StoreError::kInvalid);
}

TEST_P(StoreTest, TheoryPapersAreExamsOrPracticeAndEndOnce) {
  const int64_t pupil = NewPupil("Ann");
  const int64_t other = NewPupil("Ben");
  const int64_t examiner = store_->create_user("eve", "hash", fs::Role::kExaminer, school_);
  fs::TheoryAttempt exam;
  exam.pupil_id = pupil;
  exam.seed = 7;
  exam.questions = R"({"ids":["q01"]})";
  exam.started_at = "2026-02-01T09:00:00Z";
  exam.started_by = examiner;
  exam.deadline = "2026-02-01T09:45:00.250Z";
  const int64_t exam_id = store_->create_theory_attempt(exam);
  fs::TheoryAttempt practice = exam;
  practice.kind = forklift::PaperKind::kPractice;
  practice.started_by.reset();
  practice.deadline = "2026-02-01T09:15:00Z";
  const int64_t practice_id = store_->create_theory_attempt(practice);
  fs::TheoryAttempt undated = exam;  // no time limit
  undated.pupil_id = other;
  undated.deadline.clear();
  const int64_t undated_id = store_->create_theory_attempt(undated);

  const auto got = store_->get_theory_attempt(exam_id);
  ASSERT_TRUE(got.has_value());
  EXPECT_EQ(got->kind, forklift::PaperKind::kExam);
  EXPECT_EQ(got->deadline, exam.deadline);  // milliseconds kept
  EXPECT_EQ(got->started_by, examiner);
  EXPECT_TRUE(got->finished_at.empty());
  EXPECT_FALSE(got->outcome.has_value());
  EXPECT_EQ(store_->get_theory_attempt(practice_id)->kind, forklift::PaperKind::kPractice);
  // Open papers with a deadline, oldest first; the undated one never times out.
  std::vector<int64_t> open;
  for (const auto& a : store_->open_theory_attempts()) open.push_back(a.id);
  EXPECT_EQ(open, (std::vector<int64_t>{exam_id, practice_id}));

  // Refused: a paper that claims to be finished already.
  fs::TheoryAttempt bad = exam;
  bad.outcome = forklift::PaperOutcome::kMarked;
  EXPECT_EQ(ErrorKind([&] { store_->create_theory_attempt(bad); }), fs::StoreError::kInvalid);

  // An exam times out into its exam record; a practice paper keeps its marking and has none.
  fs::ExamRecord r;
  r.pupil_id = pupil;
  r.kind = forklift::ExamKind::kTheory;
  r.score = 0;
  r.passed = false;
  r.taken_at = "2026-02-01T09:45:01Z";
  r.details = R"({"outcome":"timed_out"})";
  EXPECT_EQ(ErrorKind([&] { store_->finish_theory_attempt(practice_id, r); }), fs::StoreError::kInvalid);
  const int64_t record = store_->finish_theory_attempt(exam_id, r, forklift::PaperOutcome::kTimedOut);
  const auto timed_out = store_->get_theory_attempt(exam_id);
  EXPECT_EQ(timed_out->exam_id, record);
  EXPECT_EQ(timed_out->outcome, forklift::PaperOutcome::kTimedOut);
  EXPECT_EQ(timed_out->finished_at, r.taken_at);
  const forklift::PaperOutcome marked = forklift::PaperOutcome::kMarked;
  EXPECT_EQ(ErrorKind([&] { store_->finish_practice_attempt(exam_id, marked, "{}", ""); }), fs::StoreError::kInvalid);
  EXPECT_EQ(ErrorKind([&] { store_->finish_practice_attempt(practice_id + 99, marked, "{}", ""); }), fs::StoreError::kNotFound);
  store_->finish_practice_attempt(practice_id, marked, R"({"correct":3})", "2026-02-01T09:10:00Z");
  EXPECT_EQ(ErrorKind([&] { store_->finish_practice_attempt(practice_id, marked, "{}", ""); }), fs::StoreError::kConflict);
  const auto done = store_->get_theory_attempt(practice_id);
  EXPECT_EQ(done->outcome, forklift::PaperOutcome::kMarked);
  EXPECT_EQ(done->result, R"({"correct":3})");
  EXPECT_FALSE(done->exam_id.has_value());
  // Practice never reaches the pupil's exam records.
  ASSERT_EQ(store_->history(pupil, "2026-03-01T00:00:00Z")->exams.size(), 1u);
  EXPECT_EQ(store_->history(pupil, "2026-03-01T00:00:00Z")->exams[0].id, record);
  EXPECT_TRUE(store_->open_theory_attempts().empty());
  std::vector<int64_t> anns;
  for (const auto& a : store_->list_theory_attempts(pupil)) anns.push_back(a.id);
  EXPECT_EQ(anns, (std::vector<int64_t>{exam_id, practice_id}));
  EXPECT_EQ(store_->list_theory_attempts(other).size(), 1u);
  EXPECT_EQ(store_->list_theory_attempts(other)[0].id, undated_id);
}

TEST_P(StoreTest, TheoryUnlocksAreKeptForEver) {
  const int64_t pupil = NewPupil("Ann");
  const int64_t ines = store_->create_user("ines", "hash", fs::Role::kInstructor, school_);
  EXPECT_TRUE(store_->list_theory_unlocks(pupil).empty());
  const int64_t first = store_->add_theory_unlock({0, pupil, ines, "2026-02-02T08:00:00Z", "retrained on ramps"});
  store_->add_theory_unlock({0, pupil, ines, "", ""});
  const auto unlocks = store_->list_theory_unlocks(pupil);
  ASSERT_EQ(unlocks.size(), 2u);
  EXPECT_EQ(unlocks[0].id, first);
  EXPECT_EQ(unlocks[0].unlocked_by, ines);
  EXPECT_EQ(unlocks[0].reason, "retrained on ramps");
  EXPECT_FALSE(unlocks[1].at.empty());  // now
  EXPECT_EQ(ErrorKind([&] { store_->add_theory_unlock({0, pupil + 99, ines, "", ""}); }), fs::StoreError::kNotFound);
  EXPECT_EQ(ErrorKind([&] { store_->add_theory_unlock({0, pupil, ines + 99, "", ""}); }), fs::StoreError::kNotFound);
  // The schema itself refuses edits, from any program.
  EXPECT_NE(RawExec("UPDATE theory_unlocks SET reason = 'x'").find("append-only"), std::string::npos);
  EXPECT_NE(RawExec("DELETE FROM theory_unlocks").find("append-only"), std::string::npos);
  EXPECT_EQ(store_->list_theory_unlocks(pupil).size(), 2u);
}

// A database from before migration 5: its marked papers read as marked exams, its open ones as
// open exams without a time limit.
TEST_P(StoreTest, TheoryPapersFromBeforeTheirKindAreMarkedExams) {
  const int64_t pupil = NewPupil("Ann");
  fs::TheoryAttempt a;
  a.pupil_id = pupil;
  a.questions = R"({"ids":["q01"]})";
  a.started_at = "2026-02-01T09:00:00Z";
  const int64_t marked = store_->create_theory_attempt(a);
  const int64_t open = store_->create_theory_attempt(a);
  fs::ExamRecord r;
  r.pupil_id = pupil;
  r.kind = forklift::ExamKind::kTheory;
  r.score = 1;
  r.passed = true;
  r.taken_at = "2026-02-01T09:20:00Z";
  store_->finish_theory_attempt(marked, r);
  store_.reset();
  // Back to schema 4, as an older program left it (keeping the rows).
  ASSERT_EQ(RawExec(DropMigration6() + "DROP INDEX theory_attempts_open; DROP TABLE theory_unlocks; "
                           "ALTER TABLE theory_attempts DROP COLUMN kind; ALTER TABLE theory_attempts DROP COLUMN deadline; "
                           "ALTER TABLE theory_attempts DROP COLUMN finished_at; ALTER TABLE theory_attempts DROP COLUMN outcome; "
                           "ALTER TABLE theory_attempts DROP COLUMN result; DELETE FROM schema_migrations WHERE version >= 5"),
            "");
  store_ = Open();
  EXPECT_GE(store_->schema_version(), 5);
  const auto m = store_->get_theory_attempt(marked), o = store_->get_theory_attempt(open);
  EXPECT_EQ(m->kind, forklift::PaperKind::kExam);
  EXPECT_EQ(m->outcome, forklift::PaperOutcome::kMarked);
  EXPECT_EQ(m->finished_at, "2026-02-01T09:20:00Z");
  EXPECT_EQ(o->kind, forklift::PaperKind::kExam);
  EXPECT_FALSE(o->outcome.has_value());
  EXPECT_TRUE(o->deadline.empty());
  EXPECT_TRUE(store_->open_theory_attempts().empty());  // no deadline: the server never times it out
}

TEST_P(StoreTest, PathPointsAreKeptInTimeOrderOncePerSimTime) {
  const int64_t pupil = NewPupil("Ann");
  const std::string s = NewSession(pupil).public_id;
  EXPECT_TRUE(store_->list_path(s).empty());
  store_->add_path_points(s, {{1.0, 2.0, 3.0, 0.5, 1.2, 0.1}, {0.5, 1.0, 1.5, 0.25, 1.0, 0.0}});
  // A repeated sim time (a state seen twice) is ignored; the first one stands.
  store_->add_path_points(s, {{1.0, 9.0, 9.0, 9.0, 9.0, 9.0}, {1.5, 3.0, 4.5, 0.75, 0.8, 0.2}});
  store_->add_path_points(s, {});
  const auto path = store_->list_path(s);
  ASSERT_EQ(path.size(), 3u);
  EXPECT_DOUBLE_EQ(path[0].sim_time_s, 0.5);
  EXPECT_DOUBLE_EQ(path[1].sim_time_s, 1.0);
  EXPECT_DOUBLE_EQ(path[1].x_m, 2.0);
  EXPECT_DOUBLE_EQ(path[1].y_m, 3.0);
  EXPECT_DOUBLE_EQ(path[1].yaw_rad, 0.5);
  EXPECT_DOUBLE_EQ(path[1].speed_m_s, 1.2);
  EXPECT_DOUBLE_EQ(path[1].lift_m, 0.1);
  EXPECT_DOUBLE_EQ(path[2].sim_time_s, 1.5);
  EXPECT_TRUE(store_->list_path(NewSession(pupil).public_id).empty());  // paths are per session
  EXPECT_EQ(ErrorKind([&] { store_->add_path_points("s-999999", {{0, 0, 0, 0, 0, 0}}); }), fs::StoreError::kNotFound);
  EXPECT_EQ(ErrorKind([&] { store_->list_path("s-999999"); }), fs::StoreError::kNotFound);
}

// ---------------------------------------------------------------- audit log

namespace {

fs::AuditRecord Audit(int64_t pupil, const std::string& action, const std::string& details = "{}") {
  fs::AuditRecord r;
  r.actor = {std::nullopt, "server"};
  r.pupil_id = pupil;
  r.action = action;
  r.details = details;
  return r;
}

}  // namespace

TEST_P(StoreTest, UpdatePupilChangesNameAndEmail) {
  const int64_t pupil = NewPupil("Ann");
  store_->update_pupil(pupil, "Ann Driver", "ann@example.org");
  EXPECT_EQ(store_->get_pupil(pupil)->name, "Ann Driver");
  EXPECT_EQ(store_->get_pupil(pupil)->email, "ann@example.org");
  EXPECT_EQ(ErrorKind([&] { store_->update_pupil(pupil + 99, "Nobody", ""); }), fs::StoreError::kNotFound);
  EXPECT_EQ(ErrorKind([&] { store_->update_pupil(pupil, "", ""); }), fs::StoreError::kInvalid);
  EXPECT_EQ(store_->get_pupil(pupil)->name, "Ann Driver");
}

// The language each person reads in: staff on their account, pupils on their record; English
// until set, and for the people of a database from before languages were kept.
TEST_P(StoreTest, ThePeoplesLanguagesRoundTripAndStartInEnglish) {
  const int64_t ines = store_->create_user("ines", "h", fs::Role::kInstructor, school_, std::nullopt, "Ines Instructor");
  const int64_t ana = NewPupil("Ana");
  const int64_t ann = NewPupil("Ann");
  EXPECT_EQ(store_->user_language(ines), "en");
  EXPECT_EQ(store_->pupil_language(ana), "en");
  store_->set_user_language(ines, "es");
  store_->batch([&] { store_->set_pupil_language(ana, "es"); });
  store_.reset();
  store_ = Open();  // from the database, not a cache
  EXPECT_EQ(store_->user_language(ines), "es");
  EXPECT_EQ(store_->pupil_language(ana), "es");
  EXPECT_EQ(store_->pupil_language(ann), "en");  // one pupil's, not the table's
  EXPECT_EQ(ErrorKind([&] { store_->set_pupil_language(ana, "es'; --"); }), fs::StoreError::kInvalid);
  EXPECT_EQ(ErrorKind([&] { store_->set_user_language(ines, ""); }), fs::StoreError::kInvalid);
  EXPECT_EQ(ErrorKind([&] { store_->set_user_language(ines + 99, "es"); }), fs::StoreError::kNotFound);
  EXPECT_EQ(ErrorKind([&] { store_->pupil_language(ann + 99); }), fs::StoreError::kNotFound);
  EXPECT_EQ(store_->pupil_language(ana), "es");

  store_.reset();
  ASSERT_EQ(RawExec(DropMigration14()), "");  // schema 13, as an older program left it
  store_ = Open();
  EXPECT_GE(store_->schema_version(), 14);
  EXPECT_EQ(store_->user_language(ines), "en");
  EXPECT_EQ(store_->pupil_language(ana), "en");
}

TEST_P(StoreTest, AuditRowsRoundTripNewestFirstPerPupilSchoolOrAll) {
  const int64_t ann = NewPupil("Ann"), bob = NewPupil("Bob");
  const int64_t other_school = store_->create_school("Other school");
  const int64_t cid = store_->create_pupil(other_school, "Cid", "");
  const int64_t ines = store_->create_user("ines", "h", fs::Role::kInstructor, school_);
  fs::AuditRecord edit = Audit(ann, "pupil_edited", R"({"before":{"name":"A"},"after":{"name":"Ann"}})");
  edit.actor = {ines, "ines"};
  edit.at = "2026-01-01T10:00:00Z";
  const int64_t first = store_->add_audit(edit);
  store_->add_audit(Audit(bob, "pupil_created"));
  store_->add_audit(Audit(ann, "licence_issued"));
  store_->add_audit(Audit(cid, "pupil_created"));

  const auto anns = store_->list_audit({ann, std::nullopt}, 10, 0);
  ASSERT_EQ(anns.size(), 2u);
  EXPECT_EQ(anns[0].action, "licence_issued");  // newest first
  EXPECT_EQ(anns[1].id, first);
  EXPECT_EQ(anns[1].actor.user_id, ines);
  EXPECT_EQ(anns[1].actor.name, "ines");
  EXPECT_EQ(anns[1].at, "2026-01-01T10:00:00Z");
  EXPECT_EQ(anns[1].details, edit.details);
  EXPECT_FALSE(anns[0].at.empty());  // stamped now
  EXPECT_FALSE(anns[0].actor.user_id.has_value());

  EXPECT_EQ(store_->list_audit({std::nullopt, school_}, 10, 0).size(), 3u);  // not Cid's
  const auto all = store_->list_audit({}, 10, 0);
  ASSERT_EQ(all.size(), 4u);
  EXPECT_EQ(all[0].pupil_id, cid);
  const auto page = store_->list_audit({}, 2, 1);
  ASSERT_EQ(page.size(), 2u);
  EXPECT_EQ(page[0].id, all[1].id);
  EXPECT_EQ(page[1].id, all[2].id);
}

TEST_P(StoreTest, AuditRowsAreValidated) {
  const int64_t ann = NewPupil("Ann");
  fs::AuditRecord no_actor = Audit(ann, "pupil_created");
  no_actor.actor.name = "";
  EXPECT_EQ(ErrorKind([&] { store_->add_audit(no_actor); }), fs::StoreError::kInvalid);
  EXPECT_EQ(ErrorKind([&] { store_->add_audit(Audit(ann, "")); }), fs::StoreError::kInvalid);
  EXPECT_EQ(ErrorKind([&] { store_->add_audit(Audit(ann, "x", "not json")); }), fs::StoreError::kInvalid);
  EXPECT_EQ(ErrorKind([&] { store_->add_audit(Audit(ann, "x", "[1]")); }), fs::StoreError::kInvalid);
  EXPECT_EQ(ErrorKind([&] { store_->add_audit(Audit(ann + 99, "x")); }), fs::StoreError::kNotFound);
  fs::AuditRecord ghost = Audit(ann, "x");
  ghost.actor.user_id = 4242;
  EXPECT_EQ(ErrorKind([&] { store_->add_audit(ghost); }), fs::StoreError::kNotFound);
  EXPECT_EQ(ErrorKind([&] { store_->list_audit({}, -1, 0); }), fs::StoreError::kInvalid);
  EXPECT_TRUE(store_->list_audit({}, 10, 0).empty());
}

TEST_P(StoreTest, AuditLogRefusesUpdateAndDeleteFromAnyConnection) {
  const int64_t ann = NewPupil("Ann");
  store_->add_audit(Audit(ann, "pupil_created"));
  EXPECT_NE(RawExec("UPDATE audit_log SET actor = 'mallory'").find("append-only"), std::string::npos);
  EXPECT_NE(RawExec("DELETE FROM audit_log").find("append-only"), std::string::npos);
  if (!sqlite()) {
    EXPECT_NE(RawExec("TRUNCATE audit_log").find("append-only"), std::string::npos);
  }
  EXPECT_EQ(RawQuery("SELECT actor FROM audit_log"), std::vector<std::string>{"server"});
  EXPECT_EQ(RawExec("INSERT INTO audit_log(at, actor, pupil_id, action, details) "
                           "VALUES ('2026-01-01T00:00:00Z', 'server', " + std::to_string(ann) + ", 'x', '{}')"),
            "");  // appending is what it is for
}

TEST_P(StoreTest, AnAuditRowInAFailedBatchIsUndoneWithItsChange) {
  const int64_t ann = NewPupil("Ann");
  EXPECT_THROW(store_->batch([&] {
    store_->update_pupil(ann, "Ann Driver", "");
    store_->add_audit(Audit(ann, "pupil_edited"));
    throw std::runtime_error("refused later");
  }), std::runtime_error);
  EXPECT_EQ(store_->get_pupil(ann)->name, "Ann");
  EXPECT_TRUE(store_->list_audit({ann, std::nullopt}, 10, 0).empty());
}

TEST_P(StoreTest, AuditedScoreAndStateWriteOneRowOnlyWhenTheyChangeSomething) {
  const int64_t ann = NewPupil("Ann");
  const fs::Session s = NewSession(ann, Mode::kExam);
  const fs::Actor worker{std::nullopt, "worker"};
  EXPECT_TRUE(store_->set_score_audited(fs::ScoreRecord{s.public_id, 82.5, true, {{"collision", 2}}},
                                        "2026-01-01T10:05:00Z", worker));
  EXPECT_FALSE(store_->set_score_audited(fs::ScoreRecord{s.public_id, 10, false, {}}, "2026-01-01T10:06:00Z", worker));
  EXPECT_TRUE(store_->set_session_state_audited(s.public_id, SessionPhase::kEnded, "duration", "2026-01-01T10:07:00Z", worker));
  EXPECT_FALSE(store_->set_session_state_audited(s.public_id, SessionPhase::kFailed, "late", "2026-01-01T10:08:00Z", worker));
  EXPECT_EQ(store_->get_session(s.public_id)->state, SessionPhase::kEnded);

  const auto rows = store_->list_audit({ann, std::nullopt}, 10, 0);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].action, "session_ended");
  EXPECT_EQ(rows[0].actor.name, "worker");
  EXPECT_EQ(rows[0].at, "2026-01-01T10:07:00Z");
  EXPECT_EQ(rows[0].details,
            R"({"session":")" + s.public_id + R"(","from":"starting","to":"ended","reason":"duration"})");
  EXPECT_EQ(rows[1].action, "session_scored");
  const std::string exam_id = RawQuery("SELECT id FROM exams").at(0);
  EXPECT_EQ(rows[1].details, R"({"session":")" + s.public_id +
                                 R"(","mode":"exam","mark":82.5,"passed":true,"counts":{"collision":2},"exam_id":)" +
                                 exam_id + "}");
  EXPECT_EQ(ErrorKind([&] { store_->set_session_state_audited("s-999999", SessionPhase::kEnded, "", "2026-01-01T10:00:00Z", worker); }),
            fs::StoreError::kNotFound);
}

TEST_P(StoreTest, ExamChainAppendsInOrderOncePerSessionAndRefusesEdits) {
  const int64_t ann = NewPupil("Ann");
  const fs::Session a = NewSession(ann, Mode::kExam), b = NewSession(ann, Mode::kExam);
  EXPECT_FALSE(store_->last_chain_entry());
  store_->append_chain_entry({1, a.public_id, R"({"entry_hash":"aa"})"});
  // A gap, a repeat of seq 1 and a second entry for the same session are all refused.
  EXPECT_THROW(store_->append_chain_entry({3, b.public_id, "{}"}), fs::StoreError);
  EXPECT_THROW(store_->append_chain_entry({1, b.public_id, "{}"}), fs::StoreError);
  EXPECT_THROW(store_->append_chain_entry({2, a.public_id, "{}"}), fs::StoreError);
  EXPECT_THROW(store_->append_chain_entry({2, "s-999999", "{}"}), fs::StoreError);
  store_->append_chain_entry({2, b.public_id, R"({"entry_hash":"bb"})"});
  EXPECT_EQ(store_->last_chain_entry()->session_public_id, b.public_id);
  EXPECT_EQ(store_->get_chain_entry(a.public_id)->entry, R"({"entry_hash":"aa"})");
  ASSERT_EQ(store_->list_chain().size(), 2u);
  EXPECT_EQ(store_->list_chain()[1].seq, 2);
  EXPECT_TRUE(store_->unchained_signed_exams().empty()) << "neither has a signed log";
  const fs::Session c = NewSession(ann, Mode::kExam), d = NewSession(ann, Mode::kTraining);
  store_->put_session_log(c.public_id, "signature", "{}");
  store_->put_session_log(d.public_id, "signature", "{}");
  store_->put_session_log(a.public_id, "signature", "{}");
  EXPECT_EQ(store_->unchained_signed_exams(), std::vector<std::string>{c.public_id}) << "only the exam not yet chained";
  EXPECT_NE(RawExec("UPDATE exam_chain SET entry = '{}'").find("append-only"), std::string::npos);
  EXPECT_NE(RawExec("DELETE FROM exam_chain").find("append-only"), std::string::npos);
  EXPECT_EQ(store_->list_chain().size(), 2u);
  EXPECT_EQ(store_->count_chain_entries(), 2);
  // Around the trigger, a deleted first entry leaves the last seq above the count: a gap.
  EXPECT_EQ(RawExec(Sql("DROP TRIGGER exam_chain_no_delete; DELETE FROM exam_chain WHERE seq = 1",
                        "DROP TRIGGER exam_chain_no_delete ON exam_chain; DELETE FROM exam_chain WHERE seq = 1")),
            "");
  EXPECT_EQ(store_->count_chain_entries(), 1);
  EXPECT_EQ(store_->last_chain_entry()->seq, 2);
}

// One rule says what a session's end means. Only a session that ran its course
// has a mark; aborted, timed-out, stopped and failed sessions have an outcome and no mark, even
// when their worker sent a score, and count in no trend; exams are not training.
TEST_P(StoreTest, OnlyCompletedSessionsHaveAMarkAndCountInTheTrend) {
  const int64_t pupil = NewPupil("Ann");
  struct Case {
    Mode mode;
    SessionPhase state;
    std::string reason;
    std::map<std::string, int> counts;
    double mark;
    fs::Outcome outcome;
  };
  const std::vector<Case> cases = {
      {Mode::kTraining, SessionPhase::kEnded, "task_complete", {}, 40, fs::Outcome::kCompleted},
      {Mode::kTraining, SessionPhase::kEnded, "duration", {}, 50, fs::Outcome::kCompleted},  // a manoeuvre: no task, its time is its course
      {Mode::kTraining, SessionPhase::kAborted, "aborted by eric", {}, 96, fs::Outcome::kAborted},
      {Mode::kTraining, SessionPhase::kEnded, "time_limit", {{"time_limit", 1}}, 91, fs::Outcome::kTimedOut},
      {Mode::kTraining, SessionPhase::kEnded, "duration", {{"task_incomplete", 1}}, 82, fs::Outcome::kTimedOut},  // 0 of 5 steps
      {Mode::kTraining, SessionPhase::kEnded, "signal", {}, 45, fs::Outcome::kStopped},
      {Mode::kTraining, SessionPhase::kEnded, "cab_gone", {}, 47, fs::Outcome::kStopped},  // the pupil closed the cab
      {Mode::kTraining, SessionPhase::kEnded, "numerical_failure", {}, 30, fs::Outcome::kFailed},
      {Mode::kTraining, SessionPhase::kEnded, "tip_over", {}, 20, fs::Outcome::kFailed},
      {Mode::kTraining, SessionPhase::kEnded, "parked", {}, 60, fs::Outcome::kCompleted},
      {Mode::kExam, SessionPhase::kEnded, "task_complete", {}, 99, fs::Outcome::kCompleted},  // a result, not a training mark
  };
  std::vector<std::string> ids;
  for (const Case& c : cases) {
    const std::string id = NewSession(pupil, c.mode).public_id;
    ids.push_back(id);
    if (c.state == SessionPhase::kAborted) store_->set_session_state(id, SessionPhase::kAborted, c.reason, "t");
    store_->set_score(fs::ScoreRecord{id, c.mark, true, c.counts}, "t");
    if (c.state != SessionPhase::kAborted) store_->set_session_state(id, c.state, c.reason, "t");
  }
  const std::string failed = NewSession(pupil).public_id;  // the worker crashed: no score at all
  store_->set_session_state(failed, SessionPhase::kFailed, "worker killed by signal 9", "t");
  const std::string open = NewSession(pupil).public_id;
  store_->set_score(fs::ScoreRecord{open, 70, true, {}}, "t");  // the score comes before the end

  for (size_t i = 0; i < cases.size(); ++i) {
    const fs::Session s = *store_->get_session(ids[i]);
    EXPECT_EQ(fs::session_outcome(s), cases[i].outcome) << s.reason;
    EXPECT_EQ(fs::mark_of(s).has_value(), cases[i].outcome == fs::Outcome::kCompleted) << s.reason;
    EXPECT_DOUBLE_EQ(*s.mark, cases[i].mark) << "the evaluator's mark is kept as it came";
  }
  EXPECT_EQ(fs::session_outcome(*store_->get_session(failed)), fs::Outcome::kFailed);
  EXPECT_EQ(fs::session_outcome(*store_->get_session(open)), fs::Outcome::kOpen);
  EXPECT_FALSE(fs::mark_of(*store_->get_session(open)).has_value());
  EXPECT_STREQ(forklift::name(fs::Outcome::kTimedOut), "timed_out");

  // The trend is over the marked training sessions alone: 40, 50, 60 in order.
  const auto h = store_->history(pupil, "t");
  ASSERT_TRUE(h->trend.has_value());
  EXPECT_NEAR(*h->trend, 10.0, 1e-9);
}

// A finished exam is kept as written, whatever writes to the file: the schema
// refuses to change or delete its record, its session once over, its score, events and logs, and
// a finished theory exam paper. Training records are not held so.
TEST_P(StoreTest, FinishedExamsAreKeptAsWritten) {
  const int64_t pupil = NewPupil("Ann");
  if (!sqlite()) {
    // PostgreSQL's TRUNCATE takes a table's rows without looking at them: with no exam in it yet,
    // nothing is kept and it goes through (below, once there is one, it is refused).
    store_->add_event(MakeEvent(NewSession(pupil).public_id, 1, "overspeed", 1));
    EXPECT_EQ(RawExec("TRUNCATE events, session_logs, scores, score_counts"), "");
  }
  const int64_t examiner = store_->create_user("eve", "h", fs::Role::kExaminer, school_, std::nullopt, "Eve Examiner");
  EXPECT_EQ(store_->get_user(examiner)->full_name, "Eve Examiner");
  const std::string exam = NewSession(pupil, Mode::kExam, "2026-01-01T10:00:00Z", examiner).public_id;
  store_->add_event(MakeEvent(exam, 1, "collision_rack", 3));
  store_->put_session_log(exam, "control", "log v1");
  // Aborted, then its score comes: the first score of a session that is over is still taken.
  ASSERT_TRUE(store_->set_session_state(exam, SessionPhase::kAborted, "aborted by eve", "2026-01-01T10:10:00Z"));
  fs::ScoreRecord score{exam, 70, false, {{"collision_rack", 1}}};
  score.exam_details = R"({"outcome":"aborted"})";
  ASSERT_TRUE(store_->set_score(score, "2026-01-01T10:10:01Z"));
  const auto exams = store_->history(pupil, "t")->exams;
  ASSERT_EQ(exams.size(), 1u);
  EXPECT_EQ(exams[0].details, score.exam_details) << "the server's reasons are in the record";
  const std::string where = " WHERE session_id = (SELECT id FROM sessions WHERE public_id = '" + exam + "')";
  for (const std::string& sql : std::vector<std::string>{"UPDATE exams SET passed = TRUE", "DELETE FROM exams",
                                 "UPDATE sessions SET mark = 100 WHERE public_id = '" + exam + "'",
                                 "UPDATE sessions SET pupil_id = pupil_id + 1 WHERE public_id = '" + exam + "'",
                                 "UPDATE sessions SET examiner_id = NULL WHERE public_id = '" + exam + "'",
                                 "DELETE FROM sessions WHERE public_id = '" + exam + "'",
                                 "UPDATE scores SET passed = TRUE" + where, "DELETE FROM scores" + where,
                                 "UPDATE score_counts SET count = 0" + where, "DELETE FROM score_counts" + where,
                                 "UPDATE events SET worry_level = 0" + where, "DELETE FROM events" + where,
                                 "UPDATE session_logs SET body = 'log v2'" + where, "DELETE FROM session_logs" + where}) {
    const std::string error = RawExec(sql);
    EXPECT_NE(error.find("kept"), std::string::npos) << sql << ": " << error;
  }
  EXPECT_EQ(ErrorKind([&] { store_->put_session_log(exam, "control", "log v2"); }), fs::StoreError::kConflict);
  store_->put_session_log(exam, "control", "log v1");  // the same log again changes nothing: taken
  store_->put_session_log(exam, "chain_refused", "a");  // the server's own note may be rewritten
  store_->put_session_log(exam, "chain_refused", "b");
  EXPECT_EQ(store_->get_session(exam)->mark, 70);
  EXPECT_EQ(store_->list_events(exam).size(), 1u);

  // A finished theory exam paper.
  fs::TheoryAttempt a;
  a.pupil_id = pupil;
  a.questions = R"({"ids":["q01"]})";
  const int64_t paper = store_->create_theory_attempt(a);
  store_->finish_theory_attempt(paper, TheoryRecord(pupil, 0.4, false));
  EXPECT_NE(RawExec("UPDATE theory_attempts SET questions = '{}' WHERE id = " + std::to_string(paper)).find("kept"), std::string::npos);
  EXPECT_NE(RawExec("DELETE FROM theory_attempts WHERE id = " + std::to_string(paper)).find("kept"), std::string::npos);
  if (!sqlite()) {
    for (const std::string table : {"exams", "sessions", "scores", "score_counts", "events", "session_logs", "theory_attempts"}) {
      const std::string error = RawExec("TRUNCATE " + table + " CASCADE");
      EXPECT_NE(error.find("kept"), std::string::npos) << table << ": " << error;
    }
    EXPECT_EQ(store_->list_events(exam).size(), 1u);
    EXPECT_EQ(store_->get_session_log(exam, "control"), "log v1");
    EXPECT_TRUE(store_->get_exam(exams[0].id).has_value());
  }

  // Training stays as it was: its logs are replaced, its rows are not held.
  const std::string training = NewSession(pupil).public_id;
  store_->set_session_state(training, SessionPhase::kEnded, "duration", "t");
  store_->put_session_log(training, "control", "v1");
  store_->put_session_log(training, "control", "v2");
  EXPECT_EQ(RawExec("UPDATE sessions SET reason = 'x' WHERE public_id = '" + training + "'"), "");
}

// A correction is a new record beside the exam, with its reason, kept for ever.
TEST_P(StoreTest, CorrectionsAreNewRecordsKeptForEver) {
  const int64_t pupil = NewPupil("Ann");
  const int64_t eve = store_->create_user("eve", "h", fs::Role::kExaminer, school_);
  const int64_t exam = store_->add_exam(TheoryRecord(pupil, 0.9, true, "2026-02-01T09:00:00Z"));
  fs::ExamCorrection c;
  c.exam_id = exam;
  c.corrected_by = eve;
  c.reason = "question q07 was marked against the wrong clause";
  c.correction = R"({"score":0.86})";
  const int64_t first = store_->add_exam_correction(c);
  c.reason = "the paper was sat with notes on the desk";
  c.correction = R"({"passed":false})";
  const int64_t second = store_->add_exam_correction(c);
  const auto list = store_->list_exam_corrections(exam);
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].id, first);
  EXPECT_EQ(list[1].id, second);
  EXPECT_EQ(list[1].correction, R"({"passed":false})");
  EXPECT_FALSE(list[0].at.empty());
  EXPECT_EQ(store_->history(pupil, "t")->corrections.size(), 2u);
  EXPECT_TRUE(store_->get_exam(exam)->passed) << "the exam itself is as it was";
  c.reason = "";
  EXPECT_EQ(ErrorKind([&] { store_->add_exam_correction(c); }), fs::StoreError::kInvalid);
  c.reason = "x";
  c.correction = "[1]";
  EXPECT_EQ(ErrorKind([&] { store_->add_exam_correction(c); }), fs::StoreError::kInvalid);
  c.correction = "{}";
  c.exam_id = exam + 99;
  EXPECT_EQ(ErrorKind([&] { store_->add_exam_correction(c); }), fs::StoreError::kNotFound);
  EXPECT_NE(RawExec("UPDATE exam_corrections SET reason = 'x'").find("append-only"), std::string::npos);
  EXPECT_NE(RawExec("DELETE FROM exam_corrections").find("append-only"), std::string::npos);
  if (!sqlite()) {
    EXPECT_NE(RawExec("TRUNCATE exam_corrections").find("append-only"), std::string::npos);
  }
}

// A certificate per licence, its number unique, kept for ever; revoked once.
TEST_P(StoreTest, CertificatesAreKeptAndRevokedOnce) {
  const int64_t ann = NewPupil("Ann"), bob = NewPupil("Bob");
  const int64_t eve = store_->create_user("eve", "h", fs::Role::kExaminer, school_);
  store_->set_user_full_name(eve, "Eve Examiner");
  EXPECT_EQ(store_->get_user(eve)->full_name, "Eve Examiner");
  EXPECT_EQ(ErrorKind([&] { store_->set_user_full_name(eve + 99, "x"); }), fs::StoreError::kNotFound);
  EXPECT_EQ(store_->get_school(school_)->name, "Depot school");
  const int64_t licence = store_->add_licence(ann, "2026-05-01T12:00:00Z", "eve");
  fs::CertificateRecord c;
  c.number = "DS-AAAA-BBBB-CCCC-DDDD";
  c.pupil_id = ann;
  c.licence_id = licence;
  c.issued_at = "2026-05-01T12:00:00Z";
  c.issued_by = eve;
  c.record = R"({"number":"DS-AAAA-BBBB-CCCC-DDDD"})";
  c.signature = R"({"format":"x"})";
  c.id = store_->add_certificate(c);
  const auto found = store_->find_certificate(c.number);
  ASSERT_TRUE(found.has_value());
  EXPECT_EQ(found->id, c.id);
  EXPECT_EQ(found->record, c.record);
  EXPECT_EQ(found->issued_by, eve);
  EXPECT_FALSE(store_->find_certificate("DS-0000-0000-0000-0000").has_value());
  EXPECT_EQ(store_->list_certificates(ann).size(), 1u);
  EXPECT_TRUE(store_->list_certificates(bob).empty());
  EXPECT_EQ(ErrorKind([&] { store_->add_certificate(c); }), fs::StoreError::kConflict);  // the licence has one
  fs::CertificateRecord other = c;
  other.number = "DS-1111-2222-3333-4444";
  other.pupil_id = bob;
  EXPECT_EQ(ErrorKind([&] { store_->add_certificate(other); }), fs::StoreError::kInvalid);  // Ann's licence
  other.licence_id = licence + 99;
  EXPECT_EQ(ErrorKind([&] { store_->add_certificate(other); }), fs::StoreError::kNotFound);

  EXPECT_FALSE(store_->certificate_revocation(c.id).has_value());
  fs::CertificateRevocation r;
  r.certificate_id = c.id;
  r.revoked_by = eve;
  r.reason = "the operator's practical exam was sat by someone else";
  store_->revoke_certificate(r);
  const auto revoked = store_->certificate_revocation(c.id);
  ASSERT_TRUE(revoked.has_value());
  EXPECT_EQ(revoked->reason, r.reason);
  EXPECT_FALSE(revoked->at.empty());
  EXPECT_EQ(ErrorKind([&] { store_->revoke_certificate(r); }), fs::StoreError::kConflict);
  r.reason = "";
  EXPECT_EQ(ErrorKind([&] { store_->revoke_certificate(r); }), fs::StoreError::kInvalid);
  for (const char* sql : {"UPDATE certificates SET record = '{}'", "DELETE FROM certificates",
                                 "UPDATE certificate_revocations SET reason = 'x'", "DELETE FROM certificate_revocations"})
    EXPECT_NE(RawExec(sql).find("append-only"), std::string::npos) << sql;
  if (!sqlite()) {
    for (const char* sql : {"TRUNCATE certificates CASCADE", "TRUNCATE certificate_revocations"})
      EXPECT_NE(RawExec(sql).find("append-only"), std::string::npos) << sql;
  }
}

// Staff administration: accounts listed by full name with a total, passwords
// reset and accounts deactivated ending their logins (login_generation), never the school's last
// active admin; the staff audit log, append-only.
TEST_P(StoreTest, UsersAreListedByFullNamePagedAndFiltered) {
  const int64_t other_school = store_->create_school("Other school");
  store_->create_user("zed", "h", fs::Role::kAdmin, school_, std::nullopt, "Zed Admin");
  store_->create_user("carl", "h", fs::Role::kInstructor, school_, std::nullopt, "carl Instructor");
  store_->create_user("bea", "h", fs::Role::kExaminer, school_, std::nullopt, "Bea Examiner");
  store_->create_user("noname", "h", fs::Role::kInstructor, school_);
  store_->create_user("ana", "h", fs::Role::kPupil, school_, NewPupil("Ana"));
  store_->create_user("elsewhere", "h", fs::Role::kAdmin, other_school, std::nullopt, "Abe Elsewhere");

  auto names = [&](const fs::UserFilter& f, int limit = 100, int offset = 0) {
    std::vector<std::string> out;
    for (const auto& u : store_->list_users(f, limit, offset).users) out.push_back(u.username);
    return out;
  };
  fs::UserFilter staff;
  staff.school_id = school_;
  // By full name, capitals read as small letters; an account without one last.
  EXPECT_EQ(names(staff), (std::vector<std::string>{"bea", "carl", "zed", "noname"}));
  const fs::UserPage page = store_->list_users(staff, 2, 1);
  EXPECT_EQ(page.total, 4);
  ASSERT_EQ(page.users.size(), 2u);
  EXPECT_EQ(page.users[0].username, "carl");
  EXPECT_EQ(page.users[0].full_name, "carl Instructor");
  EXPECT_TRUE(page.users[0].active);
  EXPECT_EQ(store_->list_users(staff, 10, 10).total, 4);  // past the end: no rows, the total still

  fs::UserFilter instructors = staff;
  instructors.role = fs::Role::kInstructor;
  EXPECT_EQ(names(instructors), (std::vector<std::string>{"carl", "noname"}));
  fs::UserFilter everyone = staff;
  everyone.include_pupils = true;
  EXPECT_EQ(names(everyone).size(), 5u);
  fs::UserFilter inactive = staff;
  inactive.active = false;
  EXPECT_TRUE(names(inactive).empty());
  store_->set_user_active(store_->find_user("bea")->id, false);
  EXPECT_EQ(names(inactive), std::vector<std::string>{"bea"});
  EXPECT_EQ(ErrorKind([&] { store_->list_users(staff, -1, 0); }), fs::StoreError::kInvalid);
}

TEST_P(StoreTest, ResetsAndDeactivationsEndLoginsAndTheLastActiveAdminStays) {
  const int64_t ada = store_->create_user("ada", "h", fs::Role::kAdmin, school_, std::nullopt, "Ada Admin");
  const int64_t erin = store_->create_user("erin", "old", fs::Role::kExaminer, school_);
  const int64_t generation = store_->get_user(erin)->login_generation;

  store_->set_user_password(erin, "new");
  EXPECT_EQ(store_->get_user(erin)->password_hash, "new");
  EXPECT_EQ(store_->get_user(erin)->login_generation, generation + 1);
  EXPECT_EQ(ErrorKind([&] { store_->set_user_password(erin + 99, "x"); }), fs::StoreError::kNotFound);

  EXPECT_TRUE(store_->set_user_active(erin, false));
  EXPECT_FALSE(store_->get_user(erin)->active);
  EXPECT_FALSE(store_->find_user("erin")->active);
  EXPECT_EQ(store_->get_user(erin)->login_generation, generation + 2);
  EXPECT_FALSE(store_->set_user_active(erin, false));  // no change
  EXPECT_TRUE(store_->set_user_active(erin, true));
  EXPECT_TRUE(store_->get_user(erin)->active);
  EXPECT_EQ(store_->get_user(erin)->login_generation, generation + 2);  // old tokens stay ended
  EXPECT_EQ(ErrorKind([&] { store_->set_user_active(erin + 99, false); }), fs::StoreError::kNotFound);

  // The school's last active admin cannot go, whichever Store asks; another school's admin does
  // not count.
  store_->create_user("other", "h", fs::Role::kAdmin, store_->create_school("Other school"));
  EXPECT_EQ(ErrorKind([&] { store_->set_user_active(ada, false); }), fs::StoreError::kConflict);
  EXPECT_TRUE(store_->get_user(ada)->active);
  const int64_t bob = store_->create_user("bob", "h", fs::Role::kAdmin, school_);
  auto second = Open();
  EXPECT_TRUE(second->set_user_active(ada, false));
  EXPECT_EQ(ErrorKind([&] { store_->set_user_active(bob, false); }), fs::StoreError::kConflict);
  EXPECT_TRUE(store_->set_user_active(ada, true));
  EXPECT_TRUE(store_->set_user_active(bob, false));
}

TEST_P(StoreTest, StaffAuditRowsRoundTripNewestFirstPerAccountOrSchoolAndAreKept) {
  const int64_t ada = store_->create_user("ada", "h", fs::Role::kAdmin, school_);
  const int64_t erin = store_->create_user("erin", "h", fs::Role::kExaminer, school_);
  const int64_t other = store_->create_user("other", "h", fs::Role::kAdmin, store_->create_school("Other school"));
  auto row = [&](int64_t user, const std::string& action, const std::string& details = "{}") {
    fs::StaffAuditRecord r;
    r.actor = {ada, "ada"};
    r.user_id = user;
    r.action = action;
    r.details = details;
    return r;
  };
  fs::StaffAuditRecord first = row(erin, "account_created", R"({"role":"examiner"})");
  first.at = "2026-01-01T10:00:00Z";
  const int64_t first_id = store_->add_staff_audit(first);
  store_->batch([&] {
    store_->set_user_active(erin, false);
    store_->add_staff_audit(row(erin, "account_deactivated"));
  });
  store_->add_staff_audit(row(ada, "password_reset"));
  store_->add_staff_audit(row(other, "password_reset"));

  const auto erins = store_->list_staff_audit(school_, erin, 10, 0);
  ASSERT_EQ(erins.size(), 2u);
  EXPECT_EQ(erins[0].action, "account_deactivated");  // newest first
  EXPECT_FALSE(erins[0].at.empty());                  // stamped now
  EXPECT_EQ(erins[1].id, first_id);
  EXPECT_EQ(erins[1].at, "2026-01-01T10:00:00Z");
  EXPECT_EQ(erins[1].actor.user_id, ada);
  EXPECT_EQ(erins[1].actor.name, "ada");
  EXPECT_EQ(erins[1].details, first.details);
  EXPECT_EQ(store_->list_staff_audit(school_, std::nullopt, 10, 0).size(), 3u);  // not the other school's
  EXPECT_EQ(store_->list_staff_audit(school_, std::nullopt, 1, 1)[0].action, "account_deactivated");
  EXPECT_TRUE(store_->list_staff_audit(school_, other, 10, 0).empty());

  // A failed batch leaves neither the change nor its row.
  EXPECT_THROW(store_->batch([&] {
    store_->set_user_active(erin, true);
    store_->add_staff_audit(row(erin, "account_reactivated"));
    throw std::runtime_error("refused later");
  }), std::runtime_error);
  EXPECT_FALSE(store_->get_user(erin)->active);
  EXPECT_EQ(store_->list_staff_audit(school_, erin, 10, 0).size(), 2u);

  EXPECT_EQ(ErrorKind([&] { store_->add_staff_audit(row(erin, "")); }), fs::StoreError::kInvalid);
  EXPECT_EQ(ErrorKind([&] { store_->add_staff_audit(row(erin, "x", "[1]")); }), fs::StoreError::kInvalid);
  EXPECT_EQ(ErrorKind([&] { store_->add_staff_audit(row(erin + 99, "x")); }), fs::StoreError::kNotFound);
  EXPECT_EQ(ErrorKind([&] { store_->list_staff_audit(school_, std::nullopt, -1, 0); }), fs::StoreError::kInvalid);

  EXPECT_NE(RawExec("UPDATE staff_audit_log SET actor = 'mallory'").find("append-only"), std::string::npos);
  EXPECT_NE(RawExec("DELETE FROM staff_audit_log").find("append-only"), std::string::npos);
  if (!sqlite()) {
    EXPECT_NE(RawExec("TRUNCATE staff_audit_log").find("append-only"), std::string::npos);
  }
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM staff_audit_log"), std::vector<std::string>{"4"});
}

TEST_P(StoreTest, AccountsFromBeforeStaffAdministrationAreActive) {
  const int64_t erin = store_->create_user("erin", "h", fs::Role::kExaminer, school_, std::nullopt, "Erin Examiner");
  store_->set_user_active(erin, false);
  store_.reset();
  ASSERT_EQ(RawExec(DropMigration7()), "");  // schema 6, as an older program left it
  store_ = Open();
  EXPECT_GE(store_->schema_version(), 7);
  const auto u = store_->get_user(erin);
  EXPECT_TRUE(u->active);
  EXPECT_EQ(u->login_generation, 0);
  EXPECT_EQ(u->full_name, "Erin Examiner");
  EXPECT_TRUE(store_->list_staff_audit(school_, std::nullopt, 10, 0).empty());
}

// The debrief: notes in order, a sign-off once, no note after it, both kept.
TEST_P(StoreTest, SessionNotesAndSignOffAreAppendOnlyAndNoNoteFollowsTheSignOff) {
  const int64_t ida = store_->create_user("ida", "h", fs::Role::kInstructor, school_);
  const int64_t pupil = store_->create_pupil(school_, "Ann Driver", "");
  const std::string s = NewSession(pupil).public_id;
  const std::string other = NewSession(pupil).public_id;
  auto note = [&](const std::string& session, const std::string& text) {
    return fs::SessionNote{0, session, ida, "", text};
  };
  const int64_t first = store_->add_session_note(note(s, "Look over the shoulder before reversing."));
  store_->add_session_note(note(s, "Lowered the forks at the end: good."));
  store_->add_session_note(note(other, "Another session's note."));
  const auto notes = store_->list_session_notes(s);
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_EQ(notes[0].id, first);
  EXPECT_EQ(notes[0].text, "Look over the shoulder before reversing.");
  EXPECT_EQ(notes[0].author_id, ida);
  EXPECT_EQ(notes[0].session_public_id, s);
  EXPECT_FALSE(notes[0].at.empty());
  EXPECT_EQ(notes[1].text, "Lowered the forks at the end: good.");

  EXPECT_EQ(ErrorKind([&] { store_->add_session_note(note(s, "")); }), fs::StoreError::kInvalid);
  EXPECT_EQ(ErrorKind([&] { store_->add_session_note(note("s-999999", "x")); }), fs::StoreError::kNotFound);
  EXPECT_EQ(ErrorKind([&] { store_->add_session_note(fs::SessionNote{0, s, ida + 99, "", "x"}); }), fs::StoreError::kNotFound);

  EXPECT_FALSE(store_->get_session_sign_off(s).has_value());
  EXPECT_TRUE(store_->sign_off_session(fs::SessionSignOff{s, ida, "2026-01-02T09:00:00Z", "Ready for the exam."}));
  auto second = Open();  // another server: the sign-off is one, whoever asks
  EXPECT_FALSE(second->sign_off_session(fs::SessionSignOff{s, ida, "", "again"}));
  const auto off = store_->get_session_sign_off(s);
  ASSERT_TRUE(off.has_value());
  EXPECT_EQ(off->signed_by, ida);
  EXPECT_EQ(off->at, "2026-01-02T09:00:00Z");
  EXPECT_EQ(off->comment, "Ready for the exam.");
  EXPECT_EQ(ErrorKind([&] { second->add_session_note(note(s, "too late")); }), fs::StoreError::kConflict);
  EXPECT_EQ(store_->list_session_notes(s).size(), 2u);
  store_->add_session_note(note(other, "still open"));  // the other session is not signed off
  EXPECT_EQ(ErrorKind([&] { store_->sign_off_session(fs::SessionSignOff{"s-999999", ida, "", ""}); }), fs::StoreError::kNotFound);

  for (const char* table : {"session_notes", "session_sign_offs"}) {
    EXPECT_NE(RawExec(std::string("UPDATE ") + table + " SET at = 'x'").find("append-only"), std::string::npos) << table;
    EXPECT_NE(RawExec(std::string("DELETE FROM ") + table).find("append-only"), std::string::npos) << table;
  }
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM session_notes"), std::vector<std::string>{"4"});
}

// ---------------------------------------------------------------- logins shared by servers, one open session per cab

// A hash as the server makes one (SHA-256 in hex): 64 hex digits, here of one repeated digit.
std::string FakeHash(char digit) { return std::string(64, digit); }

// A pupil's history reads the notes on every session of theirs and, when asked, the request's
// login token as find_login_token() reads it, with the rest: what a server's history page needs
// from the store, in one trip to it.
TEST_P(StoreTest, TheHistoryReadsTheSessionsNotesAndTheLoginWithIt) {
  const int64_t ida = store_->create_user("ida", "h", fs::Role::kInstructor, school_);
  const int64_t pupil = NewPupil("Ann"), other_pupil = NewPupil("Bob");
  const std::string first = NewSession(pupil).public_id, second = NewSession(pupil).public_id;
  const std::string others = NewSession(other_pupil).public_id;
  store_->add_session_note({0, second, ida, "2026-03-01T10:00:00Z", "Check the mirrors."});
  store_->add_session_note({0, first, ida, "2026-03-01T10:01:00Z", "Slow down at the rack."});
  store_->add_session_note({0, others, ida, "2026-03-01T10:02:00Z", "Bob's note."});
  fs::LoginToken t;
  t.hash = FakeHash('c');
  t.user_id = ida;
  t.expires_at_ms = 5000;
  store_->add_login_token(t);

  std::optional<fs::LoginToken> token;
  const auto h = store_->history(pupil, "2026-12-01T00:00:00Z", t.hash, token);
  ASSERT_TRUE(h.has_value());
  ASSERT_EQ(h->notes.size(), 2u);  // Ann's two, oldest first, not Bob's
  EXPECT_EQ(h->notes[0].session_public_id, second);
  EXPECT_EQ(h->notes[0].text, "Check the mirrors.");
  EXPECT_EQ(h->notes[1].session_public_id, first);
  EXPECT_EQ(h->notes[1].author_id, ida);
  ASSERT_TRUE(token.has_value());
  const auto found = store_->find_login_token(t.hash);
  EXPECT_EQ(token->user.username, "ida");
  EXPECT_EQ(token->user_id, found->user_id);
  EXPECT_EQ(token->expires_at_ms, found->expires_at_ms);
  EXPECT_EQ(token->login_generation, found->login_generation);
  // An unknown token, and none asked for; and no pupil, with the token still read.
  store_->history(pupil, "2026-12-01T00:00:00Z", FakeHash('d'), token);
  EXPECT_FALSE(token.has_value());
  token = found;
  EXPECT_EQ(store_->history(pupil, "2026-12-01T00:00:00Z", "", token)->notes.size(), 2u);
  EXPECT_FALSE(token.has_value());
  EXPECT_FALSE(store_->history(other_pupil + 100, "2026-12-01T00:00:00Z", t.hash, token).has_value());
  EXPECT_TRUE(token.has_value());
}

TEST_P(StoreTest, LoginTokensAreKeptByTheirHashAloneAndHonouredByEveryStore) {
  const int64_t ann = store_->create_user("ann", "h", fs::Role::kInstructor, school_);
  fs::LoginToken t;
  t.hash = FakeHash('a');
  t.user_id = ann;
  t.expires_at_ms = 5000;
  store_->add_login_token(t);
  // What the database holds is the hash: no column has anything else of the token.
  EXPECT_EQ(RawQuery("SELECT hash || ' ' || user_id || ' ' || generation || ' ' || expires_at_ms FROM login_tokens"),
            std::vector<std::string>{t.hash + " " + std::to_string(ann) + " 0 5000"});

  // Another server's Store finds it, with the account as it is now.
  auto other = Open();
  store_->set_user_password(ann, "h2");
  const auto found = other->find_login_token(t.hash);
  ASSERT_TRUE(found.has_value());
  EXPECT_EQ(found->user_id, ann);
  EXPECT_EQ(found->login_generation, 0);
  EXPECT_EQ(found->expires_at_ms, 5000);
  EXPECT_EQ(found->user.username, "ann");
  EXPECT_EQ(found->user.login_generation, 1);  // the reset: the server refuses this token
  EXPECT_FALSE(other->find_login_token(FakeHash('b')).has_value());

  EXPECT_EQ(ErrorKind([&] { store_->add_login_token(t); }), fs::StoreError::kConflict);
  fs::LoginToken bad = t;
  for (const std::string& hash : {std::string("abc"), FakeHash('A'), FakeHash('g')}) {
    bad.hash = hash;
    EXPECT_EQ(ErrorKind([&] { store_->add_login_token(bad); }), fs::StoreError::kInvalid) << hash;
  }
  bad.hash = FakeHash('c');
  bad.user_id = ann + 999;
  EXPECT_EQ(ErrorKind([&] { store_->add_login_token(bad); }), fs::StoreError::kNotFound);

  // A logout on one server ends it on the other.
  EXPECT_TRUE(other->delete_login_token(t.hash));
  EXPECT_FALSE(store_->find_login_token(t.hash).has_value());
  EXPECT_FALSE(store_->delete_login_token(t.hash));

  // Tokens expired long ago are forgotten; the rest stay.
  for (const auto& [digit, expires] : std::vector<std::pair<char, int64_t>>{{'1', 100}, {'2', 200}, {'3', 300}}) {
    t.hash = FakeHash(digit);
    t.expires_at_ms = expires;
    store_->add_login_token(t);
  }
  EXPECT_EQ(store_->forget_login_tokens(250), 2);
  EXPECT_FALSE(store_->find_login_token(FakeHash('1')).has_value());
  EXPECT_TRUE(store_->find_login_token(FakeHash('3')).has_value());
}

TEST_P(StoreTest, AttemptsAreCountedPerKeyAndLockoutsHoldForEveryStore) {
  const std::string ann = "login:user:ann", addr = "login:address:10.0.0.1";
  auto other = Open();
  const int64_t first = store_->add_attempt(ann, 1000);
  auto c = other->count_attempts(ann, 0);
  EXPECT_EQ(c.counted, 1);
  EXPECT_EQ(c.pending, 1);
  EXPECT_EQ(c.oldest_at_ms, 1000);
  EXPECT_EQ(c.locked_until_ms, 0);
  EXPECT_EQ(other->count_attempts(addr, 0).counted, 0);  // keys apart

  // A failure stays counted from when it ended; the window leaves it out once it is older.
  other->end_attempt(first, true, 1500);
  c = store_->count_attempts(ann, 0);
  EXPECT_EQ(c.counted, 1);
  EXPECT_EQ(c.pending, 0);
  EXPECT_EQ(c.oldest_at_ms, 1500);
  EXPECT_EQ(store_->count_attempts(ann, 1501).counted, 0);

  // A lockout forgets the ended attempts, not those still being checked; a success is forgotten.
  const int64_t second = store_->add_attempt(ann, 2000);
  other->reset_attempts(ann, 9000);
  c = store_->count_attempts(ann, 0);
  EXPECT_EQ(c.counted, 1);
  EXPECT_EQ(c.pending, 1);
  EXPECT_EQ(c.locked_until_ms, 9000);
  store_->end_attempt(second, false, 2100);
  EXPECT_EQ(other->count_attempts(ann, 0).counted, 0);
  store_->end_attempt(second + 999, true, 2100);  // an attempt forgotten meanwhile: nothing
  store_->reset_attempts(ann, 0);
  EXPECT_EQ(other->count_attempts(ann, 0).locked_until_ms, 0);

  // Old attempts, ended or left pending by a server that stopped, and ended lockouts go.
  store_->add_attempt(addr, 100);
  store_->end_attempt(store_->add_attempt(addr, 200), true, 5000);
  store_->reset_attempts(ann, 2500);
  store_->forget_attempts(3000);
  c = other->count_attempts(addr, 0);
  EXPECT_EQ(c.counted, 1);
  EXPECT_EQ(c.oldest_at_ms, 5000);
  EXPECT_EQ(other->count_attempts(ann, 0).locked_until_ms, 0);
  EXPECT_EQ(ErrorKind([&] { store_->add_attempt("", 1); }), fs::StoreError::kInvalid);
}

TEST_P(StoreTest, ACabHasOneOpenSessionAndOfStoresRacingForItOneWins) {
  const int64_t pupil = NewPupil("Ann");
  const std::string first = store_->create_session(pupil, "cabX", "m4", Mode::kTraining, std::nullopt, "t").public_id;
  EXPECT_EQ(ErrorKind([&] { Open()->create_session(pupil, "cabX", "m4", Mode::kTraining, std::nullopt, "t"); }), fs::StoreError::kConflict);
  // Refused inside a batch, it undoes only itself.
  store_->batch([&] {
    EXPECT_EQ(ErrorKind([&] { store_->create_session(pupil, "cabX", "m4", Mode::kTraining, std::nullopt, "t"); }), fs::StoreError::kConflict);
    store_->create_session(pupil, "cabY", "m4", Mode::kTraining, std::nullopt, "t");
  });
  EXPECT_EQ(store_->open_sessions().size(), 2u);
  ASSERT_TRUE(store_->set_session_state(first, SessionPhase::kEnded, "task_complete", "t"));
  const std::string next = store_->create_session(pupil, "cabX", "m4", Mode::kTraining, std::nullopt, "t").public_id;
  ASSERT_TRUE(store_->set_session_state(next, SessionPhase::kAborted, "aborted", "t"));

  // Eight stores (servers) start a session on one free cab at once: one wins, the rest are refused.
  constexpr int kRacers = 8;
  std::vector<std::unique_ptr<fs::Store>> stores;
  for (int i = 0; i < kRacers; ++i) stores.push_back(Open());
  std::latch go(kRacers);
  std::atomic<int> won{0}, refused{0}, other_errors{0};
  std::vector<std::thread> racers;
  for (int i = 0; i < kRacers; ++i)
    racers.emplace_back([&, i] {
      go.arrive_and_wait();
      try {
        stores[i]->batch([&] { stores[i]->create_session(pupil, "cabX", "m4", Mode::kTraining, std::nullopt, "t"); });
        ++won;
      } catch (const fs::StoreError& e) {
        ++(e.kind() == fs::StoreError::kConflict ? refused : other_errors);
      }
    });
  for (auto& t : racers) t.join();
  EXPECT_EQ(won.load(), 1);
  EXPECT_EQ(refused.load(), kRacers - 1);
  EXPECT_EQ(other_errors.load(), 0);
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM sessions WHERE cab_id = 'cabX' AND state NOT IN ('ended', 'failed', 'aborted')"),
            std::vector<std::string>{"1"});
}

// Servers sharing a store: each runs the sessions it started; a server whose signs of life have
// stopped has its open sessions taken over, each by one server, however many race for them.
TEST_P(StoreTest, EachOpenSessionIsRunByOneServerAndAStoppedServersAreTakenOver) {
  const int64_t pupil = NewPupil("Ann");
  store_->server_alive("a", "2026-12-05T10:00:00Z");
  store_->server_alive("b", "2026-12-05T10:00:00Z");
  const std::string of_a = store_->create_session(pupil, "cab1", "m4", Mode::kTraining, std::nullopt, "t", std::nullopt, "a").public_id;
  const std::string of_b = store_->create_session(pupil, "cab2", "m4", Mode::kTraining, std::nullopt, "t", std::nullopt, "b").public_id;
  const std::string of_none = store_->create_session(pupil, "cab3", "m4", Mode::kTraining, std::nullopt, "t").public_id;
  const std::string ended = store_->create_session(pupil, "cab4", "m4", Mode::kTraining, std::nullopt, "t", std::nullopt, "b").public_id;
  ASSERT_TRUE(store_->set_session_state(ended, SessionPhase::kEnded, "task_complete", "t"));
  EXPECT_EQ(store_->session_server(of_a), "a");
  EXPECT_EQ(store_->session_server(of_none), "");
  EXPECT_EQ(store_->session_server(ended), std::nullopt);  // over: nobody runs it

  // Both alive (seen at 10:00, the lease from 09:59:50): a restarted "a" takes its own and the
  // session nobody ran; "b" then finds nothing to take.
  const std::string lease = "2026-12-05T09:59:50Z";
  EXPECT_EQ(store_->claim_sessions("b", lease, false, of_a), std::vector<std::string>{});  // "a" is alive
  EXPECT_EQ(store_->claim_sessions("a", lease, true), (std::vector<std::string>{of_a, of_none}));
  EXPECT_EQ(store_->claim_sessions("b", lease, false), std::vector<std::string>{});
  EXPECT_EQ(store_->claim_sessions("a", lease, false), std::vector<std::string>{});  // its own are not taken again
  EXPECT_EQ(store_->session_server(of_b), "b");

  // "b" falls silent: after its lease, of the servers that race to take over, one takes its session.
  store_->server_alive("a", "2026-12-05T10:00:20Z");
  const std::string later = "2026-12-05T10:00:10Z";
  constexpr int kRacers = 6;
  std::vector<std::unique_ptr<fs::Store>> stores;
  for (int i = 0; i < kRacers; ++i) stores.push_back(Open());
  std::latch go(kRacers);
  std::vector<std::vector<std::string>> taken(kRacers);
  std::vector<std::thread> racers;
  for (int i = 0; i < kRacers; ++i)
    racers.emplace_back([&, i] {
      stores[i]->server_alive("r" + std::to_string(i), "2026-12-05T10:00:20Z");  // a server says so before it takes any
      go.arrive_and_wait();
      taken[i] = stores[i]->claim_sessions("r" + std::to_string(i), later, false);
    });
  for (auto& t : racers) t.join();
  int winners = 0;
  for (int i = 0; i < kRacers; ++i)
    if (!taken[i].empty()) {
      ++winners;
      EXPECT_EQ(taken[i], std::vector<std::string>{of_b});
      EXPECT_EQ(store_->session_server(of_b), "r" + std::to_string(i));
    }
  EXPECT_EQ(winners, 1);
  EXPECT_EQ(store_->session_server(of_a), "a");  // alive at 10:00:20: kept
}

TEST_P(StoreTest, TheUpgradeToOneOpenSessionPerCabFailsTheOlderOnesAndAuditsThem) {
  const int64_t pupil = NewPupil("Ann");
  ASSERT_EQ(RawExec(DropMigration11()), "");  // schema 10, as an older program left it, with two open sessions on cabA
  const std::string older = store_->create_session(pupil, "cabA", "m4", Mode::kTraining, std::nullopt, "2026-01-01T09:00:00Z").public_id;
  const std::string middle = store_->create_session(pupil, "cabA", "m4", Mode::kTraining, std::nullopt, "2026-01-01T09:30:00Z").public_id;
  const std::string newest = store_->create_session(pupil, "cabA", "m4", Mode::kTraining, std::nullopt, "2026-01-01T10:00:00Z").public_id;
  const std::string alone = store_->create_session(pupil, "cabB", "m4", Mode::kTraining, std::nullopt, "2026-01-01T10:00:00Z").public_id;
  store_.reset();

  store_ = Open();
  EXPECT_GE(store_->schema_version(), 11);  // and the later ones on top
  for (const std::string& id : {older, middle}) {
    const auto s = store_->get_session(id);
    EXPECT_EQ(s->state, SessionPhase::kFailed) << id;
    EXPECT_NE(s->reason.find("one open session per cab"), std::string::npos) << s->reason;
    EXPECT_FALSE(s->ended_at.empty());
  }
  EXPECT_EQ(store_->get_session(newest)->state, SessionPhase::kStarting);
  EXPECT_EQ(store_->get_session(alone)->state, SessionPhase::kStarting);
  const auto rows = store_->list_audit(fs::AuditScope{pupil, std::nullopt}, 10, 0);
  ASSERT_EQ(rows.size(), 2u);
  for (const auto& r : rows) {
    EXPECT_EQ(r.action, "session_failed");
    EXPECT_EQ(r.actor.name, "server");
    EXPECT_FALSE(r.actor.user_id.has_value());
    const auto d = nlohmann::json::parse(r.details);
    EXPECT_EQ(d["from"], "starting");
    EXPECT_EQ(d["to"], "failed");
    EXPECT_TRUE(d["session"] == older || d["session"] == middle) << d;
  }
  EXPECT_EQ(ErrorKind([&] { store_->create_session(pupil, "cabA", "m4", Mode::kTraining, std::nullopt, "t"); }), fs::StoreError::kConflict);
}
