// Numbers as a person reads them, written once for every program's words, tables and files.
#pragma once

#include <cstdio>
#include <string>

namespace forklift {

// `v` with exactly `decimals` digits after the point ("1.50"): columns that line up. Never "-0.0":
// a value that rounds to zero has no sign.
inline std::string fixed_decimals(double v, int decimals) {
  const int n = std::snprintf(nullptr, 0, "%.*f", decimals, v);
  std::string s(n > 0 ? size_t(n) : 0, '\0');
  if (n > 0) std::snprintf(s.data(), s.size() + 1, "%.*f", decimals, v);
  if (!s.empty() && s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
  return s;
}

// `v` with at most `decimals` digits after the point and no trailing zero ("1.5", "2"); never "-0".
inline std::string trimmed_decimals(double v, int decimals) {
  std::string s = fixed_decimals(v, decimals);
  if (s.find('.') != std::string::npos) {
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
  }
  return s;
}

}  // namespace forklift
