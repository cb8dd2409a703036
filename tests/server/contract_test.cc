// server/openapi.yaml is the contract: every route the server registers is
// documented and every documented operation is registered (compared in-process, from the table
// Api::mount keeps); on a real forklift-server every documented operation answers (never the
// "no such endpoint" 404 nor a 405), and the server keeps the rules the document states: 405 with
// Allow, Location on 201, WWW-Authenticate on 401, limits refused rather than clamped, unknown
// fields refused on POST and PATCH alike, and errors in words without a parser's or the
// database's text.
#include <gtest/gtest.h>
#include <httplib.h>

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <string>

#include "forklift/server/server.h"
#include "support/in_process.h"
#include "support/ports.h"
#include "support/server.h"

using forklift_test::error_code;
using forklift_test::kAdminPassword;
using nlohmann::json;

namespace {

// "/api/pupils/(\d+)/history\.csv" and "/api/pupils/{id}/history.csv" both read
// "/api/pupils/{}/history.csv".
std::string registered_shape(const std::string& pattern) {
  std::string out;
  int depth = 0;
  for (size_t i = 0; i < pattern.size(); ++i) {
    const char c = pattern[i];
    if (c == '\\' && i + 1 < pattern.size()) {
      if (depth == 0) out += pattern[i + 1];
      ++i;
    } else if (c == '(') {
      if (depth++ == 0) out += "{}";
    } else if (c == ')') {
      --depth;
    } else if (depth == 0) {
      out += c;
    }
  }
  return out;
}

std::string documented_shape(const std::string& path) { return std::regex_replace(path, std::regex(R"(\{[^}]+\})"), "{}"); }

std::string message_of(const json& j) { return j.is_object() && j.contains("error") ? j["error"].value("message", "") : ""; }

// Words that belong to a parser, a validator or a database, never to an answer.
void expect_plain_words(const json& j) {
  const std::string m = message_of(j);
  EXPECT_FALSE(m.empty()) << j;
  for (const char* internal : {"parse_error", "[json.exception", "syntax error", "valijson", "Value type", "constraint", "SQLITE",
                               "sqlite", "UNIQUE", "Failed to validate", "additionalProperties"})
    EXPECT_EQ(m.find(internal), std::string::npos) << "'" << internal << "' in " << j;
}

}  // namespace

TEST(Contract, EveryRegisteredRouteIsDocumentedAndEveryDocumentedOperationRegistered) {
  forklift::server::Api api(forklift_test::in_process_config(testing::TempDir() + "/contract-routes", forklift::test::free_domain()));
  httplib::Server svr;
  api.mount(svr);

  std::map<std::string, std::string> registered;  // "GET /api/pupils/{}" -> its pattern
  for (const auto& r : api.routes()) registered[r.method + " " + registered_shape(r.path)] = r.path;
  std::map<std::string, forklift::server::RouteInfo> documented;
  std::set<std::string> operation_ids;
  for (const auto& o : forklift::server::documented_operations()) {
    documented[o.method + " " + documented_shape(o.path)] = o;
    EXPECT_TRUE(std::regex_match(o.operation_id, std::regex("[a-z]+[A-Za-z0-9]*")))
        << o.method << " " << o.path << " has no camelCase operationId in server/openapi.yaml (it has '" << o.operation_id << "')";
    EXPECT_TRUE(operation_ids.insert(o.operation_id).second) << "operationId " << o.operation_id << " is used twice";
  }
  ASSERT_GT(registered.size(), 40u);
  for (const auto& [key, pattern] : registered)
    EXPECT_TRUE(documented.count(key)) << "the server registers " << key.substr(0, key.find(' ')) << " " << pattern
                                       << " but server/openapi.yaml does not document it: add that operation under paths";
  for (const auto& [key, o] : documented)
    EXPECT_TRUE(registered.count(key)) << "server/openapi.yaml documents " << o.method << " " << o.path << " (" << o.operation_id
                                       << ") but the server registers no such route";
  EXPECT_EQ(registered.size(), documented.size());
}

