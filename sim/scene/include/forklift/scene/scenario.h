// A session's starting conditions: the truck file, the start pose and the initial load.
#pragma once

#include <optional>
#include <string>

#include "forklift/dynamics/dynamics.h"

namespace forklift {

// A session's starting conditions (JSON; all keys optional):
//   { "truck": "trucks/linde_e16c.json", "start": {"x_m": 0, "y_m": 0, "yaw_deg": 0},
//     "load": {"mass_kg": 500, "lateral_m": 0, "cog_height_m": 2.0} }
// Relative paths are resolved against the data directory.
struct Scenario {
  std::string truck_file;
  double x_m = 0, y_m = 0, yaw_rad = 0;
  std::optional<Load> load;
  double lift_m = 0;
};
Scenario default_scenario(const std::string& data_dir);
// Throws std::runtime_error naming the file and the problem.
Scenario load_scenario(const std::string& path, const std::string& data_dir);

}  // namespace forklift
