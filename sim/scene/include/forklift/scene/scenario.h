// A session's starting conditions: the truck file, the start pose and the initial load.
#pragma once

#include <optional>
#include <stdexcept>
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

// A load asked for by a scenario file, a session request or forklift-sim: a 1 m cube of
// `mass_kg` at the truck's rated load centre, `lateral_m` to the left, its centre of gravity
// `cog_height_m` above the floor.
struct LoadRequest {
  double mass_kg = 0;
  double cog_height_m = 0.6;
  double lateral_m = 0;
};
// What every session shares, whatever its scenario and truck: <data>/session.json. Throws
// std::runtime_error naming the file and the key.
struct SessionSettings {
  double tick_s = 0;  // the physics tick
  double task_end_hold_s = 0;  // how long a pupil lets the truck be, its task done, before the session ends
  double load_mass_max_kg = 0, load_cog_height_max_m = 0, load_lateral_max_m = 0;  // a requested load's bounds
  size_t instructor_message_max_chars = 0;  // an instructor's message to the cab, at most
  double instructor_message_shown_s = 0;    // how long the cab shows it (wall time: a paused session shows it too)
  double instructor_rewind_every_s = 0;     // a rewind point kept every so much sim time
  size_t instructor_rewind_points = 0;      // the newest so many kept
};
SessionSettings load_session_settings(const std::string& data_dir);

// Why a request cannot be carried, naming its field as a request does
// ("'load.mass_kg' must be in (0, 20000]"), or nullopt. The bounds: <data>/session.json "load".
std::optional<std::string> load_request_problem(const LoadRequest& request, const std::string& data_dir);
// The load a request puts on the forks, and the lift that holds its centre of gravity at the
// height asked (within the mast's travel).
Load requested_load(const LoadRequest& request, const TruckParams& truck);
double requested_lift(const LoadRequest& request, const Load& load, const TruckParams& truck);

}  // namespace forklift
