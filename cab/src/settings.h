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

// What the pupil reads, in `lang`: "cab:<key>" of the shipped catalogues (data/i18n/<lang>/cab.json)
// with its {{variables}} from `vars`. Throws i18n::Missing for a key the catalogue has not (a bug).
std::string cab_words(const std::string& lang, const std::string& key, const nlohmann::json& vars = nlohmann::json::object());
// `value` with `decimals` decimals and `lang`'s decimal separator ("9,0" in Spanish).
std::string cab_number(const std::string& lang, double value, int decimals);

}  // namespace forklift::cab
