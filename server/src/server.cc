// The server's state and routes as a library (forklift/server/server.h).
#include "forklift/server/server.h"

#include <httplib.h>
#include <sodium.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "api.h"
#include "context.h"
#include "contract.h"
#include "forklift/server/listener.h"
#include "routes.h"

namespace forklift::server {

std::string machine_name() {
  char name[256] = {};
  if (gethostname(name, sizeof name - 1) != 0 || name[0] == '\0') return "localhost";
  return name;
}

namespace {

// Unless given, an address may fail this many times as many logins as one username: the cab
// stations of a school often reach the server through one address.
constexpr int kAddressAttemptsPerUserAttempt = 4;

// Every answer, pages and API alike: no sniffing, no framing, no referrer, and pages may load
// scripts, styles and data only from this server (no inline script, so an injected tag runs
// nothing); images also from blob: URLs (event stills fetched with the token).
const char* const kContentSecurityPolicy =
    "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' blob: data:; connect-src 'self'; "
    "base-uri 'none'; form-action 'self'; frame-ancestors 'none'";

void security_headers(const httplib::Request& req, httplib::Response& res) {
  // RFC 9110: a 401 names the scheme that would let the client in.
  if (res.status == 401 && !res.has_header("WWW-Authenticate")) res.set_header("WWW-Authenticate", "Bearer realm=\"forklift\"");
  res.set_header("X-Content-Type-Options", "nosniff");
  res.set_header("Content-Security-Policy", kContentSecurityPolicy);
  res.set_header("Referrer-Policy", "no-referrer");
  res.set_header("X-Frame-Options", "DENY");
  if (!res.has_header("Cache-Control")) res.set_header("Cache-Control", req.path.rfind("/api/", 0) == 0 ? "no-store" : "no-cache");
}

// The name certificates print: the configured one, else the security folder's school (as its CA
// was made for), else the database's.
std::string certificate_school_name(const ServerConfig& c, store::Store& db) {
  if (!c.school_name.empty()) return c.school_name;
  if (!c.security_dir.empty()) {
    std::ifstream in(c.security_dir + "/school");
    std::string name;
    if (std::getline(in, name) && !name.empty()) return name;
  }
  const auto admin = db.find_user("admin");
  const auto school = admin ? db.get_school(admin->school_id) : std::nullopt;
  return school ? school->name : "Default school";
}

std::string random_password() {
  unsigned char raw[9];
  randombytes_buf(raw, sizeof raw);
  char b64[32];
  sodium_bin2base64(b64, sizeof b64, raw, sizeof raw, sodium_base64_VARIANT_URLSAFE_NO_PADDING);
  return b64;
}

}  // namespace

void Routes::add(const char* method, const std::string& pattern) {
  routes_.push_back({method, pattern});
  patterns_.emplace_back(pattern);  // httplib matches the whole path against it, as here
}

std::string Routes::allowed(const std::string& path) const {
  std::string out;
  for (size_t i = 0; i < routes_.size(); ++i)
    if (std::regex_match(path, patterns_[i]) && out.find(routes_[i].method) == std::string::npos)
      out += (out.empty() ? "" : ", ") + routes_[i].method;
  return out;
}

std::vector<RouteInfo> documented_operations() {
  std::vector<RouteInfo> out;
  for (const auto& o : api_contract().operations()) out.push_back({o.method, o.path, o.operation_id});
  return out;
}

Api::Api(ServerConfig c) : ctx_(std::make_unique<Context>()), contract_(&api_contract()) {
  if (sodium_init() < 0) throw std::runtime_error("libsodium failed to initialise");
  if (c.log_dir.empty()) c.log_dir = store::is_postgresql_location(c.db_path) ? "forklift.logs" : c.db_path + ".logs";
  std::filesystem::create_directories(c.log_dir);
  log_dir_ = c.log_dir;

  Context& ctx = *ctx_;
  ctx.db_path = c.db_path;
  ctx.data_dir = c.data_dir;
  ctx.tokens = std::make_unique<Tokens>(c.token_ttl_s);
  ctx.passwords = std::make_unique<Passwords>(c.password_cost);
  if (c.password_cost == PasswordCost::kTest)
    spdlog::warn("passwords are hashed at the 'test' cost, which protects them next to nothing: for tests and demonstrations only");
  const int address_attempts = c.login_address_attempts.value_or(kAddressAttemptsPerUserAttempt * c.login_attempts);
  ctx.logins = std::make_unique<LoginThrottle>("login", LoginThrottle::Limits{c.login_attempts, address_attempts, c.login_window_s});
  // Keyed by address: an address gets as many unknown numbers as it would failed logins.
  ctx.certificate_lookups =
      std::make_unique<LoginThrottle>("certificate", LoginThrottle::Limits{address_attempts, address_attempts, c.login_window_s});
  ctx.bank = std::make_unique<QuestionBank>(load_question_bank(ctx.data_dir + "/theory/questions.json"));
  ctx.theory_policy = std::make_unique<TheoryPolicy>(
      load_theory_policy(c.theory_policy.empty() ? ctx.data_dir + "/theory/policy.json" : c.theory_policy, *ctx.bank));
  ctx.licence_rules =
      std::make_unique<LicenceRules>(load_licence_rules(c.licence_rules.empty() ? ctx.data_dir + "/licence/rules.json" : c.licence_rules));
  ctx.words = std::make_unique<i18n::Catalogue>(i18n::Catalogue::load(ctx.data_dir + "/i18n"));
  ctx.public_url = c.public_url;
  while (!ctx.public_url.empty() && ctx.public_url.back() == '/') ctx.public_url.pop_back();
  ctx.plans = std::make_unique<PlanCache>(ctx.data_dir);
  FleetConfig fc;
  fc.db_path = c.db_path;
  fc.worker_binary = c.bin_dir + "/forklift-worker";
  fc.data_dir = c.data_dir;
  fc.log_dir = c.log_dir;
  fc.chain_anchor = c.chain_anchor;
  fc.dds_domain = dds::DomainSettings::resolve(c.dds_domain, c.dds_config).domain_id;
  fc.dds_config = c.dds_config;
  fc.security_dir = c.security_dir;
  fc.identity = c.identity;
  fc.server_id = c.server_id.empty() ? machine_name() + "/" + std::to_string(getpid()) : c.server_id;
  fc.server_lease_s = c.server_lease_s;
  fc.max_workers = c.max_workers;
  fc.hang_timeout_s = c.hang_timeout_s;
  fc.frames = c.frames;
  fc.local_workers = c.local_workers;
  fc.realtime_workers = c.realtime_workers;
  fc.trust_clear_hosts = c.trust_clear_hosts;
  ctx.fleet = std::make_unique<Fleet>(fc);
  ctx.stills = std::make_unique<Stills>(c.bin_dir + "/forklift-render", c.log_dir + "/stills", ctx.data_dir);
  ctx.replays = std::make_unique<Replays>(c.bin_dir + "/forklift-sim", c.log_dir + "/replays");
  // A new database gets the default school and its administrator; last, so that a start that
  // fails leaves no admin whose made-up password nobody was shown.
  if (!ctx.db().find_user("admin")) {
    std::string password = c.admin_password;
    if (password.empty()) password = generated_admin_password_ = random_password();
    const int64_t school = ctx.db().create_school("Default school");
    ctx.db().create_user("admin", ctx.passwords->hash(password), store::Role::kAdmin, school);
  }
  ctx.school_name = certificate_school_name(c, ctx.db());
  // A paper's time limit holds without anyone asking: the clock ends papers nobody hands in.
  ctx.theory_clock = std::make_unique<Periodic>(std::chrono::seconds(1), [&ctx] { end_overdue_papers(ctx); });
}

Api::~Api() = default;

int Api::dds_domain() const { return ctx_->fleet->config().dds_domain; }

void Api::mount(httplib::Server& svr) {
  svr.set_payload_max_length(kMaxBodyBytes);  // no request of this API needs more (a Listener bounds any framing)
  // Headers and body go out as separate writes; without this, Nagle and delayed ACKs hold each
  // keep-alive answer for 40 ms.
  svr.set_tcp_nodelay(true);
  // A browser or a client keeps its connection for many requests (httplib's default closes it
  // after 5, and a new connection costs an accept and a thread hand-over; nginx allows 1,000),
  // for at most 5 s (the listener's kKeepAliveFor); an idle one ends after the keep-alive timeout.
  svr.set_keep_alive_max_count(kKeepAliveRequests);
  svr.set_exception_handler(answer_exception);
  auto routes = std::make_shared<Routes>(svr);
  svr.set_error_handler([routes](const httplib::Request& req, httplib::Response& res) {
    if (const Refusal* r = request_refusal()) {
      res.set_header("Connection", "close");  // the listener closes it after the answer
      return send_error(res, r->status, r->code, r->message);
    }
    if (!res.body.empty()) return;
    if (res.status == 413 || req.body.size() > kMaxBodyBytes) return send_error(res, 413, kBodyTooLarge.code, kBodyTooLarge.message);
    if (res.status == 404) {
      if (const std::string allow = routes->allowed(req.path); !allow.empty()) {
        res.set_header("Allow", allow);
        return send_error(res, 405, "method_not_allowed", "this address does not take " + req.method + ", only " + allow);
      }
    }
    const int s = res.status;
    send_error(res, s, s == 404 ? "not_found" : s == 400 ? "bad_request" : "error",
               s == 404 ? "no such endpoint" : s == 400 ? "the request is malformed or was cut short" : "request refused");
  });
  // Every request's query parameters are checked against server/openapi.yaml before its handler
  // (its body, which httplib reads after this, by body_json). A request that needs a login and has
  // none that holds goes on unchecked, so that its handler answers 401 first.
  svr.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    const Operation* op = contract_->find(req.method, req.path);
    if (!op) return httplib::Server::HandlerResponse::Unhandled;
    if (op->secured) {
      const std::string h = req.get_header_value("Authorization");
      if (h.rfind("Bearer ", 0) != 0 || !ctx_->tokens->check(ctx_->db(), h.substr(7)).principal) return httplib::Server::HandlerResponse::Unhandled;
    }
    try {
      contract_->check_query(*op, req);
      return httplib::Server::HandlerResponse::Unhandled;
    } catch (const ApiError& e) {
      send_error(res, e.status, e.code, e.what());
      return httplib::Server::HandlerResponse::Handled;
    }
  });
  account_routes(*routes, *ctx_);
  pupil_routes(*routes, *ctx_);
  catalogue_routes(*routes, *ctx_);
  session_routes(*routes, *ctx_);
  debrief_routes(*routes, *ctx_);
  theory_routes(*routes, *ctx_);
  exam_routes(*routes, *ctx_);
  list_routes(*routes, *ctx_);
  routes_.clear();
  for (const auto& r : routes->all()) routes_.push_back({r.method, r.pattern, ""});
  svr.set_post_routing_handler(security_headers);
}

}  // namespace forklift::server
