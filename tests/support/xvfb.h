// A real X server for a test's windows: Xvfb picks a free display number itself (-displayfd),
// so parallel tests never share one.
#pragma once

#include <gtest/gtest.h>
#include <stdlib.h>

#include <chrono>
#include <fstream>
#include <string>
#include <thread>

#include "support/process.h"
#include "support/temp_dir.h"

namespace forklift_test {

class Xvfb {
 public:
  Xvfb()
      : prefix_(process_path("xvfb", "server")),
        server_({"/usr/bin/Xvfb", "-displayfd", "1", "-screen", "0", "1280x1024x24", "-nolisten", "tcp"}, prefix_) {
    for (int i = 0; i < 1000 && display_.empty(); ++i) {
      std::ifstream in(prefix_ + ".out");
      std::string n;
      if (in >> n && !n.empty()) display_ = ":" + n;
      else std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  ~Xvfb() { server_.signal(SIGTERM); server_.wait(5); }
  const std::string& display() const { return display_; }  // empty if it did not start

 private:
  std::string prefix_;
  ::Process server_;
  std::string display_;
};

// A test whose programs open windows: its own Xvfb, DISPLAY set to it, SDL's sound silent.
class WindowTest : public testing::Test {
 protected:
  void SetUp() override {
    ASSERT_FALSE(x_.display().empty()) << "Xvfb did not start";
    setenv("DISPLAY", x_.display().c_str(), 1);
    setenv("SDL_AUDIODRIVER", "dummy", 1);
  }
  Xvfb x_;
};

}  // namespace forklift_test
