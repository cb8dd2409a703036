// forklift-server: the paper's Menu Structure as an HTTP/JSON API (server/openapi.yaml) over the
// trainee store, and the supervisor of one sim worker per cab session.
#include <httplib.h>
#include <sodium.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <regex>

#include "auth.h"
#include "exam_evidence.h"
#include "fleet.h"
#include "plan.h"
#include "stills.h"
#include "theory.h"

using namespace forklift;
using nlohmann::json;
using server::Principal;
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

// The options' defaults: logins and their failures.
constexpr double kDefaultTokenTtlS = 8 * 3600;
constexpr int kDefaultLoginAttempts = 5;
constexpr double kDefaultLoginWindowS = 60;
// Unless given, an address may fail this many times as many logins as one username: the cab
// stations of a school often reach the server through one address.
constexpr int kAddressAttemptsPerUserAttempt = 4;
constexpr size_t kMinPasswordLength = 8;

// ---------------------------------------------------------------- context
struct Context {
  std::string db_path, data_dir;
  std::unique_ptr<server::Tokens> tokens;
  std::unique_ptr<server::LoginThrottle> logins;
  std::unique_ptr<server::Fleet> fleet;
  std::unique_ptr<server::QuestionBank> bank;  // data/theory/questions.json, loaded at start
  std::unique_ptr<server::PlanCache> plans;
  std::unique_ptr<server::Stills> stills;

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
  const auto c = ctx.tokens->check(h.substr(7));
  if (c.expired) throw ApiError(401, "token_expired", "this login has expired: log in again");
  if (!c.principal) throw ApiError(401, "unauthenticated", "the token is unknown or was logged out: log in again");
  return *c.principal;
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

// The fields of a pupil that staff may edit, as an audit row shows them before and after.
json pupil_fields(const store::Pupil& p) { return {{"name", p.name}, {"email", p.email}}; }

void check_pupil_name(const std::string& name) {
  if (name.empty() || name.size() > 200) throw ApiError(400, "bad_request", "'name' must have 1-200 characters");
}

// The hash of the body's new "password", hashed before any write lock is taken (0.1 s).
std::string new_password_hash(const json& b) {
  const std::string pw = field<std::string>(b, "password");
  if (pw.size() < kMinPasswordLength)
    throw ApiError(400, "bad_request", "passwords have at least " + std::to_string(kMinPasswordLength) + " characters");
  return hash_password(pw);
}

// A whole-number query parameter clamped to [0, hi], or `dflt` when absent.
int query_int(const httplib::Request& req, const char* key, int dflt, int hi) {
  if (!req.has_param(key)) return dflt;
  try {
    return std::clamp(std::stoi(req.get_param_value(key)), 0, hi);
  } catch (const std::exception&) {
    throw ApiError(400, "bad_request", std::string("'") + key + "' must be a number");
  }
}

// ---------------------------------------------------------------- audit
// Writers that are not a logged-in user.
const store::Actor kServerActor{std::nullopt, "server"};

store::Actor actor_of(const Principal& p) { return {p.user_id, p.username}; }

// Records a change `p` made to a pupil's record. Call it inside the db.batch() that makes the
// change, so that the change and its row commit together or not at all.
void audit(store::Store& db, const Principal& p, int64_t pupil_id, const std::string& action, const json& details) {
  store::AuditRecord r;
  r.actor = actor_of(p);
  r.pupil_id = pupil_id;
  r.action = action;
  r.details = details.dump();
  db.add_audit(r);
}

json audit_json(const store::AuditRecord& r) {
  return {{"id", r.id}, {"at", r.at}, {"actor_user_id", r.actor.user_id ? json(*r.actor.user_id) : json(nullptr)},
          {"actor", r.actor.name}, {"pupil_id", r.pupil_id}, {"action", r.action},
          {"details", json::parse(r.details, nullptr, false)}};
}

// One page of audit rows, newest first, from the request's limit and offset.
json audit_page(store::Store& db, const store::AuditScope& scope, const httplib::Request& req) {
  json out = json::array();
  for (const auto& r : db.list_audit(scope, query_int(req, "limit", 100, 1000), query_int(req, "offset", 0, 1 << 30)))
    out.push_back(audit_json(r));
  return out;
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

// Trucks: every JSON file under data/trucks/, by file stem.
std::map<std::string, std::string> trucks(const std::string& data_dir) {
  std::map<std::string, std::string> out;
  const std::filesystem::path d = std::filesystem::path(data_dir) / "trucks";
  if (std::filesystem::is_directory(d))
    for (const auto& f : std::filesystem::directory_iterator(d))
      if (f.path().extension() == ".json") out[f.path().stem().string()] = f.path().string();
  return out;
}

json read_json_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  return json::parse(in);
}

// What the web pages and the certificate say about a truck: its file's name and rating, and its
// OSHA class from data/theory/certification.json (the truck files do not carry one).
json truck_json(const std::string& data_dir, const std::string& stem) {
  json j = {{"name", stem}, {"title", stem}, {"rated_capacity_kg", nullptr}, {"rated_load_centre_m", nullptr}, {"osha_class", nullptr}};
  try {
    const json t = read_json_file(data_dir + "/trucks/" + stem + ".json");
    j["title"] = t.value("name", stem);
    j["rated_capacity_kg"] = t.value("rated_capacity_kg", json(nullptr));
    j["rated_load_centre_m"] = t.value("rated_load_centre_m", json(nullptr));
    const json c = read_json_file(data_dir + "/theory/certification.json");
    if (c.contains("truck_classes") && c["truck_classes"].contains(stem)) j["osha_class"] = c["truck_classes"][stem];
  } catch (const std::exception&) {
    // an unreadable file leaves the defaults: the page still shows the name
  }
  return j;
}

// The truck and load a scenario (as run) sets: the truck file's stem, or null for the worker's
// default truck; the load object, or null for none.
std::pair<json, json> scenario_setup(const json& sc) {
  json truck = nullptr, load = nullptr;
  if (sc.contains("truck") && sc["truck"].is_string())
    truck = std::filesystem::path(sc["truck"].get<std::string>()).stem().string();
  if (sc.contains("load") && sc["load"].is_object()) load = sc["load"];
  return {truck, load};
}

// The scenario a session ran: the copy kept with it (with the truck and load chosen), else, for
// sessions from before copies were kept, the scenario file of that name.
json session_scenario(Context& ctx, const store::Session& s) {
  if (const auto kept = ctx.db().get_session_log(s.public_id, "scenario")) {
    json j = json::parse(*kept, nullptr, false);
    if (j.is_object()) return j;
  }
  const auto all = scenarios(ctx.data_dir);
  const auto it = all.find(s.scenario);
  if (it == all.end()) return json::object();
  try { return read_json_file(it->second); } catch (const std::exception&) { return json::object(); }
}

// The file to hand the renderer or a worker for a session: the session's own copy if the
// truck or load were changed, else the scenario file.
std::string session_scenario_file(Context& ctx, const store::Session& s) {
  const std::string own = ctx.fleet->config().log_dir + "/" + s.public_id + ".scenario.json";
  if (std::filesystem::exists(own)) return own;
  const auto all = scenarios(ctx.data_dir);
  const auto it = all.find(s.scenario);
  return it == all.end() ? std::string() : it->second;
}

std::string csv_escape(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) { if (c == '"') out += '"'; out += c; }
  return out + "\"";
}

