// forklift-server: the paper's Menu Structure as an HTTP/JSON API (server/openapi.yaml) over the
// trainee store, and the supervisor of one sim worker per cab session.
#include <httplib.h>
#include <sodium.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>
#include <regex>

#include "fleet.h"

using namespace forklift;
using nlohmann::json;
using store::Role;

namespace {

// ---------------------------------------------------------------- errors
struct ApiError : std::runtime_error {
  int status;
  std::string code;
  ApiError(int s, std::string c, const std::string& m) : std::runtime_error(m), status(s), code(std::move(c)) {}
};

void send_json(httplib::Response& res, int status, const json& body) {
  res.status = status;
  res.set_content(body.dump(), "application/json");
}

void send_error(httplib::Response& res, int status, const std::string& code, const std::string& message) {
  send_json(res, status, {{"error", {{"code", code}, {"message", message}}}});
}

// ---------------------------------------------------------------- auth
struct Principal {
  int64_t user_id = 0;
  std::string username;
  Role role = Role::kPupil;
  int64_t school_id = 0;
  std::optional<int64_t> pupil_id;
  std::chrono::steady_clock::time_point expires;
};

class Tokens {
 public:
  explicit Tokens(double ttl_s) : ttl_(ttl_s) {}
  std::string issue(const Principal& p) {
    unsigned char raw[32];
    randombytes_buf(raw, sizeof raw);
    char hex[65];
    sodium_bin2hex(hex, sizeof hex, raw, sizeof raw);
    Principal q = p;
    q.expires = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(ttl_));
    std::lock_guard<std::mutex> lock(mu_);
    tokens_[hex] = q;
    return hex;
  }
  std::optional<Principal> check(const std::string& token) {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = tokens_.find(token);
    if (it == tokens_.end()) return std::nullopt;
    if (std::chrono::steady_clock::now() > it->second.expires) { tokens_.erase(it); return std::nullopt; }
    return it->second;
  }
  double ttl() const { return ttl_; }

 private:
  double ttl_;
  std::mutex mu_;
  std::map<std::string, Principal> tokens_;
};

// Argon2id, libsodium's interactive limits: memory-hard, about 0.1 s per hash here.
std::string hash_password(const std::string& pw) {
  char out[crypto_pwhash_STRBYTES];
  if (crypto_pwhash_str(out, pw.c_str(), pw.size(), crypto_pwhash_OPSLIMIT_INTERACTIVE, crypto_pwhash_MEMLIMIT_INTERACTIVE) != 0)
    throw std::runtime_error("out of memory hashing a password");
  return out;
}
bool verify_password(const std::string& hash, const std::string& pw) {
  return crypto_pwhash_str_verify(hash.c_str(), pw.c_str(), pw.size()) == 0;
}

// ---------------------------------------------------------------- context
struct Context {
  std::string db_path, data_dir;
  std::unique_ptr<Tokens> tokens;
  std::unique_ptr<server::Fleet> fleet;

  // One store connection per HTTP thread (a Store is used from one thread at a time).
  store::Store& db() {
    thread_local std::unique_ptr<store::Store> s;
    thread_local std::string path;
    if (!s || path != db_path) { s = store::Store::open_sqlite(db_path); path = db_path; }
    return *s;
  }
};

Principal authenticate(Context& ctx, const httplib::Request& req) {
  const std::string h = req.get_header_value("Authorization");
  if (h.rfind("Bearer ", 0) != 0) throw ApiError(401, "unauthenticated", "log in first: Authorization: Bearer <token>");
  const auto p = ctx.tokens->check(h.substr(7));
  if (!p) throw ApiError(401, "unauthenticated", "the token is unknown or has expired: log in again");
  return *p;
}

void require_role(const Principal& p, std::initializer_list<Role> roles) {
  for (Role r : roles) if (p.role == r) return;
  throw ApiError(403, "forbidden", std::string("a ") + store::role_name(p.role) + " may not do this");
}

