// A cab that is no process, on a thread of the test: its own participant's writer sends the
// cab's controls 50 times a second (a gentle drive, `accelerator`) while `speaking` is set, until
// it is destroyed. For tests about what a worker or a server does while a cab keeps talking.
#pragma once

#include <atomic>
#include <chrono>
#include <string>
#include <thread>

#include "forklift/protocol/protocol.h"

namespace forklift_test {

class SpeakingCab {
 public:
  SpeakingCab(forklift::dds::Participant& p, const std::string& cab, double accelerator = 0)
      : out_(p, forklift::dds::cab_partition(cab)), thread_([this, cab, accelerator] {
          fk_Controls c{};
          forklift::dds::set_string(c.cab_id, cab);
          c.accelerator = accelerator;
          for (uint32_t seq = 1; !stop_; std::this_thread::sleep_for(std::chrono::milliseconds(20))) {
            if (!speaking) continue;
            c.seq = seq++;
            out_.write(c);
          }
        }) {}
  ~SpeakingCab() {
    stop_ = true;
    thread_.join();
  }
  SpeakingCab(const SpeakingCab&) = delete;
  SpeakingCab& operator=(const SpeakingCab&) = delete;

  std::atomic<bool> speaking{true};

 private:
  forklift::dds::Writer<fk_Controls> out_;
  std::atomic<bool> stop_{false};
  std::thread thread_;  // last: it starts once the rest is made
};

}  // namespace forklift_test