// `examiners`: usernames of the users who examined, by id (the exam records name them).
json history_json(const store::PupilHistory& h, const std::map<int64_t, std::string>& examiners = {}) {
  json sessions = json::array(), exams = json::array(), marks = json::array();
  for (const auto& s : h.sessions) {
    sessions.push_back(session_json(s));
    if (s.mark) marks.push_back({{"session", s.public_id}, {"at", s.created_at}, {"mark", *s.mark}});
  }
  for (const auto& e : h.exams) {
    json x = {{"id", e.id}, {"kind", e.kind}, {"score", e.score}, {"passed", e.passed}, {"taken_at", e.taken_at},
              {"session", e.session_public_id ? json(*e.session_public_id) : json(nullptr)},
              {"examiner", e.examiner_id && examiners.count(*e.examiner_id) ? json(examiners.at(*e.examiner_id)) : json(nullptr)}};
    if (e.kind == "theory") {  // the paper it marked, and how many questions were right
      const json d = json::parse(e.details, nullptr, false);
      if (d.is_object()) {
        x["attempt"] = d.value("attempt", json(nullptr));
        x["correct"] = d.value("correct", json(nullptr));
        x["total"] = d.value("total", json(nullptr));
      }
    }
    exams.push_back(x);
  }
  json licence = nullptr;
  if (h.licence) licence = {{"issued_at", h.licence->issued_at}, {"reevaluation_due", h.licence->reevaluation_due}, {"issued_by", h.licence->issued_by}};
  return {{"pupil", pupil_json(h.pupil)}, {"sessions", sessions}, {"exams", exams}, {"marks", marks},
          {"faults_by_kind", h.faults_by_kind}, {"trend", h.trend ? json(*h.trend) : json(nullptr)},
          {"licence", licence}, {"reevaluation_overdue", h.reevaluation_overdue}};
}

// ---------------------------------------------------------------- theory
std::string topic_title(const server::QuestionBank& bank, const std::string& topic) {
  for (const auto& t : bank.topics)
    if (t.id == topic) return t.title;
  return topic;
}

// The question ids of a paper, in order, as the store keeps them.
std::vector<std::string> attempt_paper(const store::TheoryAttempt& a) {
  const json j = json::parse(a.questions, nullptr, false);
  if (!j.is_object() || !j.contains("ids") || !j["ids"].is_array()) throw std::runtime_error("theory attempt " + std::to_string(a.id) + " is unreadable");
  return j["ids"].get<std::vector<std::string>>();
}

// A paper as the pupil sees it: the questions and their choices, never the answers.
json paper_json(const server::QuestionBank& bank, const std::vector<std::string>& ids) {
  json out = json::array();
  for (const std::string& id : ids) {
    const server::Question* q = bank.find(id);
    if (!q) throw std::runtime_error("question '" + id + "' is no longer in the bank");
    out.push_back({{"id", q->id}, {"topic", q->topic}, {"topic_title", topic_title(bank, q->topic)}, {"text", q->text}, {"choices", q->choices}});
  }
  return out;
}

// A marked paper from its exam record: each question with the choice made, the right one and why.
json result_json(const server::QuestionBank& bank, const store::ExamRecord& e) {
  const json d = json::parse(e.details, nullptr, false);
  json items = json::array();
  if (d.is_object() && d.contains("answers"))
    for (const json& a : d["answers"]) {
      const server::Question* q = bank.find(a.value("id", ""));
      items.push_back({{"id", a.value("id", "")}, {"chosen", a.value("chosen", json(nullptr))}, {"answer", a.value("answer", json(nullptr))},
                       {"right", a.value("right", false)}, {"topic", q ? json(q->topic) : json(nullptr)},
                       {"text", q ? json(q->text) : json(nullptr)}, {"choices", q ? json(q->choices) : json(nullptr)},
                       {"explanation", q ? json(q->explanation) : json(nullptr)}, {"reference", q ? json(q->reference) : json(nullptr)}});
    }
  return {{"exam_id", e.id}, {"taken_at", e.taken_at}, {"score", e.score}, {"passed", e.passed},
          {"pass_mark", d.value("pass_mark", json(nullptr))}, {"correct", d.value("correct", json(nullptr))},
          {"total", d.value("total", json(nullptr))}, {"by_topic", d.value("by_topic", json::object())},
          {"marked_by", d.value("marked_by", json(nullptr))}, {"items", items}};
}

json attempt_json(Context& ctx, const store::TheoryAttempt& a) {
  const server::QuestionBank& bank = *ctx.bank;
  const json q = json::parse(a.questions, nullptr, false);
  json j = {{"id", a.id}, {"pupil_id", a.pupil_id}, {"seed", a.seed}, {"started_at", a.started_at},
            {"bank_version", q.is_object() ? q.value("bank_version", json(nullptr)) : json(nullptr)},
            {"pass_mark", bank.pass_mark}, {"pass_mark_why", bank.pass_mark_why},
            {"questions", paper_json(bank, attempt_paper(a))}, {"marked", a.exam_id.has_value()}, {"result", nullptr}};
  if (a.exam_id)
    if (const auto e = ctx.db().get_exam(*a.exam_id)) j["result"] = result_json(bank, *e);
  return j;
}

// A theory paper that `p` may see: its pupil's own, or one of a pupil of their school.
store::TheoryAttempt visible_attempt(Context& ctx, const Principal& p, const std::string& id_text) {
  int64_t id = 0;
  try { id = std::stoll(id_text); } catch (const std::exception&) { throw ApiError(404, "not_found", "no theory attempt " + id_text); }
  const auto a = ctx.db().get_theory_attempt(id);
  if (!a) throw ApiError(404, "not_found", "no theory attempt " + id_text);
  visible_pupil(ctx, p, a->pupil_id);
  return *a;
}

bool is_staff(const Principal& p) { return p.role != Role::kPupil; }

