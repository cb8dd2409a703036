// Checking a document against a built-in JSON Schema (valijson does the checking), and saying
// what is wrong the way the loaders do: the dotted key, then the rule in words.
#include <cmath>
#include <map>
#include <memory>
#include <regex>
#include <sstream>
#include <valijson/adapters/nlohmann_json_adapter.hpp>
#include <valijson/schema.hpp>
#include <valijson/schema_parser.hpp>
#include <valijson/validation_results.hpp>
#include <valijson/validator.hpp>

#include "forklift/schema/checker.h"
#include "forklift/schema/data_file.h"
#include "schemas.h"

namespace forklift::schema {
namespace {

using nlohmann::json;

// One step of valijson's context ("[objects]", "[3]"), without its brackets.
std::string step_of(const std::string& context) {
  return context.size() >= 2 && context.front() == '[' && context.back() == ']' ? context.substr(1, context.size() - 2) : context;
}

// A schema node with its "$ref" (to "#/definitions/...") followed.
const json* resolve(const json& root, const json* node) {
  for (int hops = 0; node && node->is_object() && node->contains("$ref") && hops < 16; ++hops) {
    const std::string ref = (*node)["$ref"].get<std::string>();
    const std::string prefix = "#/definitions/";
    if (ref.rfind(prefix, 0) != 0 || !root.contains("definitions")) return nullptr;
    const auto& defs = root["definitions"];
    const std::string name = ref.substr(prefix.size());
    node = defs.contains(name) ? &defs[name] : nullptr;
  }
  return node;
}

// The schema a property or element of `parent` is checked against, or nullptr.
const json* child_schema(const json& root, const json* parent, const json& doc_parent, const std::string& step) {
  parent = resolve(root, parent);
  if (!parent || !parent->is_object()) return nullptr;
  if (doc_parent.is_array()) {
    if (!parent->contains("items")) return nullptr;
    const json& items = (*parent)["items"];
    if (items.is_array()) {
      const size_t i = std::stoul(step);
      return i < items.size() ? resolve(root, &items[i]) : nullptr;
    }
    return resolve(root, &items);
  }
  if (parent->contains("properties") && (*parent)["properties"].contains(step)) return resolve(root, &(*parent)["properties"][step]);
  if (parent->contains("patternProperties"))
    for (const auto& [pattern, sub] : (*parent)["patternProperties"].items())
      if (std::regex_search(step, std::regex(pattern))) return resolve(root, &sub);
  if (parent->contains("additionalProperties") && (*parent)["additionalProperties"].is_object())
    return resolve(root, &(*parent)["additionalProperties"]);
  return nullptr;
}

std::string number_words(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

std::string type_of(const json& v) {
  if (v.is_null()) return "null";
  if (v.is_boolean()) return "true or false";
  if (v.is_number()) return "a number";
  if (v.is_string()) return "a string";
  if (v.is_array()) return "an array";
  return "an object";
}

bool has_type(const json& v, const std::string& type) {
  if (type == "number") return v.is_number();
  if (type == "integer") return v.is_number_integer() || (v.is_number_float() && std::trunc(v.get<double>()) == v.get<double>());
  if (type == "string") return v.is_string();
  if (type == "boolean") return v.is_boolean();
  if (type == "array") return v.is_array();
  if (type == "object") return v.is_object();
  if (type == "null") return v.is_null();
  return false;
}

std::string type_words(const json& s) {
  static const std::map<std::string, std::string> words = {
      {"number", "is not a number"},     {"integer", "is not an integer"}, {"string", "is not a string"},
      {"boolean", "is not true or false"}, {"array", "must be an array"},  {"object", "must be an object"},
      {"null", "must be null"}};
  if (s.is_string()) return words.count(s.get<std::string>()) ? words.at(s.get<std::string>()) : "has the wrong type";
  static const std::map<std::string, std::string> nouns = {
      {"number", "a number"}, {"integer", "an integer"}, {"string", "a string"}, {"boolean", "true or false"},
      {"array", "an array"},  {"object", "an object"},   {"null", "null"}};
  std::string out = "must be";
  for (size_t i = 0; i < s.size(); ++i) {
    out += i == 0 ? " " : " or ";
    out += nouns.count(s[i].get<std::string>()) ? nouns.at(s[i].get<std::string>()) : s[i].get<std::string>();
  }
  return out;
}

// What `value` breaks in `s` (its own rules, not its children's), in the loaders' words.
std::string words_for(const json& s, const json& value) {
  const std::string unit = s.contains("unit") ? s["unit"].get<std::string>() + "; " : "";
  const std::string found = " (" + unit + "found " + (value.is_number() ? number_words(value.get<double>()) : type_of(value)) + ")";
  if (s.contains("type")) {
    const json& t = s["type"];
    const bool ok = t.is_string() ? has_type(value, t.get<std::string>())
                                  : std::any_of(t.begin(), t.end(), [&](const json& x) { return has_type(value, x.get<std::string>()); });
    if (!ok) return type_words(t) + " (found " + type_of(value) + ")";
  }
  if (value.is_number()) {
    const double v = value.get<double>();
    if (!std::isfinite(v)) return "is not finite";
    if (s.contains("exclusiveMinimum") && !(v > s["exclusiveMinimum"].get<double>()))
      return (s["exclusiveMinimum"].get<double>() == 0 ? std::string("must be positive")
                                                       : "must be above " + number_words(s["exclusiveMinimum"].get<double>())) + found;
    if (s.contains("minimum") && !(v >= s["minimum"].get<double>()))
      return (s["minimum"].get<double>() == 0 ? std::string("must not be negative")
                                              : "must be at least " + number_words(s["minimum"].get<double>())) + found;
    if (s.contains("exclusiveMaximum") && !(v < s["exclusiveMaximum"].get<double>()))
      return "must be below " + number_words(s["exclusiveMaximum"].get<double>()) + found;
    if (s.contains("maximum") && !(v <= s["maximum"].get<double>()))
      return "must be at most " + number_words(s["maximum"].get<double>()) + found;
  }
  if (value.is_array()) {
    const bool fixed = s.contains("minItems") && s.contains("maxItems") && s["minItems"] == s["maxItems"];
    if (fixed && value.size() != s["minItems"].get<size_t>())
      return "must be an array of " + std::to_string(s["minItems"].get<size_t>()) + " elements (found " + std::to_string(value.size()) + ")";
    if (s.contains("minItems") && value.size() < s["minItems"].get<size_t>())
      return "must have at least " + std::to_string(s["minItems"].get<size_t>()) + " elements";
    if (s.contains("maxItems") && value.size() > s["maxItems"].get<size_t>())
      return "must have at most " + std::to_string(s["maxItems"].get<size_t>()) + " elements (found " + std::to_string(value.size()) + ")";
  }
  if (value.is_object() && s.contains("maxProperties") && value.size() > s["maxProperties"].get<size_t>())
    return "must have at most " + std::to_string(s["maxProperties"].get<size_t>()) + " entries (found " + std::to_string(value.size()) + ")";
  if (value.is_string()) {
    const size_t n = value.get<std::string>().size();
    if (s.contains("minLength") && n < s["minLength"].get<size_t>()) return "must not be empty";
    if (s.contains("maxLength") && n > s["maxLength"].get<size_t>())
      return "is longer than " + std::to_string(s["maxLength"].get<size_t>()) + " characters";
  }
  // "x-rule" says in words what a pattern asks for (the API description's own key).
  if (value.is_string() && s.contains("pattern") && !std::regex_search(value.get<std::string>(), std::regex(s["pattern"].get<std::string>())))
    return s.contains("x-rule") ? s["x-rule"].get<std::string>() : "is not in the form it must have";
  if (s.contains("enum") && std::find(s["enum"].begin(), s["enum"].end(), value) == s["enum"].end()) {
    // "must be chassis, mast or carriage (found wheel)"
    const auto word = [](const json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); };
    std::string out = "must be";
    const size_t n = s["enum"].size();
    for (size_t i = 0; i < n; ++i) out += std::string(i == 0 ? " " : i + 1 == n ? " or " : ", ") + word(s["enum"][i]);
    return out + " (found " + word(value) + ")";
  }
  return "";
}

}  // namespace

struct SchemaChecker::Compiled {
  json text;  // the schema as JSON, walked again to word a problem
  valijson::Schema schema;
};

SchemaChecker::SchemaChecker(json schema) : compiled_(std::make_unique<Compiled>()) {
  compiled_->text = std::move(schema);
  valijson::SchemaParser parser;
  valijson::adapters::NlohmannJsonAdapter adapter(compiled_->text);
  parser.populateSchema(adapter, compiled_->schema);
}
SchemaChecker::~SchemaChecker() = default;
SchemaChecker::SchemaChecker(SchemaChecker&&) noexcept = default;
SchemaChecker& SchemaChecker::operator=(SchemaChecker&&) noexcept = default;

std::optional<SchemaChecker::Problem> SchemaChecker::problem(const json& doc) const {
  const Compiled& c = *compiled_;
  valijson::Validator validator;
  valijson::ValidationResults results;
  valijson::adapters::NlohmannJsonAdapter adapter(doc);
  if (validator.validate(c.schema, adapter, &results)) return std::nullopt;

  // valijson lists a failing value's own error before its parents' "Failed to validate ..."
  // summaries; the first that is not a summary is the one to tell.
  valijson::ValidationResults::Error error;
  while (results.popError(error)) {
    if (error.description.rfind("Failed to validate", 0) == 0) continue;
    std::string key;
    const json* value = &doc;
    const json* sub = resolve(c.text, &c.text);
    for (size_t i = 1; i < error.context.size() && value; ++i) {  // context[0] is "<root>"
      const std::string step = step_of(error.context[i]);
      sub = child_schema(c.text, sub, *value, step);
      if (value->is_array()) {
        const size_t index = std::stoul(step);
        key += "[" + step + "]";
        value = index < value->size() ? &(*value)[index] : nullptr;
      } else {
        key += (key.empty() ? "" : ".") + step;
        value = value->contains(step) ? &(*value)[step] : nullptr;
      }
    }
    const std::string& d = error.description;
    const auto quoted = [&] {  // the name valijson quotes at the end: "... 'x_m'."
      const size_t end = d.find_last_of('\'');
      const size_t start = end == std::string::npos ? end : d.find_last_of('\'', end - 1);
      return start == std::string::npos ? std::string() : d.substr(start + 1, end - start - 1);
    };
    const std::string prefix = key.empty() ? "" : key + ".";
    if (d.rfind("Missing required property", 0) == 0) return Problem{Problem::kMissing, prefix + quoted(), "", d};
    if (d.find("could not be validated using 'properties' or 'additionalProperties'") != std::string::npos)
      return Problem{Problem::kUnknownKey, prefix + quoted(), "", d};
    return Problem{Problem::kRule, key, value && sub ? words_for(*sub, *value) : "", d};
  }
  return Problem{Problem::kRule, "", "", "no error listed"};
}

namespace {

// The built-in schemas, compiled once per program (they never change while it runs).
const SchemaChecker& built_in(Schema which) {
  static const SchemaChecker truck(json::parse(kTruckSchemaText));  // our own files: a parse error is a build mistake
  static const SchemaChecker scenario(json::parse(kScenarioSchemaText));
  return which == Schema::kTruck ? truck : scenario;
}

}  // namespace

std::optional<std::string> schema_problem(const json& doc, Schema which) {
  const auto p = built_in(which).problem(doc);
  if (!p) return std::nullopt;
  switch (p->kind) {
    case SchemaChecker::Problem::kMissing: return "'" + p->key + "' is missing";
    case SchemaChecker::Problem::kUnknownKey: return "'" + p->key + "' is not a known key";
    case SchemaChecker::Problem::kRule: break;
  }
  const std::string words = p->words.empty() ? "breaks the file's schema: " + p->detail : p->words;
  return (p->key.empty() ? std::string("the top level") : "'" + p->key + "'") + " " + words;
}

}  // namespace forklift::schema
