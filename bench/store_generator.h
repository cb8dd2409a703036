// A store filled with generated sessions, for the lists' and the history's growth curve
// (forklift-bench-store) and the plans' guard (tests/store/store_test.cc): N sessions of pupils
// who drive 50 sessions each, spread over two years of days on cabs that each run some 16 sessions
// a day, with the results a school sees (completed and passed or not, out of time, stopped,
// aborted, failed), a fault counted on each scored session, one session in 20 a practical exam
// with its exam record, and a theory exam per pupil. No events or paths: the lists never read
// them, and history() reads a pupil's fault counts from the scores.
//
// Written past the store's interface, straight into its tables (the store migrates the database
// first, Store::open): PostgreSQL's COPY, SQLite's prepared inserts in one transaction; then the
// statistics a planner has once autovacuum has seen a bulk load (ANALYZE).
#pragma once

#include <cstdint>
#include <string>

namespace forklift::bench {

struct GeneratedStore {
  int64_t school_id = 0;
  int64_t pupils = 0;
  int64_t sessions = 0;
  int64_t exams = 0;
  int cabs = 0;              // named cab1, cab2, ...
  std::string first_day;     // the first day that has sessions, 2025-01-01
  int days = 0;              // days with sessions, from first_day
  int64_t first_pupil_id = 0;  // the pupils' ids are first_pupil_id .. first_pupil_id + pupils - 1
  double seconds = 0;        // how long the filling took
};

// Fills the store at `location` (an SQLite file's path or a postgresql:// URI; made and migrated
// if new) with `sessions` generated sessions (at least 1) of a new school. The store must hold no
// session yet: a second generation into the same store is refused (std::runtime_error), as is a
// failing database. `progress`: lines on stderr as it goes.
GeneratedStore generate_sessions(const std::string& location, int64_t sessions, bool progress = false);

// The day `day` days after 2025-01-01, as "YYYY-MM-DD".
std::string generated_day(int day);

}  // namespace forklift::bench
