// A store filled with generated sessions, for the lists' and the history's growth curve
// (forklift-bench-store) and the plans' guard (tests/store/store_test.cc): the region's schools
// on one database, each of at most 100,000 sessions (two years of a school with 8 cabs), so that
// a bigger store is more schools, as a region's is, not a school driving more sessions a day. In
// each school, pupils drive 50 sessions each, spread over two years of days on cabs that each run
// some 16 sessions a day, with the results a school sees (completed and passed or not, out of
// time, stopped, aborted, failed), a fault counted on each scored session, one session in 20 a
// practical exam with its exam record, and a theory exam per pupil. The schools drive at the same
// time: their rows are written interleaved, in time order, as a region's server writes them, so a
// school's rows lie among the others'. No events or paths: the lists never read them.
//
// Written past the store's interface, straight into its tables (the store migrates the database
// first, Store::open): PostgreSQL's COPY, SQLite's prepared inserts in one transaction; then the
// statistics a planner has once autovacuum has seen a bulk load (ANALYZE).
#pragma once

#include <cstdint>
#include <string>

namespace forklift::bench {

// What was generated. The figures but `schools`, `all_sessions` and `seconds` are the first
// school's, the one the benches and tests read.
struct GeneratedStore {
  int64_t school_id = 0;
  int64_t pupils = 0;
  int64_t sessions = 0;
  int64_t exams = 0;
  int cabs = 0;              // named cab1, cab2, ... (the other schools' school2-cab1, ...)
  std::string first_day;     // the first day that has sessions, 2025-01-01
  int days = 0;              // days with sessions, from first_day
  // The school's k-th pupil (0 <= k < pupils) is first_pupil_id + k * schools, its i-th session
  // first_session_id + i * schools, its e-th exam first_exam_id + e * schools: the schools' rows
  // interleave.
  int64_t first_pupil_id = 0, first_session_id = 0, first_exam_id = 0;
  int schools = 1;
  int64_t all_sessions = 0;  // of every school
  double seconds = 0;        // how long the filling took

  int64_t pupil_id(int64_t k) const { return first_pupil_id + k * schools; }
  int64_t session_id(int64_t i) const { return first_session_id + i * schools; }
  int64_t exam_id(int64_t e) const { return first_exam_id + e * schools; }
};

constexpr int64_t kGeneratedSessionsPerSchool = 100000;

// Fills the store at `location` (an SQLite file's path or a postgresql:// URI; made and migrated
// if new) with `sessions` generated sessions (at least 1) of new schools of at most
// `per_school` sessions each, shared out evenly. The store must hold no session yet: a second
// generation into the same store is refused (std::runtime_error), as is a failing database.
// `progress`: lines on stderr as it goes.
GeneratedStore generate_sessions(const std::string& location, int64_t sessions, bool progress = false,
                                 int64_t per_school = kGeneratedSessionsPerSchool);

// The day `day` days after 2025-01-01, as "YYYY-MM-DD".
std::string generated_day(int day);

}  // namespace forklift::bench
