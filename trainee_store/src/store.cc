// The store's functions that no backend owns: names, times, and which backend a location opens.
#include "forklift/store/store.h"

#include <cctype>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <string_view>

namespace forklift::store {

const char* role_name(Role role) {
  switch (role) {
    case Role::kAdmin: return "admin";
    case Role::kInstructor: return "instructor";
    case Role::kExaminer: return "examiner";
    case Role::kPupil: return "pupil";
  }
  return "unknown";  // not a Role; the schema's CHECK rejects it
}

std::optional<Role> parse_role(const std::string& name) {
  for (Role r : {Role::kAdmin, Role::kInstructor, Role::kExaminer, Role::kPupil}) {
    if (name == role_name(r)) return r;
  }
  return std::nullopt;
}

std::optional<std::string> canonical_username(const std::string& name) {
  if (name.empty() || name.size() > kMaxUsernameLength) return std::nullopt;
  std::string out = name;
  for (char& c : out) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-')) return std::nullopt;
  }
  return out;
}

std::string now_iso8601() { return iso8601_of(std::chrono::system_clock::to_time_t(std::chrono::system_clock::now())); }

std::string iso8601_of(std::time_t t) {
  std::tm utc{};
  gmtime_r(&t, &utc);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return buf;
}

std::string add_years_iso8601(const std::string& iso, int years) { return add_months_iso8601(iso, 12 * years); }

std::string add_months_iso8601(const std::string& iso, int months) {
  using namespace std::chrono;
  // Only the form the store writes, "YYYY-MM-DDTHH:MM:SSZ", so that times compare as strings.
  constexpr std::string_view kForm = "dddd-dd-ddTdd:dd:ddZ";
  bool ok = iso.size() == kForm.size();
  for (size_t i = 0; ok && i < iso.size(); ++i) {
    ok = kForm[i] == 'd' ? std::isdigit(static_cast<unsigned char>(iso[i])) != 0 : iso[i] == kForm[i];
  }
  auto field = [&](size_t pos, size_t len) {
    int v = 0;
    for (size_t i = pos; i < pos + len; ++i) v = v * 10 + (iso[i] - '0');
    return v;
  };
  if (ok) {
    const year_month_day date{year{field(0, 4)}, month{static_cast<unsigned>(field(5, 2))},
                              day{static_cast<unsigned>(field(8, 2))}};
    ok = date.ok() && field(11, 2) < 24 && field(14, 2) < 60 && field(17, 2) < 60;
  }
  if (!ok) throw StoreError(StoreError::kInvalid, "not an ISO-8601 UTC time (YYYY-MM-DDTHH:MM:SSZ): '" + iso + "'");

  const int total = field(0, 4) * 12 + (field(5, 2) - 1) + months;  // months since year 0
  const int y = total >= 0 ? total / 12 : -1;
  if (y < 0 || y > 9999) throw StoreError(StoreError::kInvalid, "year out of range adding to '" + iso + "'");
  const month m{static_cast<unsigned>(total % 12 + 1)};
  year_month_day date{year{y}, m, day{static_cast<unsigned>(field(8, 2))}};
  // A day the month has not (29 February into a common year, 31 March less a month): its last.
  if (!date.ok()) date = year_month_day{year{y} / m / last};
  char buf[32];
  std::snprintf(buf, sizeof buf, "%04d-%02u-%02u", y, static_cast<unsigned>(date.month()),
                static_cast<unsigned>(date.day()));
  return buf + iso.substr(10);
}

bool is_postgresql_location(const std::string& location) {
  return location.rfind("postgresql://", 0) == 0 || location.rfind("postgres://", 0) == 0;
}

std::string printable_location(const std::string& location) {
  if (!is_postgresql_location(location)) return location;
  std::string out = location;
  // postgresql://user:password@host...: the authority ends at the first '/', '?' or '#' after "//".
  const size_t authority = out.find("//") + 2;
  const size_t end = std::min(out.find_first_of("/?#", authority), out.size());
  const size_t at = out.rfind('@', end);
  if (at != std::string::npos && at >= authority) {
    const size_t colon = out.find(':', authority);
    if (colon < at) out.replace(colon + 1, at - colon - 1, "***");
  }
  // ...?password=secret&...
  for (size_t p = out.find("password=", authority); p != std::string::npos; p = out.find("password=", p + 1)) {
    if (out[p - 1] != '?' && out[p - 1] != '&') continue;
    const size_t value = p + 9;
    out.replace(value, std::min(out.find('&', value), out.size()) - value, "***");
  }
  return out;
}

std::unique_ptr<Store> Store::open(const std::string& location) {
  return is_postgresql_location(location) ? open_postgresql(location) : open_sqlite(location);
}

}  // namespace forklift::store
