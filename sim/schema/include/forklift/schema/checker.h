// Checking a JSON document against any JSON Schema (draft 7, valijson), and telling the first
// problem as the key it is at and the rule it breaks in words: for the data files (data_file.h)
// and for the server's requests, which are checked against its API description.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

namespace forklift::schema {

class SchemaChecker {
 public:
  // `schema` with its "$ref"s into its own "#/definitions/" only; compiled once, here.
  explicit SchemaChecker(nlohmann::json schema);
  ~SchemaChecker();
  SchemaChecker(SchemaChecker&&) noexcept;
  SchemaChecker& operator=(SchemaChecker&&) noexcept;

  struct Problem {
    enum Kind { kMissing, kUnknownKey, kRule } kind;
    std::string key;     // dotted, [i] for an element; empty: the document itself
    std::string words;   // kRule: what is wrong, e.g. "must be at most 1000 (found 5000)"; empty if no words fit
    std::string detail;  // valijson's own text, for a developer's eyes only
  };
  // The first problem of `doc`, or nullopt when it holds. Safe to call from many threads.
  std::optional<Problem> problem(const nlohmann::json& doc) const;

 private:
  struct Compiled;
  std::unique_ptr<Compiled> compiled_;
};

}  // namespace forklift::schema
