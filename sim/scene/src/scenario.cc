#include "forklift/scene/scenario.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "forklift/dynamics/manoeuvre.h"

namespace forklift {

Scenario default_scenario(const std::string& data_dir) {
  Scenario s;
  s.truck_file = data_dir + "/trucks/linde_e16c.json";
  return s;
}

Scenario load_scenario(const std::string& path, const std::string& data_dir) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open scenario");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path + ": not valid JSON: " + e.what());
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
      const double mass = l.at("mass_kg").get<double>();
      if (!(mass > 0 && mass < 20000)) throw std::runtime_error("load.mass_kg must be in (0, 20000)");
      s.load = box_load(mass, 1.0, 1.0, 1.0, truck.rated_load_centre_m, l.value("lateral_m", 0.0));
      s.lift_m = std::clamp(lift_for_load_height(truck, *s.load, l.value("cog_height_m", 0.6)), 0.0, truck.limits.lift_max_m);
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

}  // namespace forklift