// A pupil sees only their own records; staff only their school's.
store::Pupil visible_pupil(Context& ctx, const Principal& p, int64_t id) {
  const auto pupil = ctx.db().get_pupil(id);
  if (!pupil) throw ApiError(404, "not_found", "no pupil " + std::to_string(id));
  if (p.role == Role::kPupil && p.pupil_id != id) throw ApiError(403, "forbidden", "a pupil may see only their own records");
  if (p.role != Role::kPupil && pupil->school_id != p.school_id) throw ApiError(404, "not_found", "no pupil " + std::to_string(id));
  return *pupil;
}

json body_json(const httplib::Request& req) {
  if (req.body.empty()) throw ApiError(400, "bad_request", "a JSON body is required");
  try {
    json j = json::parse(req.body);
    if (!j.is_object()) throw ApiError(400, "bad_request", "the body must be a JSON object");
    return j;
  } catch (const json::parse_error& e) {
    throw ApiError(400, "bad_json", std::string("the body is not valid JSON: ") + e.what());
  }
}

template <typename T>
T field(const json& j, const char* key, std::optional<T> fallback = std::nullopt) {
  if (!j.contains(key) || j[key].is_null()) {
    if (fallback) return *fallback;
    throw ApiError(400, "bad_request", std::string("'") + key + "' is required");
  }
  try {
    return j[key].get<T>();
  } catch (const json::exception&) {
    throw ApiError(400, "bad_request", std::string("'") + key + "' has the wrong type");
  }
}

int64_t path_id(const httplib::Request& req, int i = 1) {
  try {
    return std::stoll(req.matches[i]);
  } catch (const std::exception&) {
    throw ApiError(404, "not_found", "no such id");
  }
}

json pupil_json(const store::Pupil& p) {
  return {{"id", p.id}, {"name", p.name}, {"email", p.email}, {"created_at", p.created_at}};
}

json session_json(const store::Session& s) {
  json j = {{"id", s.public_id}, {"pupil_id", s.pupil_id}, {"cab_id", s.cab_id}, {"scenario", s.scenario},
            {"mode", s.mode}, {"state", s.state}, {"reason", s.reason}, {"created_at", s.created_at},
            {"ended_at", s.ended_at}, {"mark", s.mark ? json(*s.mark) : json(nullptr)},
            {"passed", s.passed ? json(*s.passed) : json(nullptr)}};
  if (s.examiner_id) j["examiner_id"] = *s.examiner_id;
  return j;
}

json event_json(const store::EventRecord& e) {
  return {{"seq", e.seq}, {"sim_time_s", e.sim_time_s}, {"kind", e.kind}, {"worry_level", e.worry_level},
          {"x_m", e.x_m}, {"y_m", e.y_m}, {"details", e.details}};
}

// Scenarios: every JSON file under data/manoeuvres/ and data/scenarios/, by file stem.
std::map<std::string, std::string> scenarios(const std::string& data_dir) {
  std::map<std::string, std::string> out;
  for (const char* dir : {"manoeuvres", "scenarios"}) {
    const std::filesystem::path d = std::filesystem::path(data_dir) / dir;
    if (!std::filesystem::is_directory(d)) continue;
    for (const auto& f : std::filesystem::directory_iterator(d))
      if (f.path().extension() == ".json") out[f.path().stem().string()] = f.path().string();
  }
  return out;
}

std::string csv_escape(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) { if (c == '"') out += '"'; out += c; }
  return out + "\"";
}

json history_json(const store::PupilHistory& h) {
  json sessions = json::array(), exams = json::array(), marks = json::array();
  for (const auto& s : h.sessions) {
    sessions.push_back(session_json(s));
    if (s.mark) marks.push_back({{"session", s.public_id}, {"at", s.created_at}, {"mark", *s.mark}});
  }
  for (const auto& e : h.exams)
    exams.push_back({{"id", e.id}, {"kind", e.kind}, {"score", e.score}, {"passed", e.passed}, {"taken_at", e.taken_at},
                     {"session", e.session_public_id ? json(*e.session_public_id) : json(nullptr)}});
  json licence = nullptr;
  if (h.licence) licence = {{"issued_at", h.licence->issued_at}, {"reevaluation_due", h.licence->reevaluation_due}, {"issued_by", h.licence->issued_by}};
  return {{"pupil", pupil_json(h.pupil)}, {"sessions", sessions}, {"exams", exams}, {"marks", marks},
          {"faults_by_kind", h.faults_by_kind}, {"trend", h.trend ? json(*h.trend) : json(nullptr)},
          {"licence", licence}, {"reevaluation_overdue", h.reevaluation_overdue}};
}