TEST(Contract, EveryDocumentedOperationAnswersOnARealServer) {
  forklift_test::Server s("contract-every");
  const std::string admin = s.login("admin", kAdminPassword);
  auto [st, pupil] = s.call("POST", "/api/pupils", admin, R"({"name":"Ada Lovelace","email":"ada@example.org"})");
  ASSERT_EQ(st, 201) << pupil;
  const std::string id = std::to_string(pupil["id"].get<int64_t>());
  const json scenarios = s.call("GET", "/api/scenarios", admin).second;
  ASSERT_TRUE(scenarios.is_array() && !scenarios.empty()) << scenarios;
  const std::map<std::string, std::string> values = {{"{id}", id}, {"{name}", scenarios[0]["name"]}, {"{number}", "WS-0000-0000-0000-0000"},
                                                     {"{seq}", "0"}};

  auto ops = forklift::server::documented_operations();
  // The logout last: it ends the token the others use.
  std::stable_partition(ops.begin(), ops.end(), [](const auto& o) { return o.operation_id != "logOut"; });
  int asked = 0;
  for (const auto& o : ops) {
    std::string path = o.path;
    for (const auto& [param, value] : values)
      for (size_t at; (at = path.find(param)) != std::string::npos;) path.replace(at, param.size(), value);
    if (path.rfind("/api/sessions/", 0) == 0) path = std::regex_replace(path, std::regex("^/api/sessions/[^/]+"), "/api/sessions/s-000001");
    if (path.find("/api/theory/images/") == 0) path = "/api/theory/images/none.svg";
    auto c = s.client();
    httplib::Headers h = {{"Authorization", "Bearer " + admin}};
    httplib::Result r = o.method == "GET"     ? c.Get(path, h)
                        : o.method == "PATCH" ? c.Patch(path, h, "{}", "application/json")
                        : o.method == "POST"  ? c.Post(path, h, "{}", "application/json")
                        : o.method == "PUT"   ? c.Put(path, h, "{}", "application/json")
                                              : c.Delete(path, h);
    ASSERT_TRUE(r) << o.method << " " << path;
    json j;
    try { j = json::parse(r->body); } catch (...) {}
    EXPECT_NE(r->status, 405) << o.operation_id << ": " << o.method << " " << path << " " << r->body;
    EXPECT_FALSE(r->status == 404 && message_of(j) == "no such endpoint") << o.operation_id << ": " << o.method << " " << path << " is not served";
    EXPECT_NE(r->status, 500) << o.operation_id << ": " << o.method << " " << path << " " << r->body;
    ++asked;
  }
  EXPECT_GT(asked, 40);
}

TEST(Contract, AWrongMethodIs405WithAllow) {
  forklift_test::Server s("contract-405");
  const std::string admin = s.login("admin", kAdminPassword);
  auto c = s.client();
  httplib::Headers h = {{"Authorization", "Bearer " + admin}};
  auto r = c.Delete("/api/pupils", h);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 405) << r->body;
  EXPECT_EQ(r->get_header_value("Allow"), "GET, POST");
  EXPECT_EQ(error_code(json::parse(r->body)), "method_not_allowed");
  r = c.Put("/api/pupils/1", h, "{}", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 405);
  EXPECT_EQ(r->get_header_value("Allow"), "PATCH, GET");
  // A path the API does not have stays 404.
  r = c.Delete("/api/nothing-here", h);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 404);
  EXPECT_FALSE(r->has_header("Allow"));
}

