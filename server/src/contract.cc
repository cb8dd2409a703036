#include "contract.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <stdexcept>

#include "api.h"

namespace forklift::server {

extern const char* const kOpenApiText;  // openapi_text.cc, made by CMake from server/openapi.yaml

namespace {

// A plain scalar as YAML 1.2's core schema reads it; a quoted one is always a string.
json scalar_of(const YAML::Node& n) {
  const std::string& s = n.Scalar();
  if (n.Tag() == "!") return s;
  if (s == "null" || s == "~" || s.empty()) return nullptr;
  if (s == "true") return true;
  if (s == "false") return false;
  static const std::regex integer("[-+]?[0-9]+"), number("[-+]?([0-9]+\\.?[0-9]*|\\.[0-9]+)([eE][-+]?[0-9]+)?");
  if (std::regex_match(s, integer)) {
    try { return std::stoll(s); } catch (const std::out_of_range&) { return std::stod(s); }
  }
  if (std::regex_match(s, number)) return std::stod(s);
  return s;
}

json json_of(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Map: {
      json j = json::object();
      for (const auto& kv : n) j[kv.first.as<std::string>()] = json_of(kv.second);
      return j;
    }
    case YAML::NodeType::Sequence: {
      json j = json::array();
      for (const auto& e : n) j.push_back(json_of(e));
      return j;
    }
    case YAML::NodeType::Scalar: return scalar_of(n);
    default: return nullptr;
  }
}

// A "$ref" of the document ("#/components/parameters/Limit") followed.
const json& deref(const json& doc, const json& node) {
  if (!node.is_object() || !node.contains("$ref")) return node;
  return doc.at(json::json_pointer(node["$ref"].get<std::string>().substr(1)));
}

// "/api/pupils/{id}/history.csv" -> ^/api/pupils/[^/]+/history\.csv$
std::regex pattern_of(const std::string& path) {
  std::string re;
  for (size_t i = 0; i < path.size(); ++i) {
    if (path[i] == '{') {
      i = path.find('}', i);
      re += "[^/]+";
    } else {
      if (std::string(".^$|()[]*+?\\").find(path[i]) != std::string::npos) re += '\\';
      re += path[i];
    }
  }
  return std::regex(re);
}

// A query parameter's text as the JSON value its schema's type reads, or the text itself when it
// is not one (the check then says what it must be).
json query_value(const std::string& text, const std::string& type) {
  if (type == "integer" && std::regex_match(text, std::regex("-?[0-9]{1,18}"))) return std::stoll(text);
  if (type == "number") {
    try {
      size_t used = 0;
      const double d = std::stod(text, &used);
      if (used == text.size() && std::isfinite(d)) return d;
    } catch (const std::exception&) {
    }
  }
  if (type == "boolean" && (text == "true" || text == "false")) return text == "true";
  return text;
}

// "'limit' must be at most 1000 (found 5000)", in words a school reads.
std::string words_of(const schema::SchemaChecker::Problem& p, const char* what) {
  const std::string key = "'" + p.key + "'";
  switch (p.kind) {
    case schema::SchemaChecker::Problem::kMissing: return key + " is required";
    case schema::SchemaChecker::Problem::kUnknownKey: return key + " is not a field " + what + " takes";
    case schema::SchemaChecker::Problem::kRule: break;
  }
  if (p.key.empty()) return p.words.empty() ? std::string("the body must be a JSON object of the documented fields") : "the body " + p.words;
  return key + " " + (p.words.empty() ? std::string("is not one of the values it may have") : p.words);
}

}  // namespace

const json& openapi_document() {
  static const json doc = json_of(YAML::Load(kOpenApiText));  // our own file: a YAML error is a build mistake
  return doc;
}