// The session named by the path's first match, if `p` may see it. A function, not a lambda local
// to routes(): handlers run after routes() has returned.
store::Session session_for(Context& ctx, const httplib::Request& req, const Principal& p);

// The session of the request, for staff, with what the fleet sees of it now (live follow).
std::pair<store::Session, server::LiveView> followed(Context& ctx, const httplib::Request& req) {
  const Principal p = authenticate(ctx, req);
  require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
  const store::Session s = session_for(ctx, req, p);
  const auto v = ctx.fleet->follow(s.public_id);
  if (!v) throw ApiError(409, "not_running", "session " + s.public_id + " has no running worker (" + s.state + ")");
  return {s, *v};
}

store::Session session_for(Context& ctx, const httplib::Request& req, const Principal& p) {
  const auto s = ctx.db().get_session(req.matches[1]);
  if (!s) throw ApiError(404, "not_found", "no session " + std::string(req.matches[1]));
  visible_pupil(ctx, p, s->pupil_id);
  return *s;
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
    const std::string username = field<std::string>(b, "username"), password = field<std::string>(b, "password");
    // Checked before the password, so that a locked-out guesser learns nothing from it.
    if (const int wait_s = ctx.logins->retry_after(username, req.remote_addr)) {
      res.set_header("Retry-After", std::to_string(wait_s));
      throw ApiError(429, "too_many_attempts",
                     "too many failed logins for this user or from this address: try again in " + std::to_string(wait_s) + " s");
    }
    const auto user = ctx.db().find_user(username);
    if (!user || !verify_password(user->password_hash, password)) {
      ctx.logins->failed(username, req.remote_addr);
      throw ApiError(401, "bad_credentials", "unknown user or wrong password");
    }
    ctx.logins->succeeded(username);
    Principal p{user->id, user->username, user->role, user->school_id, user->pupil_id, {}};
    send_json(res, 200, {{"token", ctx.tokens->issue(p)}, {"role", store::role_name(user->role)},
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
    const std::string username = field<std::string>(b, "username");
    const std::string hash = new_password_hash(b);
    std::optional<int64_t> pupil;
    if (*role == Role::kPupil) pupil = visible_pupil(ctx, p, field<int64_t>(b, "pupil_id")).id;
    int64_t id = 0;
    ctx.db().batch([&] {
      id = ctx.db().create_user(username, hash, *role, p.school_id, pupil);
      if (pupil) audit(ctx.db(), p, *pupil, "login_created", {{"user_id", id}, {"username", username}});
    });
    send_json(res, 201, {{"id", id}});
  }));

  svr.Get("/api/pupils", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    json out = json::array();
    for (const auto& pupil : ctx.db().list_pupils(p.school_id, req.get_param_value("search"), query_int(req, "limit", 100, 1000),
                                                  query_int(req, "offset", 0, 1 << 30)))
      out.push_back(pupil_json(pupil));
    send_json(res, 200, out);
  }));

  svr.Post("/api/pupils", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor});
    const json b = body_json(req);
    const std::string name = field<std::string>(b, "name");
    check_pupil_name(name);
    const std::string email = field<std::string>(b, "email", std::string());
    // Optionally the pupil's own login, so they can see their records and take theory exams.
    std::optional<std::string> username, hash;
    if (b.contains("username")) {
      username = field<std::string>(b, "username");
      hash = new_password_hash(b);
    }
    int64_t id = 0;
    ctx.db().batch([&] {
      id = ctx.db().create_pupil(p.school_id, name, email);
      if (username) ctx.db().create_user(*username, *hash, Role::kPupil, p.school_id, id);
      audit(ctx.db(), p, id, "pupil_created", {{"name", name}, {"email", email}, {"username", username ? json(*username) : json(nullptr)}});
    });
    send_json(res, 201, pupil_json(*ctx.db().get_pupil(id)));
  }));

  // Corrects a pupil's name or email; the audit row keeps both versions. No change, no row.
  svr.Patch(R"(/api/pupils/(\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor});
    const json b = body_json(req);
    for (const auto& [key, value] : b.items())
      if (key != "name" && key != "email") throw ApiError(400, "bad_request", "'" + key + "' cannot be edited: only name and email");
    store::Pupil after;
    ctx.db().batch([&] {  // read inside, so that the "before" recorded is the version replaced
      const store::Pupil before = visible_pupil(ctx, p, path_id(req));
      after = before;
      after.name = field<std::string>(b, "name", before.name);
      after.email = field<std::string>(b, "email", before.email);
      check_pupil_name(after.name);
      if (after.name == before.name && after.email == before.email) return;
      ctx.db().update_pupil(after.id, after.name, after.email);
      audit(ctx.db(), p, after.id, "pupil_edited", {{"before", pupil_fields(before)}, {"after", pupil_fields(after)}});
    });
    send_json(res, 200, pupil_json(after));
  }));

  // Every change to one pupil's record, newest first: staff of the pupil's school.
  svr.Get(R"(/api/pupils/(\d+)/audit)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const store::Pupil pupil = visible_pupil(ctx, p, path_id(req));
    send_json(res, 200, audit_page(ctx.db(), {pupil.id, std::nullopt}, req));
  }));

  // Every change to the records of the school's pupils, newest first: admin only.
  svr.Get("/api/audit", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin});
    send_json(res, 200, audit_page(ctx.db(), {std::nullopt, p.school_id}, req));
  }));

  svr.Get(R"(/api/pupils/(\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    send_json(res, 200, pupil_json(visible_pupil(ctx, p, path_id(req))));
  }));

  svr.Get(R"(/api/pupils/(\d+)/history)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Pupil pupil = visible_pupil(ctx, p, path_id(req));
    const store::PupilHistory h = *ctx.db().history(pupil.id, store::now_iso8601());
    std::map<int64_t, std::string> examiners;
    for (const auto& e : h.exams)
      if (e.examiner_id && !examiners.count(*e.examiner_id))
        if (const auto u = ctx.db().get_user(*e.examiner_id)) examiners[*e.examiner_id] = u->username;
    send_json(res, 200, history_json(h, examiners));
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
    json licence;
    ctx.db().batch([&] {
      ctx.db().add_licence(pupil.id, store::now_iso8601(), p.username);
      licence = history_json(*ctx.db().history(pupil.id, store::now_iso8601()))["licence"];
      audit(ctx.db(), p, pupil.id, "licence_issued", licence);
    });
    send_json(res, 201, licence);
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
        j["kind"] = path.find("/manoeuvres/") != std::string::npos ? "manoeuvre" : "scenario";
        j["description"] = sc.value("description", json(nullptr));
        j["time_limit_s"] = sc.value("time_limit_s", json(nullptr));
        j["truck"] = scenario_setup(sc).first;
      } catch (const std::exception&) {
        j["error"] = "unreadable";
      }
      out.push_back(j);
    }
    send_json(res, 200, out);
  }));

  // One scenario file as it is, and its plan (includes resolved, objects with footprints) to draw.
  svr.Get(R"(/api/scenarios/([A-Za-z0-9_-]+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    authenticate(ctx, req);
    const auto all = scenarios(ctx.data_dir);
    const auto it = all.find(req.matches[1]);
    if (it == all.end()) throw ApiError(404, "not_found", "no scenario '" + std::string(req.matches[1]) + "'");
    try {
      send_json(res, 200, read_json_file(it->second));
    } catch (const std::exception& e) {
      throw ApiError(500, "bad_scenario", e.what());
    }
  }));

  svr.Get(R"(/api/scenarios/([A-Za-z0-9_-]+)/plan)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    authenticate(ctx, req);
    const auto all = scenarios(ctx.data_dir);
    const auto it = all.find(req.matches[1]);
    if (it == all.end()) throw ApiError(404, "not_found", "no scenario '" + std::string(req.matches[1]) + "'");
    try {
      send_json(res, 200, ctx.plans->plan(it->second));
    } catch (const std::exception& e) {
      throw ApiError(500, "bad_scenario", e.what());
    }
  }));

  svr.Get("/api/trucks", guarded([&](const httplib::Request& req, httplib::Response& res) {
    authenticate(ctx, req);
    json out = json::array();
    for (const auto& [name, path] : trucks(ctx.data_dir)) out.push_back(truck_json(ctx.data_dir, name));
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
    if (mode == "exam") {
      require_role(p, {Role::kAdmin, Role::kExaminer});
      // A licence exam's result must be trusted: authenticated cab, encrypted traffic, signed log.
      if (!ctx.fleet->secure())
        throw ApiError(409, "security_required", "exams need DDS Security: start the server with --security DIR (scripts/forklift-pki.sh)");
    }
    if (ctx.fleet->cab_busy(cab)) throw ApiError(409, "cab_busy", "cab " + cab + " is already running a session");
    std::optional<double> duration;
    json run;  // the scenario as this session runs it
    try {
      run = read_json_file(sc->second);
      if (run.contains("duration_s") && run["duration_s"].is_number()) duration = run["duration_s"].get<double>();
    } catch (const std::exception&) {
      throw ApiError(500, "bad_scenario", "scenario '" + scenario + "' is unreadable");
    }
    // The truck and the load may replace the scenario's own (the paper's "characteristics of the
    // simulation environment"); the worker then runs a copy of the scenario with them.
    bool own_copy = false;
    if (b.contains("truck")) {
      const std::string truck = field<std::string>(b, "truck");
      if (!trucks(ctx.data_dir).count(truck)) throw ApiError(404, "not_found", "no truck '" + truck + "'");
      run["truck"] = "trucks/" + truck + ".json";  // relative to data/, as scenario files name it
      own_copy = true;
    }
    if (b.contains("load")) {
      const json& l = b["load"];
      if (l.is_null()) {
        run.erase("load");
      } else {
        if (!l.is_object()) throw ApiError(400, "bad_request", "'load' must be null (no load) or an object");
        // The worker's own limits (sim/scene/src/scenario.cc, forklift-sim's options), checked here
        // too so that a bad load is a 400 now rather than a failed session later.
        json load = json::object();
        for (const auto& [k, v] : l.items()) {
          if (k != "mass_kg" && k != "cog_height_m" && k != "lateral_m") throw ApiError(400, "bad_request", "'load." + k + "' is not a load field");
          if (!v.is_number()) throw ApiError(400, "bad_request", "'load." + k + "' must be a number");
          load[k] = v.get<double>();
        }
        const auto in = [&](const char* k, double lo, double hi, bool open_lo) {
          if (!load.contains(k)) return true;
          const double v = load[k].get<double>();
          return std::isfinite(v) && (open_lo ? v > lo : v >= lo) && v <= hi;
        };
        if (!load.contains("mass_kg") || !in("mass_kg", 0, 20000, true)) throw ApiError(400, "bad_request", "'load.mass_kg' must be in (0, 20000]");
        if (!in("cog_height_m", 0, 10, false)) throw ApiError(400, "bad_request", "'load.cog_height_m' must be in [0, 10]");
        if (!in("lateral_m", -2, 2, false)) throw ApiError(400, "bad_request", "'load.lateral_m' must be in [-2, 2]");
        run["load"] = load;
      }
      own_copy = true;
    }
    // An instructor may shorten a session (never lengthen an exam's time limit).
    if (b.contains("time_limit_s")) {
      const double limit = field<double>(b, "time_limit_s");
      if (!(limit > 0 && limit <= 24 * 3600)) throw ApiError(400, "bad_request", "'time_limit_s' must be in (0, 86400]");
      duration = duration ? std::min(*duration, limit) : limit;
    }
    store::Session s;
    ctx.db().batch([&] {
      s = ctx.db().create_session(pupil.id, cab, scenario, mode, mode == "exam" ? std::optional<int64_t>(p.user_id) : std::nullopt,
                                  store::now_iso8601());
      ctx.db().put_session_log(s.public_id, "scenario", run.dump(2));
      const auto [truck, load] = scenario_setup(run);
      audit(ctx.db(), p, pupil.id, "session_started",
            {{"session", s.public_id}, {"mode", mode}, {"cab", cab}, {"scenario", scenario},
             {"time_limit_s", duration ? json(*duration) : json(nullptr)}, {"truck", truck}, {"load", load}});
    });
    std::string file = sc->second;
    if (own_copy) {
      file = ctx.fleet->config().log_dir + "/" + s.public_id + ".scenario.json";
      std::ofstream(file) << run.dump(2) << '\n';
    }
    try {
      ctx.fleet->start_worker(s, file, duration);
    } catch (const std::exception& e) {
      ctx.db().set_session_state_audited(s.public_id, "failed", e.what(), store::now_iso8601(), kServerActor);
      throw ApiError(503, "no_worker", e.what());
    }
    send_json(res, 201, session_json(*ctx.db().get_session(s.public_id)));
  }));

  svr.Get(R"(/api/sessions/(s-\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Session s = session_for(ctx, req, p);
    json j = session_json(s);
    j["events"] = json::array();
    for (const auto& e : ctx.db().list_events(s.public_id)) j["events"].push_back(event_json(e));
    if (const auto sc = ctx.db().get_score(s.public_id)) j["score"] = {{"mark", sc->mark}, {"passed", sc->passed}, {"counts", sc->counts}};
    const auto [truck, load] = scenario_setup(session_scenario(ctx, s));
    j["truck"] = truck.is_null() ? json(nullptr) : truck_json(ctx.data_dir, truck.get<std::string>());
    j["load"] = load;
    j["stills_available"] = ctx.stills->available();
    send_json(res, 200, j);
  }));

  // The truck's path, about two points a second, for drawing over the warehouse plan.
  svr.Get(R"(/api/sessions/(s-\d+)/path)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Session s = session_for(ctx, req, p);
    json points = json::array();
    for (const auto& q : ctx.db().list_path(s.public_id))
      points.push_back({{"t", q.sim_time_s}, {"x_m", q.x_m}, {"y_m", q.y_m}, {"yaw_deg", q.yaw_rad * 180 / M_PI},
                        {"speed_m_s", q.speed_m_s}, {"lift_m", q.lift_m}});
    send_json(res, 200, {{"session", s.public_id}, {"interval_s", ctx.fleet->config().path_interval_s}, {"points", points}});
  }));

  // A still rendered where an event happened: the truck at the event's position, heading and fork
  // height from the path point nearest in time.
  svr.Get(R"(/api/sessions/(s-\d+)/events/(\d+)/still\.png)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Session s = session_for(ctx, req, p);
    const int64_t seq = path_id(req, 2);
    std::optional<store::EventRecord> event;
    for (const auto& e : ctx.db().list_events(s.public_id))
      if (e.seq == seq) event = e;
    if (!event) throw ApiError(404, "not_found", "session " + s.public_id + " has no event " + std::to_string(seq));
    if (!ctx.stills->available()) throw ApiError(503, "no_renderer", "stills need forklift-render, which has not been built");
    server::StillRequest r;
    r.key = s.public_id + "-e" + std::to_string(seq);
    r.scenario_file = session_scenario_file(ctx, s);
    if (r.scenario_file.empty()) throw ApiError(404, "not_found", "scenario '" + s.scenario + "' is gone");
    r.x_m = event->x_m;
    r.y_m = event->y_m;
    double best = std::numeric_limits<double>::infinity();
    for (const auto& q : ctx.db().list_path(s.public_id))
      if (std::abs(q.sim_time_s - event->sim_time_s) < best) {
        best = std::abs(q.sim_time_s - event->sim_time_s);
        r.yaw_deg = q.yaw_rad * 180 / M_PI;
        r.fork_height_m = std::max(0.0, q.lift_m);
      }
    try {
      res.set_content(ctx.stills->png(r), "image/png");
      res.set_header("Cache-Control", "private, max-age=86400");
    } catch (const std::runtime_error& e) {
      throw ApiError(500, "render_failed", e.what());
    }
  }));

  svr.Post(R"(/api/sessions/(s-\d+)/abort)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const store::Session s = session_for(ctx, req, p);
    if (!ctx.db().set_session_state_audited(s.public_id, "aborted", "aborted by " + p.username, store::now_iso8601(), actor_of(p)))
      throw ApiError(409, "session_over", "session " + s.public_id + " is already " + s.state);
    ctx.fleet->abort(s.public_id);
    send_json(res, 200, session_json(*ctx.db().get_session(s.public_id)));
  }));

  // Live follow (the remote examiner): the newest truck state, and whether a frame is there to
  // fetch from /live/frame.jpg. Asking keeps the server subscribed to the cab's frames.
  svr.Get(R"(/api/sessions/(s-\d+)/live)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const auto [s, v] = followed(ctx, req);
    json state = nullptr;
    if (v.have_state) {
      const fk_TruckState& t = v.state;
      state = {{"sim_time_s", t.sim_time_s}, {"x_m", t.x_m}, {"y_m", t.y_m}, {"yaw_deg", t.yaw_rad * 180 / M_PI},
               {"speed_m_s", t.speed_m_s}, {"lift_m", t.lift_m}, {"tilt_deg", t.tilt_rad * 180 / M_PI},
               {"load_attached", t.load_attached}, {"load_mass_kg", t.load_mass_kg}, {"stability_margin", t.stability_margin},
               {"deadman", t.deadman}, {"applied_control_sequence", t.applied_control_sequence}};
    }
    send_json(res, 200, {{"session", s.public_id}, {"state", state}, {"frame_available", !v.jpeg.empty()},
                         {"frame_seq", v.frame_seq}, {"frame_sim_time_s", v.frame_sim_time_s}});
  }));

  svr.Get(R"(/api/sessions/(s-\d+)/live/frame\.jpg)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const auto [s, v] = followed(ctx, req);
    if (v.jpeg.empty()) throw ApiError(404, "no_frame", "no frame from cab " + s.cab_id + " yet (the worker renders none, or it is starting)");
    res.set_content(std::string(v.jpeg.begin(), v.jpeg.end()), "image/jpeg");
  }));

  // A chained exam's evidence, for `forklift-menu verify`, which checks it against the school's CA.
  svr.Get(R"(/api/sessions/(s-\d+)/evidence)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    const store::Session s = session_for(ctx, req, p);
    send_json(res, 200, server::exam_evidence(ctx.db(), s));
  }));

  svr.Get("/api/fleet", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    json workers = json::array(), cabs = json::array();
    const auto now = std::chrono::steady_clock::now();
    for (const auto& w : ctx.fleet->workers())
      workers.push_back({{"session", w.session}, {"cab", w.cab}, {"pid", w.pid}, {"sim_time_s", w.last.sim_time_s}, {"speed_m_s", w.last.speed_m_s},
                         {"seconds_since_state", w.seen_state ? json(std::chrono::duration<double>(now - w.last_state).count()) : json(nullptr)},
                         {"healthy", !w.seen_state || std::chrono::duration<double>(now - w.last_state).count() < 1.0}});
    for (const auto& c : ctx.fleet->cabs_online()) cabs.push_back({{"id", c.id}, {"mode", c.mode}});
    // Every cab, online or not, with what it runs and for whom (the fleet page).
    std::map<std::string, json> all;
    auto cab = [&](const std::string& id) -> json& {
      if (!all.count(id)) all[id] = {{"id", id}, {"online", false}, {"mode", nullptr}, {"last_seen_at", nullptr}, {"session", nullptr}};
      return all[id];
    };
    for (const auto& c : ctx.db().list_cabs(p.school_id)) cab(c.id)["last_seen_at"] = c.last_seen_at.empty() ? json(nullptr) : json(c.last_seen_at);
    for (const auto& c : ctx.fleet->cabs_online()) { cab(c.id)["online"] = true; cab(c.id)["mode"] = c.mode; }
    for (const auto& w : workers) {
      const auto s = ctx.db().get_session(w["session"].get<std::string>());
      const auto pupil = s ? ctx.db().get_pupil(s->pupil_id) : std::nullopt;
      json& c = cab(w["cab"].get<std::string>());
      if (!s || !pupil || pupil->school_id != p.school_id) { c["session"] = {{"id", nullptr}, {"other_school", true}}; continue; }
      c["session"] = {{"id", s->public_id}, {"pupil_id", pupil->id}, {"pupil_name", pupil->name}, {"scenario", s->scenario},
                      {"mode", s->mode}, {"state", s->state}, {"created_at", s->created_at}, {"sim_time_s", w["sim_time_s"]},
                      {"speed_m_s", w["speed_m_s"]}, {"seconds_since_state", w["seconds_since_state"]}, {"healthy", w["healthy"]},
                      {"pid", w["pid"]}};
    }
    json every = json::array();
    for (auto& [id, c] : all) every.push_back(std::move(c));
    send_json(res, 200, {{"workers", workers}, {"cabs_online", cabs}, {"cabs", every}, {"max_workers", ctx.fleet->config().max_workers}});
  }));

  // ------------------------------------------------------------ theory exams
  svr.Get("/api/theory", guarded([&](const httplib::Request& req, httplib::Response& res) {
    authenticate(ctx, req);
    const server::QuestionBank& bank = *ctx.bank;
    json topics = json::array();
    for (const auto& t : bank.topics) {
      int n = 0;
      for (const auto& q : bank.questions) n += q.topic == t.id;
      topics.push_back({{"id", t.id}, {"title", t.title}, {"osha", t.osha}, {"questions", n}});
    }
    send_json(res, 200, {{"bank_version", bank.version}, {"questions_in_bank", bank.questions.size()},
                         {"questions_per_exam", bank.questions_per_exam}, {"pass_mark", bank.pass_mark},
                         {"pass_mark_why", bank.pass_mark_why}, {"topics", topics}});
  }));

  // The whole bank with its answers: for staff preparing lessons, never for pupils.
  svr.Get("/api/theory/questions", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kInstructor, Role::kExaminer});
    json out = json::array();
    for (const auto& q : ctx.bank->questions)
      out.push_back({{"id", q.id}, {"topic", q.topic}, {"text", q.text}, {"choices", q.choices}, {"answer", q.answer},
                     {"explanation", q.explanation}, {"reference", q.reference}});
    send_json(res, 200, out);
  }));

  // A new paper: a pupil asks for their own; staff ask for one of their school's pupils (and may
  // give the seed, to hand out a paper again).
  svr.Post("/api/theory/attempts", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const json b = req.body.empty() ? json::object() : body_json(req);
    int64_t pupil_id = 0;
    if (p.role == Role::kPupil) {
      if (!p.pupil_id) throw ApiError(403, "forbidden", "this login is not a pupil's record");
      pupil_id = field<int64_t>(b, "pupil_id", *p.pupil_id);
      if (b.contains("seed")) throw ApiError(403, "forbidden", "only staff choose a paper's seed");
    } else {
      pupil_id = field<int64_t>(b, "pupil_id");
    }
    const store::Pupil pupil = visible_pupil(ctx, p, pupil_id);
    int64_t seed = 0;
    if (b.contains("seed")) {
      seed = field<int64_t>(b, "seed");
      if (seed < 0 || seed >= (int64_t{1} << 53)) throw ApiError(400, "bad_request", "'seed' must be in [0, 2^53)");
    } else {
      randombytes_buf(&seed, sizeof seed);
      seed &= (int64_t{1} << 53) - 1;  // exact as a JSON number
    }
    store::TheoryAttempt a;
    a.pupil_id = pupil.id;
    a.seed = seed;
    a.questions = json{{"bank_version", ctx.bank->version}, {"ids", server::draw_paper(*ctx.bank, static_cast<uint64_t>(seed))}}.dump();
    a.started_at = store::now_iso8601();
    a.started_by = p.user_id;
    ctx.db().batch([&] {
      a.id = ctx.db().create_theory_attempt(a);
      audit(ctx.db(), p, a.pupil_id, "theory_paper_handed_out", {{"attempt", a.id}, {"seed", a.seed}, {"bank_version", ctx.bank->version}});
    });
    send_json(res, 201, attempt_json(ctx, a));
  }));

  svr.Get(R"(/api/theory/attempts/(\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    send_json(res, 200, attempt_json(ctx, visible_attempt(ctx, p, req.matches[1])));
  }));

  // Marks a paper once: {"answers": {"<question id>": <choice index>, ...}}; a question left out is
  // wrong. The result is stored as the pupil's theory exam record.
  svr.Post(R"(/api/theory/attempts/(\d+)/answers)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::TheoryAttempt a = visible_attempt(ctx, p, req.matches[1]);
    const json b = body_json(req);
    if (!b.contains("answers") || !b["answers"].is_object())
      throw ApiError(400, "bad_request", "'answers' must be an object of question id to choice index");
    std::map<std::string, int> answers;
    for (const auto& [id, v] : b["answers"].items()) {
      if (!v.is_number_integer()) throw ApiError(400, "bad_request", "the answer to '" + id + "' must be a choice index (0, 1, ...)");
      const int64_t c = v.get<int64_t>();
      if (c < 0 || c > 100) throw ApiError(400, "bad_request", "the answer to '" + id + "' is not one of its choices");
      answers[id] = static_cast<int>(c);
    }
    if (a.exam_id) throw ApiError(409, "already_marked", "theory attempt " + std::to_string(a.id) + " has been marked already");
    const std::vector<std::string> paper = attempt_paper(a);
    server::Marking m;
    try {
      m = server::mark_paper(*ctx.bank, paper, answers);
    } catch (const server::BadAnswers& e) {
      throw ApiError(400, "bad_request", e.what());
    }
    json items = json::array(), by_topic = json::object();
    for (const auto& it : m.items)
      items.push_back({{"id", it.question->id}, {"chosen", it.chosen ? json(*it.chosen) : json(nullptr)},
                       {"answer", it.question->answer}, {"right", it.right}});
    for (const auto& [topic, ct] : m.by_topic) by_topic[topic] = {{"correct", ct.first}, {"total", ct.second}};
    store::ExamRecord r;
    r.pupil_id = a.pupil_id;
    r.kind = "theory";
    r.score = m.score;
    r.passed = m.passed;
    if (is_staff(p)) r.examiner_id = p.user_id;  // marked at a supervised station
    r.taken_at = store::now_iso8601();
    r.details = json{{"attempt", a.id}, {"seed", a.seed}, {"bank_version", ctx.bank->version}, {"pass_mark", ctx.bank->pass_mark},
                     {"correct", m.correct}, {"total", m.total}, {"by_topic", by_topic}, {"answers", items},
                     {"marked_by", p.username}}.dump();
    ctx.db().batch([&] {
      r.id = ctx.db().finish_theory_attempt(a.id, r);
      audit(ctx.db(), p, a.pupil_id, "theory_marked",
            {{"attempt", a.id}, {"exam_id", r.id}, {"score", m.score}, {"passed", m.passed}, {"correct", m.correct}, {"total", m.total}});
    });
    send_json(res, 200, attempt_json(ctx, *ctx.db().get_theory_attempt(a.id)));
  }));

  // ------------------------------------------------------------ certification record
  // What the printable certificate shows, for a pupil with a passed theory exam and a passed
  // practical exam (OSHA 1910.178(l)(6): the operator, the dates of training and evaluation, and
  // who evaluated); else 409.
  svr.Get(R"(/api/pupils/(\d+)/certificate)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Pupil pupil = visible_pupil(ctx, p, path_id(req));
    const auto h = ctx.db().history(pupil.id, store::now_iso8601());
    const store::ExamRecord *theory = nullptr, *practical = nullptr;
    for (const auto& e : h->exams)  // oldest first: the latest passes win
      if (e.passed) (e.kind == "theory" ? theory : practical) = &e;
    if (!theory || !practical)
      throw ApiError(409, "not_certified", pupil.name + " has not passed " +
                     (!theory && !practical ? "the theory and the practical exams" : !theory ? "the theory exam" : "the practical exam"));
    const json td = json::parse(theory->details, nullptr, false);
    json practical_j = {{"exam_id", practical->id}, {"taken_at", practical->taken_at}, {"mark", practical->score},
                        {"session", practical->session_public_id ? json(*practical->session_public_id) : json(nullptr)},
                        {"scenario", nullptr}, {"examiner", nullptr}, {"truck", nullptr}};
    if (practical->examiner_id)
      if (const auto u = ctx.db().get_user(*practical->examiner_id)) practical_j["examiner"] = u->username;
    if (practical->session_public_id)
      if (const auto s = ctx.db().get_session(*practical->session_public_id)) {
        practical_j["scenario"] = s->scenario;
        const json truck = scenario_setup(session_scenario(ctx, *s)).first;
        if (!truck.is_null()) practical_j["truck"] = truck_json(ctx.data_dir, truck.get<std::string>());
      }
    json training = {{"sessions", 0}, {"first_at", nullptr}, {"last_at", nullptr}};
    for (const auto& s : h->sessions)
      if (s.mode == "training" && s.state == "ended") {
        if (training["first_at"].is_null()) training["first_at"] = s.created_at;
        training["last_at"] = s.created_at;
        training["sessions"] = training["sessions"].get<int>() + 1;
      }
    json licence = nullptr;
    std::string due;
    if (h->licence) {
      licence = {{"issued_at", h->licence->issued_at}, {"reevaluation_due", h->licence->reevaluation_due}, {"issued_by", h->licence->issued_by}};
      due = h->licence->reevaluation_due;
    } else {
      // OSHA 1910.178(l)(4)(iii): evaluated again at least every three years from the evaluation.
      due = store::add_years_iso8601(std::max(theory->taken_at, practical->taken_at), 3);
    }
    json statement = nullptr;
    try {
      statement = read_json_file(ctx.data_dir + "/theory/certification.json").value("statement", json(nullptr));
    } catch (const std::exception&) {
    }
    send_json(res, 200, {{"pupil", pupil_json(pupil)},
                         {"theory", {{"exam_id", theory->id}, {"taken_at", theory->taken_at}, {"score", theory->score},
                                     {"correct", td.is_object() ? td.value("correct", json(nullptr)) : json(nullptr)},
                                     {"total", td.is_object() ? td.value("total", json(nullptr)) : json(nullptr)},
                                     {"pass_mark", td.is_object() ? td.value("pass_mark", json(nullptr)) : json(nullptr)}}},
                         {"practical", practical_j}, {"training", training}, {"licence", licence},
                         {"reevaluation_due", due}, {"reevaluation_overdue", h->reevaluation_overdue},
                         {"statement", statement}, {"issued_at", store::now_iso8601()}});
  }));
}

