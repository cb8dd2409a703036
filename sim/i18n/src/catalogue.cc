#include "forklift/i18n/catalogue.h"

#include <cstdlib>
#include <fstream>
#include <sstream>

namespace forklift::i18n {
namespace {

using nlohmann::json;

void check_tree(const json& node, const std::string& where) {
  if (!node.is_object()) throw std::runtime_error(where + " is not a set of keys and texts");
  for (const auto& [k, v] : node.items()) {
    if (v.is_object()) check_tree(v, where + " " + k);
    else if (!v.is_string()) throw std::runtime_error(where + ": key \"" + k + "\" is neither a text nor a group of keys");
  }
}

void flatten(const json& node, const std::string& prefix, std::map<std::string, std::string>& out) {
  for (const auto& [k, v] : node.items()) {
    const std::string key = prefix + k;
    if (v.is_object()) flatten(v, key + ".", out);
    else out[key] = v.get<std::string>();
  }
}

std::string number_text(const json& v) {
  if (v.is_number_integer() || v.is_number_unsigned()) return v.dump();
  if (v.is_number_float()) {
    std::ostringstream s;
    s << v.get<double>();
    return s.str();
  }
  if (v.is_string()) return v.get<std::string>();
  return v.dump();
}

}  // namespace

Catalogue Catalogue::load(const std::filesystem::path& dir) {
  Catalogue c;
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec))
    throw std::runtime_error("the message catalogues' folder " + dir.string() + " is not there");
  for (const auto& lang_dir : std::filesystem::directory_iterator(dir)) {
    if (!lang_dir.is_directory()) continue;
    const std::string lang = lang_dir.path().filename().string();
    for (const auto& f : std::filesystem::directory_iterator(lang_dir.path())) {
      if (f.path().extension() != ".json") continue;
      std::ifstream in(f.path());
      json file = json::parse(in, nullptr, false);
      if (file.is_discarded()) throw std::runtime_error("the message catalogue " + f.path().string() + " is not valid JSON");
      check_tree(file, "the message catalogue " + f.path().string());
      c.files_[lang][f.path().stem().string()] = std::move(file);
    }
  }
  if (c.files_.empty()) throw std::runtime_error("the message catalogues' folder " + dir.string() + " holds no language");
  if (!c.has_language(kSourceLanguage))
    throw std::runtime_error("the message catalogues' folder " + dir.string() + " has no English, the language they are written from");
  return c;
}

const std::string* Catalogue::find(const std::string& lang, const std::string& key) const {
  const auto l = files_.find(lang);
  if (l == files_.end()) return nullptr;
  const auto colon = key.find(':');
  if (colon == std::string::npos) return nullptr;
  const auto ns = l->second.find(key.substr(0, colon));
  if (ns == l->second.end()) return nullptr;
  const json* node = &ns->second;
  std::string rest = key.substr(colon + 1);
  for (size_t start = 0;;) {
    const size_t dot = rest.find('.', start);
    const std::string part = rest.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    const auto it = node->find(part);
    if (it == node->end()) return nullptr;
    node = &*it;
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  return node->is_string() ? node->get_ptr<const std::string*>() : nullptr;
}

bool Catalogue::has(const std::string& lang, const std::string& key) const {
  return find(lang, key) || (find(lang, key + "_one") && find(lang, key + "_other"));
}

std::string Catalogue::text(const std::string& lang, const std::string& key, const json& vars) const {
  if (!has_language(lang)) throw Missing("there are no messages in the language \"" + lang + "\"");
  const std::string* t = nullptr;
  if (vars.is_object() && vars.contains("count") && vars["count"].is_number())
    t = find(lang, key + (vars["count"].get<double>() == 1 ? "_one" : "_other"));
  if (!t) t = find(lang, key);
  if (!t) throw Missing("the message \"" + key + "\" is missing in the language \"" + lang + "\"");
  return interpolate(*t, vars);
}

std::vector<std::string> Catalogue::languages() const {
  std::vector<std::string> out;
  for (const auto& [lang, _] : files_) out.push_back(lang);
  return out;
}

std::map<std::string, std::string> Catalogue::flat(const std::string& lang) const {
  std::map<std::string, std::string> out;
  const auto l = files_.find(lang);
  if (l == files_.end()) throw Missing("there are no messages in the language \"" + lang + "\"");
  for (const auto& [ns, file] : l->second) flatten(file, ns + ":", out);
  return out;
}

const json* Catalogue::namespace_file(const std::string& lang, const std::string& ns) const {
  const auto l = files_.find(lang);
  if (l == files_.end()) return nullptr;
  const auto f = l->second.find(ns);
  return f == l->second.end() ? nullptr : &f->second;
}

const Catalogue& shipped() {
  static const Catalogue c = Catalogue::load(std::filesystem::path(FORKLIFT_DATA_DIR) / "i18n");
  return c;
}

std::string environment_language(const Catalogue& c) {
  for (const char* name : {"LC_ALL", "LC_MESSAGES", "LANG"}) {
    const char* v = std::getenv(name);
    if (!v || !*v) continue;
    return c.supported(std::string(v).substr(0, 2));
  }
  return kSourceLanguage;
}

std::set<std::string> variables(const std::string& text) {
  std::set<std::string> out;
  for (size_t at = text.find("{{"); at != std::string::npos; at = text.find("{{", at + 2)) {
    const size_t end = text.find("}}", at + 2);
    if (end == std::string::npos) break;
    std::string name = text.substr(at + 2, end - at - 2);
    // i18next allows spaces and a format after a comma: {{ value, number }}
    if (const size_t comma = name.find(','); comma != std::string::npos) name.resize(comma);
    while (!name.empty() && name.back() == ' ') name.pop_back();
    while (!name.empty() && name.front() == ' ') name.erase(0, 1);
    out.insert(name);
  }
  return out;
}

std::string interpolate(const std::string& text, const json& vars) {
  std::string out;
  size_t from = 0;
  for (size_t at = text.find("{{"); at != std::string::npos; at = text.find("{{", from)) {
    const size_t end = text.find("}}", at + 2);
    if (end == std::string::npos) break;
    out += text.substr(from, at - from);
    std::string name = *variables(text.substr(at, end + 2 - at)).begin();
    if (!vars.is_object() || !vars.contains(name)) throw Missing("the message \"" + text + "\" needs a value for {{" + name + "}}");
    out += number_text(vars[name]);
    from = end + 2;
  }
  return out + text.substr(from);
}

}  // namespace forklift::i18n
