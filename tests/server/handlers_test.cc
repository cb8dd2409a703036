// The API's handlers in this process: forklift_server_core mounted on its listener in a
// thread, on a loopback port from the tests' allocator (support/ports.h), over a real SQLite file
// in a fresh folder; the tests talk real HTTP. No real worker ever starts: the bin folder given is
// empty, and every session request here is refused before one would be spawned, but in the tests
// that put a stand-in forklift-worker there (a shell script that writes down its arguments and the
// signal it got).
#include <gtest/gtest.h>
#include <httplib.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <functional>
#include <thread>
#include <tuple>

#include "forklift/protocol/protocol.h"
#include "forklift/server/listener.h"
#include "forklift/server/server.h"
#include "support/ports.h"
#include "support/api_client.h"
#include "support/in_process.h"

using forklift_test::error_code;
using forklift_test::kAdminPassword;
using nlohmann::json;

namespace {

// Each server takes its port and its DDS domain (the fleet joins one even with no cab about) from
// the tests' allocator.
struct InProcessServer : forklift_test::ApiClient {
  std::string dir;
  std::unique_ptr<forklift::server::Api> api;
  forklift::server::Listener http;
  int port = forklift::test::free_port();
  std::thread thread;

  explicit InProcessServer(const std::string& name, int domain = forklift::test::free_domain(),
                           const std::function<void(forklift::server::ServerConfig&)>& configure = {})
      : dir(testing::TempDir() + "/handlers-" + name) {
    forklift::server::ServerConfig config = forklift_test::in_process_config(dir, domain);
    if (configure) configure(config);
    api = std::make_unique<forklift::server::Api>(config);
    api->mount(http);
    if (!http.bind_to_port("127.0.0.1", port)) ADD_FAILURE() << "cannot listen on 127.0.0.1:" << port;
    thread = std::thread([this] { http.listen_after_bind(); });
    // stop() is lost on a server not yet listening, and the destructor would wait for ever.
    for (int i = 0; i < 500 && !http.is_running(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ~InProcessServer() override {
    http.stop();
    thread.join();
  }
  httplib::Client client() const override { return httplib::Client("127.0.0.1", port); }

  // A pupil of the admin's school, with a login of their own when `username` is given.
  json add_pupil(const std::string& admin, const std::string& name, const std::string& username = "") const {
    json b = {{"name", name}};
    if (!username.empty()) b.update({{"username", username}, {"password", username + "-pass-1"}});
    auto [status, j] = call("POST", "/api/pupils", admin, b.dump());
    EXPECT_EQ(status, 201) << j;
    return j;
  }
  json audit(const std::string& admin) const { return call("GET", "/api/audit", admin).second; }
};

std::string pupil_path(const json& pupil) { return "/api/pupils/" + std::to_string(pupil["id"].get<int64_t>()); }

}  // namespace

TEST(Handlers, TheBootstrapAdminLogsInAndAWrongPasswordIs401) {
  InProcessServer s("login");
  ASSERT_GT(s.port, 0);
  auto [st, j] = s.call("POST", "/api/login", "", json{{"username", "admin"}, {"password", kAdminPassword}}.dump());
  ASSERT_EQ(st, 200) << j;
  EXPECT_EQ(j["role"], "admin");
  EXPECT_FALSE(j["token"].get<std::string>().empty());
  EXPECT_EQ(s.call("GET", "/api/pupils", j["token"]).first, 200);

  auto [wst, wrong] = s.call("POST", "/api/login", "", R"({"username":"admin","password":"admin-pass-2"})");
  EXPECT_EQ(wst, 401);
  EXPECT_EQ(error_code(wrong), "bad_credentials");
  EXPECT_EQ(s.call("POST", "/api/login", "", R"({"username":"nobody","password":"admin-pass-1"})").first, 401);
  EXPECT_EQ(error_code(s.call("GET", "/api/pupils", "").second), "unauthenticated");
}

TEST(Handlers, ALoggedOutTokenIsRefused) {
  InProcessServer s("logout");
  const std::string admin = s.login("admin", kAdminPassword);
  EXPECT_EQ(s.call("POST", "/api/logout", admin).first, 200);
  auto [st, j] = s.call("GET", "/api/pupils", admin);
  EXPECT_EQ(st, 401);
  EXPECT_EQ(error_code(j), "unauthenticated");
}

TEST(Handlers, EveryAnswerCarriesTheSecurityHeaders) {
  InProcessServer s("headers");
  auto c = s.client();
  for (const char* path : {"/api/health", "/api/no-such-thing"}) {
    const auto r = c.Get(path);
    ASSERT_TRUE(r) << path;
    EXPECT_EQ(r->get_header_value("X-Content-Type-Options"), "nosniff") << path;
    EXPECT_EQ(r->get_header_value("X-Frame-Options"), "DENY") << path;
    EXPECT_EQ(r->get_header_value("Cache-Control"), "no-store") << path;
  }
  const auto missing = c.Get("/api/no-such-thing");
  EXPECT_EQ(missing->status, 404);
  EXPECT_EQ(error_code(json::parse(missing->body)), "not_found");
}

TEST(Handlers, APupilCreatedIsListedAndFetched) {
  InProcessServer s("pupil");
  const std::string admin = s.login("admin", kAdminPassword);
  const json p = s.add_pupil(admin, "Ana Pupil");
  ASSERT_TRUE(p["id"].is_number_integer()) << p;

  const json page = s.call("GET", "/api/pupils", admin).second;
  EXPECT_EQ(page["total"], 1) << page;
  const json list = page["pupils"];
  ASSERT_EQ(list.size(), 1u) << page;
  EXPECT_EQ(list[0]["id"], p["id"]);
  EXPECT_EQ(list[0]["name"], "Ana Pupil");
  auto [st, got] = s.call("GET", pupil_path(p), admin);
  EXPECT_EQ(st, 200);
  EXPECT_EQ(got, p);
  const json audit = s.audit(admin);
  ASSERT_EQ(audit.size(), 1u);
  EXPECT_EQ(audit[0]["action"], "pupil_created");
  EXPECT_EQ(audit[0]["actor"], "admin");
}

TEST(Handlers, AMalformedBodyIs400WithItsReasonAndChangesNothing) {
  InProcessServer s("malformed");
  const std::string admin = s.login("admin", kAdminPassword);
  const json p = s.add_pupil(admin, "Ben");

  auto [st1, j1] = s.call("POST", "/api/pupils", admin, R"({"name": "Carl")");
  EXPECT_EQ(st1, 400);
  EXPECT_EQ(error_code(j1), "bad_json");
  EXPECT_NE(j1["error"]["message"].get<std::string>().find("not valid JSON"), std::string::npos) << j1;
  auto [st2, j2] = s.call("POST", "/api/pupils", admin, "[1, 2]");
  EXPECT_EQ(st2, 400);
  EXPECT_EQ(j2["error"]["message"], "the body must be a JSON object");
  auto [st3, j3] = s.call("PATCH", pupil_path(p), admin, "{name: 'Bob'}");
  EXPECT_EQ(st3, 400);
  EXPECT_EQ(error_code(j3), "bad_json");
  EXPECT_EQ(error_code(s.call("POST", "/api/pupils", admin, R"({"name": 5})").second), "bad_request");
  // Bytes that are not UTF-8, and a number beyond a double: 400 in words, never 500.
  for (const std::string& body : {std::string("\xff\xfe"), std::string(R"({"name": "Ca)") + "\xff" + R"(rl"})",
                                 std::string(R"({"name": "Dan", "email": 1e99999})")}) {
    auto [st, j] = s.call("POST", "/api/pupils", admin, body);
    EXPECT_EQ(st, 400) << j;
    EXPECT_EQ(error_code(j), "bad_json") << j;
  }

  EXPECT_EQ(s.call("GET", "/api/pupils", admin).second["pupils"].size(), 1u);
  EXPECT_EQ(s.call("GET", pupil_path(p), admin).second["name"], "Ben");
  EXPECT_EQ(s.audit(admin).size(), 1u);  // only Ben's creation
}

// Past 1 MiB a body is refused, announced or not: by its Content-Length before it is read; in
// chunks, by the chunks' data once it has come (the listener stops reading at twice that).
TEST(Handlers, ABodyPastOneMiBIs413WhateverItsFraming) {
  InProcessServer s("too-large");
  auto c = s.client();
  const std::string login = json{{"username", "admin"}, {"password", kAdminPassword}}.dump();
  const std::string big = R"({"username": "admin", "password": ")" + std::string(3 << 19, 'x') + "\"}";  // 1.5 MiB
  auto chunked = [&](const std::string& path, const std::string& body) {
    return c.Post(path.c_str(), [&](size_t offset, httplib::DataSink& sink) {
      if (offset >= body.size()) return sink.done(), true;
      return sink.write(body.data() + offset, std::min<size_t>(64 << 10, body.size() - offset));
    }, "application/json");
  };
  for (const auto& [what, r] : {std::pair{"with a length", c.Post("/api/login", big, "application/json")},
                                {"in chunks", chunked("/api/login", big)},
                                {"in chunks to no endpoint", chunked("/api/no-such-thing", big)}}) {
    ASSERT_TRUE(r) << what;
    EXPECT_EQ(r->status, 413) << what << ": " << r->body;
    EXPECT_EQ(error_code(json::parse(r->body)), "too_large") << what;
  }
  const auto small = chunked("/api/login", login);
  ASSERT_TRUE(small);
  EXPECT_EQ(small->status, 200) << small->body;
}

TEST(Handlers, AnUnknownPupilIs404) {
  InProcessServer s("unknown");
  const std::string admin = s.login("admin", kAdminPassword);
  for (const char* path : {"/api/pupils/999", "/api/pupils/999/history", "/api/pupils/999/audit"}) {
    auto [st, j] = s.call("GET", path, admin);
    EXPECT_EQ(st, 404) << path;
    EXPECT_EQ(error_code(j), "not_found") << path;
  }
  EXPECT_EQ(s.call("GET", "/api/pupils/999", admin).second["error"]["message"], "no pupil 999");
  EXPECT_EQ(s.call("PATCH", "/api/pupils/999", admin, R"({"name":"X"})").first, 404);
  EXPECT_EQ(s.call("GET", "/api/sessions/s-999999", admin).first, 404);
}

TEST(Handlers, APupilSeesOnlyTheirOwnRecordAndNoList) {
  InProcessServer s("roles");
  const std::string admin = s.login("admin", kAdminPassword);
  const json ana = s.add_pupil(admin, "Ana", "ana"), ben = s.add_pupil(admin, "Ben");
  const std::string token = s.login("ana", "ana-pass-1");

  auto [st, j] = s.call("GET", "/api/pupils", token);
  EXPECT_EQ(st, 403);
  EXPECT_EQ(error_code(j), "forbidden");
  EXPECT_EQ(s.call("GET", pupil_path(ana), token).first, 200);
  EXPECT_EQ(s.call("GET", pupil_path(ana) + "/history", token).first, 200);
  EXPECT_EQ(s.call("GET", pupil_path(ben), token).first, 403);
  EXPECT_EQ(s.call("GET", pupil_path(ana) + "/audit", token).first, 403);  // not even their own
  EXPECT_EQ(s.call("POST", "/api/pupils", token, R"({"name":"Eve"})").first, 403);
  EXPECT_EQ(s.call("PATCH", pupil_path(ana), token, R"({"name":"Queen Ana"})").first, 403);
  // Her language is hers to choose (not with anything else, not another's), and her next login says it.
  EXPECT_EQ(s.call("GET", pupil_path(ana), token).second["language"], "en");
  EXPECT_EQ(s.call("PATCH", pupil_path(ana), token, R"({"language":"es"})").second["language"], "es");
  EXPECT_EQ(s.call("PATCH", pupil_path(ana), token, R"({"language":"es","name":"Queen Ana"})").first, 403);
  EXPECT_EQ(s.call("PATCH", pupil_path(ben), token, R"({"language":"es"})").first, 403);
  EXPECT_EQ(s.call("PATCH", pupil_path(ana), token, R"({"language":"fr"})").first, 400);
  EXPECT_EQ(s.call("GET", pupil_path(ana), admin).second["language"], "es");
  EXPECT_EQ(s.call("GET", pupil_path(ben), admin).second["language"], "en");
  EXPECT_EQ(s.call("POST", "/api/login", "", R"({"username":"ana","password":"ana-pass-1"})").second["language"], "es");
  EXPECT_EQ(s.call("GET", "/api/pupils", admin).second["pupils"].size(), 2u);
  EXPECT_EQ(s.call("GET", pupil_path(ana), admin).second["name"], "Ana");
}

TEST(Handlers, ABadLoadIsRefusedBeforeAnySessionStarts) {
  InProcessServer s("load");
  const std::string admin = s.login("admin", kAdminPassword);
  const json pupil = s.add_pupil(admin, "Dan");
  const auto start = [&](const std::string& load) {
    return s.call("POST", "/api/sessions", admin,
                  R"({"pupil_id": )" + pupil["id"].dump() + R"(, "cab_id": "cab1", "scenario": "manoeuvre_1", "load": )" + load + "}");
  };
  const std::pair<const char*, const char*> bad[] = {
      // Worded from the Load schema of server/openapi.yaml, which the request is checked against.
      {R"({"mass_kg": 0})", "'load.mass_kg' must be positive (found 0)"},
      {R"({"mass_kg": -5})", "'load.mass_kg' must be positive (found -5)"},
      {R"({"mass_kg": 20001})", "'load.mass_kg' must be at most 20000 (found 20001)"},
      {R"({"mass_kg": "heavy"})", "'load.mass_kg' is not a number (found a string)"},
      {R"({"cog_height_m": 1})", "'load.mass_kg' is required"},
      {R"({"mass_kg": 500, "colour": 1})", "'load.colour' is not a field this request takes"},
      {R"({"mass_kg": 500, "cog_height_m": 11})", "'load.cog_height_m' must be at most 10 (found 11)"},
      {R"({"mass_kg": 500, "lateral_m": -2.5})", "'load.lateral_m' must be at least -2 (found -2.5)"},
      {R"([500])", "'load' must be an object or null (found an array)"},
  };
  for (const auto& [load, message] : bad) {
    auto [st, j] = start(load);
    EXPECT_EQ(st, 400) << load << ": " << j;
    EXPECT_EQ(error_code(j), "bad_request") << load;
    EXPECT_EQ(j["error"]["message"], message) << load;
  }
  // NaN is not JSON: the body itself is refused.
  EXPECT_EQ(error_code(start(R"({"mass_kg": NaN})").second), "bad_json");

  EXPECT_EQ(s.call("GET", pupil_path(pupil) + "/history", admin).second["sessions"].size(), 0u);
  EXPECT_EQ(s.audit(admin).size(), 1u);  // the pupil's creation, no session_started
  EXPECT_EQ(s.call("GET", "/api/fleet", admin).second["workers"].size(), 0u);
}

TEST(Handlers, AnExamNeedsAnExamCourseDdsSecurityAndAnExaminer) {
  InProcessServer s("exam");
  const std::string admin = s.login("admin", kAdminPassword);
  const json pupil = s.add_pupil(admin, "Eva");
  EXPECT_EQ(s.call("POST", "/api/users", admin, R"({"username":"ines","password":"ines-pass-1","role":"instructor"})").first, 201);
  const json body = {{"pupil_id", pupil["id"]}, {"cab_id", "cab1"}, {"scenario", "counterbalance_exam"}, {"mode", "exam"}};
  auto [st, j] = s.call("POST", "/api/sessions", admin, body.dump());
  EXPECT_EQ(st, 409);
  EXPECT_EQ(error_code(j), "security_required");  // this server runs without --security
  EXPECT_EQ(error_code(s.call("POST", "/api/sessions", s.login("ines", "ines-pass-1"), body.dump()).second), "forbidden");
  // The paper's manoeuvres and the training scenarios are for practice: never an exam.
  for (const char* training : {"manoeuvre_1", "first_drive_yard", "practical_exam"}) {
    json other = body;
    other["scenario"] = training;
    auto [st2, j2] = s.call("POST", "/api/sessions", admin, other.dump());
    EXPECT_EQ(st2, 400) << training;
    EXPECT_EQ(error_code(j2), "not_exam_course") << training;
    EXPECT_NE(j2["error"]["message"].get<std::string>().find("is not an exam course"), std::string::npos) << j2;
  }
  // An exam course runs as it is laid out: no other truck, no other load.
  json other_truck = body;
  other_truck["truck"] = "simucel_paper";
  EXPECT_EQ(s.call("POST", "/api/sessions", admin, other_truck.dump()).first, 400);
  // The catalogue says which scenarios are exam courses.
  int courses = 0;
  for (const json& sc : s.call("GET", "/api/scenarios", admin).second) {
    EXPECT_TRUE(sc.contains("exam_course")) << sc;
    if (sc.value("exam_course", false)) {
      ++courses;
      EXPECT_EQ(sc["name"], "counterbalance_exam");
    }
  }
  EXPECT_EQ(courses, 1);
  EXPECT_EQ(s.call("GET", pupil_path(pupil) + "/history", admin).second["sessions"].size(), 0u);
}

// A number too large for a double (1e999) makes nlohmann throw out_of_range, not parse_error:
// still a bad body (400), never a 500.
TEST(Handlers, AnOverflowingNumberIsBadJsonNot500) {
  InProcessServer s("overflow");
  const std::string admin = s.login("admin", kAdminPassword);
  const json pupil = s.add_pupil(admin, "Fay");
  auto [st, j] = s.call("POST", "/api/sessions", admin,
                        R"({"pupil_id": )" + pupil["id"].dump() + R"(, "cab_id": "cab1", "scenario": "manoeuvre_1", "load": {"mass_kg": 1e999}})");
  EXPECT_EQ(st, 400) << j;
  EXPECT_EQ(error_code(j), "bad_json");
}

// Every body endpoint's numbers: a boolean, a fraction or a whole number past its type is 400
// naming the field (nlohmann would read true as 1, 1.5 as 1 and 2^64 - 1 as -1), as is a value out
// of the field's own range; a string where a number belongs, and a number where a string does.
TEST(Handlers, NumbersOutOfRangeForTheirFieldAre400NamingItOnEveryBodyEndpoint) {
  InProcessServer s("numbers");
  const std::string admin = s.login("admin", kAdminPassword);
  const json pupil = s.add_pupil(admin, "Ivy");
  const json id = pupil["id"];
  const std::vector<json> not_ids = {1.5, true, json(uint64_t{18446744073709551615u}), 1e20, -1e300, "1"};
  auto session = [&](json extra) {
    json b = {{"pupil_id", id}, {"cab_id", "cab1"}, {"scenario", "manoeuvre_1"}};
    b.update(extra);
    return b;
  };
  struct Case {
    const char* method;
    std::string path;
    json body;
    std::string field;  // the message names it
  };
  std::vector<Case> cases;
  for (const json& v : not_ids) {
    cases.push_back({"POST", "/api/sessions", session({{"pupil_id", v}}), "'pupil_id'"});
    cases.push_back({"POST", "/api/users", {{"username", "ivy2"}, {"password", "ivy-pass-1"}, {"role", "pupil"}, {"pupil_id", v}}, "'pupil_id'"});
    cases.push_back({"POST", "/api/theory/attempts", {{"pupil_id", v}}, "'pupil_id'"});
  }
  for (const json& v : {json(-5), json(0), json(1e308), json(true), json("30")})
    cases.push_back({"POST", "/api/sessions", session({{"time_limit_s", v}}), "'time_limit_s'"});
  for (const json& v : {json(-1), json(1e308), json(true)})
    cases.push_back({"POST", "/api/sessions", session({{"load", {{"mass_kg", v}}}}), "'load.mass_kg'"});
  for (const json& v : {json(-1), json(9007199254740992), json(1.5), json(true), json(1e300), json(uint64_t{18446744073709551615u})})
    cases.push_back({"POST", "/api/theory/attempts", {{"pupil_id", id}, {"seed", v}}, "'seed'"});
  auto [ast, attempt] = s.call("POST", "/api/theory/attempts", admin, json{{"pupil_id", id}}.dump());
  ASSERT_EQ(ast, 201) << attempt;
  const std::string question = attempt["questions"][0]["id"];
  for (const json& v : {json(1.5), json(-1), json(true), json(1e300), json(uint64_t{18446744073709551615u})})
    cases.push_back({"POST", "/api/theory/attempts/" + attempt["id"].dump() + "/answers", {{"answers", {{question, v}}}},
                     question + "'"});  // "'answers.<id>' ..." (the schema) or "the answer to '<id>' ..." (the paper)
  cases.push_back({"POST", "/api/login", {{"username", 5}, {"password", "x"}}, "'username'"});
  cases.push_back({"POST", "/api/pupils", {{"name", 1e300}}, "'name'"});
  cases.push_back({"PATCH", pupil_path(pupil), {{"email", 1}}, "'email'"});

  for (const Case& c : cases) {
    auto [st, j] = s.call(c.method, c.path, admin, c.body.dump());
    EXPECT_EQ(st, 400) << c.path << " " << c.body << ": " << j;
    EXPECT_EQ(error_code(j), "bad_request") << c.path << " " << c.body;
    const std::string message = j.is_object() ? j.value("error", json::object()).value("message", "") : "";
    EXPECT_NE(message.find(c.field), std::string::npos) << c.path << " " << c.body << ": " << j;
  }
  EXPECT_EQ(s.call("GET", pupil_path(pupil) + "/history", admin).second["sessions"].size(), 0u);
  EXPECT_EQ(s.audit(admin).size(), 2u);  // Ivy's creation and her one paper
}

// A byte that is not UTF-8 (raw, or %-encoded) in a path, a query or a header: refused or not
// found in words, never a 500. A query number must be one.
TEST(Handlers, BytesThatAreNotUtf8InPathsQueriesAndHeadersAreNeverA500) {
  InProcessServer s("not-utf8");
  const std::string admin = s.login("admin", kAdminPassword);
  const json pupil = s.add_pupil(admin, "Jo");
  const std::string p = pupil_path(pupil);
  std::vector<std::string> paths;
  for (const std::string bad : {"%FF%FE", "\xff\xfe", "%C0%AF"}) {
    for (const std::string& path : {"/api/pupils/" + bad, p + bad + "/history", "/api/scenarios/" + bad, "/api/scenarios/" + bad + "/plan",
                                    "/api/sessions/s-" + bad, "/api/sessions/s-1/events/" + bad + "/still.png",
                                    "/api/theory/attempts/" + bad, "/" + bad, "/api/" + bad})
      paths.push_back(path);
    for (const std::string& query : {std::string("/api/pupils?search="), std::string("/api/pupils?limit="),
                                     std::string("/api/audit?offset="), p + "/audit?limit=", std::string("/api/fleet?"),
                                     std::string("/api/cabs?x=")})
      paths.push_back(query + bad);
  }
  auto c = s.client();
  c.set_url_encode(false);  // the raw bytes as they are
  const httplib::Headers bad_headers = {{"Authorization", "Bearer \xff\xfe"}, {"X-Forwarded-For", "\xff"}, {"Accept", "\xc0\xaf"}};
  for (const std::string& path : paths) {
    for (const httplib::Headers& h : {httplib::Headers{{"Authorization", "Bearer " + admin}}, bad_headers}) {
      for (const auto& r : {c.Get(path.c_str(), h), c.Post(path.c_str(), h, "{}", "application/json")}) {
        ASSERT_TRUE(r) << path;
        EXPECT_LT(r->status, 500) << path << ": " << r->body;
        EXPECT_TRUE(json::accept(r->body)) << path << ": " << r->body;
      }
    }
  }
  // Query numbers: whole ones only, within their documented range: refused beyond it, never
  // clamped.
  EXPECT_EQ(s.call("GET", "/api/pupils?limit=1x", admin).first, 400);
  EXPECT_EQ(s.call("GET", "/api/pupils?limit=99999999999999999999", admin).first, 400);
  EXPECT_EQ(s.call("GET", "/api/pupils?limit=1001", admin).first, 400);
  EXPECT_EQ(s.call("GET", "/api/pupils?offset=-3", admin).first, 400);
  EXPECT_EQ(s.call("GET", "/api/pupils?limit=1000&offset=0", admin).second["pupils"].size(), 1u);
}

TEST(Handlers, AidsAreRefusedInAnExamAndCheckedInTraining) {
  InProcessServer s("aids-refused");
  const std::string admin = s.login("admin", kAdminPassword);
  const json pupil = s.add_pupil(admin, "Gil");
  const auto start = [&](const std::string& mode, const json& aids) {
    return s.call("POST", "/api/sessions", admin,
                  json{{"pupil_id", pupil["id"]}, {"cab_id", "cab1"}, {"scenario", "manoeuvre_1"}, {"mode", mode}, {"aids", aids}}.dump());
  };
  const std::tuple<const char*, json, const char*> bad[] = {
      {"exam", json::array({"rear_view"}), "an exam is taken without training aids: leave 'aids' out of an exam session"},
      {"training", json::array({"rear_view", "autopilot"}), "'aids[1]' must be rear_view, see_through_mast, chase_camera or fork_camera (found autopilot)"},
      {"training", "rear_view", "'aids' must be an array (found a string)"},
      {"training", json::array({7}), "'aids[0]' is not a string (found a number)"},
  };
  for (const auto& [mode, aids, message] : bad) {
    auto [st, j] = start(mode, aids);
    EXPECT_EQ(st, 400) << aids << ": " << j;
    EXPECT_EQ(error_code(j), "bad_request") << aids;
    EXPECT_EQ(j["error"]["message"], message) << aids;
  }
  EXPECT_EQ(s.call("GET", pupil_path(pupil) + "/history", admin).second["sessions"].size(), 0u);
}

// A stand-in worker: writes its arguments to <bin>/worker.args, and on SIGUSR1 (the abort) or
// SIGTERM writes which it was to <bin>/worker.signal and exits.
void worker_script(const std::string& bin, const std::string& body) {
  const std::string path = bin + "/forklift-worker";
  std::ofstream(path) << "#!/bin/sh\n" << body << "while :; do sleep 0.05; done\n";
  std::filesystem::permissions(path, std::filesystem::perms::owner_all);
}
void stand_in_worker(const std::string& bin) {
  worker_script(bin,
                "echo \"$@\" > \"$(dirname \"$0\")/worker.args\"\n"
                "trap 'echo USR1 > \"$(dirname \"$0\")/worker.signal\"; exit 0' USR1\n"
                "trap 'echo TERM > \"$(dirname \"$0\")/worker.signal\"; exit 0' TERM\n");
}

std::string wait_for_file(const std::string& path) {
  for (int i = 0; i < 500; ++i) {
    std::ifstream in(path);
    std::string text;
    if (in && std::getline(in, text) && !text.empty()) return text;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return "";
}

TEST(Handlers, TrainingAidsReachTheSpawnedWorkerAndAnAbortIsSignalledAsSuch) {
  InProcessServer s("aids-spawn");
  stand_in_worker(s.dir + "/bin");
  const std::string admin = s.login("admin", kAdminPassword);
  const json pupil = s.add_pupil(admin, "Hal");
  auto [st, j] = s.call("POST", "/api/sessions", admin,
                        json{{"pupil_id", pupil["id"]}, {"cab_id", "cab1"}, {"scenario", "manoeuvre_1"},
                             {"aids", {"rear_view", "chase_camera", "rear_view"}}}.dump());
  ASSERT_EQ(st, 201) << j;
  const std::string args = wait_for_file(s.dir + "/bin/worker.args");
  EXPECT_NE(args.find("--mode training"), std::string::npos) << args;
  EXPECT_NE((args + " ").find("--aids rear_view,chase_camera "), std::string::npos) << args;  // once each, in order
  // The audit log keeps what was asked for (the session's record has no column for it).
  bool audited = false;
  for (const json& a : s.audit(admin))
    if (a.value("action", "") == "session_started") audited = a["details"]["aids"] == "rear_view,chase_camera";
  EXPECT_TRUE(audited) << s.audit(admin);

  // The instructor's abort is SIGUSR1, which the worker ends as "aborted" (SIGTERM: "signal").
  auto [ast, aj] = s.call("POST", "/api/sessions/" + j["id"].get<std::string>() + "/abort", admin);
  ASSERT_EQ(ast, 200) << aj;
  EXPECT_EQ(aj["state"], "aborted");
  EXPECT_EQ(wait_for_file(s.dir + "/bin/worker.signal"), "USR1");
}

// The ingest believes a session's reports only from its worker,
// refuses what is not UTF-8 or not finite one sample at a time, and counts every refusal. The
// stand-in worker here vouches for this test's own DDS participant (it writes the test's GUID
// where a worker writes its own), so the test can speak as the worker, and as anyone else.
TEST(Handlers, OnlyTheSessionsWorkerIsBelievedAndABadSampleCostsOnlyItself) {
  const int domain = forklift::test::free_domain();
  InProcessServer s("ingest", domain);
  namespace dds = forklift::dds;
  dds::Participant worker(dds::DomainSettings::resolve(domain, "")), outsider(dds::DomainSettings::resolve(domain, ""));
  const std::string bin = s.dir + "/bin";
  std::ofstream(bin + "/guid") << dds::participant_guid(worker.handle()) << '\n';
  worker_script(bin,
                "while [ $# -gt 0 ]; do [ \"$1\" = --log ] && log=\"$2\"; shift; done\n"
                "cp \"$(dirname \"$0\")/guid\" \"$log.participant\"\n"
                "trap 'exit 0' TERM\n");
  const std::string admin = s.login("admin", kAdminPassword);
  const json pupil = s.add_pupil(admin, "Wire Test");
  auto [st, j] = s.call("POST", "/api/sessions", admin,
                        json{{"pupil_id", pupil["id"]}, {"cab_id", "cab1"}, {"scenario", "manoeuvre_1"}}.dump());
  ASSERT_EQ(st, 201) << j;
  const std::string id = j["id"];
  // A worker says who it is before it publishes anything.
  ASSERT_FALSE(wait_for_file(s.dir + "/forklift.db.logs/" + id + ".ctl.participant").empty());

  dds::Writer<fk_Event> events(worker, dds::worker_partition("cab1"));
  dds::Writer<fk_Event> forged_events(outsider, dds::worker_partition("cab1"));
  dds::Writer<fk_Score> forged_scores(outsider, dds::worker_partition("cab1")), scores(worker, dds::worker_partition("cab1"));
  dds::Writer<fk_SessionStatus> forged_status(outsider, dds::worker_partition("cab1"));
  dds::Writer<fk_SessionStatus> status(worker, dds::worker_partition("cab1"));
  dds::Writer<fk_CabAnnounce> announce_cab2(outsider, dds::cab_partition("cab2")), announce_bad(outsider, dds::cab_partition("bad\xff" "cab"));
  for (int i = 0; i < 200 && (events.matched() == 0 || forged_events.matched() == 0 || forged_scores.matched() == 0 ||
                              scores.matched() == 0 || forged_status.matched() == 0 || status.matched() == 0 ||
                              announce_cab2.matched() == 0 || announce_bad.matched() == 0); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ASSERT_GT(scores.matched(), 0);
  auto event = [&](uint32_t seq, double t, const char* kind) {
    fk_Event e{};
    dds::set_string(e.session_id, id);
    e.seq = seq;
    e.sim_time_s = t;
    dds::set_string(e.kind, kind);
    e.worry_level = 1;
    dds::set_string(e.details, "{}");
    return e;
  };
  fk_SessionStatus running{};
  dds::set_string(running.session_id, id);
  dds::set_string(running.cab_id, "cab1");
  dds::set_string(running.state, "running");
  ASSERT_TRUE(status.write(running));
  // One batch from the worker: good, NaN, not UTF-8, good.
  ASSERT_TRUE(events.write(event(1, 0.5, "speed_near_walkway")));
  ASSERT_TRUE(events.write(event(2, std::nan(""), "speed_near_walkway")));
  ASSERT_TRUE(events.write(event(3, 0.7, "bad\xff\xfe" "kind")));
  ASSERT_TRUE(events.write(event(4, 0.9, "harsh_braking")));
  // From anyone else: an event, a perfect mark, an end.
  ASSERT_TRUE(forged_events.write(event(5, 1.0, "forged")));
  fk_Score perfect{};
  dds::set_string(perfect.session_id, id);
  perfect.mark = 100;
  perfect.passed = true;
  ASSERT_TRUE(forged_scores.write(perfect));
  fk_SessionStatus ended = running;
  dds::set_string(ended.state, "ended");
  ASSERT_TRUE(forged_status.write(ended));
  // The worker's own score, which its session log (there is none here) does not hold.
  fk_Score unlogged = perfect;
  unlogged.mark = 55;
  unlogged.passed = false;
  ASSERT_TRUE(scores.write(unlogged));
  // Cab announcements: one naming another cab than its partition's, one not UTF-8.
  fk_CabAnnounce a{};
  dds::set_string(a.cab_id, "cab9");
  dds::set_string(a.mode, "script");
  ASSERT_TRUE(announce_cab2.write(a));
  dds::set_string(a.cab_id, "bad\xff" "cab");
  ASSERT_TRUE(announce_bad.write(a));

  json fleet;
  for (int i = 0; i < 100; ++i) {
    fleet = s.call("GET", "/api/fleet", admin).second;
    const json& r = fleet["refused_samples"];
    if (r["malformed"] >= 3 && r["wrong_sender"] >= 4 && r["score_disagrees"] >= 1) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(fleet["refused_samples"]["malformed"], 3) << fleet;       // NaN, two not UTF-8
  EXPECT_EQ(fleet["refused_samples"]["wrong_sender"], 4) << fleet;    // event, score, status, cab9
  EXPECT_EQ(fleet["refused_samples"]["score_disagrees"], 1) << fleet;
  const json session = s.call("GET", "/api/sessions/" + id, admin).second;
  EXPECT_EQ(session["state"], "running") << session;  // the worker's "running", not the forged end
  EXPECT_TRUE(session["mark"].is_null()) << session;
  std::vector<int64_t> seqs;
  for (const json& e : session["events"]) seqs.push_back(e["seq"]);
  EXPECT_EQ(seqs, (std::vector<int64_t>{1, 4})) << session["events"];
  auto [cst, cabs] = s.call("GET", "/api/cabs", admin);
  EXPECT_EQ(cst, 200) << cabs;
  EXPECT_EQ(cabs.dump().find("cab9"), std::string::npos) << cabs;
}

// A worker host's status counts only from the host's own partition and only in range: a status
// naming another host, one in a state no host has, and one with a load that is not a number are
// each refused and counted; the good one is listed; the server goes on answering.
TEST(Handlers, AWorkerHostsStatusFromOutsideItsPartitionOrOutOfRangeIsRefused) {
  const int domain = forklift::test::free_domain();
  // Hosts believed in clear DDS, as on a closed network (--trust-clear-hosts).
  InProcessServer s("hoststatus", domain, [](forklift::server::ServerConfig& c) { c.trust_clear_hosts = true; });
  namespace dds = forklift::dds;
  dds::Participant p(dds::DomainSettings::resolve(domain, ""));
  const std::string admin = s.login("admin", kAdminPassword);
  // Each in its own instance (host id), so that none supersedes another before it is read.
  dds::Writer<fk_HostStatus> h1(p, dds::host_partition("h1")), h3(p, dds::host_partition("h3")), h4(p, dds::host_partition("h4"));
  for (int i = 0; i < 200 && (h1.matched() == 0 || h3.matched() == 0 || h4.matched() == 0); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ASSERT_GT(h1.matched() * h3.matched() * h4.matched(), 0u);
  auto status = [](const char* id, const char* state, double load) {
    fk_HostStatus h{};
    dds::set_string(h.host_id, id);
    dds::set_string(h.state, state);
    h.capacity = 4;
    h.cores = 2;
    h.load_1min = load;
    h.memory_free_mib = 1000;
    return h;
  };
  ASSERT_TRUE(h1.write(status("h2", "ready", 0.5)));               // h2's status from h1's partition
  ASSERT_TRUE(h3.write(status("h3", "dancing", 0.5)));             // no such state
  ASSERT_TRUE(h4.write(status("h4", "ready", std::nan(""))));      // a load that is not a number
  ASSERT_TRUE(h1.write(status("h1", "ready", 0.5)));               // good
  json fleet;
  for (int i = 0; i < 100; ++i) {
    fleet = s.call("GET", "/api/fleet", admin).second;
    const json& r = fleet["refused_samples"];
    if (r["malformed"] >= 2 && r["wrong_sender"] >= 1 && fleet["hosts"].size() >= 1) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(fleet["refused_samples"]["malformed"], 2) << fleet;
  EXPECT_EQ(fleet["refused_samples"]["wrong_sender"], 1) << fleet;
  ASSERT_EQ(fleet["hosts"].size(), 1u) << fleet;
  EXPECT_EQ(fleet["hosts"][0]["id"], "h1") << fleet;
  EXPECT_EQ(fleet["hosts"][0]["state"], "ready") << fleet;
  EXPECT_EQ(fleet["hosts"][0]["alive"], true) << fleet;
  EXPECT_EQ(s.call("GET", "/api/health").first, 200);
}

// Clear DDS is for one machine: without --trust-clear-hosts (or DDS Security) no worker host is
// believed. A status with room for 100 and a report that a session's worker exited with a perfect
// log are each refused and counted; nothing is listed, placed or stored, and a start runs here.
TEST(Handlers, InClearDdsNoWorkerHostIsBelievedWithoutTheOperatorsWord) {
  const int domain = forklift::test::free_domain();
  InProcessServer s("untrusted", domain);
  namespace dds = forklift::dds;
  dds::Participant p(dds::DomainSettings::resolve(domain, ""));
  const std::string admin = s.login("admin", kAdminPassword);
  dds::Writer<fk_HostStatus> status(p, dds::host_partition("evil"));
  dds::Writer<fk_WorkerReport> report(p, dds::host_partition(""));
  for (int i = 0; i < 200 && (status.matched() == 0 || report.matched() == 0); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ASSERT_GT(status.matched() * report.matched(), 0u);
  fk_HostStatus h{};
  dds::set_string(h.host_id, "evil");
  dds::set_string(h.state, "ready");
  h.capacity = 100;
  ASSERT_TRUE(status.write(h));
  auto r = std::make_unique<fk_WorkerReport>();
  dds::set_string(r->session_id, "s-1");
  dds::set_string(r->state, "exited");
  ASSERT_TRUE(report.write(*r));
  json fleet;
  for (int i = 0; i < 100; ++i) {
    fleet = s.call("GET", "/api/fleet", admin).second;
    if (fleet["refused_samples"]["no_identity"] >= 2) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(fleet["refused_samples"]["no_identity"], 2) << fleet;
  EXPECT_EQ(fleet["hosts_believed"], false) << fleet;
  EXPECT_TRUE(fleet["hosts"].empty()) << fleet;
  EXPECT_EQ(s.call("GET", "/api/health").first, 200);
}
