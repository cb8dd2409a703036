// Reading the data files a school or a user hands in (scenarios, layouts, trucks, meshes) without
// trusting them: only regular files of a bounded size are read, JSON is bounded in depth, and a
// document is checked against its JSON Schema (data/schema/, built into the programs) before any
// of its numbers reach the scene, FCL or the integrator.
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>

namespace forklift::schema {

// Every refusal: the message starts with the file's path and says what is wrong in words.
class DataFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A JSON data file is at most this big: the largest shipped one (the warehouse) is about 40 kB.
constexpr size_t kMaxJsonBytes = size_t{16} << 20;
// A mesh file (OBJ, glTF, their material files): the shipped ones are under 100 kB.
constexpr size_t kMaxMeshBytes = size_t{64} << 20;
// Arrays and objects nest at most this deep in a JSON data file (the shipped ones: 5).
constexpr int kMaxJsonDepth = 64;

// Why `path` cannot be read as a data file of at most `max_bytes`, or nullopt: it must be a regular
// file (a pipe, a device or a folder is refused unread: reading one could block or never end).
std::optional<std::string> file_problem(const std::string& path, size_t max_bytes);

// The bytes of `path` under the rules of file_problem. Throws DataFileError "<path>: ...".
std::string read_file(const std::string& path, size_t max_bytes);

// The JSON document in `path`: read as above (at most kMaxJsonBytes), nested at most
// kMaxJsonDepth deep. Throws DataFileError "<path>: ...".
nlohmann::json read_json(const std::string& path);

// The schemas of data/schema/ (built in: the ranges there are the programs' contract).
enum class Schema {
  kTruck,     // data/schema/truck.schema.json: a truck file
  kScenario,  // data/schema/scenario.schema.json: a scenario file or a layout it includes
};

// The first way `doc` breaks `schema`, naming the dotted key as the loaders do:
// "'objects[3].x_m' must be at most 10000 (metres; found 1e+308)", or nullopt when it holds.
std::optional<std::string> schema_problem(const nlohmann::json& doc, Schema schema);

// read_json, then schema_problem; throws DataFileError "<path>: <problem>".
nlohmann::json read_checked_json(const std::string& path, Schema schema);

}  // namespace forklift::schema
