// The generated store (store_generator.h): one deterministic description of every row, written
// by COPY into PostgreSQL or by prepared inserts into SQLite.
#include "store_generator.h"

#include <libpq-fe.h>
#include <sqlite3.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "forklift/store/store.h"

namespace forklift::bench {

namespace {

using Clock = std::chrono::steady_clock;

constexpr int kDays = 730;             // two years of sessions
constexpr int kSessionsPerPupil = 50;  // a pupil's course
constexpr int kSessionsPerCabDay = 16; // a cab's working day of 40-minute sessions
const char* const kScenarios[] = {"first_drive", "slalom", "rack_pick", "practical_exam", "load_lorry", "pedestrian_awareness"};
const char* const kFaults[] = {"speeding", "collision_rack", "harsh_braking", "forks_high", "off_route"};
const char* const kFirst[] = {"Ann", "Ben", "Carla", "Dev", "Eva", "Farid", "Greta", "Hugo", "Ines", "Jon", "Kira", "Luis",
                              "Mia", "Nils", "Olga", "Pavel", "Rosa", "Sam", "Tara", "Umar", "Vera", "Wim", "Yusuf", "Zoe"};
const char* const kLast[] = {"Driver", "Baker", "Costa", "Dubois", "Evans", "Fischer", "Garcia", "Hansen", "Ivanova", "Jensen",
                             "Kowalski", "Lopez", "Moreau", "Novak", "Olsen", "Petrov", "Quinn", "Rossi", "Silva", "Tanaka",
                             "Urban", "Varga", "Weber", "Young"};

uint64_t mix(uint64_t x) {  // splitmix64: a session's dice, the same on every run
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// One school's rows. Its k-th pupil, i-th session and e-th exam have the ids first_pupil +
// k * stride, first_session + i * stride and first_exam + e * stride: the region's schools' rows
// interleave, each school's first ids one after the other's.
struct Layout {
  int64_t n = 0;          // sessions
  int64_t block = 1;      // pupils who drive in turn through the same weeks (a cohort)
  int64_t pupils = 0;
  int cabs = 4;
  int64_t first_session = 1, first_pupil = 1, first_exam = 1, stride = 1;
  int64_t exams = 0;  // written
  int64_t school = 0;
  std::string cab_prefix = "cab";  // its cabs' names: cab_prefix + 1, 2, ...

  int64_t next_exam_id() { return first_exam + exams++ * stride; }
};

// `each(layout, k)` for each school's k-th row of `count(layout)` rows, the k-th of every school
// before the (k + 1)-th of any: the schools' rows in the order their days bring them.
template <class Count, class Each>
void interleaved(std::vector<Layout>& ls, Count count, Each each) {
  int64_t most = 0;
  for (const Layout& l : ls) most = std::max(most, count(l));
  for (int64_t k = 0; k < most; ++k)
    for (Layout& l : ls)
      if (k < count(l)) each(l, k);
}
const auto sessions_of = [](const Layout& l) { return l.n; };
const auto pupils_of = [](const Layout& l) { return l.pupils; };

// Each school's first pupil and exam ids: the store's next free ones for the first school, one more
// for each school after it (their rows interleave). The sessions of them all.
int64_t give_first_ids(std::vector<Layout>& ls, int64_t first_pupil, int64_t first_exam) {
  int64_t all = 0;
  for (size_t j = 0; j < ls.size(); ++j) {
    ls[j].first_pupil = first_pupil + static_cast<int64_t>(j);
    ls[j].first_exam = first_exam + static_cast<int64_t>(j);
    all += ls[j].n;
  }
  return all;
}

struct SessionRow {
  int64_t id, pupil;
  int cab;
  const char* scenario;
  bool exam;
  const char* state;
  const char* reason;
  std::string created_at, ended_at;
  bool scored, passed, task_incomplete;
  double mark;
  const char* fault;
  int fault_count;
  const char* outcome;  // as the store keeps it (session_outcome())
};

struct PupilRow {
  int64_t id;
  std::string name, email, created_at;
  double theory_score;
};

int64_t first_of_day(const Layout& l, int64_t day) { return (day * l.n + kDays - 1) / kDays; }

std::string time_text(int day, int seconds) {
  std::tm tm{};
  tm.tm_year = 125;
  tm.tm_mday = 1 + day;
  tm.tm_sec = seconds;
  return store::iso8601_of(timegm(&tm));
}

// Session i (0-based, in time order): its pupil is of the cohort driving those weeks, each of the
// cohort in turn; its cab the next in turn; its result by its dice.
SessionRow session_row(const Layout& l, int64_t i) {
  SessionRow s{};
  s.id = l.first_session + i * l.stride;
  const int64_t in_block = i % (l.block * kSessionsPerPupil);
  s.pupil = l.first_pupil + (i / (l.block * kSessionsPerPupil) * l.block + in_block % l.block) * l.stride;
  s.cab = static_cast<int>(i % l.cabs) + 1;
  const int64_t day = i * kDays / l.n;
  const int64_t in_day = i - first_of_day(l, day), of_day = std::max<int64_t>(1, first_of_day(l, day + 1) - first_of_day(l, day));
  const int start = 7 * 3600 + static_cast<int>(in_day * 11 * 3600 / of_day);  // 07:00 to 18:00
  s.created_at = time_text(static_cast<int>(day), start);
  s.ended_at = time_text(static_cast<int>(day), start + 20 * 60);
  const uint64_t h = mix(static_cast<uint64_t>(s.id));
  s.scenario = kScenarios[h % 6];
  s.exam = i % 20 == 7;
  if (s.exam) s.scenario = "practical_exam";
  const int r = static_cast<int>((h >> 8) % 100);
  s.mark = 40 + static_cast<double>((h >> 16) % 601) / 10;
  s.state = "ended";
  s.scored = true;
  if (r < 62) s.reason = "task_complete";
  else if (r < 72) s.reason = "duration", s.task_incomplete = (h >> 32) % 2;
  else if (r < 80) s.reason = "time_limit";
  else {
    s.scored = false;
    if (r < 86) s.state = "aborted", s.reason = "aborted";
    else if (r < 90) s.state = "failed", s.reason = "numerical_failure";
    else if (r < 95) s.reason = "signal";
    else s.reason = "cab_gone";
  }
  s.passed = s.scored && s.mark >= 70 && std::string(s.reason) != "time_limit";
  store::Session as_stored;
  as_stored.state = *parse<SessionPhase>(s.state);
  as_stored.reason = s.reason;
  as_stored.task_left_unfinished = s.task_incomplete;
  s.outcome = name(store::session_outcome(as_stored));
  s.fault = kFaults[(h >> 40) % 5];
  s.fault_count = 1 + static_cast<int>((h >> 48) % 3);
  return s;
}

PupilRow pupil_row(const Layout& l, int64_t k) {
  PupilRow p;
  p.id = l.first_pupil + k * l.stride;
  const size_t nf = std::size(kFirst), nl = std::size(kLast);
  const std::string first = kFirst[mix(k) % nf], last = kLast[(mix(k) >> 20) % nl];
  p.name = first + " " + last + " " + std::to_string(k);
  p.email = first + "." + last + std::to_string(k) + "@example.org";
  for (char& c : p.email) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  // The pupil's first session: the first of the cohort's weeks.
  const int64_t first_session = k / l.block * l.block * kSessionsPerPupil + k % l.block;
  p.created_at = time_text(static_cast<int>(std::min<int64_t>(first_session, l.n - 1) * kDays / l.n), 6 * 3600);
  p.theory_score = 60 + static_cast<double>(mix(k + 77) % 41);
  return p;
}

void say(bool progress, const char* what, int64_t done, int64_t of, Clock::time_point t0) {
  if (progress)
    std::fprintf(stderr, "\rgenerating: %s %lld of %lld (%.0f s)   ", what, static_cast<long long>(done),
                 static_cast<long long>(of), std::chrono::duration<double>(Clock::now() - t0).count());
}

// ------------------------------------------------------------------------------- PostgreSQL

struct PgConn {
  explicit PgConn(const std::string& uri) : c(PQconnectdb(uri.c_str())) {
    if (PQstatus(c) != CONNECTION_OK) throw std::runtime_error(std::string("cannot connect: ") + PQerrorMessage(c));
  }
  ~PgConn() { PQfinish(c); }
  // The first column of the first row, or "".
  std::string exec(const std::string& sql) {
    std::unique_ptr<PGresult, decltype(&PQclear)> r(PQexec(c, sql.c_str()), &PQclear);
    const ExecStatusType st = PQresultStatus(r.get());
    if (st != PGRES_COMMAND_OK && st != PGRES_TUPLES_OK)
      throw std::runtime_error(sql.substr(0, 60) + ": " + PQresultErrorMessage(r.get()));
    return st == PGRES_TUPLES_OK && PQntuples(r.get()) > 0 ? PQgetvalue(r.get(), 0, 0) : "";
  }
  // The first two columns of every row.
  std::vector<std::pair<std::string, std::string>> rows(const std::string& sql) {
    std::unique_ptr<PGresult, decltype(&PQclear)> r(PQexec(c, sql.c_str()), &PQclear);
    if (PQresultStatus(r.get()) != PGRES_TUPLES_OK) throw std::runtime_error(sql.substr(0, 60) + ": " + PQresultErrorMessage(r.get()));
    std::vector<std::pair<std::string, std::string>> out;
    for (int i = 0; i < PQntuples(r.get()); ++i) out.emplace_back(PQgetvalue(r.get(), i, 0), PQgetvalue(r.get(), i, 1));
    return out;
  }
  // COPY table(columns) FROM STDIN of the lines `rows` writes through its `line` argument.
  void copy(const std::string& table, const std::function<void(const std::function<void(const std::string&)>&)>& rows) {
    {
      std::unique_ptr<PGresult, decltype(&PQclear)> r(PQexec(c, ("COPY " + table + " FROM STDIN").c_str()), &PQclear);
      if (PQresultStatus(r.get()) != PGRES_COPY_IN) throw std::runtime_error("COPY " + table + ": " + PQresultErrorMessage(r.get()));
    }
    std::string buf;
    const auto flush = [&] {
      if (PQputCopyData(c, buf.data(), static_cast<int>(buf.size())) != 1) throw std::runtime_error(PQerrorMessage(c));
      buf.clear();
    };
    rows([&](const std::string& line) {
      buf += line;
      buf += '\n';
      if (buf.size() > (1 << 20)) flush();
    });
    if (!buf.empty()) flush();
    if (PQputCopyEnd(c, nullptr) != 1) throw std::runtime_error(PQerrorMessage(c));
    std::unique_ptr<PGresult, decltype(&PQclear)> r(PQgetResult(c), &PQclear);
    if (PQresultStatus(r.get()) != PGRES_COMMAND_OK) throw std::runtime_error("COPY " + table + ": " + PQresultErrorMessage(r.get()));
    while (PGresult* more = PQgetResult(c)) PQclear(more);
  }
  PGconn* c;
};

std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", v);
  return b;
}

void fill_postgresql(const std::string& uri, std::vector<Layout>& ls, bool progress, Clock::time_point t0) {
  PgConn pg(uri);
  pg.exec("SET synchronous_commit = off");
  pg.exec("SET maintenance_work_mem = '512MB'");
  pg.exec("BEGIN");
  // The filled tables' indexes (not their keys) made once at the end, sorted, rather than
  // updated row by row: ten times faster at 10 million sessions.
  const auto indexes = pg.rows(
      "SELECT indexname, indexdef FROM pg_indexes WHERE schemaname = current_schema() AND tablename IN "
      "('pupils', 'sessions', 'scores', 'score_counts', 'exams') AND indexname NOT IN (SELECT conname FROM pg_constraint)");
  for (const auto& [name, definition] : indexes) pg.exec("DROP INDEX " + name);
  const int64_t all = give_first_ids(ls, std::stoll(pg.exec("SELECT COALESCE(MAX(id), 0) + 1 FROM pupils")),
                                     std::stoll(pg.exec("SELECT COALESCE(MAX(id), 0) + 1 FROM exams")));
  int64_t pupils = 0;
  for (const Layout& l : ls) {
    pupils += l.pupils;
    pg.exec("INSERT INTO cabs(id, school_id) SELECT '" + l.cab_prefix + "' || n, " + std::to_string(l.school) +
            " FROM generate_series(1, " + std::to_string(l.cabs) + ") n ON CONFLICT DO NOTHING");
  }
  pg.copy("pupils(id, school_id, name, email, created_at)", [&](const auto& line) {
    interleaved(ls, pupils_of, [&](const Layout& l, int64_t k) {
      const PupilRow p = pupil_row(l, k);
      line(std::to_string(p.id) + '\t' + std::to_string(l.school) + '\t' + p.name + '\t' + p.email + '\t' + p.created_at);
    });
  });
  say(progress, "pupils", pupils, pupils, t0);
  pg.copy("sessions(id, pupil_id, cab_id, scenario, mode, state, reason, created_at, ended_at, mark, passed, school_id, outcome)",
          [&](const auto& line) {
            int64_t done = 0;
            interleaved(ls, sessions_of, [&](const Layout& l, int64_t i) {
              const SessionRow r = session_row(l, i);
              line(std::to_string(r.id) + '\t' + std::to_string(r.pupil) + '\t' + l.cab_prefix + std::to_string(r.cab) + '\t' +
                   r.scenario + (r.exam ? "\texam\t" : "\ttraining\t") + r.state + '\t' + r.reason + '\t' + r.created_at + '\t' +
                   r.ended_at + '\t' + (r.scored ? num(r.mark) : "\\N") + '\t' + (r.scored ? (r.passed ? "t" : "f") : "\\N") + '\t' +
                   std::to_string(l.school) + '\t' + r.outcome);
              if (done++ % 1000000 == 0) say(progress, "sessions", done, all, t0);
            });
          });
  say(progress, "sessions", all, all, t0);
  pg.copy("scores(session_id, mark, passed)", [&](const auto& line) {
    interleaved(ls, sessions_of, [&](const Layout& l, int64_t i) {
      if (const SessionRow r = session_row(l, i); r.scored) line(std::to_string(r.id) + '\t' + num(r.mark) + '\t' + (r.passed ? "t" : "f"));
    });
  });
  pg.copy("score_counts(session_id, kind, count)", [&](const auto& line) {
    interleaved(ls, sessions_of, [&](const Layout& l, int64_t i) {
      const SessionRow r = session_row(l, i);
      if (!r.scored) return;
      line(std::to_string(r.id) + '\t' + r.fault + '\t' + std::to_string(r.fault_count));
      if (r.task_incomplete) line(std::to_string(r.id) + "\ttask_incomplete\t1");
    });
  });
  say(progress, "scores", all, all, t0);
  pg.copy("exams(id, pupil_id, kind, session_id, score, passed, taken_at, school_id)", [&](const auto& line) {
    interleaved(ls, pupils_of, [&](Layout& l, int64_t k) {
      const PupilRow p = pupil_row(l, k);
      line(std::to_string(l.next_exam_id()) + '\t' + std::to_string(p.id) + "\ttheory\t\\N\t" + num(p.theory_score) + '\t' +
           (p.theory_score >= 80 ? "t" : "f") + '\t' + p.created_at + '\t' + std::to_string(l.school));
    });
    interleaved(ls, sessions_of, [&](Layout& l, int64_t i) {
      if (const SessionRow r = session_row(l, i); r.exam && r.scored)
        line(std::to_string(l.next_exam_id()) + '\t' + std::to_string(r.pupil) + "\tpractical\t" + std::to_string(r.id) + '\t' +
             num(r.mark) + '\t' + (r.passed ? "t" : "f") + '\t' + r.ended_at + '\t' + std::to_string(l.school));
    });
  });
  say(progress, "indexes", 0, static_cast<int64_t>(indexes.size()), t0);
  for (const auto& [name, definition] : indexes) pg.exec(definition);
  for (const char* t : {"pupils", "sessions", "exams"})
    pg.exec(std::string("SELECT setval(pg_get_serial_sequence('") + t + "', 'id'), (SELECT MAX(id) FROM " + t + "))");
  // Committed to the disk before VACUUM: it sets no page all-visible (no index-only scans) while
  // the commit that wrote its rows may still be lost, as an asynchronous commit may.
  pg.exec("SET synchronous_commit = on");
  pg.exec("COMMIT");
  say(progress, "statistics", 0, 1, t0);
  // The statistics and visibility map autovacuum makes within minutes of a bulk load.
  pg.exec("VACUUM (ANALYZE)");
}

// ---------------------------------------------------------------------------------- SQLite

struct Sqlite {
  explicit Sqlite(const std::string& path) {
    if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK)
      throw std::runtime_error(path + ": " + sqlite3_errmsg(db));
    sqlite3_busy_timeout(db, 10000);
  }
  ~Sqlite() {
    for (sqlite3_stmt* s : made) sqlite3_finalize(s);
    sqlite3_close(db);
  }
  void exec(const std::string& sql) {
    char* msg = nullptr;
    if (sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &msg) != SQLITE_OK) {
      const std::string m = msg ? msg : "failed";
      sqlite3_free(msg);
      throw std::runtime_error(sql.substr(0, 60) + ": " + m);
    }
  }
  int64_t value(const std::string& sql) {
    sqlite3_stmt* s = prepare(sql);
    const int64_t v = sqlite3_step(s) == SQLITE_ROW ? sqlite3_column_int64(s, 0) : 0;
    sqlite3_reset(s);
    return v;
  }
  sqlite3_stmt* prepare(const std::string& sql) {
    sqlite3_stmt* s = nullptr;
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &s, nullptr) != SQLITE_OK) throw std::runtime_error(sql + ": " + sqlite3_errmsg(db));
    made.push_back(s);
    return s;
  }
  void run(sqlite3_stmt* s) {
    if (sqlite3_step(s) != SQLITE_DONE) throw std::runtime_error(std::string("insert: ") + sqlite3_errmsg(db));
    sqlite3_reset(s);
  }
  sqlite3* db = nullptr;
  std::vector<sqlite3_stmt*> made;
};

