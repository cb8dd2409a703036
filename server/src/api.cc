#include "api.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <mutex>

#include "contract.h"
#include "forklift/server/listener.h"

namespace forklift::server {

using store::Role;

void send_json(httplib::Response& res, int status, const json& body) {
  res.status = status;
  // A byte that is not UTF-8 (quoted back from a bad request, say) is sent as U+FFFD, never an
  // exception that turns an answer into a 500.
  res.set_content(body.dump(-1, ' ', false, json::error_handler_t::replace), "application/json");
}

void send_json_text(httplib::Response& res, int status, std::string body) {
  res.status = status;
  res.body = std::move(body);
  res.set_header("Content-Type", "application/json");
}

void send_error(httplib::Response& res, int status, const std::string& code, const std::string& message) {
  send_json(res, status, {{"error", {{"code", code}, {"message", message}}}});
}

void internal_error(httplib::Response& res, const httplib::Request& req, const std::string& detail) {
  spdlog::error("{} {}: {}", req.method, req.path, detail);  // the detail for the administrator, never the client
  send_error(res, 500, "internal", "the server could not do this just now: try again, or ask the school's administrator (the server's log says why)");
}

namespace {

// Whether the last write that failed for want of storage has been followed by one that succeeded.
class StorageWatch {
 public:
  void failed(const std::string& reason) {
    std::lock_guard<std::mutex> lock(mu_);
    reason_ = reason;
  }
  void wrote() {
    std::lock_guard<std::mutex> lock(mu_);
    reason_.reset();
  }
  std::optional<std::string> failure() {
    std::lock_guard<std::mutex> lock(mu_);
    return reason_;
  }

