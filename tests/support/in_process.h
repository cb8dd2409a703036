// The server library (forklift_server_core) for a test in this process: its configuration in a
// fresh folder, with an empty bin/ (no worker ever starts), the shipped data and the tests' admin.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "forklift/server/server.h"
#include "support/api_client.h"

namespace forklift_test {

// `dir` emptied, its SQLite file, in DDS domain `domain` (from support/ports.h).
inline forklift::server::ServerConfig in_process_config(const std::string& dir, int domain) {
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir + "/bin");
  forklift::server::ServerConfig c;
  c.db_path = dir + "/forklift.db";
  c.data_dir = FORKLIFT_DATA_DIR;
  c.bin_dir = dir + "/bin";
  c.admin_password = kAdminPassword;
  c.dds_domain = domain;
  // As a server process started by the test would take it (tests/support/test_environment.cc).
  if (const char* cost = std::getenv("FORKLIFT_PASSWORD_COST"))
    if (const auto parsed = forklift::server::parse_password_cost(cost)) c.password_cost = *parsed;
  return c;
}

}  // namespace forklift_test
