// The school's languages: message catalogues in i18next's JSON v4 format, one file per language
// and namespace, data/i18n/<lang>/<namespace>.json, shared by the pages (i18next from npm) and the
// C++ programs (this). Keys nest ("outcome.passed"), "{{name}}" is replaced by a variable, and a
// key asked with a numeric "count" reads "<key>_one" for 1 and "<key>_other" otherwise (the only
// plural forms English and Spanish need). English is the source: every other language has every
// key, which the catalogue tests check, so a lookup never falls back to English unseen.
#pragma once

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace forklift::i18n {

// A lookup of a key or a language the catalogue does not have: what() names both.
class Missing : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The language every catalogue is written from.
inline constexpr const char* kSourceLanguage = "en";

class Catalogue {
 public:
  // Every <lang>/<namespace>.json under `dir` (each folder a language, each file a namespace).
  // Throws std::runtime_error naming the file when one cannot be read or is not a JSON object of
  // strings and objects, or when `dir` holds no language at all.
  static Catalogue load(const std::filesystem::path& dir);

  // The text of "namespace:key.path" in `lang`, its {{variables}} replaced from `vars` (numbers
  // as written, strings as they are; a variable not given is an error). With a numeric "count"
  // in `vars` the plural form is taken. Throws Missing for a language or key it does not have.
  std::string text(const std::string& lang, const std::string& key, const nlohmann::json& vars = nlohmann::json::object()) const;

  // Whether `lang` has "namespace:key.path" (either plural form counts).
  bool has(const std::string& lang, const std::string& key) const;

  // The languages loaded, in order ("en", "es").
  std::vector<std::string> languages() const;
  bool has_language(const std::string& lang) const { return files_.count(lang) != 0; }

  // `lang` when the catalogue has it, else the source language: for a language from a request or
  // a record (a language chosen then removed must not make a page fail).
  std::string supported(const std::string& lang) const { return has_language(lang) ? lang : kSourceLanguage; }

  // Every leaf of `lang` as "namespace:key.path" -> text (for the catalogue tests and for pages).
  std::map<std::string, std::string> flat(const std::string& lang) const;

  // One namespace's file as loaded, for the server to serve to the pages.
  const nlohmann::json* namespace_file(const std::string& lang, const std::string& ns) const;

 private:
  const std::string* find(const std::string& lang, const std::string& key) const;
  std::map<std::string, std::map<std::string, nlohmann::json>> files_;  // lang -> namespace -> file
};

// The catalogues shipped in the data folder the programs were built with (data/i18n/), loaded on
// first use; throws as load() does when they cannot be read.
const Catalogue& shipped();

// The language a program run from a terminal speaks when not told (a person's --language wins):
// the first of LC_ALL, LC_MESSAGES and LANG that is set, as gettext reads them, when `c` has its
// first two letters ("es_ES.UTF-8" -> "es"); else the source language ("C.UTF-8", nothing set).
std::string environment_language(const Catalogue& c);

// The names of the {{variables}} in `text`.
std::set<std::string> variables(const std::string& text);

// `text` with each {{name}} replaced from `vars`; throws Missing naming a variable not given.
std::string interpolate(const std::string& text, const nlohmann::json& vars);

}  // namespace forklift::i18n