 private:
  std::mutex mu_;
  std::optional<std::string> reason_;
};

StorageWatch& storage_watch() {
  static StorageWatch watch;
  return watch;
}

// A store's refusal in words a school reads: what() has the store's function and, for some, the
// database's own text (SQLite's or PostgreSQL's), which go to the server's log only.
void store_refusal(httplib::Response& res, const httplib::Request& req, const store::StoreError& e) {
  switch (e.kind()) {
    case store::StoreError::kNotFound:
      spdlog::info("{} {}: {}", req.method, req.path, e.what());
      return send_error(res, 404, "not_found", "a record this needs does not exist (or is another school's)");
    case store::StoreError::kConflict:
      spdlog::info("{} {}: {}", req.method, req.path, e.what());
      return send_error(res, 409, "conflict", "this conflicts with what the school's records hold: a name already taken, or a record that is kept as it was written");
    case store::StoreError::kInvalid:
      spdlog::info("{} {}: {}", req.method, req.path, e.what());
      return send_error(res, 400, "bad_request", "the school's records cannot hold a value of this request");
    case store::StoreError::kIo: break;
  }
  spdlog::error("{} {}: {}", req.method, req.path, e.what());
  if (const auto* u = dynamic_cast<const store::StorageUnavailable*>(&e)) {
    storage_watch().failed(u->reason());
    return send_json(res, 503, {{"error", {{"code", "storage_unavailable"}, {"reason", u->reason()},
                                           {"message", u->reason() + ". Nothing of this request was written: try again "
                                                       "once the school's administrator has put it right"}}}});
  }
  send_error(res, 500, "store_error", "the school's records could not be read or written just now: try again, or ask the school's administrator");
}

}  // namespace

std::optional<std::string> storage_unavailable(store::Store& db) {
  if (auto problem = db.storage_problem()) return problem;
  if (!storage_watch().failure()) return std::nullopt;
  try {
    // One committed write that leaves nothing: an attempt under a key no login uses, ended as a success.
    db.batch([&] { db.end_attempt(db.add_attempt("health:write", unix_ms()), false, 0); });
  } catch (const store::StorageUnavailable& e) {
    return e.reason();
  }
  storage_watch().wrote();
  return std::nullopt;
}

void answer_exception(const httplib::Request& req, httplib::Response& res, std::exception_ptr ep) {
  try {
    std::rethrow_exception(ep);
  } catch (const ApiError& e) {
    send_error(res, e.status, e.code, e.what());
  } catch (const store::StoreError& e) {
    store_refusal(res, req, e);
  } catch (const std::exception& e) {
    internal_error(res, req, e.what());
  } catch (...) {
    internal_error(res, req, "unknown exception");
  }
}

Handler guarded(Handler h) {
  return [h](const httplib::Request& req, httplib::Response& res) {
    try {
      // The listener bounds a chunked body by its bytes with their framing; this, by its own.
      if (req.body.size() > kMaxBodyBytes) throw ApiError(413, kBodyTooLarge.code, kBodyTooLarge.message);
      h(req, res);
      if (req.method != "GET" && res.status < 300) storage_watch().wrote();
    } catch (...) {
      answer_exception(req, res, std::current_exception());
    }
  };
}

json body_json(const httplib::Request& req) {
  if (req.body.empty()) throw ApiError(400, "bad_request", "a JSON body is required");
  json j;
  try {
    j = json::parse(req.body);
  } catch (const json::parse_error& e) {  // its what() is the parser's: say where, in words
    throw ApiError(400, "bad_json", "the body is not valid JSON (it goes wrong at character " + std::to_string(e.byte) + ")");
  } catch (const json::exception&) {  // out_of_range: a number beyond a double
    throw ApiError(400, "bad_json", "the body is not valid JSON (a number in it is too large)");
  }
  if (!j.is_object()) throw ApiError(400, "bad_request", "the body must be a JSON object");
  // The body as server/openapi.yaml has it for this request.
  if (const Operation* op = api_contract().find(req.method, req.path)) api_contract().check_body(*op, j);
  return j;
}

Mode mode_field(const json& j) {
  const std::string text = field<std::string>(j, "mode", std::string(name(Mode::kTraining)));
  if (const std::optional<Mode> mode = parse<Mode>(text)) return *mode;
  throw ApiError(400, "bad_request", "'mode' must be training or exam");
}

std::string username_field(const json& j) {
  const auto name = store::canonical_username(field<std::string>(j, "username"));
  if (!name)
    throw ApiError(400, "bad_request", "'username' may have only the letters a-z, digits, '.', '_' and '-', 1 to " +
                                           std::to_string(store::kMaxUsernameLength) + " of them (capitals read as small letters)");
  return *name;
}

int64_t path_id(const httplib::Request& req, int i) {
  try {
    return std::stoll(req.matches[i]);
  } catch (const std::exception&) {
    throw ApiError(404, "not_found", "no such id");
  }
}

int query_int(const httplib::Request& req, const char* key, int dflt, int hi) {
  if (!req.has_param(key)) return dflt;
  const std::string text = req.get_param_value(key);
  // A whole number in [0, hi] (server/openapi.yaml's range, which the contract has checked
  // already for a documented operation), else 400: never clamped, so no client reads a short page
  // as the whole.
  if (text.empty() || text.size() > 12 || text.find_first_not_of("0123456789") != std::string::npos)
    throw ApiError(400, "bad_request", std::string("'") + key + "' must be a whole number from 0 to " + std::to_string(hi));
  const int64_t v = std::stoll(text);
  if (v > hi) throw ApiError(400, "bad_request", std::string("'") + key + "' must be at most " + std::to_string(hi) + " (found " + text + ")");
  return static_cast<int>(v);
}

namespace {
// The request's bearer token, else 401.
std::string bearer_token(const httplib::Request& req) {
  const std::string h = req.get_header_value("Authorization");
  if (h.rfind("Bearer ", 0) != 0) throw ApiError(401, "unauthenticated", "log in first: Authorization: Bearer <token>");
  return h.substr(7);
}

// The login that check `c` of the request's `token` found, else 401.
Principal login_of(Context& ctx, const std::string& token, const Tokens::Check& c) {
  if (c.expired) throw ApiError(401, "token_expired", "this login has expired: log in again");
  if (!c.principal) throw ApiError(401, "unauthenticated", "the token is unknown or was logged out: log in again");
  // The account as it is now, read from the store with the token, so that a deactivation or a
  // password reset made through any server sharing it ends this login at once.
  const auto& u = c.user;
  if (!u || !u->active) {
    ctx.tokens->revoke(ctx.db(), token);
    throw ApiError(401, "account_deactivated", "this account has been deactivated: ask the school's administrator");
  }
  if (u->login_generation != c.principal->login_generation) {
    ctx.tokens->revoke(ctx.db(), token);
    throw ApiError(401, "unauthenticated", "this login was ended by the school's administrator (a new password, or the account deactivated): log in again");
  }
  request_notes().user = c.principal->username;  // for the access log
  return *c.principal;
}
}  // namespace

Principal authenticate(Context& ctx, const httplib::Request& req) {
  const std::string token = bearer_token(req);
  return login_of(ctx, token, ctx.tokens->check(ctx.db(), token));
}

void require_role(const Principal& p, std::initializer_list<Role> roles) {
  for (Role r : roles) if (p.role == r) return;
  throw ApiError(403, "forbidden", std::string("a ") + store::role_name(p.role) + " may not do this");
}

bool is_staff(const Principal& p) { return p.role != Role::kPupil; }

std::string language_of(Context& ctx, const Principal& p) {
  return ctx.words->supported(p.pupil_id ? ctx.db().pupil_language(*p.pupil_id) : ctx.db().user_language(p.user_id));
}

std::string request_language(Context& ctx, const httplib::Request& req) {
  return req.has_param("lang") ? ctx.words->supported(req.get_param_value("lang")) : i18n::kSourceLanguage;
}

std::optional<std::string> language_field(Context& ctx, const json& b) {
  if (!b.contains("language")) return std::nullopt;
  const std::string lang = field<std::string>(b, "language");
  if (!ctx.words->has_language(lang)) {
    std::string known;
    for (const std::string& l : ctx.words->languages()) known += (known.empty() ? "" : ", ") + l;
    throw ApiError(400, "bad_request", "'language' must be one of the school's languages: " + known);
  }
  return lang;
}

namespace {
// Refuses `pupil` (none: there is no such pupil) unless `p` may see it.
void check_visible(const Principal& p, int64_t id, const store::Pupil* pupil) {
  if (!pupil) throw ApiError(404, "not_found", "no pupil " + std::to_string(id));
  if (p.role == Role::kPupil && p.pupil_id != id) throw ApiError(403, "forbidden", "a pupil may see only their own records");
  if (p.role != Role::kPupil && pupil->school_id != p.school_id) throw ApiError(404, "not_found", "no pupil " + std::to_string(id));
}
}  // namespace

store::Pupil visible_pupil(Context& ctx, const Principal& p, int64_t id) {
  const auto pupil = ctx.db().get_pupil(id);
  check_visible(p, id, pupil ? &*pupil : nullptr);
  return *pupil;
}

store::PupilHistory visible_history(Context& ctx, const Principal& p, int64_t id) {
  auto h = ctx.db().history(id, store::now_iso8601());
  check_visible(p, id, h ? &h->pupil : nullptr);
  return std::move(*h);
}

std::pair<Principal, store::PupilHistory> login_and_history(Context& ctx, const httplib::Request& req, int64_t id) {
  const std::string token = bearer_token(req);
  std::optional<store::LoginToken> found;
  auto h = ctx.db().history(id, store::now_iso8601(), Tokens::key_of(token), found);
  // Nothing of the history is used before the login is checked as authenticate() checks it.
  const Principal p = login_of(ctx, token, ctx.tokens->checked(found));
  check_visible(p, id, h ? &h->pupil : nullptr);
  return {p, std::move(*h)};
}

store::Session visible_session(Context& ctx, const Principal& p, const std::string& public_id) {
  const auto s = ctx.db().get_session(public_id);
  if (!s) throw ApiError(404, "not_found", "no session " + public_id);
  visible_pupil(ctx, p, s->pupil_id);
  return *s;
}

json pupil_json(const store::Pupil& p) {
  return {{"id", p.id}, {"name", p.name}, {"email", p.email}, {"created_at", p.created_at},
          {"group_id", p.group_id ? json(*p.group_id) : json(nullptr)}};
}

json session_json(const store::Session& s) {
  json j = json::object();
  session_fields(s, [&](const char* key, const auto& value) {
    if constexpr (requires { value.has_value(); })
      j[key] = value ? json(*value) : json(nullptr);
    else
      j[key] = value;
  });
  return j;
}

const store::Actor kServerActor{std::nullopt, "server"};

store::Actor actor_of(const Principal& p) { return {p.user_id, p.username}; }

void audit(store::Store& db, const Principal& p, int64_t pupil_id, const std::string& action, const json& details) {
  store::AuditRecord r;
  r.actor = actor_of(p);
  r.pupil_id = pupil_id;
  r.action = action;
  r.details = details.dump();
  db.add_audit(r);
}

void staff_audit(store::Store& db, const Principal& p, int64_t user_id, const std::string& action, const json& details) {
  store::StaffAuditRecord r;
  r.actor = actor_of(p);
  r.user_id = user_id;
  r.action = action;
  r.details = details.dump();
  db.add_staff_audit(r);
}

namespace {

// A row of either audit log; `subject` names what it is about ("pupil_id" or "user_id").
template <class Row>
json audit_json(const Row& r, const char* subject, int64_t subject_id) {
  return {{"id", r.id}, {"at", r.at}, {"actor_user_id", r.actor.user_id ? json(*r.actor.user_id) : json(nullptr)},
          {"actor", r.actor.name}, {subject, subject_id}, {"action", r.action},
          {"details", json::parse(r.details, nullptr, false)}};
}

int audit_limit(const httplib::Request& req) { return query_int(req, "limit", 100, 1000); }
int audit_offset(const httplib::Request& req) { return query_int(req, "offset", 0, 1 << 30); }

}  // namespace

json audit_page(store::Store& db, const store::AuditScope& scope, const httplib::Request& req) {
  json out = json::array();
  for (const auto& r : db.list_audit(scope, audit_limit(req), audit_offset(req))) out.push_back(audit_json(r, "pupil_id", r.pupil_id));
  return out;
}

json staff_audit_page(store::Store& db, int64_t school_id, std::optional<int64_t> user_id, const httplib::Request& req) {
  json out = json::array();
  for (const auto& r : db.list_staff_audit(school_id, user_id, audit_limit(req), audit_offset(req)))
    out.push_back(audit_json(r, "user_id", r.user_id));
  return out;
}

}  // namespace forklift::server