json json_schema_of(const json& given, const json& schemas) {
  if (!given.is_object()) return given;
  // A nullable reference ({nullable: true, allOf: [{$ref}]}) as the schema it names with null
  // allowed: its fields are then checked, and named, one by one.
  json s = given;
  if (s.value("nullable", false) && s.contains("allOf") && s["allOf"].size() == 1 && s["allOf"][0].contains("$ref")) {
    const std::string ref = s["allOf"][0]["$ref"], prefix = "#/components/schemas/";
    if (ref.rfind(prefix, 0) == 0 && schemas.contains(ref.substr(prefix.size()))) {
      s.erase("allOf");
      for (const auto& [k, v] : schemas[ref.substr(prefix.size())].items())
        if (!s.contains(k)) s[k] = v;
    }
  }
  json out = json::object();
  for (const auto& [k, v] : s.items()) {
    if (k == "$ref") {
      const std::string ref = v.get<std::string>(), prefix = "#/components/schemas/";
      out[k] = ref.rfind(prefix, 0) == 0 ? "#/definitions/" + ref.substr(prefix.size()) : ref;
    } else if (k == "properties" || k == "patternProperties") {
      for (const auto& [name, sub] : v.items()) out[k][name] = json_schema_of(sub, schemas);
    } else if (k == "items" || k == "not" || (k == "additionalProperties" && v.is_object())) {
      out[k] = json_schema_of(v, schemas);
    } else if (k == "allOf" || k == "anyOf" || k == "oneOf") {
      for (const auto& sub : v) out[k].push_back(json_schema_of(sub, schemas));
    } else if (k == "exclusiveMinimum" || k == "exclusiveMaximum") {
      const char* bound = k == "exclusiveMinimum" ? "minimum" : "maximum";
      if (v == true && s.contains(bound)) out[k] = s[bound];
    } else if (k == "nullable" || k == "example" || k == "format" || k == "readOnly" || k == "writeOnly" || k == "deprecated") {
      // nullable below; the others say nothing a request is checked by
    } else {
      out[k] = v;
    }
  }
  // OpenAPI 3.0's exclusive bound is the draft's number in place of the inclusive one.
  for (const auto& [k, bound] : {std::pair{"exclusiveMinimum", "minimum"}, std::pair{"exclusiveMaximum", "maximum"}})
    if (out.contains(k)) out.erase(bound);
  if (s.value("nullable", false)) {
    if (out.contains("allOf") || out.contains("$ref") || !out.contains("type")) return {{"anyOf", {{{"type", "null"}}, out}}};
    if (out["type"].is_string()) out["type"] = json::array({out["type"], "null"});
    if (out.contains("enum")) out["enum"].push_back(nullptr);
  }
  return out;
}

const Contract& api_contract() {
  static const Contract contract;
  return contract;
}

Contract::Contract(const json& doc) {
  json definitions = json::object();
  const json& schemas = doc["components"]["schemas"];
  for (const auto& [name, s] : schemas.items()) definitions[name] = json_schema_of(s, schemas);
  const bool secured_by_default = doc.contains("security") && !doc["security"].empty();
  for (const auto& [path, item] : doc["paths"].items()) {
    for (const auto& [method, op] : item.items()) {
      if (method == "parameters" || method == "summary" || method == "description") continue;
      Operation o;
      o.method = method;
      for (auto& c : o.method) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      o.path = path;
      o.operation_id = op.value("operationId", "");
      o.pattern = pattern_of(path);
      o.secured = op.contains("security") ? !op["security"].empty() : secured_by_default;
      if (op.contains("requestBody")) {
        const json& rb = deref(doc, op["requestBody"]);
        json s = json_schema_of(rb["content"]["application/json"]["schema"], schemas);
        s["definitions"] = definitions;
        o.body = std::make_shared<schema::SchemaChecker>(std::move(s));
      }
      json query = {{"type", "object"}, {"properties", json::object()}, {"required", json::array()}};
      for (const json* list : {item.contains("parameters") ? &item["parameters"] : nullptr, op.contains("parameters") ? &op["parameters"] : nullptr}) {
        if (!list) continue;
        for (const auto& ref : *list) {
          const json& p = deref(doc, ref);
          if (p["in"] != "query") continue;
          const std::string name = p["name"];
          query["properties"][name] = json_schema_of(p["schema"], schemas);
          o.query_types[name] = p["schema"].value("type", "string");
          if (p.value("required", false)) query["required"].push_back(name);
        }
      }
      if (!query["properties"].empty()) {
        query["definitions"] = definitions;
        o.query = std::make_shared<schema::SchemaChecker>(std::move(query));
      }
      operations_.push_back(std::move(o));
    }
  }
}

const Operation* Contract::find(const std::string& method, const std::string& path) const {
  for (const auto& o : operations_)
    if (o.method == method && std::regex_match(path, o.pattern)) return &o;
  return nullptr;
}

void Contract::check_query(const Operation& op, const httplib::Request& req) const {
  if (!op.query) return;
  json q = json::object();
  for (const auto& [name, type] : op.query_types.items())
    if (req.has_param(name)) q[name] = query_value(req.get_param_value(name), type.get<std::string>());
  if (const auto p = op.query->problem(q)) throw ApiError(400, "bad_request", words_of(*p, "this request"));
}

void Contract::check_body(const Operation& op, const json& body) const {
  if (!op.body) return;
  if (const auto p = op.body->problem(body)) throw ApiError(400, "bad_request", words_of(*p, "this request"));
}

}  // namespace forklift::server
