// Health, logging in and out, and new logins.
#include "api.h"
#include "routes.h"

namespace forklift::server {

using store::Role;

namespace {

// The name a login's failures count against: as the store compares names (capitals read as
// small letters), cut short so that long made-up names cannot fill the throttle's memory.
std::string throttle_key(const std::string& username) {
  std::string key = username.substr(0, 4 * store::kMaxUsernameLength);
  for (char& c : key)
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  return key;
}

// The body's "full_name" (optional): the name certificates print for staff.
std::string full_name_field(const json& b) {
  const std::string name = field<std::string>(b, "full_name", std::string());
  if (name.size() > 200) throw ApiError(400, "bad_request", "'full_name' must have at most 200 characters");
  if (name.find_first_of("\r\n\t") != std::string::npos) throw ApiError(400, "bad_request", "'full_name' must be one line");
  return name;
}

json user_json(const store::User& u) {
  return {{"id", u.id}, {"username", u.username}, {"role", store::role_name(u.role)},
          {"full_name", u.full_name.empty() ? json(nullptr) : json(u.full_name)},
          {"pupil_id", u.pupil_id ? json(*u.pupil_id) : json(nullptr)}, {"active", u.active}};
}

// The most rows a page of accounts has (the API's documented limit).
constexpr int kMaxPageLimit = 1000;

// The account the path names, of the admin's own school, else 404 (another school's reads as none).
store::User school_user(Context& ctx, const Principal& p, const httplib::Request& req) {
  const auto u = ctx.db().get_user(path_id(req));
  if (!u || u->school_id != p.school_id) throw ApiError(404, "not_found", "no user " + std::string(req.matches[1]));
  return *u;
}

// A query parameter that is "true" or "false", if given.
std::optional<bool> query_bool(const httplib::Request& req, const char* key) {
  if (!req.has_param(key)) return std::nullopt;
  const std::string v = req.get_param_value(key);
  if (v == "true") return true;
  if (v == "false") return false;
  throw ApiError(400, "bad_request", std::string("'") + key + "' must be true or false");
}

// Ends or restores an account's logins: `active` false refuses its login and its tokens at once.
// An admin cannot deactivate their own account, nor the school's last active admin (the store
// decides that one, in the transaction that changes it).
void set_active(Context& ctx, const Principal& p, const httplib::Request& req, httplib::Response& res, bool active) {
  require_role(p, {Role::kAdmin});
  const store::User u = school_user(ctx, p, req);
  if (!active && u.id == p.user_id)
    throw ApiError(409, "cannot_deactivate_self", "you cannot deactivate your own account: ask another admin");
  try {
    ctx.db().batch([&] {
      if (ctx.db().set_user_active(u.id, active))
        staff_audit(ctx.db(), p, u.id, active ? "account_reactivated" : "account_deactivated", {{"username", u.username}});
    });
  } catch (const store::StoreError& e) {
    if (e.kind() != store::StoreError::kConflict) throw;
    throw ApiError(409, "last_admin", "this is the school's last active admin: make another admin first");
  }
  send_json(res, 200, user_json(*ctx.db().get_user(u.id)));
}

}  // namespace

void account_routes(Routes& svr, Context& ctx) {
  // 503 while the store cannot write (a full or read-only disk, an unreachable database server).
  svr.Get("/api/health", guarded([&](const httplib::Request&, httplib::Response& res) {
    if (const auto problem = storage_unavailable(ctx.db()))
      return send_json(res, 503, {{"status", "storage_unavailable"}, {"reason", *problem}});
    send_json(res, 200, {{"status", "ok"}, {"schema_version", ctx.db().schema_version()}});
  }));

  svr.Post("/api/login", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const json b = body_json(req);
    const std::string username = field<std::string>(b, "username"), password = field<std::string>(b, "password");
    // Let in (and counted) before the password is checked, so that a locked-out guesser learns
    // nothing from it and parallel guesses cannot pass the limit; a failure unless it succeeds.
    auto attempt = ctx.logins->attempt(ctx.db(), throttle_key(username), req.remote_addr);
    if (const int wait_s = attempt.retry_after_s()) {
      res.set_header("Retry-After", std::to_string(wait_s));
      throw ApiError(429, "too_many_attempts",
                     "too many failed logins for this user or from this address: try again in " + std::to_string(wait_s) + " s");
    }
    const auto user = ctx.db().find_user(username);
    if (!ctx.passwords->matches(user, password)) throw ApiError(401, "bad_credentials", "unknown user or wrong password");
    // Said only to whoever knows the password.
    if (!user->active)
      throw ApiError(403, "account_deactivated", "this account has been deactivated: ask the school's administrator");
    attempt.succeeded();
    Principal p{user->id, user->username, user->role, user->school_id, user->pupil_id, 0, user->login_generation};
    send_json(res, 200, {{"token", ctx.tokens->issue(ctx.db(), p)}, {"role", store::role_name(user->role)}, {"user_id", user->id},
                         {"expires_in_s", ctx.tokens->ttl()}, {"pupil_id", user->pupil_id ? json(*user->pupil_id) : json(nullptr)},
                         {"language", language_of(ctx, p)}});
  }));

  // Ends a login before its time: the token is forgotten at once, on every server sharing the store.
  svr.Post("/api/logout", guarded([&](const httplib::Request& req, httplib::Response& res) {
    authenticate(ctx, req);
    ctx.tokens->revoke(ctx.db(), req.get_header_value("Authorization").substr(7));
    send_json(res, 200, {{"status", "logged out"}});
  }));

  svr.Post("/api/users", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin});
    const json b = body_json(req);
    const auto role = store::parse_role(field<std::string>(b, "role"));
    if (!role) throw ApiError(400, "bad_request", "'role' must be admin, instructor, examiner or pupil");
    const std::string username = username_field(b);
    const std::string hash = ctx.passwords->new_hash(b);
    std::optional<int64_t> pupil;
    if (*role == Role::kPupil) pupil = visible_pupil(ctx, p, field<int64_t>(b, "pupil_id")).id;
    const std::string full_name = full_name_field(b);
    int64_t id = 0;
    ctx.db().batch([&] {
      id = ctx.db().create_user(username, hash, *role, p.school_id, pupil, full_name);
      if (pupil) audit(ctx.db(), p, *pupil, "login_created", {{"user_id", id}, {"username", username}});
      staff_audit(ctx.db(), p, id, "account_created",
                  {{"username", username}, {"role", store::role_name(*role)}, {"full_name", full_name}});
    });
    res.set_header("Location", "/api/users/" + std::to_string(id));
    send_json(res, 201, {{"id", id}});
  }));

  // An account as certificates name it, {"full_name"}, and the language its person reads in,
  // {"language"} (admin, own school; a member of staff may change their own language). Staff
  // accounts made before full names were kept have none, and a certificate naming them cannot be
  // issued until they do. A pupil's login reads its pupil record's language (PATCH /api/pupils/{id}).
  svr.Patch(R"(/api/users/(\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const json b = body_json(req);  // UserEdit
    const std::optional<std::string> lang = language_field(ctx, b);
    const bool own_language = lang && b.size() == 1 && p.user_id == path_id(req) && !p.pupil_id;
    if (!own_language) require_role(p, {Role::kAdmin});
    const auto u = ctx.db().get_user(path_id(req));
    if (!u || u->school_id != p.school_id) throw ApiError(404, "not_found", "no user " + std::string(req.matches[1]));
    const std::string name = full_name_field(b);
    if (name.empty() && !lang) throw ApiError(400, "bad_request", "'full_name' or 'language' is required");
    if (lang && u->pupil_id) throw ApiError(400, "bad_request", "a pupil's login reads in its pupil record's language: change that instead");
    ctx.db().batch([&] {
      if (!name.empty()) {
        ctx.db().set_user_full_name(u->id, name);
        staff_audit(ctx.db(), p, u->id, "full_name_changed", {{"before", u->full_name}, {"after", name}});
      }
      if (lang) ctx.db().set_user_language(u->id, *lang);
    });
    json j = user_json(*ctx.db().get_user(u->id));
    j["language"] = ctx.db().user_language(u->id);
    send_json(res, 200, j);
  }));

  // The school's accounts by full name (admin): staff, and pupils' logins when asked
  // (include_pupils=true, or role=pupil); of one role, active or not; paged with the total.
  svr.Get("/api/users", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin});
    store::UserFilter f;
    f.school_id = p.school_id;
    if (req.has_param("role")) {
      f.role = store::parse_role(req.get_param_value("role"));
      if (!f.role) throw ApiError(400, "bad_request", "'role' must be admin, instructor, examiner or pupil");
    }
    f.active = query_bool(req, "active");
    f.include_pupils = query_bool(req, "include_pupils").value_or(false) || f.role == Role::kPupil;
    const int limit = query_int(req, "limit", 100, 1 << 30), offset = query_int(req, "offset", 0, 1 << 30);
    if (limit > kMaxPageLimit)
      throw ApiError(400, "bad_request", "'limit' must be at most " + std::to_string(kMaxPageLimit));
    const store::UserPage page = ctx.db().list_users(f, limit, offset);
    json users = json::array();
    for (const auto& u : page.users) users.push_back(user_json(u));
    send_json(res, 200, {{"users", users}, {"total", page.total}, {"limit", limit}, {"offset", offset}});
  }));

  // A new password for an account (admin): {"password"}. The account's logins end at once.
  svr.Post(R"(/api/users/(\d+)/password)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin});
    const store::User u = school_user(ctx, p, req);
    const json b = body_json(req);  // the password alone (PasswordReset)
    const std::string hash = ctx.passwords->new_hash(b);
    ctx.db().batch([&] {
      ctx.db().set_user_password(u.id, hash);
      staff_audit(ctx.db(), p, u.id, "password_reset", {{"username", u.username}});
    });
    send_json(res, 200, user_json(*ctx.db().get_user(u.id)));
  }));

  svr.Post(R"(/api/users/(\d+)/deactivate)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    set_active(ctx, authenticate(ctx, req), req, res, false);
  }));
  svr.Post(R"(/api/users/(\d+)/reactivate)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    set_active(ctx, authenticate(ctx, req), req, res, true);
  }));

  // The staff audit log (admin): one account's rows, or the school's, newest first.
  svr.Get(R"(/api/users/(\d+)/audit)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin});
    const store::User u = school_user(ctx, p, req);
    send_json(res, 200, staff_audit_page(ctx.db(), p.school_id, u.id, req));
  }));
  svr.Get("/api/staff-audit", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin});
    send_json(res, 200, staff_audit_page(ctx.db(), p.school_id, std::nullopt, req));
  }));

  svr.Get(R"(/api/users/(\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const auto u = ctx.db().get_user(path_id(req));
    if (!u || u->school_id != p.school_id || (p.role != Role::kAdmin && p.user_id != u->id))
      throw ApiError(404, "not_found", "no user " + std::string(req.matches[1]));
    json j = user_json(*u);
    j["language"] = u->pupil_id ? ctx.db().pupil_language(*u->pupil_id) : ctx.db().user_language(u->id);
    send_json(res, 200, j);
  }));
}

}  // namespace forklift::server