// Every answer, pages and API alike: no sniffing, no framing, no referrer, and pages may load
// scripts, styles and data only from this server (no inline script, so an injected tag runs
// nothing); images also from blob: URLs (event stills fetched with the token).
const char* const kContentSecurityPolicy =
    "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' blob: data:; connect-src 'self'; "
    "base-uri 'none'; form-action 'self'; frame-ancestors 'none'";

void security_headers(const httplib::Request& req, httplib::Response& res) {
  res.set_header("X-Content-Type-Options", "nosniff");
  res.set_header("Content-Security-Policy", kContentSecurityPolicy);
  res.set_header("Referrer-Policy", "no-referrer");
  res.set_header("X-Frame-Options", "DENY");
  if (!res.has_header("Cache-Control")) res.set_header("Cache-Control", req.path.rfind("/api/", 0) == 0 ? "no-store" : "no-cache");
}

// Fails with a message naming the option when `path` cannot be read (httplib would only say no).
void require_readable(const std::string& option, const std::string& path) {
  std::ifstream in(path);
  char c;
  if (!in || !in.get(c)) throw std::runtime_error(option + " " + path + ": cannot read it (" + std::strerror(errno) + ")");
}

// HTTPS with the certificate and key when both are given, else plain HTTP.
std::unique_ptr<httplib::Server> make_http_server(const std::string& cert, const std::string& key) {
  if (cert.empty() != key.empty()) throw std::runtime_error("--tls-cert and --tls-key go together: give both or neither");
  if (cert.empty()) return std::make_unique<httplib::Server>();
  require_readable("--tls-cert", cert);
  require_readable("--tls-key", key);
  auto svr = std::make_unique<httplib::SSLServer>(cert.c_str(), key.c_str());
  if (!svr->is_valid())
    throw std::runtime_error("--tls-cert " + cert + " and --tls-key " + key + " are not a PEM certificate and its private key");
  return svr;
}

