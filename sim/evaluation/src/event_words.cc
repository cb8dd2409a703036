#include "forklift/evaluation/event_words.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <utility>
#include <vector>

#include "forklift/units/decimals.h"

namespace forklift {
namespace {

using nlohmann::json;

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() > tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// Units by the suffix the evaluator gives every number, longest first ("_m_s2" before "_m_s").
const std::vector<std::pair<std::string, std::string>> kUnits = {
    {"_m_s2", "m/s2"}, {"_m_s", "m/s"}, {"_fraction", "fraction"}, {"_deg", "deg"}, {"_kg", "kg"},
    {"_N", "N"},       {"_s", "s"},     {"_m", "m"}};

// A number's name in `lang`: the rule's own name for it where the same name means something else
// in that rule ("margin" is the stability margin but for the people's rules), else the common
// one, else its words without the underscores.
std::string name_of(const i18n::Catalogue& words, const std::string& lang, const std::string& kind, const std::string& bare) {
  if (const std::string own = "words:quantity_of_rule." + kind + "." + bare; words.has(lang, own)) return words.text(lang, own);
  if (const std::string common = "words:quantity." + bare; words.has(lang, common)) return words.text(lang, common);
  std::string plain = bare;
  for (char& c : plain)
    if (c == '_') c = ' ';
  return plain;
}

json quantities(const i18n::Catalogue& words, const std::string& lang, const json& group, const std::string& kind) {
  const std::string decimal = words.text(lang, "words:number.decimal");
  json out = json::array();
  if (!group.is_object()) return out;
  for (const auto& [key, v] : group.items()) {
    if (!v.is_number()) continue;
    std::string bare = key;
    for (const auto& [suffix, unit] : kUnits)
      if (ends_with(key, suffix)) {
        bare = key.substr(0, key.size() - suffix.size());
        break;
      }
    out.push_back({{"what", name_of(words, lang, kind, bare)}, {"value", quantity_words(key, v.get<double>(), decimal)}});
  }
  return out;
}

std::string listed(const json& items) {
  std::string s;
  for (const json& i : items) s += (s.empty() ? "" : ", ") + i["what"].get<std::string>() + " " + i["value"].get<std::string>();
  return s;
}

}  // namespace

std::string worry_words(const i18n::Catalogue& words, const std::string& lang, int level) {
  const std::string key = "words:worry." + std::to_string(level);
  return words.has(lang, key) ? words.text(lang, key) : words.text(lang, "words:worry.other", {{"level", level}});
}

std::string worry_words(int level) { return worry_words(i18n::shipped(), i18n::kSourceLanguage, level); }

std::string quantity_words(const std::string& key, double v, const std::string& decimal) {
  const auto fixed = [&](double x, int places) {
    std::string s = fixed_decimals(x, places);
    if (const size_t dot = s.find('.'); dot != std::string::npos) s.replace(dot, 1, decimal);
    return s;
  };
  if (ends_with(key, "_m_s2")) return fixed(v, 2) + " m/s²";
  if (ends_with(key, "_m_s")) return fixed(v, 2) + " m/s (" + fixed(v * 3.6, 1) + " km/h)";
  if (ends_with(key, "_fraction")) return fixed(v * 100, 0) + " %";
  if (ends_with(key, "_deg")) return fixed(v, 1) + "°";
  if (ends_with(key, "_kg")) return fixed(v, 0) + " kg";
  if (ends_with(key, "_N")) return std::abs(v) >= 1000 ? fixed(v / 1000, 1) + " kN" : fixed(v, 0) + " N";
  if (ends_with(key, "_s")) return fixed(v, 1) + " s";
  if (ends_with(key, "_m")) return std::abs(v) < 1 ? fixed(v * 100, 0) + " cm" : fixed(v, 2) + " m";
  return fixed(v, 2);  // a control's deflection, a count: no unit
}

namespace {

json words_of(const i18n::Catalogue& words, const std::string& lang, std::string title, const std::string& kind,
              const std::string& details) {
  if (title.empty()) {
    if (const std::string rule = "words:rules." + kind + ".title"; words.has(lang, rule)) title = words.text(lang, rule);
    else if (const std::string info = "words:information." + kind; words.has(lang, info)) title = words.text(lang, info);
    else {
      title = kind;
      for (char& c : title)
        if (c == '_') c = ' ';
    }
  }
  const json d = json::parse(details, nullptr, false);
  const json measured = quantities(words, lang, d.is_object() ? d.value("measured", json()) : json(), kind);
  const json limits = quantities(words, lang, d.is_object() ? d.value("thresholds", json()) : json(), kind);
  std::string summary;
  if (!measured.empty()) summary = words.text(lang, "words:summary.measured", {{"list", listed(measured)}});
  if (!limits.empty())
    summary += std::string(summary.empty() ? "" : " ") + words.text(lang, "words:summary.limit", {{"list", listed(limits)}});
  return {{"title", title}, {"measured", measured}, {"limits", limits}, {"summary", summary}};
}

}  // namespace

json event_words(const std::string& rule_title, const std::string& kind, const std::string& details) {
  return words_of(i18n::shipped(), i18n::kSourceLanguage, rule_title, kind, details);
}

json event_words(const i18n::Catalogue& words, const std::string& lang, const std::string& kind, const std::string& details) {
  return words_of(words, words.supported(lang), "", kind, details);
}

}  // namespace forklift
