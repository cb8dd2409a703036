// The plumbing every route file shares: errors as JSON answers, reading the request (body, fields,
// path ids, query numbers), who is asking and what they may see, and the audit log.
#pragma once

#include <httplib.h>

#include <cmath>
#include <cstdint>
#include <exception>
#include <functional>
#include <initializer_list>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "auth.h"
#include "context.h"
#include "forklift/store/store.h"

namespace forklift::server {

using nlohmann::json;

// ---------------------------------------------------------------- errors
// Thrown by a handler; guarded() turns it into {"error": {"code", "message"}} with `status`.
struct ApiError : std::runtime_error {
  int status;
  std::string code;
  ApiError(int s, std::string c, const std::string& m) : std::runtime_error(m), status(s), code(std::move(c)) {}
};

void send_json(httplib::Response& res, int status, const json& body);
// A body written already (JsonStream), sent as send_json sends a document.
void send_json_text(httplib::Response& res, int status, std::string body);
void send_error(httplib::Response& res, int status, const std::string& code, const std::string& message);

using Handler = std::function<void(const httplib::Request&, httplib::Response&)>;
// `h` with whatever it throws answered by answer_exception().
Handler guarded(Handler h);
// The answer to an exception a request raised, the one place that maps them: ApiError as it says;
// StoreError in words (404, 409, 400, or 500; store::StorageUnavailable 503 storage_unavailable
// with its reason), the store's own text going to the server's log only; anything else 500.
void answer_exception(const httplib::Request& req, httplib::Response& res, std::exception_ptr e);
// Why the store cannot write just now, or nullopt, for the health endpoint: what `db` sees itself
// (store::Store::storage_problem), else, if a request failed for want of storage
// (store::StorageUnavailable) and none that writes has succeeded since, what a small write of its
// own says (a row added and removed), which clears that once it succeeds, so that a server taken
// out of rotation for it comes back without anyone writing through it. For the whole process.
std::optional<std::string> storage_unavailable(store::Store& db);
// 500 internal, saying nothing of `detail` (an exception's text), which goes to the server's log.
void internal_error(httplib::Response& res, const httplib::Request& req, const std::string& detail);

// ---------------------------------------------------------------- the request
json body_json(const httplib::Request& req);  // a JSON object, else 400

// `v`, the body's `name`, as the number T it must be, else 400 naming it: a JSON number (nlohmann
// would read true as 1), for an integer T a whole one within T's range (it would truncate 1.5 and
// wrap 2^64 - 1 to -1).
template <typename T>
T number_field(const json& v, const std::string& name) {
  static_assert(std::is_arithmetic_v<T> && !std::is_same_v<T, bool>);
  if (!v.is_number()) throw ApiError(400, "bad_request", "'" + name + "' must be a number");
  if constexpr (std::is_integral_v<T>) {
    using Limits = std::numeric_limits<T>;
    bool in_range;
    if (v.is_number_unsigned()) {
      in_range = v.get<uint64_t>() <= static_cast<uint64_t>(Limits::max());
    } else if (v.is_number_integer()) {
      const int64_t i = v.get<int64_t>();
      in_range = i >= static_cast<int64_t>(Limits::min()) && (i < 0 || static_cast<uint64_t>(i) <= static_cast<uint64_t>(Limits::max()));
    } else {
      const double d = v.get<double>();
      if (d != std::trunc(d)) throw ApiError(400, "bad_request", "'" + name + "' must be a whole number");
      // Limits::max() + 1 is a power of two, exact as a double.
      in_range = d >= static_cast<double>(Limits::min()) && d < static_cast<double>(Limits::max() / 2 + 1) * 2;
      if (in_range) return static_cast<T>(d);
    }
    if (!in_range) throw ApiError(400, "bad_request", "'" + name + "' is out of range");
  }
  return v.get<T>();  // a double: the parser makes only finite ones
}

// The body's `key` as a T: `fallback` when absent or null, else 400 if it is required; a number
// as number_field() takes it.
template <typename T>
T field(const json& j, const char* key, std::optional<T> fallback = std::nullopt) {
  if (!j.contains(key) || j[key].is_null()) {
    if (fallback) return *fallback;
    throw ApiError(400, "bad_request", std::string("'") + key + "' is required");
  }
  if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
    return number_field<T>(j[key], key);
  } else {
    try {
      return j[key].get<T>();
    } catch (const json::exception&) {
      throw ApiError(400, "bad_request", std::string("'") + key + "' has the wrong type");
    }
  }
}

