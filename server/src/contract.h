// The API description (server/openapi.yaml, built into the server) as the contract: the
// operations it documents, and each request checked against them before a handler sees it:
// the body against the operation's schema, the query parameters against theirs.
#pragma once

#include <httplib.h>

#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <regex>
#include <string>
#include <vector>

#include "forklift/schema/checker.h"

namespace forklift::server {

// server/openapi.yaml as JSON (YAML's plain scalars read as the core schema reads them).
const nlohmann::json& openapi_document();

// The part of a schema of the description that JSON Schema (draft 7) reads differently: "$ref"s to
// "#/components/schemas/X" become "#/definitions/X", "nullable" a "null" type, OpenAPI 3.0's
// boolean exclusiveMinimum/Maximum the draft's numbers; a nullable reference the schema it names
// (from `schemas`, components/schemas) with null allowed.
nlohmann::json json_schema_of(const nlohmann::json& openapi_schema, const nlohmann::json& schemas);

struct Operation {
  std::string method;        // GET, POST, PATCH, ...
  std::string path;          // as documented: /api/pupils/{id}
  std::string operation_id;
  std::regex pattern;        // the path with each {param} as one segment
  bool secured = true;       // needs a login (the document's security, or the operation's)
  std::shared_ptr<const schema::SchemaChecker> body;   // null: the operation takes no body
  std::shared_ptr<const schema::SchemaChecker> query;  // its query parameters as one object
  nlohmann::json query_types;                           // name -> "integer", "number", "boolean" or "string"
};

class Contract;
// The contract of openapi_document(), made once.
const Contract& api_contract();

class Contract {
 public:
  explicit Contract(const nlohmann::json& document = openapi_document());

  const std::vector<Operation>& operations() const { return operations_; }
  const Operation* find(const std::string& method, const std::string& path) const;
  // Each throws ApiError 400 bad_request naming the first field that breaks `op`'s schema: the
  // request's query parameters (before routing), its body (parsed: api.h's body_json calls it).
  void check_query(const Operation& op, const httplib::Request& req) const;
  void check_body(const Operation& op, const nlohmann::json& body) const;

 private:
  std::vector<Operation> operations_;
};

}  // namespace forklift::server