// ---------------------------------------------------------------- routes
using Handler = std::function<void(const httplib::Request&, httplib::Response&)>;

Handler guarded(Handler h) {
  return [h](const httplib::Request& req, httplib::Response& res) {
    try {
      h(req, res);
    } catch (const ApiError& e) {
      send_error(res, e.status, e.code, e.what());
    } catch (const store::StoreError& e) {
      const int status = e.kind() == store::StoreError::kNotFound ? 404 : e.kind() == store::StoreError::kConflict ? 409
                         : e.kind() == store::StoreError::kInvalid ? 400 : 500;
      const char* code = status == 404 ? "not_found" : status == 409 ? "conflict" : status == 400 ? "bad_request" : "store_error";
      send_error(res, status, code, e.what());
    }
  };
}

void routes(httplib::Server& svr, Context& ctx) {
  svr.Get("/api/health", guarded([&](const httplib::Request&, httplib::Response& res) {
    send_json(res, 200, {{"status", "ok"}, {"schema_version", ctx.db().schema_version()}});
  }));

  svr.Post("/api/login", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const json b = body_json(req);
    const auto user = ctx.db().find_user(field<std::string>(b, "username"));
    if (!user || !verify_password(user->password_hash, field<std::string>(b, "password")))
      throw ApiError(401, "bad_credentials", "unknown user or wrong password");
    Principal p{user->id, user->username, user->role, user->school_id, user->pupil_id, {}};
    send_json(res, 200, {{"token", ctx.tokens->issue(p)}, {"role", store::role_name(user->role)},
                         {"expires_in_s", ctx.tokens->ttl()}, {"pupil_id", user->pupil_id ? json(*user->pupil_id) : json(nullptr)}});
  }));

  svr.Post("/api/users", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin});
    const json b = body_json(req);
    const auto role = store::parse_role(field<std::string>(b, "role"));
    if (!role) throw ApiError(400, "bad_request", "'role' must be admin, instructor, examiner or pupil");
    const std::string pw = field<std::string>(b, "password");
    if (pw.size() < 8) throw ApiError(400, "bad_request", "passwords have at least 8 characters");
    std::optional<int64_t> pupil;
    if (*role == Role::kPupil) pupil = visible_pupil(ctx, p, field<int64_t>(b, "pupil_id")).id;
    const int64_t id = ctx.db().create_user(field<std::string>(b, "username"), hash_password(pw), *role, p.school_id, pupil);
    send_json(res, 201, {{"id", id}});
  }));

  svr.Get("/api/pupils", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    auto num = [&](const char* k, int dflt, int hi) {
      if (!req.has_param(k)) return dflt;
      try { return std::clamp(std::stoi(req.get_param_value(k)), 0, hi); } catch (...) { throw ApiError(400, "bad_request", std::string("'") + k + "' must be a number"); }
    };
    json out = json::array();
    for (const auto& pupil : ctx.db().list_pupils(p.school_id, req.get_param_value("search"), num("limit", 100, 1000), num("offset", 0, 1 << 30)))
      out.push_back(pupil_json(pupil));
    send_json(res, 200, out);
  }));

  svr.Post("/api/pupils", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor});
    const json b = body_json(req);
    const std::string name = field<std::string>(b, "name");
    if (name.empty() || name.size() > 200) throw ApiError(400, "bad_request", "'name' must have 1-200 characters");
    const int64_t id = ctx.db().create_pupil(p.school_id, name, field<std::string>(b, "email", std::string()));
    // Optionally the pupil's own login, so they can see their records and take theory exams.
    if (b.contains("username")) {
      const std::string pw = field<std::string>(b, "password");
      if (pw.size() < 8) throw ApiError(400, "bad_request", "passwords have at least 8 characters");
      ctx.db().create_user(field<std::string>(b, "username"), hash_password(pw), Role::kPupil, p.school_id, id);
    }
    send_json(res, 201, pupil_json(*ctx.db().get_pupil(id)));
  }));

  svr.Get(R"(/api/pupils/(\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    send_json(res, 200, pupil_json(visible_pupil(ctx, p, path_id(req))));
  }));

  svr.Get(R"(/api/pupils/(\d+)/history)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Pupil pupil = visible_pupil(ctx, p, path_id(req));
    send_json(res, 200, history_json(*ctx.db().history(pupil.id, store::now_iso8601())));
  }));

  svr.Get(R"(/api/pupils/(\d+)/history\.csv)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Pupil pupil = visible_pupil(ctx, p, path_id(req));
    const auto h = ctx.db().history(pupil.id, store::now_iso8601());
    std::string csv = "record,id,date,scenario_or_kind,mode,state,mark_or_score,passed\n";
    for (const auto& s : h->sessions)
      csv += "session," + s.public_id + "," + s.created_at + "," + csv_escape(s.scenario) + "," + s.mode + "," + s.state +
             "," + (s.mark ? std::to_string(*s.mark) : "") + "," + (s.passed ? (*s.passed ? "yes" : "no") : "") + "\n";
    for (const auto& e : h->exams)
      csv += "exam," + std::to_string(e.id) + "," + e.taken_at + "," + e.kind + ",,," + std::to_string(e.score) + "," +
             (e.passed ? "yes" : "no") + "\n";
    res.set_header("Content-Disposition", "attachment; filename=\"pupil-" + std::to_string(pupil.id) + "-history.csv\"");
    res.set_content(csv, "text/csv");
  }));

  // A licence issued after the pupil passed both exams; re-evaluation falls due 3 years later.
  svr.Post(R"(/api/pupils/(\d+)/licence)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kExaminer});
    const store::Pupil pupil = visible_pupil(ctx, p, path_id(req));
    ctx.db().add_licence(pupil.id, store::now_iso8601(), p.username);
    send_json(res, 201, history_json(*ctx.db().history(pupil.id, store::now_iso8601()))["licence"]);
  }));

  svr.Get("/api/scenarios", guarded([&](const httplib::Request& req, httplib::Response& res) {
    authenticate(ctx, req);
    json out = json::array();
    for (const auto& [name, path] : scenarios(ctx.data_dir)) {
      json j = {{"name", name}};
      try {
        std::ifstream in(path);
        const json sc = json::parse(in);
        j["load"] = sc.value("load", json(nullptr));
        j["duration_s"] = sc.value("duration_s", json(nullptr));
      } catch (const std::exception&) {
        j["error"] = "unreadable";
      }
      out.push_back(j);
    }
    send_json(res, 200, out);
  }));

  svr.Get("/api/cabs", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    std::set<std::string> online;
    for (const auto& c : ctx.fleet->cabs_online()) online.insert(c.id);
    json out = json::array();
    for (const auto& c : ctx.db().list_cabs(p.school_id))
      out.push_back({{"id", c.id}, {"online", online.count(c.id) > 0}, {"busy", ctx.fleet->cab_busy(c.id)}, {"last_seen_at", c.last_seen_at}});
    send_json(res, 200, out);
  }));

  svr.Post("/api/sessions", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const json b = body_json(req);
    const store::Pupil pupil = visible_pupil(ctx, p, field<int64_t>(b, "pupil_id"));
    const std::string cab = field<std::string>(b, "cab_id");
    if (!std::regex_match(cab, std::regex("[A-Za-z0-9_-]{1,32}"))) throw ApiError(400, "bad_request", "'cab_id' must be 1-32 letters, digits, - or _");
    const std::string scenario = field<std::string>(b, "scenario");
    const auto all = scenarios(ctx.data_dir);
    const auto sc = all.find(scenario);
    if (sc == all.end()) throw ApiError(404, "not_found", "no scenario '" + scenario + "'");
    const std::string mode = field<std::string>(b, "mode", std::string("training"));
    if (mode == "exam") require_role(p, {Role::kAdmin, Role::kExaminer});
    if (ctx.fleet->cab_busy(cab)) throw ApiError(409, "cab_busy", "cab " + cab + " is already running a session");
    std::optional<double> duration;
    try {
      std::ifstream in(sc->second);
      const json j = json::parse(in);
      if (j.contains("duration_s") && j["duration_s"].is_number()) duration = j["duration_s"].get<double>();
    } catch (const std::exception&) {
      throw ApiError(500, "bad_scenario", "scenario '" + scenario + "' is unreadable");
    }
    // An instructor may shorten a session (never lengthen an exam's time limit).
    if (b.contains("time_limit_s")) {
      const double limit = field<double>(b, "time_limit_s");
      if (!(limit > 0 && limit <= 24 * 3600)) throw ApiError(400, "bad_request", "'time_limit_s' must be in (0, 86400]");
      duration = duration ? std::min(*duration, limit) : limit;
    }
    const store::Session s = ctx.db().create_session(pupil.id, cab, scenario, mode,
                                                      mode == "exam" ? std::optional<int64_t>(p.user_id) : std::nullopt,
                                                      store::now_iso8601());
    try {
      ctx.fleet->start_worker(s, sc->second, duration);
    } catch (const std::exception& e) {
      ctx.db().set_session_state(s.public_id, "failed", e.what(), store::now_iso8601());
      throw ApiError(503, "no_worker", e.what());
    }
    send_json(res, 201, session_json(*ctx.db().get_session(s.public_id)));
  }));

  auto session_for = [&](const httplib::Request& req, const Principal& p) {
    const auto s = ctx.db().get_session(req.matches[1]);
    if (!s) throw ApiError(404, "not_found", "no session " + std::string(req.matches[1]));
    visible_pupil(ctx, p, s->pupil_id);
    return *s;
  };

  svr.Get(R"(/api/sessions/(s-\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Session s = session_for(req, p);
    json j = session_json(s);
    j["events"] = json::array();
    for (const auto& e : ctx.db().list_events(s.public_id)) j["events"].push_back(event_json(e));
    if (const auto sc = ctx.db().get_score(s.public_id)) j["score"] = {{"mark", sc->mark}, {"passed", sc->passed}, {"counts", sc->counts}};
    send_json(res, 200, j);
  }));

  svr.Post(R"(/api/sessions/(s-\d+)/abort)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const store::Session s = session_for(req, p);
    if (!ctx.db().set_session_state(s.public_id, "aborted", "aborted by " + p.username, store::now_iso8601()))
      throw ApiError(409, "session_over", "session " + s.public_id + " is already " + s.state);
    ctx.fleet->abort(s.public_id);
    send_json(res, 200, session_json(*ctx.db().get_session(s.public_id)));
  }));

  svr.Get("/api/fleet", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    json workers = json::array(), cabs = json::array();
    const auto now = std::chrono::steady_clock::now();
    for (const auto& w : ctx.fleet->workers())
      workers.push_back({{"session", w.session}, {"cab", w.cab}, {"pid", w.pid}, {"sim_time_s", w.sim_time_s}, {"speed_m_s", w.speed_m_s},
                         {"seconds_since_state", w.seen_state ? json(std::chrono::duration<double>(now - w.last_state).count()) : json(nullptr)},
                         {"healthy", !w.seen_state || std::chrono::duration<double>(now - w.last_state).count() < 1.0}});
    for (const auto& c : ctx.fleet->cabs_online()) cabs.push_back({{"id", c.id}, {"mode", c.mode}});
    send_json(res, 200, {{"workers", workers}, {"cabs_online", cabs}, {"max_workers", ctx.fleet->config().max_workers}});
  }));
}