// The body's "mode": training when absent, else 400 for anything but training or exam.
Mode mode_field(const json& j);

// The body's "username" for a new login, as stored (store::canonical_username), else 400 with the rule.
std::string username_field(const json& j);

int64_t path_id(const httplib::Request& req, int i = 1);  // the path's i-th match as an id, else 404
// A whole-number query parameter in [0, hi], or `dflt` when absent; 400 if it is not one (digits
// and nothing else) or is above `hi`.
int query_int(const httplib::Request& req, const char* key, int dflt, int hi);

// ---------------------------------------------------------------- who asks
Principal authenticate(Context& ctx, const httplib::Request& req);  // the bearer token's login, else 401
void require_role(const Principal& p, std::initializer_list<store::Role> roles);  // else 403
bool is_staff(const Principal& p);
// The language a signed-in person reads in: staff their account's, a pupil their record's.
std::string language_of(Context& ctx, const Principal& p);
// The language the request's words are given in: ?lang= (the contract allows the catalogue's
// languages only), else English: the pages not yet worded in the school's languages, and the
// command line, read English, and must not get another language's words in an English page.
std::string request_language(Context& ctx, const httplib::Request& req);
// The body's "language", if given: one the catalogue has (else 400).
std::optional<std::string> language_field(Context& ctx, const json& b);
// A pupil sees only their own records; staff only their school's.
store::Pupil visible_pupil(Context& ctx, const Principal& p, int64_t id);
// A visible pupil's history (else 404 or 403 as visible_pupil), in one read of the store: the
// pupil comes with it.
store::PupilHistory visible_history(Context& ctx, const Principal& p, int64_t id);
// authenticate() and visible_history() in one trip to the store: the login's token read with the
// history (Store::history with a token), checked before anything of it is used.
std::pair<Principal, store::PupilHistory> login_and_history(Context& ctx, const httplib::Request& req, int64_t id);
// The session `public_id`, if its pupil is visible to `p` (else 404 or 403 as visible_pupil).
store::Session visible_session(Context& ctx, const Principal& p, const std::string& public_id);

// ---------------------------------------------------------------- records shared by several routes
json pupil_json(const store::Pupil& p);
// A session with its outcome; its mark and passed only as the store's rule gives them (mark_of).
json session_json(const store::Session& s);
// The same fields, one put(key, value) each, for a document (session_json) or a stream (the
// history): values are strings, integers, the mark (optional<double>) and passed (optional<bool>).
template <class Put>
void session_fields(const store::Session& s, Put&& put) {
  // A session has a mark only when it completed (store::session_outcome, the one rule); an exam
  // that ended otherwise did not pass.
  const store::Outcome o = store::session_outcome(s);
  std::optional<bool> passed;
  if (o == store::Outcome::kCompleted) passed = s.passed;
  else if (s.mode == Mode::kExam && o != store::Outcome::kOpen) passed.emplace(false);
  put("id", s.public_id);
  put("pupil_id", s.pupil_id);
  put("cab_id", s.cab_id);
  put("scenario", s.scenario);
  put("mode", name(s.mode));
  put("state", name(s.state));
  put("reason", s.reason);
  put("outcome", name(o));
  put("created_at", s.created_at);
  put("ended_at", s.ended_at);
  put("mark", store::mark_of(s));
  put("passed", passed);
  if (s.examiner_id) put("examiner_id", *s.examiner_id);
}

// ---------------------------------------------------------------- audit
extern const store::Actor kServerActor;  // writers that are not a logged-in user
store::Actor actor_of(const Principal& p);
// Records a change `p` made to a pupil's record. Call it inside the db.batch() that makes the
// change, so that the change and its row commit together or not at all.
void audit(store::Store& db, const Principal& p, int64_t pupil_id, const std::string& action, const json& details);
// One page of audit rows, newest first, from the request's limit and offset.
json audit_page(store::Store& db, const store::AuditScope& scope, const httplib::Request& req);
// Records an administrator's change to an account (`user_id`) in the staff audit log, inside the
// db.batch() that makes the change, as audit() does.
void staff_audit(store::Store& db, const Principal& p, int64_t user_id, const std::string& action, const json& details);
// One page of the staff audit log of `school_id`'s accounts (only `user_id`'s when set), as audit_page().
json staff_audit_page(store::Store& db, int64_t school_id, std::optional<int64_t> user_id, const httplib::Request& req);

}  // namespace forklift::server
