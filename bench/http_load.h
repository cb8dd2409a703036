// HTTP load for the benchmarks: keep-alive clients asking a path back to back, and the latencies
// they saw (forklift-bench-server, forklift-bench-ingest).
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <httplib.h>

#include "support/loopback.h"

namespace forklift::bench {

using Clock = std::chrono::steady_clock;

inline double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

struct Load {
  double seconds = 0;
  std::vector<double> latency_ms;
  long errors = 0;
  double rps() const { return latency_ms.size() / seconds; }
  double pct(double q) const {
    if (latency_ms.empty()) return NAN;
    return latency_ms[std::min(latency_ms.size() - 1, size_t(q * latency_ms.size()))];
  }
};

// GETs on a kept-alive HTTP/1.1 connection (tests/support/loopback.h), with no more work than
// reading the answers whole: the load runs on the same two cores as the server, and httplib's
// client took a sixth of them from it. A connection told "Connection: close", or failing, is
// opened again for the next request.
class LoadClient {
 public:
  LoadClient(int port, const std::string& token) : port_(port), auth_("Authorization: Bearer " + token + "\r\n") {}

  // The answer's status, its whole body read; 0 if there was none.
  int get(const std::string& path) {
    if (!c_) c_ = std::make_unique<forklift_test::KeptConnection>(port_, 10);
    const std::string head = c_->ask("GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\n" + auth_ + "\r\n");
    const bool answered = head.rfind("HTTP/1.1 ", 0) == 0;
    if (!answered || forklift_test::says_close(head)) c_.reset();
    return answered ? std::atoi(head.c_str() + 9) : 0;
  }

 private:
  int port_;
  std::string auth_;  // the header line
  std::unique_ptr<forklift_test::KeptConnection> c_;
};

// `clients` keep-alive connections, each asking path(i) back to back for `seconds`.
// With `per_client_rps`, each client asks at that pace (an open loop, as pages poll) rather than
// back to back.
inline Load hammer(int port, const std::string& token, int clients, double seconds,
                   const std::function<std::string(std::mt19937&)>& path, double per_client_rps = 0) {
  std::vector<std::vector<double>> lat(clients);
  std::atomic<long> errors{0};
  std::vector<std::thread> threads;
  const auto t0 = Clock::now();
  for (int c = 0; c < clients; ++c) {
    threads.emplace_back([&, c] {
      LoadClient cli(port, token);
      std::mt19937 rng(c + 1);
      auto next = Clock::now();
      while (ms_since(t0) < seconds * 1e3) {
        if (per_client_rps > 0) {
          std::this_thread::sleep_until(next);
          next += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1 / per_client_rps));
        }
        const std::string p = path(rng);
        const auto t = Clock::now();
        if (cli.get(p) != 200) ++errors;
        else lat[c].push_back(ms_since(t));
      }
    });
  }
  for (auto& t : threads) t.join();
  Load l;
  l.seconds = ms_since(t0) / 1e3;
  for (auto& v : lat) l.latency_ms.insert(l.latency_ms.end(), v.begin(), v.end());
  std::sort(l.latency_ms.begin(), l.latency_ms.end());
  l.errors = errors;
  return l;
}

// Whether a server just started answers GET /api/health within 20 s.
inline bool answers_health(httplib::Client& c) {
  for (int i = 0; i < 400; ++i) {
    if (auto r = c.Get("/api/health"); r && r->status == 200) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

}  // namespace forklift::bench
