#include "forklift/scene/scenario.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "forklift/dynamics/manoeuvre.h"
#include "forklift/schema/data_file.h"
#include "forklift/session/vocabulary.h"
#include "forklift/units/decimals.h"

namespace forklift {

Scenario default_scenario(const std::string& data_dir) {
  Scenario s;
  s.truck_file = data_dir + "/trucks/linde_e16c.json";
  return s;
}

Scenario load_scenario(const std::string& path, const std::string& data_dir) {
  nlohmann::json j;
  try {
    j = schema::read_checked_json(path, schema::Schema::kScenario);
  } catch (const schema::DataFileError& e) {
    throw std::runtime_error(e.what());
  }
  Scenario s = default_scenario(data_dir);
  try {
    if (j.contains("truck")) {
      const std::string t = j.at("truck").get<std::string>();
      s.truck_file = (!t.empty() && t[0] == '/') ? t : data_dir + "/" + t;
    }
    if (j.contains("start")) {
      const auto& st = j.at("start");
      s.x_m = st.value("x_m", 0.0);
      s.y_m = st.value("y_m", 0.0);
      s.yaw_rad = st.value("yaw_deg", 0.0) * M_PI / 180;
    }
    const TruckParams truck = load_truck(s.truck_file);
    if (j.contains("load") && !j.at("load").is_null()) {
      const auto& l = j.at("load");
      LoadRequest r;
      r.mass_kg = l.at("mass_kg").get<double>();
      r.lateral_m = l.value("lateral_m", r.lateral_m);
      r.cog_height_m = l.value("cog_height_m", r.cog_height_m);
      if (const auto problem = load_request_problem(r, data_dir)) throw std::runtime_error(*problem);
      s.load = requested_load(r, truck);
      s.lift_m = requested_lift(r, *s.load, truck);
    }
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path + ": " + e.what());
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  if (!std::isfinite(s.x_m) || !std::isfinite(s.y_m) || !std::isfinite(s.yaw_rad))
    throw std::runtime_error(path + ": start pose is not finite");
  return s;
}

SessionSettings load_session_settings(const std::string& data_dir) {
  const std::string path = data_dir + "/session.json";
  try {
    const nlohmann::json j = schema::read_json(path);
    SessionSettings s;
    s.tick_s = j.at("tick_s").get<double>();
    if (!(s.tick_s >= 1e-4 && s.tick_s <= 0.01)) throw std::runtime_error("tick_s must be in [0.0001, 0.01] s");
    s.task_end_hold_s = j.at("task_end_hold_s").get<double>();
    if (!(s.task_end_hold_s >= 0 && s.task_end_hold_s <= 60)) throw std::runtime_error("task_end_hold_s must be in [0, 60] s");
    const nlohmann::json& ins = j.at("instructor");
    const int max_chars = ins.at("message_max_chars").get<int>();
    if (max_chars < 1 || size_t(max_chars) > kInstructorMessageCharsCeiling)
      throw std::runtime_error("instructor.message_max_chars must be in [1, " + std::to_string(kInstructorMessageCharsCeiling) + "]");
    s.instructor_message_max_chars = size_t(max_chars);
    s.instructor_message_shown_s = ins.at("message_shown_s").get<double>();
    if (!(s.instructor_message_shown_s >= 1 && s.instructor_message_shown_s <= 120))
      throw std::runtime_error("instructor.message_shown_s must be in [1, 120] s");
    s.instructor_rewind_every_s = ins.at("rewind_point_every_s").get<double>();
    if (!(s.instructor_rewind_every_s >= 0.1 && s.instructor_rewind_every_s <= 60))
      throw std::runtime_error("instructor.rewind_point_every_s must be in [0.1, 60] s");
    const int points = ins.at("rewind_points_kept").get<int>();
    if (points < 1 || points > 1000) throw std::runtime_error("instructor.rewind_points_kept must be in [1, 1000]");
    s.instructor_rewind_points = size_t(points);
    const nlohmann::json& l = j.at("load");
    s.load_mass_max_kg = l.at("mass_max_kg").get<double>();
    s.load_cog_height_max_m = l.at("cog_height_max_m").get<double>();
    s.load_lateral_max_m = l.at("lateral_max_m").get<double>();
    return s;
  } catch (const schema::DataFileError& e) {
    throw std::runtime_error(e.what());  // names the file already
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
}

std::optional<std::string> load_request_problem(const LoadRequest& r, const std::string& data_dir) {
  const SessionSettings lim = load_session_settings(data_dir);
  if (!(std::isfinite(r.mass_kg) && r.mass_kg > 0 && r.mass_kg <= lim.load_mass_max_kg))
    return "'load.mass_kg' must be in (0, " + trimmed_decimals(lim.load_mass_max_kg, 6) + "]";
  if (!(std::isfinite(r.cog_height_m) && r.cog_height_m >= 0 && r.cog_height_m <= lim.load_cog_height_max_m))
    return "'load.cog_height_m' must be in [0, " + trimmed_decimals(lim.load_cog_height_max_m, 6) + "]";
  if (!(std::isfinite(r.lateral_m) && std::abs(r.lateral_m) <= lim.load_lateral_max_m))
    return "'load.lateral_m' must be in [-" + trimmed_decimals(lim.load_lateral_max_m, 6) + ", " + trimmed_decimals(lim.load_lateral_max_m, 6) + "]";
  return std::nullopt;
}

Load requested_load(const LoadRequest& r, const TruckParams& truck) {
  return box_load(r.mass_kg, 1.0, 1.0, 1.0, truck.rated_load_centre_m, r.lateral_m);
}

double requested_lift(const LoadRequest& r, const Load& load, const TruckParams& truck) {
  return std::clamp(lift_for_load_height(truck, load, r.cog_height_m), 0.0, truck.limits.lift_max_m);
}

}  // namespace forklift
