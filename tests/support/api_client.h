// Small helpers for forklift-server's JSON API over real HTTP(S), whatever runs the server: a
// process (support/server.h) or the library in this one (tests/server/handlers_test.cc).
#pragma once

#include <gtest/gtest.h>
#include <httplib.h>

#include <chrono>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <utility>

namespace forklift_test {

using nlohmann::json;

inline const std::string kAdminPassword = "admin-pass-1";

struct ApiClient {
  virtual ~ApiClient() = default;
  virtual httplib::Client client() const = 0;

  // Status and JSON body of one request.
  std::pair<int, json> call(const std::string& method, const std::string& path, const std::string& token = "",
                            const std::string& body = "") const {
    auto c = client();
    httplib::Headers h;
    if (!token.empty()) h.emplace("Authorization", "Bearer " + token);
    auto r = method == "GET"     ? c.Get(path, h)
             : method == "PATCH"  ? c.Patch(path, h, body, "application/json")
             : method == "PUT"    ? c.Put(path, h, body, "application/json")
             : method == "DELETE" ? c.Delete(path, h)
                                  : c.Post(path, h, body, "application/json");
    if (!r) return {0, nullptr};
    json j;
    try { j = json::parse(r->body); } catch (...) { j = r->body; }
    return {r->status, j};
  }
  std::string login(const std::string& user, const std::string& pw) const {
    auto [status, j] = call("POST", "/api/login", "", json{{"username", user}, {"password", pw}}.dump());
    EXPECT_EQ(status, 200) << j;
    return status == 200 ? j["token"].get<std::string>() : "";
  }
  json wait_session(const std::string& token, const std::string& id, double seconds) const {
    json s;
    for (int i = 0; i < seconds * 10; ++i) {
      s = call("GET", "/api/sessions/" + id, token).second;
      const std::string st = s.value("state", "");
      if (st == "ended" || st == "failed" || st == "aborted") break;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return s;
  }
  // Polls the session's live view (GET /api/sessions/{id}/live) until its truck state satisfies
  // `done`; whether it did within `seconds` (a bound that only stops a test that would hang).
  bool live_until(const std::string& token, const std::string& id, const std::function<bool(const json&)>& done,
                  double seconds = 30) const {
    for (int i = 0; i < seconds * 50; ++i) {
      const auto [code, v] = call("GET", "/api/sessions/" + id + "/live", token);
      if (code == 200 && v["state"].is_object() && done(v["state"])) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }
};

inline std::string error_code(const json& j) { return j.is_object() && j.contains("error") ? j["error"].value("code", "") : ""; }

}  // namespace forklift_test
