// The machine's own stalls, watched in the same window as a latency figure (a baseline measured
// in the same run, as cyclictest measures it): one thread per CPU, pinned to it, at SCHED_FIFO 99
// where allowed, sleeps to the next whole period and notes how late it woke. No program's work
// can hold such a thread back for long: on a quiet development VM it wakes 63 us late (median;
// 95 us p99), so one late by more than 0.2 ms means the CPU itself was taken away (a virtual
// CPU the host did not run, or one woken late from halt).
//
// Why the round trip needs it: traced with ftrace on the development VM (sched and irq events),
// the round trip's slow samples were threads shown running for 4-12 ms without progress, and a
// SCHED_FIFO thread taking 0.8 ms to preempt a normal one; the VM reports no steal time. A
// sample whose window holds such a stall measures the host, not the worker.
#pragma once

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

namespace forklift::bench {

class StallWatch {
 public:
  using Clock = std::chrono::steady_clock;
  struct Stall {
    Clock::time_point from, to;  // the CPU was gone at least from `from` (the wake-up due) to `to`
  };

  // Watches every CPU this process may run on, waking every `period`; a wake-up later than
  // `late` counts as a stall.
  explicit StallWatch(std::chrono::microseconds period = std::chrono::microseconds(1000),
                      std::chrono::microseconds late = std::chrono::microseconds(200))
      : period_(period), late_(late) {
    cpu_set_t mine;
    CPU_ZERO(&mine);
    sched_getaffinity(0, sizeof mine, &mine);
    for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu)
      if (CPU_ISSET(cpu, &mine)) cpus_.push_back(cpu);
    stalls_.resize(cpus_.size());
    wakeups_.assign(cpus_.size(), 0);
    for (size_t k = 0; k < cpus_.size(); ++k) threads_.emplace_back([this, k] { watch(k); });
  }
  ~StallWatch() { stop(); }
  StallWatch(const StallWatch&) = delete;
  StallWatch& operator=(const StallWatch&) = delete;

  void stop() {
    running_ = false;
    for (std::thread& t : threads_)
      if (t.joinable()) t.join();
  }

  // After stop(): whether any CPU stalled within [from, to].
  bool stalled(Clock::time_point from, Clock::time_point to) const {
    for (const auto& cpu : stalls_)
      for (const Stall& s : cpu)
        if (s.from < to && s.to > from) return true;
    return false;
  }
  // After stop(): every stall, the longest, and whether every watcher ran at SCHED_FIFO.
  size_t count() const {
    size_t n = 0;
    for (const auto& cpu : stalls_) n += cpu.size();
    return n;
  }
  double longest_ms() const {
    double ms = 0;
    for (const auto& cpu : stalls_)
      for (const Stall& s : cpu) ms = std::max(ms, std::chrono::duration<double, std::milli>(s.to - s.from).count());
    return ms;
  }
  long wakeups() const {
    long n = 0;
    for (long w : wakeups_) n += w;
    return n;
  }
  bool fifo() const { return fifo_; }
  size_t cpus() const { return cpus_.size(); }
  double late_ms() const { return std::chrono::duration<double, std::milli>(late_).count(); }

 private:
  void watch(size_t k) {
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(cpus_[k], &one);
    pthread_setaffinity_np(pthread_self(), sizeof one, &one);
    sched_param p{};
    p.sched_priority = sched_get_priority_max(SCHED_FIFO);
    if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &p) != 0) fifo_ = false;
    auto due = Clock::now();
    while (running_) {
      due += period_;
      std::this_thread::sleep_until(due);
      const auto woke = Clock::now();
      ++wakeups_[k];
      if (woke - due > late_) stalls_[k].push_back({due, woke});
      if (woke - due > period_) due = woke;  // the next wake-up a whole period on, not a burst
    }
  }

  std::chrono::microseconds period_, late_;
  std::vector<int> cpus_;
  std::vector<std::vector<Stall>> stalls_;  // each written by its own watcher only, read after stop()
  std::vector<long> wakeups_;
  std::atomic<bool> running_{true}, fifo_{true};
  std::vector<std::thread> threads_;
};

}  // namespace forklift::bench
