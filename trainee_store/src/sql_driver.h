// The seam between the store, written once in SQL (sql_store.cc), and a database's C library:
// a driver prepares statements, binds their parameters by position, steps their rows, reads
// columns, counts changed rows and runs transactions; a dialect holds the few SQL fragments in
// which SQLite and PostgreSQL differ, and each backend's migrations. Two drivers:
// sqlite_driver.cc (sqlite3) and postgres_driver.cc (libpq).
//
// SQL is written with SQLite's parameters: `?` for the next one, `?N` for the N-th (a value used
// twice); the PostgreSQL driver numbers them ($N). No statement has a `?` in a literal.
// Booleans are bound as bool and read as int64 1 or 0, on either backend.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "forklift/store/store.h"

namespace forklift::store::detail {

// A prepared statement, used by one Query at a time. Errors throw StoreError (of the contract's
// kind, by the database's error code) naming the operation the statement was prepared for.
class Statement {
 public:
  virtual ~Statement() = default;
  virtual void bind_null() = 0;
  virtual void bind_int64(int64_t v) = 0;
  virtual void bind_double(double v) = 0;
  virtual void bind_bool(bool v) = 0;
  virtual void bind_text(const std::string& v) = 0;
  // Runs the statement on the first call; true when a row is ready.
  virtual bool step() = 0;
  // Runs the statement; the rows it inserted, updated or deleted.
  virtual int64_t changes() = 0;
  virtual int64_t int64(int col) const = 0;
  virtual double real(int col) const = 0;
  virtual std::string text(int col) const = 0;
  virtual bool is_null(int col) const = 0;
  // Ready for the next use: parameters and rows forgotten, no read snapshot held.
  virtual void reset() = 0;
};

// What a transaction is for.
//   kStatement: one statement, atomic by itself: nothing to begin outside a transaction; inside one
//     a savepoint (PostgreSQL refuses the rest of a transaction after a failed statement).
//   kRead: several reads from one snapshot.
//   kWrite: reads and writes, holding the database's write lock from the start (SQLite's BEGIN
//     IMMEDIATE; PostgreSQL's advisory lock), so that reads inside it see the rows it replaces.
//   kMigrate: kWrite that waits for the lock however long another server's migration takes.
// Inside an open transaction (a batch) each is a savepoint, so that a call failing inside a
// batch undoes only itself and the batch decides the rest.
enum class TxKind { kStatement, kRead, kWrite, kMigrate };

// A transaction's state as its driver keeps it between begin() and commit() or end().
struct TxState {
  bool open = false;     // something to commit or roll back
  bool nested = false;   // a savepoint in an enclosing transaction
  bool counted = false;  // counted in the driver's depth until end()
};

class Driver {
 public:
  virtual ~Driver() = default;
  // The statement for `sql` (prepared once per connection), for one use by operation `op`.
  virtual Statement& prepare(const char* op, const std::string& sql) = 0;
  // Runs SQL without parameters: one or several statements (a migration).
  virtual void exec(const char* op, const std::string& sql) = 0;
  // Whether a transaction is open (a batch).
  virtual bool in_transaction() = 0;
  virtual TxState begin(const char* op, TxKind kind) = 0;
  virtual void commit(const char* op, TxState& tx) = 0;
  // Rolls back what `tx` still holds open; never throws.
  virtual void end(TxState& tx) noexcept = 0;
  // Runs `statements` (bound, not run yet) now, the last of transaction `tx`, in one round trip
  // where the database is a network away: with the transaction's BEGIN ahead of them and its
  // COMMIT behind them (tx then closed), their rows read afterwards as usual. SQLite, in the
  // process, runs each on its first step as always, and commits at commit().
  virtual void run_together(const char* /*op*/, const std::vector<Statement*>& /*statements*/, TxState& /*tx*/) {}
  // Commits made until durable_end() reach the disk before they return (an exam result must
  // survive a power cut); whether the driver changed anything, to undo. Outside a transaction only.
  virtual bool durable_begin(const char* op) = 0;
  virtual void durable_end() noexcept = 0;
  // Store::storage_problem().
  virtual std::optional<std::string> storage_problem() = 0;
  // From now on, before each statement runs, its SQL and plan go to `plans` (Store::query_plans);
  // null: no more.
  virtual void explain_into(std::vector<std::string>* plans) = 0;
};

// One use of a prepared statement: binds parameters in order, steps, reads columns. Resets the
// statement when it goes out of scope, so that no read snapshot outlives the call.
class Query {
 public:
  Query(Driver& d, const char* op, const std::string& sql) : s_(d.prepare(op, sql)) {}
  ~Query() { s_.reset(); }
  Query(const Query&) = delete;
  Query& operator=(const Query&) = delete;

