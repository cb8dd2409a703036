#include "auth.h"

#include <sodium.h>

#include <algorithm>
#include <cmath>

#include "api.h"

namespace forklift::server {

namespace {

// Below this many entries a throttle table is never pruned: a sweep would cost more than it frees.
constexpr size_t kMinPruneAt = 1024;

Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

}  // namespace

// ---------------------------------------------------------------- passwords

std::string hash_password(const std::string& pw) {
  char out[crypto_pwhash_STRBYTES];
  if (crypto_pwhash_str(out, pw.c_str(), pw.size(), crypto_pwhash_OPSLIMIT_INTERACTIVE, crypto_pwhash_MEMLIMIT_INTERACTIVE) != 0)
    throw std::runtime_error("out of memory hashing a password");
  return out;
}

bool verify_password(const std::string& hash, const std::string& pw) {
  return crypto_pwhash_str_verify(hash.c_str(), pw.c_str(), pw.size()) == 0;
}

bool password_matches(const std::optional<store::User>& user, const std::string& password) {
  const bool matches = verify_password(user ? user->password_hash : decoy_hash(), password);
  return matches && user.has_value();
}

const std::string& decoy_hash() {
  static const std::string hash = [] {
    unsigned char raw[32];
    randombytes_buf(raw, sizeof raw);
    return hash_password(std::string(reinterpret_cast<const char*>(raw), sizeof raw));
  }();
  return hash;
}

std::string new_password_hash(const nlohmann::json& body) {
  const std::string pw = field<std::string>(body, "password");
  if (pw.size() < kMinPasswordLength)
    throw ApiError(400, "bad_request", "passwords have at least " + std::to_string(kMinPasswordLength) + " characters");
  return hash_password(pw);
}

// ---------------------------------------------------------------- Tokens

Tokens::Tokens(double ttl_s, size_t remember_expired) : ttl_(ttl_s), remember_expired_(remember_expired) {}

std::string Tokens::issue(const Principal& p) {
  unsigned char raw[32];
  randombytes_buf(raw, sizeof raw);
  char hex[65];
  sodium_bin2hex(hex, sizeof hex, raw, sizeof raw);
  const auto now = Clock::now();
  Principal q = p;
  q.expires = now + seconds(ttl_);
  std::lock_guard<std::mutex> lock(mu_);
  retire_expired(now);
  live_[hex] = q;
  by_expiry_.emplace_back(q.expires, hex);
  return hex;
}

Tokens::Check Tokens::check(const std::string& token) {
  std::lock_guard<std::mutex> lock(mu_);
  retire_expired(Clock::now());
  const auto it = live_.find(token);
  if (it != live_.end()) return {it->second, false};
  return {std::nullopt, expired_.count(token) > 0};
}

void Tokens::revoke(const std::string& token) {
  std::lock_guard<std::mutex> lock(mu_);
  live_.erase(token);
}

void Tokens::retire_expired(Clock::time_point now) {
  while (!by_expiry_.empty() && by_expiry_.front().first < now) {
    const std::string token = std::move(by_expiry_.front().second);
    by_expiry_.pop_front();
    if (live_.erase(token) == 0 || remember_expired_ == 0) continue;  // logged out meanwhile
    expired_.insert(token);
    expired_order_.push_back(token);
    if (expired_order_.size() > remember_expired_) {
      expired_.erase(expired_order_.front());
      expired_order_.pop_front();
    }
  }
}

// ---------------------------------------------------------------- LoginThrottle

LoginThrottle::LoginThrottle(Limits limits)
    : limits_(limits), window_(seconds(limits.window_s)), prune_at_users_(kMinPruneAt), prune_at_addresses_(kMinPruneAt) {}

LoginThrottle::Attempt::Attempt(LoginThrottle* throttle, std::string user, std::string address, int retry_after_s)
    : throttle_(throttle), user_(std::move(user)), address_(std::move(address)), retry_after_s_(retry_after_s) {}

LoginThrottle::Attempt::Attempt(Attempt&& other) noexcept
    : throttle_(std::exchange(other.throttle_, nullptr)), user_(std::move(other.user_)), address_(std::move(other.address_)),
      retry_after_s_(other.retry_after_s_) {}

LoginThrottle::Attempt::~Attempt() {
  if (throttle_) throttle_->end(user_, address_, false);
}

void LoginThrottle::Attempt::succeeded() {
  if (throttle_) std::exchange(throttle_, nullptr)->end(user_, address_, true);
}

LoginThrottle::Attempt LoginThrottle::attempt(const std::string& user, const std::string& address) {
  const auto now = Clock::now();
  std::lock_guard<std::mutex> lock(mu_);
  const auto w = std::max(wait(users_, user, limits_.per_user, now), wait(addresses_, address, limits_.per_address, now));
  if (w > Clock::duration::zero())
    return Attempt(nullptr, user, address, std::max(1, static_cast<int>(std::ceil(std::chrono::duration<double>(w).count()))));
  ++users_[user].checking;
  ++addresses_[address].checking;
  return Attempt(this, user, address, 0);
}

void LoginThrottle::end(const std::string& user, const std::string& address, bool ok) {
  const auto now = Clock::now();
  std::lock_guard<std::mutex> lock(mu_);
  --users_[user].checking;
  --addresses_[address].checking;
  if (ok) {
    Entry& e = users_[user];
    e.failures.clear();
    e.locked_until = {};
    return;
  }
  fail(users_, user, limits_.per_user, now);
  fail(addresses_, address, limits_.per_address, now);
  // Amortised: a sweep only once a table has doubled since the last one.
  if (users_.size() > prune_at_users_) {
    prune(users_, now);
    prune_at_users_ = std::max(kMinPruneAt, 2 * users_.size());
  }
  if (addresses_.size() > prune_at_addresses_) {
    prune(addresses_, now);
    prune_at_addresses_ = std::max(kMinPruneAt, 2 * addresses_.size());
  }
}

Clock::duration LoginThrottle::wait(Table& table, const std::string& key, int limit, Clock::time_point now) {
  const auto it = table.find(key);
  if (it == table.end()) return Clock::duration::zero();
  Entry& e = it->second;
  if (e.locked_until > now) return e.locked_until - now;
  while (!e.failures.empty() && e.failures.front() <= now - window_) e.failures.pop_front();
  // Full with attempts still being checked: those end within a second or so.
  if (static_cast<int>(e.failures.size()) + e.checking >= limit) return std::chrono::seconds(1);
  return Clock::duration::zero();
}

void LoginThrottle::fail(Table& table, const std::string& key, int limit, Clock::time_point now) {
  Entry& e = table[key];
  while (!e.failures.empty() && e.failures.front() <= now - window_) e.failures.pop_front();
  e.failures.push_back(now);
  if (static_cast<int>(e.failures.size()) < limit) return;
  e.locked_until = now + window_;
  e.failures.clear();  // the lockout is the penalty; afterwards the count starts again
}

void LoginThrottle::prune(Table& table, Clock::time_point now) {
  for (auto it = table.begin(); it != table.end();) {
    const Entry& e = it->second;
    const bool idle = e.checking == 0 && e.locked_until <= now && (e.failures.empty() || e.failures.back() <= now - window_);
    it = idle ? table.erase(it) : std::next(it);
  }
}

}  // namespace forklift::server
