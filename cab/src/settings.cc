#include "settings.h"

#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "forklift/i18n/catalogue.h"

namespace forklift::cab {

nlohmann::json read_settings_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  try {
    return nlohmann::json::parse(in);
  } catch (const std::exception& e) {
    throw std::runtime_error(path + " is not valid JSON: " + e.what());
  }
}

const nlohmann::json& settings_at(const nlohmann::json& j, const char* key, const std::string& where) {
  if (!j.is_object() || !j.contains(key)) throw std::runtime_error(where + ": missing \"" + key + "\"");
  return j.at(key);
}

double settings_number(const nlohmann::json& j, const char* key, const std::string& where) {
  const nlohmann::json& v = settings_at(j, key, where);
  if (!v.is_number()) throw std::runtime_error(where + ": \"" + key + "\" must be a number");
  return v.get<double>();
}

std::string cab_words(const std::string& lang, const std::string& key, const nlohmann::json& vars) {
  return i18n::shipped().text(lang, "cab:" + key, vars);
}

std::string cab_number(const std::string& lang, double value, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, value);
  std::string s = buf;
  if (s.find_first_not_of("-0.") == std::string::npos && s[0] == '-') s.erase(0, 1);  // "0.0", never "-0.0"
  const std::string decimal = i18n::shipped().text(lang, "words:number.decimal");
  if (const size_t dot = s.find('.'); dot != std::string::npos) s.replace(dot, 1, decimal);
  return s;
}

}  // namespace forklift::cab
