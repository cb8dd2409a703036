// forklift-test-alloc: runs a test that is not C++ (tests/web/e2e.mjs) on a loopback port and a
// DDS domain from the tests' one allocator (support/ports.h), so that it never meets another test.
//
//   forklift-test-alloc COMMAND [ARGS...]
//
// Takes a port and a domain, puts them in FORKLIFT_TEST_PORT and FORKLIFT_TEST_DOMAIN, and exec()s
// COMMAND. COMMAND inherits the two locks and hands them on to its children, so both numbers stay
// taken until the last of them has exited, however it exits.
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>

#include "support/ports.h"

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: forklift-test-alloc COMMAND [ARGS...]\n"
                         "runs COMMAND with FORKLIFT_TEST_PORT and FORKLIFT_TEST_DOMAIN set to a free port and DDS domain\n");
    return 2;
  }
  try {
    const std::string port = std::to_string(forklift::test::free_port());
    const std::string domain = std::to_string(forklift::test::free_domain());
    setenv("FORKLIFT_TEST_PORT", port.c_str(), 1);
    setenv("FORKLIFT_TEST_DOMAIN", domain.c_str(), 1);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "forklift-test-alloc: %s\n", e.what());
    return 1;
  }
  forklift::test::keep_locks_across_exec();
  execvp(argv[1], argv + 1);
  std::fprintf(stderr, "forklift-test-alloc: cannot run %s: %s\n", argv[1], std::strerror(errno));
  return 127;
}
