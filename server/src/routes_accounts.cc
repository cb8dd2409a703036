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
          {"pupil_id", u.pupil_id ? json(*u.pupil_id) : json(nullptr)}};
}

}  // namespace

void account_routes(httplib::Server& svr, Context& ctx) {
  svr.Get("/api/health", guarded([&](const httplib::Request&, httplib::Response& res) {
    send_json(res, 200, {{"status", "ok"}, {"schema_version", ctx.db().schema_version()}});
  }));

  svr.Post("/api/login", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const json b = body_json(req);
    const std::string username = field<std::string>(b, "username"), password = field<std::string>(b, "password");
    // Let in (and counted) before the password is checked, so that a locked-out guesser learns
    // nothing from it and parallel guesses cannot pass the limit; a failure unless it succeeds.
    auto attempt = ctx.logins->attempt(throttle_key(username), req.remote_addr);
    if (const int wait_s = attempt.retry_after_s()) {
      res.set_header("Retry-After", std::to_string(wait_s));
      throw ApiError(429, "too_many_attempts",
                     "too many failed logins for this user or from this address: try again in " + std::to_string(wait_s) + " s");
    }
    const auto user = ctx.db().find_user(username);
    if (!password_matches(user, password)) throw ApiError(401, "bad_credentials", "unknown user or wrong password");
    attempt.succeeded();
    Principal p{user->id, user->username, user->role, user->school_id, user->pupil_id, {}};
    send_json(res, 200, {{"token", ctx.tokens->issue(p)}, {"role", store::role_name(user->role)}, {"user_id", user->id},
                         {"expires_in_s", ctx.tokens->ttl()}, {"pupil_id", user->pupil_id ? json(*user->pupil_id) : json(nullptr)}});
  }));

  // Ends a login before its time: the token is forgotten at once.
  svr.Post("/api/logout", guarded([&](const httplib::Request& req, httplib::Response& res) {
    authenticate(ctx, req);
    ctx.tokens->revoke(req.get_header_value("Authorization").substr(7));
    send_json(res, 200, {{"status", "logged out"}});
  }));

  svr.Post("/api/users", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin});
    const json b = body_json(req);
    const auto role = store::parse_role(field<std::string>(b, "role"));
    if (!role) throw ApiError(400, "bad_request", "'role' must be admin, instructor, examiner or pupil");
    const std::string username = username_field(b);
    const std::string hash = new_password_hash(b);
    std::optional<int64_t> pupil;
    if (*role == Role::kPupil) pupil = visible_pupil(ctx, p, field<int64_t>(b, "pupil_id")).id;
    const std::string full_name = full_name_field(b);
    int64_t id = 0;
    ctx.db().batch([&] {
      id = ctx.db().create_user(username, hash, *role, p.school_id, pupil, full_name);
      if (pupil) audit(ctx.db(), p, *pupil, "login_created", {{"user_id", id}, {"username", username}});
    });
    send_json(res, 201, {{"id", id}});
  }));

  // An account as certificates name it: {"full_name"} (admin, own school). Staff accounts made
  // before full names were kept have none, and a certificate naming them cannot be issued until
  // they do.
  svr.Patch(R"(/api/users/(\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin});
    const auto u = ctx.db().get_user(path_id(req));
    if (!u || u->school_id != p.school_id) throw ApiError(404, "not_found", "no user " + std::string(req.matches[1]));
    const json b = body_json(req);
    for (const auto& [key, value] : b.items())
      if (key != "full_name") throw ApiError(400, "bad_request", "'" + key + "' cannot be edited: only full_name");
    const std::string name = full_name_field(b);
    if (name.empty()) throw ApiError(400, "bad_request", "'full_name' is required");
    ctx.db().set_user_full_name(u->id, name);
    send_json(res, 200, user_json(*ctx.db().get_user(u->id)));
  }));

  svr.Get(R"(/api/users/(\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const auto u = ctx.db().get_user(path_id(req));
    if (!u || u->school_id != p.school_id || (p.role != Role::kAdmin && p.user_id != u->id))
      throw ApiError(404, "not_found", "no user " + std::string(req.matches[1]));
    send_json(res, 200, user_json(*u));
  }));
}

}  // namespace forklift::server
