// The warehouse plan of a scenario for the web pages: what the simulator loads (the scene
// library's load_scene, includes resolved, meshes read), flattened to 2-D JSON in world metres:
// floor, zones, ramps, objects with their footprints, the route, the task and the start pose.
#pragma once

#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>

namespace forklift::server {

// Plans by scenario file, built once per version of that file (its modification time) so that
// pages do not reload meshes on every view; a layout it includes that is edited while the server
// runs shows after the scenario file is touched or the server restarts. Thread-safe.
class PlanCache {
 public:
  explicit PlanCache(std::string data_dir) : data_dir_(std::move(data_dir)) {}
  // The plan of the scenario in `file`. Throws std::runtime_error (the scene's own message,
  // naming the file and key) if the file or a mesh it names is bad.
  nlohmann::json plan(const std::string& file);

 private:
  std::string data_dir_;
  std::mutex mu_;
  std::map<std::string, std::pair<long long, nlohmann::json>> plans_;  // file -> (mtime, plan)
};

}  // namespace forklift::server
