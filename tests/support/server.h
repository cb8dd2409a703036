// A real forklift-server for a test: its own loopback port, DDS domain and SQLite file in a
// fresh folder (or the PostgreSQL database it is given), over https when given the CA of the
// server's certificate (whose --tls-cert and --tls-key then go in `extra`). ApiClient has the
// helpers for its JSON API.
#pragma once

#include <gtest/gtest.h>
#include <httplib.h>

#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "support/api_client.h"
#include "support/ports.h"
#include "support/process.h"

namespace forklift_test {

using nlohmann::json;

struct Server : ApiClient {
  static constexpr const char* kBin = FORKLIFT_BIN_DIR;

  int port, domain;
  std::string dir, db;
  std::string ca;  // empty: plain http
  std::unique_ptr<Process> proc;

  // On `port_` and `domain_`, which the test took from support/ports.h.
  Server(int port_, int domain_, const std::string& name, std::vector<std::string> extra = {}, std::string ca_file = {})
      : port(port_), domain(domain_), dir(testing::TempDir() + "/server-" + name), ca(std::move(ca_file)) {
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    db = dir + "/forklift.db";
    start(extra);
  }
  // On a port and a domain of its own from support/ports.h.
  explicit Server(const std::string& name, std::vector<std::string> extra = {}, std::string ca_file = {})
      : Server(forklift::test::free_port(), forklift::test::free_domain(), name, std::move(extra), std::move(ca_file)) {}
  // The same on a store of the test's choosing (--db: a PostgreSQL database's URI), its workers'
  // logs in its folder.
  struct Database {
    std::string location;
  };
  Server(const std::string& name, const Database& database, std::vector<std::string> extra = {})
      : port(forklift::test::free_port()), domain(forklift::test::free_domain()), dir(testing::TempDir() + "/server-" + name),
        db(database.location) {
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    extra.insert(extra.begin(), {"--log-dir", dir + "/logs"});
    start(extra);
  }
  // On a copy of a school a test left behind (`folder`: its forklift.db and forklift.db.logs/, as
  // a server made them), so that tests may change the copy as they please.
  struct Copy {
    std::string folder;
  };
  // What of a server's folder makes its school: its database and its workers' logs.
  static constexpr const char* kSchoolParts[] = {"forklift.db", "forklift.db.logs"};
  Server(const std::string& name, const Copy& school, std::vector<std::string> extra = {})
      : port(forklift::test::free_port()), domain(forklift::test::free_domain()), dir(testing::TempDir() + "/server-" + name) {
    namespace fs = std::filesystem;
    fs::remove_all(dir);
    fs::create_directories(dir);
    for (const char* part : kSchoolParts)
      if (fs::exists(school.folder + "/" + part)) fs::copy(school.folder + "/" + part, dir + "/" + part, fs::copy_options::recursive);
    db = dir + "/forklift.db";
    start(extra);
  }
  // A failed test shows the server's own log (its last lines): the reason behind a 500 or a 503
  // is there, and a CI run keeps nothing else.
  ~Server() override {
    if (!proc || !testing::Test::HasFailure()) return;
    const std::string log = proc->err();
    const size_t keep = 6000;
    std::cerr << "--- forklift-server's log" << (log.size() > keep ? " (its end)" : "") << ":\n"
              << (log.size() > keep ? log.substr(log.size() - keep) : log) << "---\n";
  }
  // Stops it as a service manager would (SIGTERM), so that it finishes what it was writing.
  int stop(double timeout_s = 30) {
    proc->signal(SIGTERM);
    return proc->wait(timeout_s);
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
  httplib::Client client() const override {
    httplib::Client c(url());
    if (!ca.empty()) c.set_ca_cert_path(ca);
    return c;
  }
};

}  // namespace forklift_test