void text(sqlite3_stmt* s, int i, const std::string& v) { sqlite3_bind_text(s, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT); }
void text(sqlite3_stmt* s, int i, const char* v) { sqlite3_bind_text(s, i, v, -1, SQLITE_STATIC); }

void fill_sqlite(const std::string& path, std::vector<Layout>& ls, bool progress, Clock::time_point t0) {
  Sqlite db(path);
  // A generated store can be made again: no need to survive a power cut while it is filled. Each
  // insert that fires a trigger keeps a statement journal: in memory, not a temporary file
  // (400,000 writes to /var/tmp for 20,000 sessions).
  db.exec("PRAGMA synchronous = OFF; PRAGMA cache_size = -1048576; PRAGMA cache_spill = OFF; PRAGMA temp_store = MEMORY; BEGIN IMMEDIATE");
  const int64_t all = give_first_ids(ls, db.value("SELECT COALESCE(MAX(id), 0) + 1 FROM pupils"),
                                     db.value("SELECT COALESCE(MAX(id), 0) + 1 FROM exams"));
  // The filled tables' indexes (not their keys) made once at the end, as PostgreSQL's.
  std::vector<std::pair<std::string, std::string>> indexes;
  {
    sqlite3_stmt* q = db.prepare(
        "SELECT name, sql FROM sqlite_master WHERE type = 'index' AND sql IS NOT NULL AND tbl_name IN "
        "('pupils', 'sessions', 'scores', 'score_counts', 'exams')");
    while (sqlite3_step(q) == SQLITE_ROW)
      indexes.emplace_back(reinterpret_cast<const char*>(sqlite3_column_text(q, 0)), reinterpret_cast<const char*>(sqlite3_column_text(q, 1)));
    sqlite3_reset(q);
  }
  for (const auto& [name, definition] : indexes) db.exec("DROP INDEX " + name);
  sqlite3_stmt* cab = db.prepare("INSERT INTO cabs(id, school_id) VALUES (?1, ?2) ON CONFLICT DO NOTHING");
  for (const Layout& l : ls)
    for (int c = 1; c <= l.cabs; ++c) {
      text(cab, 1, l.cab_prefix + std::to_string(c));
      sqlite3_bind_int64(cab, 2, l.school);
      db.run(cab);
    }
  sqlite3_stmt* pupil = db.prepare("INSERT INTO pupils(id, school_id, name, email, created_at) VALUES (?1, ?2, ?3, ?4, ?5)");
  sqlite3_stmt* exam = db.prepare(
      "INSERT INTO exams(id, pupil_id, kind, session_id, score, passed, taken_at, school_id) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)");
  const auto add_exam = [&](Layout& l, int64_t pupil_id, const char* kind, std::optional<int64_t> session, double score,
                            bool passed, const std::string& at) {
    sqlite3_bind_int64(exam, 1, l.next_exam_id());
    sqlite3_bind_int64(exam, 2, pupil_id);
    text(exam, 3, kind);
    if (session) sqlite3_bind_int64(exam, 4, *session);
    else sqlite3_bind_null(exam, 4);
    sqlite3_bind_double(exam, 5, score);
    sqlite3_bind_int(exam, 6, passed);
    text(exam, 7, at);
    sqlite3_bind_int64(exam, 8, l.school);
    db.run(exam);
  };
  interleaved(ls, pupils_of, [&](Layout& l, int64_t k) {
    const PupilRow p = pupil_row(l, k);
    sqlite3_bind_int64(pupil, 1, p.id);
    sqlite3_bind_int64(pupil, 2, l.school);
    text(pupil, 3, p.name);
    text(pupil, 4, p.email);
    text(pupil, 5, p.created_at);
    db.run(pupil);
    add_exam(l, p.id, "theory", std::nullopt, p.theory_score, p.theory_score >= 80, p.created_at);
  });
  sqlite3_stmt* session = db.prepare(
      "INSERT INTO sessions(id, pupil_id, cab_id, scenario, mode, state, reason, created_at, ended_at, mark, passed, school_id, outcome) "
      "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13)");
  sqlite3_stmt* score = db.prepare("INSERT INTO scores(session_id, mark, passed) VALUES (?1, ?2, ?3)");
  sqlite3_stmt* count = db.prepare("INSERT INTO score_counts(session_id, kind, count) VALUES (?1, ?2, ?3)");
  int64_t done = 0;
  interleaved(ls, sessions_of, [&](Layout& l, int64_t i) {
    const SessionRow r = session_row(l, i);
    sqlite3_bind_int64(session, 1, r.id);
    sqlite3_bind_int64(session, 2, r.pupil);
    text(session, 3, l.cab_prefix + std::to_string(r.cab));
    text(session, 4, r.scenario);
    text(session, 5, r.exam ? "exam" : "training");
    text(session, 6, r.state);
    text(session, 7, r.reason);
    text(session, 8, r.created_at);
    text(session, 9, r.ended_at);
    if (r.scored) {
      sqlite3_bind_double(session, 10, r.mark);
      sqlite3_bind_int(session, 11, r.passed);
    } else {
      sqlite3_bind_null(session, 10);
      sqlite3_bind_null(session, 11);
    }
    sqlite3_bind_int64(session, 12, l.school);
    text(session, 13, r.outcome);
    db.run(session);
    if (r.scored) {
      sqlite3_bind_int64(score, 1, r.id);
      sqlite3_bind_double(score, 2, r.mark);
      sqlite3_bind_int(score, 3, r.passed);
      db.run(score);
      const auto add_count = [&](const char* kind, int n) {
        sqlite3_bind_int64(count, 1, r.id);
        text(count, 2, kind);
        sqlite3_bind_int(count, 3, n);
        db.run(count);
      };
      add_count(r.fault, r.fault_count);
      if (r.task_incomplete) add_count("task_incomplete", 1);
      if (r.exam) add_exam(l, r.pupil, "practical", r.id, r.mark, r.passed, r.ended_at);
    }
    if (done++ % 1000000 == 0) say(progress, "sessions", done, all, t0);
  });
  say(progress, "indexes", 0, static_cast<int64_t>(indexes.size()), t0);
  for (const auto& [name, definition] : indexes) db.exec(definition);
  db.exec("COMMIT");
  say(progress, "statistics", 0, 1, t0);
  // The statistics a school's store gathers (the server's PRAGMA optimize), so that the planner
  // chooses as it would there.
  db.exec("ANALYZE");
}

}  // namespace

