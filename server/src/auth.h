// Logins: the passwords' hashes, the bearer tokens the server hands out, and the limit on failed
// password attempts. Tokens and failures live in the store: every server sharing it sees them, and
// a restarted server forgets none.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "forklift/server/server.h"
#include "forklift/store/store.h"

namespace forklift::server {

constexpr size_t kMinPasswordLength = 8;

// Passwords' hashes: Argon2id, memory-hard, at the school's cost (ServerConfig::password_cost;
// interactive, libsodium's default, is about 0.1 s and 64 MiB per hash here).
class Passwords {
 public:
  // Makes the decoy's hash now, not in the time of the first login of an unknown username.
  explicit Passwords(PasswordCost cost);
  std::string hash(const std::string& pw) const;
  // The hash of a request body's new "password" (400 if missing or shorter than
  // kMinPasswordLength): hash it before taking any write lock, it takes 0.1 s.
  std::string new_hash(const nlohmann::json& body) const;
  // Whether `password` is `user`'s, at the cost its hash was made with. With no user it is
  // checked against a decoy of the same cost, so that a username nobody has is refused as slowly
  // as a wrong password (else the time of an answer tells which usernames exist).
  bool matches(const std::optional<store::User>& user, const std::string& password) const;

 private:
  PasswordCost cost_;
  std::string decoy_;  // the hash of a random password nobody knows
};

// Who a token speaks for.
struct Principal {
  int64_t user_id = 0;
  std::string username;
  store::Role role = store::Role::kPupil;
  int64_t school_id = 0;
  std::optional<int64_t> pupil_id;
  int64_t expires_at_ms = 0;  // Unix time
  // The account's store::User::login_generation at login: a token of an earlier one is refused.
  int64_t login_generation = 0;
};

// Unix time in milliseconds: the clock tokens and failed logins are kept by, shared with the other
// servers on the store (so their clocks must agree to well within a token's TTL and a window).
int64_t unix_ms();

// Random tokens, each valid for one TTL after login or until logout. The store keeps them (their
// SHA-256 only), so every server sharing it honours, expires and revokes them alike, and a
// restart forgets none; nothing is cached here, so a logout holds on every server at once.
class Tokens {
 public:
  // What check() found: the login, or none, and then whether the token was real but ran out;
  // with the account as it is now.
  struct Check {
    std::optional<Principal> principal;
    bool expired = false;
    std::optional<store::User> user;
  };

  // `remember_expired_s`: how long an expired token is kept to tell "expired" from "unknown" in
  // a refusal; after that it reads as unknown.
  explicit Tokens(double ttl_s, double remember_expired_s = 24 * 3600);
  std::string issue(store::LoginStore& db, const Principal& p);
  Check check(store::LoginStore& db, const std::string& token);
  // The store's key of `token` (its SHA-256 in hex), or empty for one never issued (not 64
  // lower-case hex digits): nothing to look up.
  static std::string key_of(const std::string& token);
  // check() of a token that the caller looked up by its key_of() with its page (none: not found).
  Check checked(const std::optional<store::LoginToken>& found) const;
  void revoke(store::LoginStore& db, const std::string& token);  // a revoked token reads as unknown, not expired
  double ttl() const { return ttl_; }

 private:
  double ttl_;
  int64_t remember_expired_ms_;
};

// Failed attempts counted per username and per client address over a sliding window, in the
// store, so that a lockout on one server holds on every server sharing it. A name or an address
// with `limit` failures in the window is locked out for one window, right password or not. An
// attempt counts from the moment it is let in, before its slow password check: while attempts
// are being checked, no more are let in than the failures the limit still allows, so that
// parallel attempts (through any server) cannot check more passwords than the limit.
class LoginThrottle {
 public:
  struct Limits {
    int per_user = 5;
    int per_address = 20;  // higher: a school's stations often reach the server from one address
    double window_s = 60;
  };

  // The store's keys of an attempt, the username's first, each with its limit.
  using Keys = std::vector<std::pair<std::string, int>>;

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
    Attempt(const LoginThrottle* throttle, store::Store* db, Keys keys, std::vector<int64_t> ids, int retry_after_s);
    const LoginThrottle* throttle_;  // null once ended, or if not let in
    store::Store* db_;
    Keys keys_;
    std::vector<int64_t> ids_;  // the attempt's row under each key
    int retry_after_s_;
  };

  // `name` sets these attempts apart from another throttle's in the store ("login", "certificate").
  LoginThrottle(std::string name, Limits limits);
  // An attempt by `user` from `address`, counted in `db` (the calling thread's store, which the
  // attempt uses again when it ends).
  Attempt attempt(store::Store& db, const std::string& user, const std::string& address) const;

 private:
  void end(store::Store& db, const Keys& keys, const std::vector<int64_t>& ids, bool ok) const;

  std::string name_;
  Limits limits_;
  int64_t window_ms_;
};

}  // namespace forklift::server
