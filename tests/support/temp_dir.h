// A folder of this test process's own under the test temp dir: ctest runs each test in its own
// process, several at once, so fixed names would collide.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

namespace forklift_test {

// `prefix`-<pid>/name, the folder created on first use.
inline std::string process_path(const std::string& prefix, const std::string& name) {
  const std::string dir = testing::TempDir() + "/" + prefix + "-" + std::to_string(getpid());
  std::filesystem::create_directories(dir);
  return dir + "/" + name;
}

}  // namespace forklift_test