std::string generated_day(int day) { return time_text(day, 0).substr(0, 10); }

GeneratedStore generate_sessions(const std::string& location, int64_t sessions, bool progress, int64_t per_school) {
  if (sessions < 1) throw std::runtime_error("at least one session to generate");
  if (per_school < 1) throw std::runtime_error("at least one session a school");
  const auto t0 = Clock::now();
  const int64_t schools = (sessions + per_school - 1) / per_school;
  std::vector<Layout> ls(static_cast<size_t>(schools));
  {
    // Made and migrated by the store itself, its schools too.
    auto store = store::Store::open(location);
    if (store::is_postgresql_location(location)) {
      PgConn pg(location);
      if (pg.exec("SELECT EXISTS (SELECT 1 FROM sessions)") == "t")
        throw std::runtime_error("the store holds sessions already: generate into a new one");
    } else {
      Sqlite db(location);
      if (db.value("SELECT EXISTS (SELECT 1 FROM sessions)"))
        throw std::runtime_error("the store holds sessions already: generate into a new one");
    }
    for (int64_t j = 0; j < schools; ++j) {
      Layout& l = ls[static_cast<size_t>(j)];
      l.school = store->create_school(schools == 1 ? "Generated school" : "Generated school " + std::to_string(j + 1));
      if (j > 0) l.cab_prefix = "school" + std::to_string(j + 1) + "-cab";
      // Shared out evenly: the first sessions % schools schools have one more.
      l.n = sessions / schools + (j < sessions % schools ? 1 : 0);
      l.first_session = 1 + j;
      l.stride = schools;
      l.cabs = static_cast<int>(std::max<int64_t>(4, l.n / (kDays * kSessionsPerCabDay)));
      // A cohort drives every other day: half a day's sessions of pupils at once.
      l.block = std::max<int64_t>(1, l.n / kDays / 2);
      const int64_t whole = l.block * kSessionsPerPupil;
      const int64_t last = (l.n - 1) / whole;
      l.pupils = last * l.block + std::min(l.block, l.n - last * whole);
    }
  }
  if (store::is_postgresql_location(location)) fill_postgresql(location, ls, progress, t0);
  else fill_sqlite(location, ls, progress, t0);
  const Layout& first = ls.front();
  GeneratedStore g;
  g.school_id = first.school;
  g.pupils = first.pupils;
  g.sessions = first.n;
  g.exams = first.exams;
  g.cabs = first.cabs;
  g.first_day = generated_day(0);
  g.days = kDays;
  g.first_pupil_id = first.first_pupil;
  g.first_session_id = first.first_session;
  g.first_exam_id = first.first_exam;
  g.schools = static_cast<int>(schools);
  g.all_sessions = sessions;
  g.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  if (progress)
    std::fprintf(stderr, "\rgenerated %lld sessions of %lld school%s in %.1f s                    \n", static_cast<long long>(sessions),
                 static_cast<long long>(schools), schools == 1 ? "" : "s", g.seconds);
  return g;
}

}  // namespace forklift::bench