std::atomic<httplib::Server*> g_server{nullptr};
void on_signal(int) {
  if (auto* s = g_server.load()) s->stop();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"forklift-server: pupils, sessions, exams and the sim-worker fleet, over HTTP/JSON"};
  app.set_version_flag("--version", FORKLIFT_VERSION);
  std::string db_path = "forklift.db", listen = "127.0.0.1:8080", log_dir, dds_config, admin_password, web_dir;
  std::optional<int> domain;
  double token_ttl = kDefaultTokenTtlS;
  std::string tls_cert, tls_key, security_dir, identity = "server.main";
  server::LoginThrottle::Limits login_limits{kDefaultLoginAttempts, 0, kDefaultLoginWindowS};
  std::optional<int> login_address_attempts;
  int max_workers = 8;
  double hang_timeout = 5;
  double frame_fps = 30;
  std::string frame_size = "640x480";
  bool frame_jpeg = false;
  app.add_option("--db", db_path, "SQLite database file (created if missing)");
  app.add_option("--listen", listen, "address:port to serve on");
  app.add_option("--dds-domain", domain, "DDS domain id (default FORKLIFT_DDS_DOMAIN or 0)")->check(CLI::Range(0, 232));
  app.add_option("--dds-config", dds_config, "Cyclone DDS configuration file")->check(CLI::ExistingFile);
  app.add_option("--log-dir", log_dir, "where workers' logs go (default: <db>.logs/)");
  app.add_option("--max-workers", max_workers, "sim workers this machine may run at once")->check(CLI::Range(1, 256));
  app.add_option("--hang-timeout", hang_timeout, "kill a worker that sends no state for this long, s")->check(CLI::Range(0.5, 600.0));
  app.add_option("--frame-fps", frame_fps, "frames each worker renders for its cab per second (0: none)")->check(CLI::Range(0.0, 120.0));
  app.add_option("--frame-size", frame_size, "size of those frames, WxH");
  app.add_flag("--frame-jpeg", frame_jpeg, "send frames as JPEG (cabs on a real network) instead of raw RGB");
  app.add_option("--token-ttl", token_ttl, "how long a login lasts, s")->check(CLI::Range(1.0, 30.0 * 86400));
  app.add_option("--tls-cert", tls_cert, "serve HTTPS with this PEM certificate (chain); needs --tls-key");
  app.add_option("--tls-key", tls_key, "the PEM private key of --tls-cert");
  app.add_option("--login-attempts", login_limits.per_user, "failed logins of one username within --login-window before it is locked out for the window")
      ->check(CLI::Range(1, 1000));
  app.add_option("--login-address-attempts", login_address_attempts,
                 "failed logins from one client address within --login-window before it is locked out (default 4 x --login-attempts)")
      ->check(CLI::Range(1, 100000));
  app.add_option("--login-window", login_limits.window_s, "the window of --login-attempts, and the lockout, s")->check(CLI::Range(1.0, 86400.0));
  app.add_option("--security", security_dir, "the school's DDS Security folder (scripts/forklift-pki.sh; default FORKLIFT_SECURITY_DIR): "
                 "needed for exams")->envname("FORKLIFT_SECURITY_DIR");
  app.add_option("--identity", identity, "the server's identity in it");
  app.add_option("--admin-password", admin_password, "password of the 'admin' account created with a new database (else FORKLIFT_ADMIN_PASSWORD, else random)");
  app.add_option("--web-dir", web_dir, "the built web pages (default: web/ beside bin/ in the build tree)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help and --version: 0; bad usage: 2, as every program
  }

  try {
    if (sodium_init() < 0) throw std::runtime_error("libsodium failed to initialise");
    const std::unique_ptr<httplib::Server> svr = make_http_server(tls_cert, tls_key);  // first: a bad flag changes nothing
    login_limits.per_address = login_address_attempts.value_or(kAddressAttemptsPerUserAttempt * login_limits.per_user);
    const auto colon = listen.rfind(':');
    if (colon == std::string::npos) throw std::runtime_error("--listen must be address:port");
    const std::string host = listen.substr(0, colon);
    const int port = std::stoi(listen.substr(colon + 1));
    if (log_dir.empty()) log_dir = db_path + ".logs";
    std::filesystem::create_directories(log_dir);

    Context ctx;
    ctx.db_path = db_path;
    ctx.data_dir = FORKLIFT_DATA_DIR;
    ctx.tokens = std::make_unique<server::Tokens>(token_ttl);
    ctx.logins = std::make_unique<server::LoginThrottle>(login_limits);
    ctx.bank = std::make_unique<server::QuestionBank>(server::load_question_bank(ctx.data_dir + "/theory/questions.json"));
    ctx.plans = std::make_unique<server::PlanCache>(ctx.data_dir);
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
    fc.security_dir = security_dir;
    fc.identity = identity;
    fc.max_workers = max_workers;
    fc.hang_timeout_s = hang_timeout;
    fc.worker_args = {"--fps", std::to_string(frame_fps), "--frame-size", frame_size};
    if (frame_jpeg) fc.worker_args.push_back("--jpeg");
    ctx.fleet = std::make_unique<server::Fleet>(fc);
    ctx.stills = std::make_unique<server::Stills>((self.parent_path() / "forklift-render").string(), log_dir + "/stills", ctx.data_dir);
    if (web_dir.empty()) web_dir = (self.parent_path().parent_path() / "web").string();

    svr->set_payload_max_length(1 << 20);  // 1 MiB: no request of this API needs more
    // Headers and body go out as separate writes; without this, Nagle and delayed ACKs hold each
    // keep-alive answer for 40 ms.
    svr->set_tcp_nodelay(true);
    svr->set_exception_handler([](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
      std::string what = "internal error";
      try { std::rethrow_exception(ep); } catch (const std::exception& e) { what = e.what(); } catch (...) {}
      send_error(res, 500, "internal", what);
    });
    svr->set_error_handler([](const httplib::Request&, httplib::Response& res) {
      if (!res.body.empty()) return;
      const int s = res.status;
      send_error(res, s, s == 404 ? "not_found" : s == 413 ? "too_large" : "error", s == 404 ? "no such endpoint" : s == 413 ? "the body is larger than 1 MiB" : "request refused");
    });
    routes(*svr, ctx);
    // The web pages (menu/web/, copied with the chart library into the build's web/), at /.
    if (!std::filesystem::is_directory(web_dir) || !svr->set_mount_point("/", web_dir))
      std::cerr << "forklift-server: no web pages at " << web_dir << ": serving the API only" << std::endl;
    svr->set_post_routing_handler(security_headers);
    g_server = svr.get();
    std::signal(SIGTERM, on_signal);
    std::signal(SIGINT, on_signal);
    if (!svr->bind_to_port(host, port)) throw std::runtime_error("cannot listen on " + listen);
    std::cerr << "forklift-server: listening on " << (tls_cert.empty() ? "http://" : "https://") << listen << " (db " << db_path << ", DDS domain " << fc.dds_domain << ")" << std::endl;
    svr->listen_after_bind();
    g_server = nullptr;
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "forklift-server: " << e.what() << '\n';
    return 2;
  }
}
