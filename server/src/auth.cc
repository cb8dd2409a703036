#include "auth.h"

#include <sodium.h>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "api.h"

namespace forklift::server {

namespace {

int64_t ms_of(double s) { return static_cast<int64_t>(std::llround(s * 1000)); }

// The store's name of a token: its SHA-256 in hex, so that the database never holds a login.
std::string token_hash(const std::string& token) {
  unsigned char digest[crypto_hash_sha256_BYTES];
  crypto_hash_sha256(digest, reinterpret_cast<const unsigned char*>(token.data()), token.size());
  char hex[2 * sizeof digest + 1];
  sodium_bin2hex(hex, sizeof hex, digest, sizeof digest);
  return hex;
}

}  // namespace

int64_t unix_ms() {
  using namespace std::chrono;
  return duration_cast<std::chrono::milliseconds>(system_clock::now().time_since_epoch()).count();
}

// ---------------------------------------------------------------- passwords

namespace {

struct PasswordCostLevel {
  PasswordCost cost;
  const char* name;
  unsigned long long passes;
  size_t memory_bytes;
};
constexpr PasswordCostLevel kPasswordCosts[] = {
    {PasswordCost::kInteractive, "interactive", crypto_pwhash_OPSLIMIT_INTERACTIVE, crypto_pwhash_MEMLIMIT_INTERACTIVE},
    {PasswordCost::kModerate, "moderate", crypto_pwhash_OPSLIMIT_MODERATE, crypto_pwhash_MEMLIMIT_MODERATE},
    {PasswordCost::kSensitive, "sensitive", crypto_pwhash_OPSLIMIT_SENSITIVE, crypto_pwhash_MEMLIMIT_SENSITIVE},
    {PasswordCost::kTest, "test", crypto_pwhash_OPSLIMIT_MIN, crypto_pwhash_MEMLIMIT_MIN},
};

const PasswordCostLevel& level_of(PasswordCost cost) {
  for (const auto& l : kPasswordCosts)
    if (l.cost == cost) return l;
  return kPasswordCosts[0];
}

}  // namespace

const char* name(PasswordCost cost) { return level_of(cost).name; }

std::optional<PasswordCost> parse_password_cost(const std::string& text) {
  for (const auto& l : kPasswordCosts)
    if (text == l.name) return l.cost;
  return std::nullopt;
}

Passwords::Passwords(PasswordCost cost) : cost_(cost) {
  unsigned char raw[32];
  randombytes_buf(raw, sizeof raw);
  decoy_ = hash(std::string(reinterpret_cast<const char*>(raw), sizeof raw));
}

std::string Passwords::hash(const std::string& pw) const {
  const PasswordCostLevel& l = level_of(cost_);
  char out[crypto_pwhash_STRBYTES];
  if (crypto_pwhash_str(out, pw.c_str(), pw.size(), l.passes, l.memory_bytes) != 0)
    throw std::runtime_error("out of memory hashing a password");
  return out;
}

bool Passwords::matches(const std::optional<store::User>& user, const std::string& password) const {
  const std::string& hash = user ? user->password_hash : decoy_;
  const bool matches = crypto_pwhash_str_verify(hash.c_str(), password.c_str(), password.size()) == 0;
  return matches && user.has_value();
}

std::string Passwords::new_hash(const nlohmann::json& body) const {
  const std::string pw = field<std::string>(body, "password");
  if (pw.size() < kMinPasswordLength)
    throw ApiError(400, "bad_request", "passwords have at least " + std::to_string(kMinPasswordLength) + " characters");
  return hash(pw);
}

// ---------------------------------------------------------------- Tokens

Tokens::Tokens(double ttl_s, double remember_expired_s) : ttl_(ttl_s), remember_expired_ms_(ms_of(remember_expired_s)) {}

std::string Tokens::issue(store::LoginStore& db, const Principal& p) {
  unsigned char raw[32];
  randombytes_buf(raw, sizeof raw);
  char hex[65];
  sodium_bin2hex(hex, sizeof hex, raw, sizeof raw);
  const int64_t now = unix_ms();
  store::LoginToken t;
  t.hash = token_hash(hex);
  t.user_id = p.user_id;
  t.login_generation = p.login_generation;
  t.expires_at_ms = now + ms_of(ttl_);
  db.add_login_token(t);
  // Each login sweeps the tokens long expired (an index range: a few rows at a time).
  db.forget_login_tokens(now - remember_expired_ms_);
  return hex;
}

std::string Tokens::key_of(const std::string& token) {
  // Not hex of the right length: never issued, and not worth a look-up.
  if (token.size() != 64 || token.find_first_not_of("0123456789abcdef") != std::string::npos) return "";
  return token_hash(token);
}

Tokens::Check Tokens::check(store::LoginStore& db, const std::string& token) {
  const std::string key = key_of(token);
  return key.empty() ? Check{} : checked(db.find_login_token(key));
}

Tokens::Check Tokens::checked(const std::optional<store::LoginToken>& t) const {
  if (!t) return {};
  if (t->expires_at_ms <= unix_ms()) return {std::nullopt, true, t->user};
  const store::User& u = t->user;
  return {Principal{u.id, u.username, u.role, u.school_id, u.pupil_id, t->expires_at_ms, t->login_generation}, false, u};
}

void Tokens::revoke(store::LoginStore& db, const std::string& token) { db.delete_login_token(token_hash(token)); }

// ---------------------------------------------------------------- LoginThrottle

LoginThrottle::LoginThrottle(std::string name, Limits limits)
    : name_(std::move(name)), limits_(limits), window_ms_(ms_of(limits.window_s)) {}

LoginThrottle::Attempt::Attempt(const LoginThrottle* throttle, store::Store* db, Keys keys, std::vector<int64_t> ids,
                                int retry_after_s)
    : throttle_(throttle), db_(db), keys_(std::move(keys)), ids_(std::move(ids)), retry_after_s_(retry_after_s) {}

LoginThrottle::Attempt::Attempt(Attempt&& other) noexcept
    : throttle_(std::exchange(other.throttle_, nullptr)), db_(other.db_), keys_(std::move(other.keys_)), ids_(std::move(other.ids_)),
      retry_after_s_(other.retry_after_s_) {}

LoginThrottle::Attempt::~Attempt() {
  if (throttle_) throttle_->end(*db_, keys_, ids_, false);
}

void LoginThrottle::Attempt::succeeded() {
  if (throttle_) std::exchange(throttle_, nullptr)->end(*db_, keys_, ids_, true);
}

LoginThrottle::Attempt LoginThrottle::attempt(store::Store& db, const std::string& user, const std::string& address) const {
  Keys keys = {{name_ + ":user:" + user, limits_.per_user}, {name_ + ":address:" + address, limits_.per_address}};
  const int64_t now = unix_ms();
  int64_t wait_ms = 0;
  std::vector<int64_t> ids;
  // Counted and let in in one transaction: the store's write lock orders attempts from every server.
  db.batch([&] {
    for (const auto& [key, limit] : keys) {
      const store::AttemptCount c = db.count_attempts(key, now - window_ms_);
      if (c.locked_until_ms > now) wait_ms = std::max(wait_ms, c.locked_until_ms - now);
      // Full with attempts still being checked: those end within a second or so.
      else if (c.counted >= limit) wait_ms = std::max<int64_t>(wait_ms, 1000);
    }
    if (wait_ms > 0) return;
    for (const auto& k : keys) ids.push_back(db.add_attempt(k.first, now));
  });
  if (wait_ms > 0) return Attempt(nullptr, &db, {}, {}, static_cast<int>((wait_ms + 999) / 1000));
  return Attempt(this, &db, std::move(keys), std::move(ids), 0);
}

void LoginThrottle::end(store::Store& db, const Keys& keys, const std::vector<int64_t>& ids, bool ok) const {
  const int64_t now = unix_ms();
  try {
    db.batch([&] {
      for (const int64_t id : ids) db.end_attempt(id, !ok, now);
      if (ok) return db.reset_attempts(keys[0].first, 0);  // the name's failures, not the address's
      for (const auto& [key, limit] : keys) {
        const store::AttemptCount c = db.count_attempts(key, now - window_ms_);
        // The lockout is the penalty; afterwards the count starts again.
        if (c.counted - c.pending >= limit) db.reset_attempts(key, now + window_ms_);
      }
      db.forget_attempts(now - window_ms_);
    });
  } catch (const std::exception& e) {
    // Runs in a destructor: never throws. The attempt stays counted until its window passes.
    spdlog::warn("{} attempt not ended in the store: {}", name_, e.what());
  }
}

}  // namespace forklift::server
