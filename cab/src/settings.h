// Reading the cab's data files (data/cab/*.json, and the rules' words): a file that is missing or
// not JSON, or a key that is missing or of the wrong kind, is refused naming the file and the key.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace forklift::cab {

nlohmann::json read_settings_file(const std::string& path);  // throws std::runtime_error
// j[key], which must be there; `where` names the file (and section) in the message.
const nlohmann::json& settings_at(const nlohmann::json& j, const char* key, const std::string& where);
double settings_number(const nlohmann::json& j, const char* key, const std::string& where);

}  // namespace forklift::cab
