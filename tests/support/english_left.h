// What a person reading another language must not find: the English of the message catalogues
// (data/i18n/), as tests/web/harness.mjs looks for it on a page. Each English text whose
// translation differs, cut at its {{variables}}, each piece with three letters or more that the
// other language never writes itself ("km/h" it does), found as
// whole words only ("limit" is English, "límite" Spanish).
#pragma once

#include <algorithm>
#include <cctype>
#include <set>
#include <string>
#include <vector>

#include "forklift/i18n/catalogue.h"

namespace forklift::test {

inline std::vector<std::string> english_pieces(const i18n::Catalogue& c, const std::string& lang,
                                               const std::vector<std::string>& namespaces) {
  const auto english = c.flat("en"), other = c.flat(lang);
  // Each text's pieces: what is between its {{variables}}, trimmed, with three letters or more.
  const auto pieces = [](const std::string& text) {
    std::set<std::string> out;
    size_t from = 0;
    for (;;) {
      const size_t at = text.find("{{", from);
      std::string piece = text.substr(from, at == std::string::npos ? std::string::npos : at - from);
      while (!piece.empty() && piece.front() == ' ') piece.erase(0, 1);
      while (!piece.empty() && piece.back() == ' ') piece.pop_back();
      int letters = 0;
      for (char ch : piece) letters += std::isalpha(static_cast<unsigned char>(ch)) ? 1 : 0;
      if (letters >= 3) out.insert(piece);
      if (at == std::string::npos) break;
      const size_t end = text.find("}}", at);
      if (end == std::string::npos) break;
      from = end + 2;
    }
    return out;
  };
  std::set<std::string> both;  // pieces the other language writes too ("km/h")
  for (const auto& [key, text] : other) both.merge(pieces(text));
  std::set<std::string> out;
  for (const auto& [key, text] : english) {
    const std::string ns = key.substr(0, key.find(':'));
    if (std::find(namespaces.begin(), namespaces.end(), ns) == namespaces.end()) continue;
    if (key.find(":_") != std::string::npos || key.find("._") != std::string::npos) continue;  // notes for translators
    if (const auto it = other.find(key); it != other.end() && it->second == text) continue;
    for (const std::string& p : pieces(text))
      if (!both.count(p)) out.insert(p);
  }
  return {out.begin(), out.end()};
}

// The pieces `text` holds as whole words (neither side a letter, a byte of UTF-8 counting as one),
// each with what is round it.
inline std::vector<std::string> english_left(const std::string& text, const std::vector<std::string>& pieces) {
  const auto letter = [](char ch) { return std::isalpha(static_cast<unsigned char>(ch)) || static_cast<unsigned char>(ch) >= 0x80; };
  std::vector<std::string> found;
  for (const std::string& p : pieces)
    for (size_t at = text.find(p); at != std::string::npos; at = text.find(p, at + 1)) {
      const bool starts = at == 0 || !letter(text[at - 1]) || !letter(p.front());
      const bool ends = at + p.size() == text.size() || !letter(text[at + p.size()]) || !letter(p.back());
      if (!starts || !ends) continue;
      const size_t from = at > 30 ? at - 30 : 0;
      found.push_back(p + " (in \"" + text.substr(from, p.size() + 60) + "\")");
      break;
    }
  return found;
}

}  // namespace forklift::test
