// For the scene's tests: the pupil's truck as the people and the other trucks see it (a truck of
// boxes standing where a test puts it), and the loader's words for a scenario file.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "forklift/scene/pedestrians.h"

namespace forklift::scene_test {

// The chassis 2.6 m long and 1.1 m wide behind its origin, forks 1.2 m ahead.
inline TruckOutline outline() {
  TruckOutline o;
  o.chassis_m = Eigen::AlignedBox2d(Eigen::Vector2d(-2.5, -0.55), Eigen::Vector2d(0.1, 0.55));
  o.forks_m = Eigen::AlignedBox2d(Eigen::Vector2d(0, -0.25), Eigen::Vector2d(1.2, 0.25));
  return o;
}

// The truck's chassis origin at (x, y), heading +x; the fork heel 0.5 m ahead of it.
inline BodyPoses truck_at(double x, double y) {
  BodyPoses p;
  p.chassis = Eigen::Isometry3d(Eigen::Translation3d(x, y, 0.3));
  p.mast = p.chassis;
  p.carriage = Eigen::Isometry3d(Eigen::Translation3d(x + 0.5, y, 0.2));
  for (auto& w : p.wheels) w = p.chassis;
  return p;
}

// The loader's words for a scenario file `name` holding `body` (JSON text), or "(no error)".
inline std::string load_error(const std::string& name, const std::string& body) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("scene_test_" + name + "_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path) << body;
  std::string error = "(no error)";
  try {
    load_scene(path, FORKLIFT_DATA_DIR);
  } catch (const SceneError& e) {
    error = e.what();
  }
  fs::remove_all(dir);
  return error;
}

}  // namespace forklift::scene_test