  Query& bind(int v) { return bind(static_cast<int64_t>(v)); }
  Query& bind(int64_t v) { return s_.bind_int64(v), *this; }
  Query& bind(bool v) { return s_.bind_bool(v), *this; }
  Query& bind(double v) { return s_.bind_double(v), *this; }
  Query& bind(const std::string& v) { return s_.bind_text(v), *this; }
  Query& bind(const char*) = delete;  // would bind as a bool: pass a std::string
  template <class T>
  Query& bind(const std::optional<T>& v) {
    if (v) return bind(*v);
    return s_.bind_null(), *this;
  }

  // True when a row is ready.
  bool step() { return s_.step(); }
  void run() {
    while (step()) {
    }
  }
  int64_t changes() { return s_.changes(); }
  // The id an INSERT ... RETURNING id gave, the statement run to its end (outside a transaction,
  // SQLite commits it only then).
  int64_t returned_id() {
    step();
    const int64_t id = int64(0);
    run();
    return id;
  }

  int64_t int64(int col) const { return s_.int64(col); }
  double real(int col) const { return s_.real(col); }
  std::string text(int col) const { return s_.text(col); }
  bool is_null(int col) const { return s_.is_null(col); }
  Statement& statement() { return s_; }
  std::optional<int64_t> opt_int64(int col) const { return is_null(col) ? std::nullopt : std::optional(int64(col)); }
  std::optional<double> opt_real(int col) const { return is_null(col) ? std::nullopt : std::optional(real(col)); }

 private:
  Statement& s_;
};

// One atomic unit of `kind`, rolled back unless committed.
class Transaction {
 public:
  Transaction(Driver& d, const char* op, TxKind kind) : d_(d), op_(op), state_(d.begin(op, kind)) {}
  ~Transaction() { d_.end(state_); }
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void commit() { d_.commit(op_, state_); }
  // Runs `queries`, bound, as the transaction's last statements (Driver::run_together); their rows
  // are read after, and commit() still ends the transaction.
  void run_last(std::initializer_list<Query*> queries) {
    std::vector<Statement*> statements;
    for (Query* q : queries) statements.push_back(&q->statement());
    d_.run_together(op_, statements, state_);
  }

 private:
  Driver& d_;
  const char* op_;
  TxState state_;
};

// Commits within this scope reach the disk before they return. It must enclose the transaction;
// inside a batch it does nothing and the batch's own commit decides.
class Durable {
 public:
  Durable(Driver& d, const char* op) : d_(d), active_(!d.in_transaction() && d.durable_begin(op)) {}
  ~Durable() {
    if (active_) d_.durable_end();
  }
  Durable(const Durable&) = delete;
  Durable& operator=(const Durable&) = delete;

 private:
  Driver& d_;
  bool active_;
};

// The SQL fragments in which the backends differ, and each one's migrations.
struct Dialect {
  // Schema migrations in order: entry i brings the schema to version i + 1, the same version in
  // both backends.
  const char* const* migrations;
  int migration_count;
  // `expr` as a key compared and sorted with ASCII capitals read as small letters.
  std::string (*folded)(const std::string& expr);
  // `column` equal to text parameter `param`, capitals or not.
  std::string (*equal_folded)(const std::string& column, const std::string& param);
  // `column` LIKE the next text parameter (a contains_pattern with '\' escapes), capitals or not.
  std::string (*like_folded)(const std::string& column);
  // `expr` sorted byte by byte.
  std::string (*bytewise)(const std::string& expr);
  // A session's columns (read_session), read FROM `sessions_from`, and the join of sessions to
  // their pupils on a page of find_sessions.
  const char* session_columns;
  const char* sessions_from;
  const char* session_page_join;
  // INSERT of a user (?1 username, ?2 password hash, ?3 role, ?4 school, ?5 pupil, ?6 full name)
  // RETURNING id, no row when the name is taken, capitals or not.
  const char* insert_user;
  // INSERT of the audit row of a score (?1 at, ?2 actor id, ?3 actor, ?4 session id), its details
  // a JSON object written by the database from the rows stored.
  const char* insert_score_audit;
  // SELECT of a state change's details, a JSON object (?1 session, ?2 from, ?3 to, ?4 reason).
  const char* state_audit_details;
};

// The store over `driver`, speaking `dialect`; applies pending migrations.
std::unique_ptr<Store> make_sql_store(std::unique_ptr<Driver> driver, const Dialect& dialect);

}  // namespace forklift::store::detail
