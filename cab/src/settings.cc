#include "settings.h"

#include <fstream>
#include <stdexcept>

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

}  // namespace forklift::cab
