// A real forklift-server for a test: its own loopback port, DDS domain and SQLite file in a
// fresh folder, and small helpers for its JSON API (over https when given the CA of the server's
// certificate, whose --tls-cert and --tls-key then go in `extra`).
#pragma once

#include <gtest/gtest.h>
#include <httplib.h>

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "support/process.h"

namespace forklift_test {

using nlohmann::json;

inline const std::string kAdminPassword = "admin-pass-1";

struct Server {
  static constexpr const char* kBin = FORKLIFT_BIN_DIR;

  int port, domain;
  std::string dir, db;
  std::string ca;  // empty: plain http
  std::unique_ptr<Process> proc;

  Server(int port_, int domain_, const std::string& name, std::vector<std::string> extra = {}, std::string ca_file = {})
      : port(port_), domain(domain_), dir(testing::TempDir() + "/server-" + name), ca(std::move(ca_file)) {
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    db = dir + "/forklift.db";
    start(extra);
  }
  void start(std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {std::string(kBin) + "/forklift-server", "--db", db, "--listen", "127.0.0.1:" + std::to_string(port),
                                     "--dds-domain", std::to_string(domain), "--admin-password", kAdminPassword};
    args.insert(args.end(), extra.begin(), extra.end());
    proc = std::make_unique<Process>(args, dir + "/server-" + std::to_string(std::rand()));
    httplib::Client c = client();
    for (int i = 0; i < 200; ++i) {
      if (auto r = c.Get("/api/health"); r && r->status == 200) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    ADD_FAILURE() << "server did not come up: " << proc->err();
  }
  std::string url() const { return (ca.empty() ? "http://127.0.0.1:" : "https://127.0.0.1:") + std::to_string(port); }
  httplib::Client client() const {
    httplib::Client c(url());
    if (!ca.empty()) c.set_ca_cert_path(ca);
    return c;
  }

  // Status and JSON body of one request.
  std::pair<int, json> call(const std::string& method, const std::string& path, const std::string& token = "",
                            const std::string& body = "") const {
    auto c = client();
    httplib::Headers h;
    if (!token.empty()) h.emplace("Authorization", "Bearer " + token);
    auto r = method == "GET"     ? c.Get(path, h)
             : method == "PATCH" ? c.Patch(path, h, body, "application/json")
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
};

inline std::string error_code(const json& j) { return j.is_object() && j.contains("error") ? j["error"].value("code", "") : ""; }

}  // namespace forklift_test