std::atomic<httplib::Server*> g_server{nullptr};
void on_signal(int) {
  if (auto* s = g_server.load()) s->stop();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"forklift-server: pupils, sessions, exams and the sim-worker fleet, over HTTP/JSON"};
  std::string db_path = "forklift.db", listen = "127.0.0.1:8080", log_dir, dds_config, admin_password;
  std::optional<int> domain;
  double token_ttl = 8 * 3600;
  int max_workers = 8;
  double hang_timeout = 5;
  app.add_option("--db", db_path, "SQLite database file (created if missing)");
  app.add_option("--listen", listen, "address:port to serve on");
  app.add_option("--dds-domain", domain, "DDS domain id (default FORKLIFT_DDS_DOMAIN or 0)")->check(CLI::Range(0, 232));
  app.add_option("--dds-config", dds_config, "Cyclone DDS configuration file")->check(CLI::ExistingFile);
  app.add_option("--log-dir", log_dir, "where workers' logs go (default: <db>.logs/)");
  app.add_option("--max-workers", max_workers, "sim workers this machine may run at once")->check(CLI::Range(1, 256));
  app.add_option("--hang-timeout", hang_timeout, "kill a worker that sends no state for this long, s")->check(CLI::Range(0.5, 600.0));
  app.add_option("--token-ttl", token_ttl, "how long a login lasts, s")->check(CLI::Range(1.0, 30.0 * 86400));
  app.add_option("--admin-password", admin_password, "password of the 'admin' account created with a new database (else FORKLIFT_ADMIN_PASSWORD, else random)");
  CLI11_PARSE(app, argc, argv);

  try {
    if (sodium_init() < 0) throw std::runtime_error("libsodium failed to initialise");
    const auto colon = listen.rfind(':');
    if (colon == std::string::npos) throw std::runtime_error("--listen must be address:port");
    const std::string host = listen.substr(0, colon);
    const int port = std::stoi(listen.substr(colon + 1));
    if (log_dir.empty()) log_dir = db_path + ".logs";
    std::filesystem::create_directories(log_dir);

    Context ctx;
    ctx.db_path = db_path;
    ctx.data_dir = FORKLIFT_DATA_DIR;
    ctx.tokens = std::make_unique<Tokens>(token_ttl);
    // A new database gets the default school and its administrator.
    if (!ctx.db().find_user("admin")) {
      if (admin_password.empty())
        if (const char* env = std::getenv("FORKLIFT_ADMIN_PASSWORD")) admin_password = env;
      if (admin_password.empty()) {
        unsigned char raw[9];
        randombytes_buf(raw, sizeof raw);
        char b64[32];
        sodium_bin2base64(b64, sizeof b64, raw, sizeof raw, sodium_base64_VARIANT_URLSAFE_NO_PADDING);
        admin_password = b64;
        std::cerr << "forklift-server: created user 'admin' with password " << admin_password << std::endl;
      }
      const int64_t school = ctx.db().create_school("Default school");
      ctx.db().create_user("admin", hash_password(admin_password), Role::kAdmin, school);
    }
    const std::filesystem::path self = std::filesystem::canonical("/proc/self/exe");
    server::FleetConfig fc;
    fc.db_path = db_path;
    fc.worker_binary = (self.parent_path() / "forklift-worker").string();
    fc.data_dir = FORKLIFT_DATA_DIR;
    fc.log_dir = log_dir;
    fc.dds_domain = dds::DomainSettings::resolve(domain, dds_config).domain_id;
    fc.dds_config = dds_config;
    fc.max_workers = max_workers;
    fc.hang_timeout_s = hang_timeout;
    ctx.fleet = std::make_unique<server::Fleet>(fc);

    httplib::Server svr;
    svr.set_payload_max_length(1 << 20);  // 1 MiB: no request of this API needs more
    // Headers and body go out as separate writes; without this, Nagle and delayed ACKs hold each
    // keep-alive answer for 40 ms.
    svr.set_tcp_nodelay(true);
    svr.set_exception_handler([](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
      std::string what = "internal error";
      try { std::rethrow_exception(ep); } catch (const std::exception& e) { what = e.what(); } catch (...) {}
      send_error(res, 500, "internal", what);
    });
    svr.set_error_handler([](const httplib::Request&, httplib::Response& res) {
      if (!res.body.empty()) return;
      const int s = res.status;
      send_error(res, s, s == 404 ? "not_found" : s == 413 ? "too_large" : "error", s == 404 ? "no such endpoint" : s == 413 ? "the body is larger than 1 MiB" : "request refused");
    });
    routes(svr, ctx);
    g_server = &svr;
    std::signal(SIGTERM, on_signal);
    std::signal(SIGINT, on_signal);
    if (!svr.bind_to_port(host, port)) throw std::runtime_error("cannot listen on " + listen);
    std::cerr << "forklift-server: listening on http://" << listen << " (db " << db_path << ", DDS domain " << fc.dds_domain << ")" << std::endl;
    svr.listen_after_bind();
    g_server = nullptr;
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "forklift-server: " << e.what() << '\n';
    return 2;
  }
}