TEST(Contract, A201HasLocationAnd401HasWwwAuthenticate) {
  forklift_test::Server s("contract-headers");
  const std::string admin = s.login("admin", kAdminPassword);
  auto c = s.client();
  auto r = c.Post("/api/pupils", {{"Authorization", "Bearer " + admin}}, R"({"name":"Grace Hopper"})", "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 201) << r->body;
  const std::string location = r->get_header_value("Location");
  EXPECT_EQ(location, "/api/pupils/" + std::to_string(json::parse(r->body)["id"].get<int64_t>()));
  auto [status, again] = s.call("GET", location, admin);
  EXPECT_EQ(status, 200);
  EXPECT_EQ(again["name"], "Grace Hopper");

  r = c.Post("/api/users", {{"Authorization", "Bearer " + admin}}, R"({"username":"ex1","password":"exam-pass-1","role":"examiner"})",
             "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 201) << r->body;
  EXPECT_EQ(r->get_header_value("Location"), "/api/users/" + std::to_string(json::parse(r->body)["id"].get<int64_t>()));

  for (const auto& [method, path, token] : {std::tuple<std::string, std::string, std::string>{"GET", "/api/pupils", ""},
                                            {"GET", "/api/pupils", "not-a-token"},
                                            {"POST", "/api/login", ""}}) {
    httplib::Headers h;
    if (!token.empty()) h.emplace("Authorization", "Bearer " + token);
    auto a = method == "GET" ? c.Get(path, h) : c.Post(path, h, R"({"username":"admin","password":"wrong-one"})", "application/json");
    ASSERT_TRUE(a);
    EXPECT_EQ(a->status, 401) << method << " " << path;
    EXPECT_EQ(a->get_header_value("WWW-Authenticate").rfind("Bearer", 0), 0u) << method << " " << path;
  }
}

TEST(Contract, RequestsBreakingTheSchemasAre400NamingTheFieldInWords) {
  forklift_test::Server s("contract-400");
  const std::string admin = s.login("admin", kAdminPassword);
  auto [st, pupil] = s.call("POST", "/api/pupils", admin, R"({"name":"Ada"})");
  ASSERT_EQ(st, 201);
  const std::string pupil_path = "/api/pupils/" + std::to_string(pupil["id"].get<int64_t>());
  struct Case {
    std::string method, path, body, field;
  };
  const Case cases[] = {
      // POST and PATCH alike refuse a field they do not take (POST took any before).
      {"POST", "/api/pupils", R"({"name":"Bo","nmae":"Bo"})", "'nmae'"},
      {"PATCH", pupil_path, R"({"name":"Bo","mail":"b@example.org"})", "'mail'"},
      {"POST", "/api/pupils", R"({"email":"b@example.org"})", "'name'"},
      {"POST", "/api/pupils", R"({"name":42})", "'name'"},
      {"POST", "/api/sessions", R"({"pupil_id":"one","cab_id":"cab1","scenario":"x"})", "'pupil_id'"},
      {"POST", "/api/sessions", R"({"pupil_id":1,"cab_id":"cab 1!","scenario":"x"})", "'cab_id'"},
      {"POST", "/api/sessions", R"({"pupil_id":1,"cab_id":"cab1","scenario":"x","mode":"race"})", "'mode'"},
      {"POST", "/api/sessions", R"({"pupil_id":1,"cab_id":"cab1","scenario":"x","load":{"mass_kg":0}})", "'load.mass_kg' must be positive"},
      {"POST", "/api/users", R"({"username":"Bad Name","password":"exam-pass-1","role":"examiner"})", "'username' may have only the letters"},
      {"POST", "/api/users", R"({"username":"x1","password":"short","role":"examiner"})", "'password'"},
      {"POST", "/api/login", R"({"username":"admin","password":"admin-pass-1","remember":true})", "'remember'"},
      {"GET", "/api/pupils?limit=1001", "", "'limit'"},
      {"GET", "/api/pupils?limit=ten", "", "'limit'"},
      {"GET", "/api/pupils?offset=-3", "", "'offset'"},
      {"GET", "/api/audit?limit=5000", "", "'limit'"},
      {"GET", "/api/users?active=maybe", "", "'active'"},
  };
  for (const auto& c : cases) {
    auto [status, j] = s.call(c.method, c.path, admin, c.body);
    EXPECT_EQ(status, 400) << c.method << " " << c.path << " " << c.body << ": " << j;
    EXPECT_EQ(error_code(j), "bad_request") << j;
    EXPECT_NE(message_of(j).find(c.field), std::string::npos) << c.method << " " << c.path << " " << c.body << ": " << j;
    expect_plain_words(j);
  }
  // The documented maximum itself is taken.
  EXPECT_EQ(s.call("GET", "/api/pupils?limit=1000", admin).first, 200);
  // Not JSON: where it goes wrong, not the parser's own text.
  auto [status, j] = s.call("POST", "/api/pupils", admin, R"({"name": "Ada)");
  EXPECT_EQ(status, 400);
  EXPECT_EQ(error_code(j), "bad_json");
  expect_plain_words(j);
  // A name already taken: the store's refusal, without the database's words.
  ASSERT_EQ(s.call("POST", "/api/users", admin, R"({"username":"dup1","password":"exam-pass-1","role":"examiner"})").first, 201);
  std::tie(status, j) = s.call("POST", "/api/users", admin, R"({"username":"dup1","password":"exam-pass-1","role":"examiner"})");
  EXPECT_EQ(status, 409) << j;
  expect_plain_words(j);
  // Without a login the answer is 401 whatever the body.
  EXPECT_EQ(s.call("POST", "/api/pupils", "", R"({"nmae":1})").first, 401);
  EXPECT_EQ(s.call("GET", "/api/pupils?limit=5000", "").first, 401);
}
