// The tests' one allocator of loopback ports and DDS domains (support/ports.h) between real
// processes: a number held is nobody else's until its holder ends, forklift-test-alloc keeps its
// numbers for the program it runs, and two runs of one server test at once both pass.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "support/ports.h"
#include "support/process.h"
#include "support/temp_dir.h"

namespace {

namespace ports = forklift::test::ports_detail;

std::string tmp(const std::string& name) { return forklift_test::process_path("ports", name); }

TEST(Ports, ANumberIsNobodyElsesUntilTheProcessHoldingItEnds) {
  int pipe_fds[2];
  ASSERT_EQ(pipe(pipe_fds), 0);
  const pid_t holder = fork();
  ASSERT_GE(holder, 0);
  if (holder == 0) {
    const int port = forklift::test::free_port();
    if (write(pipe_fds[1], &port, sizeof port) != sizeof port) _exit(1);
    pause();  // until killed
    _exit(0);
  }
  close(pipe_fds[1]);
  int port = 0;
  ASSERT_EQ(read(pipe_fds[0], &port, sizeof port), static_cast<ssize_t>(sizeof port));
  close(pipe_fds[0]);
  EXPECT_GE(port, 20000);
  EXPECT_LE(port, 32000);
  EXPECT_FALSE(ports::try_hold("port-" + std::to_string(port))) << "port " << port << " is another process's";
  kill(holder, SIGKILL);
  waitpid(holder, nullptr, 0);
  EXPECT_TRUE(ports::try_hold("port-" + std::to_string(port))) << "a killed holder's port " << port << " is free again";
  // In one process too, no number is handed out twice.
  const int a = forklift::test::free_domain(), b = forklift::test::free_domain();
  EXPECT_NE(a, b);
}

// The web test's launcher: the program it runs gets a port and a domain in its environment, and
// both stay taken while that program lives (it inherits the locks) and are free once it has gone.
TEST(Ports, TheLauncherHoldsItsNumbersForTheProgramItRuns) {
  const std::string out = tmp("launched");
  Process p({TEST_ALLOC_BIN, "/bin/sh", "-c", "echo $FORKLIFT_TEST_PORT $FORKLIFT_TEST_DOMAIN; exec sleep 60"}, out);
  int port = 0, domain = 0;
  for (int i = 0; i < 1000 && domain == 0; ++i) {
    std::ifstream in(out + ".out");
    if (!(in >> port >> domain)) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_GT(domain, 0) << p.err();
  EXPECT_GE(port, 20000);
  EXPECT_LE(port, 32000);
  EXPECT_LE(domain, 230);
  EXPECT_FALSE(ports::try_hold("port-" + std::to_string(port))) << "the running program's port";
  EXPECT_FALSE(ports::try_hold("domain-" + std::to_string(domain))) << "the running program's domain";
  p.signal(SIGKILL);
  p.wait(10);
  EXPECT_TRUE(ports::try_hold("port-" + std::to_string(port)));
  EXPECT_TRUE(ports::try_hold("domain-" + std::to_string(domain)));

  Process usage({TEST_ALLOC_BIN}, tmp("usage"));
  EXPECT_EQ(usage.wait(10), 2);
  EXPECT_NE(usage.err().find("usage: forklift-test-alloc COMMAND"), std::string::npos) << usage.err();
}

// Two runs of one server test at once, as from two build trees (each its own temporary folder):
// both pass. With fixed numbers both servers bound one port (SO_REUSEPORT) and each run's
// requests reached the other's server.
TEST(Ports, TwoRunsOfOneServerTestAtOnceBothPass) {
  std::vector<std::unique_ptr<Process>> runs;
  for (const std::string run : {"a", "b"}) {
    const std::string dir = tmp("run-" + run);
    std::filesystem::create_directories(dir);
    runs.push_back(std::make_unique<Process>(
        std::vector<std::string>{"/usr/bin/env", "TEST_TMPDIR=" + dir, SERVER_TEST_BIN, "--gtest_filter=Server.LoginRolesAndVisibility"},
        dir + "/server_test"));
  }
  for (auto& r : runs) EXPECT_EQ(r->wait(120), 0) << r->out() << r->err();
}

}  // namespace
