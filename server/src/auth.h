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
// Whether `password` is `user`'s. With no user it is checked against decoy_hash(), so that a
// username nobody has is refused as slowly as a wrong password (else the time of an answer tells
// which usernames exist).
bool password_matches(const std::optional<store::User>& user, const std::string& password);
// The hash of a random password nobody knows, made at the first call (0.1 s): make it at start.
const std::string& decoy_hash();

// Who a token speaks for.
struct Principal {
  int64_t user_id = 0;
  std::string username;
  store::Role role = store::Role::kPupil;
  int64_t school_id = 0;
  std::optional<int64_t> pupil_id;
  Clock::time_point expires;
  // The account's store::User::login_generation at login: a token of an earlier one is refused.
  int64_t login_generation = 0;
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
// not. An attempt counts from the moment it is let in, before its slow password check: while
// attempts are being checked, no more are let in than the failures the limit still allows, so
// that parallel attempts cannot check more passwords than the limit. Memory: entries idle for a
// window are pruned whenever the table has doubled.
class LoginThrottle {
 public:
  struct Limits {
    int per_user = 5;
    int per_address = 20;  // higher: a school's stations often reach the server from one address
    double window_s = 60;
  };

  // One login attempt, let in or not. Let in, it ends as a failure unless succeeded() is called.
  class Attempt {
   public:
    Attempt(Attempt&& other) noexcept;
    Attempt& operator=(Attempt&&) = delete;
    ~Attempt();
    // Whole seconds until the username and address may try again; 0: this attempt was let in.
    int retry_after_s() const { return retry_after_s_; }
    void succeeded();  // forgets the name's failures (not the address's)

   private:
    friend class LoginThrottle;
    Attempt(LoginThrottle* throttle, std::string user, std::string address, int retry_after_s);
    LoginThrottle* throttle_;  // null once ended, or if not let in
    std::string user_, address_;
    int retry_after_s_;
  };

  explicit LoginThrottle(Limits limits);
  Attempt attempt(const std::string& user, const std::string& address);

 private:
  struct Entry {
    std::deque<Clock::time_point> failures;  // within the window, oldest first
    int checking = 0;                        // attempts let in and not yet ended
    Clock::time_point locked_until{};
  };
  using Table = std::unordered_map<std::string, Entry>;

  void end(const std::string& user, const std::string& address, bool ok);
  // The wait before `key` may try, with `now`'s failures expired; zero: it may.
  Clock::duration wait(Table& table, const std::string& key, int limit, Clock::time_point now);
  void fail(Table& table, const std::string& key, int limit, Clock::time_point now);
  void prune(Table& table, Clock::time_point now);

  Limits limits_;
  Clock::duration window_;
  std::mutex mu_;
  Table users_, addresses_;
  size_t prune_at_users_, prune_at_addresses_;
};

}  // namespace forklift::server
