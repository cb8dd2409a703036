// Logins: the passwords' hashes, the bearer tokens the server hands out, and the limit on failed
// password attempts. Tokens and failures live in memory only: a restarted server forgets them.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <nlohmann/json.hpp>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>

#include "forklift/store/store.h"

namespace forklift::server {

using Clock = std::chrono::steady_clock;

constexpr size_t kMinPasswordLength = 8;

// Argon2id, libsodium's interactive limits: memory-hard, about 0.1 s per hash here.
std::string hash_password(const std::string& pw);
bool verify_password(const std::string& hash, const std::string& pw);
// The hash of a request body's new "password" (400 if missing or shorter than
// kMinPasswordLength): hash it before taking any write lock, it takes 0.1 s.
std::string new_password_hash(const nlohmann::json& body);

// Who a token speaks for.
struct Principal {
  int64_t user_id = 0;
  std::string username;
  store::Role role = store::Role::kPupil;
  int64_t school_id = 0;
  std::optional<int64_t> pupil_id;
  Clock::time_point expires;
};

// Random tokens, each valid for one TTL after login or until logout.
class Tokens {
 public:
  // What check() found: the login, or none, and then whether the token was real but ran out.
  struct Check {
    std::optional<Principal> principal;
    bool expired = false;
  };

  // `remember_expired`: how many expired tokens are kept (newest first) to tell "expired" from
  // "unknown" in a refusal; older ones read as unknown.
  explicit Tokens(double ttl_s, size_t remember_expired = 10000);
  std::string issue(const Principal& p);
  Check check(const std::string& token);
  void revoke(const std::string& token);  // a revoked token reads as unknown, not expired
  double ttl() const { return ttl_; }

 private:
  void retire_expired(Clock::time_point now);  // with mu_ held

  double ttl_;
  size_t remember_expired_;
  std::mutex mu_;
  std::map<std::string, Principal> live_;
  // Every TTL is the same, so issue order is expiry order: retiring pops from the front.
  std::deque<std::pair<Clock::time_point, std::string>> by_expiry_;
  std::set<std::string> expired_;
  std::deque<std::string> expired_order_;  // oldest first, to forget beyond remember_expired_
};

// Failed logins counted per username and per client address over a sliding window. A name or an
// address with `limit` failures in the window is locked out for one window, right password or
// not. Memory: entries idle for a window are pruned whenever the table has doubled.
class LoginThrottle {
 public:
  struct Limits {
    int per_user = 5;
    int per_address = 20;  // higher: a school's stations often reach the server from one address
    double window_s = 60;
  };

  explicit LoginThrottle(Limits limits);
  // Whole seconds until `user` from `address` may try again; 0: now.
  int retry_after(const std::string& user, const std::string& address);
  void failed(const std::string& user, const std::string& address);
  void succeeded(const std::string& user);  // forgets the name's failures (not the address's)

 private:
  struct Entry {
    std::deque<Clock::time_point> failures;  // within the window, oldest first
    Clock::time_point locked_until{};
  };
  using Table = std::unordered_map<std::string, Entry>;

  void fail(Table& table, const std::string& key, int limit, Clock::time_point now);
  Clock::duration locked_for(const Table& table, const std::string& key, Clock::time_point now) const;
  void prune(Table& table, Clock::time_point now);

  Limits limits_;
  Clock::duration window_;
  std::mutex mu_;
  Table users_, addresses_;
  size_t prune_at_users_, prune_at_addresses_;
};

}  // namespace forklift::server
