#include "load_request.h"

#include <cmath>

#include "forklift/scene/scenario.h"

#include "api.h"

namespace forklift::server {

nlohmann::json check_load_request(const nlohmann::json& l, const std::string& data_dir) {
  if (!l.is_object()) throw ApiError(400, "bad_request", "'load' must be null (no load) or an object");
  json load = json::object();
  for (const auto& [k, v] : l.items()) {
    if (k != "mass_kg" && k != "cog_height_m" && k != "lateral_m") throw ApiError(400, "bad_request", "'load." + k + "' is not a load field");
    if (!v.is_number()) throw ApiError(400, "bad_request", "'load." + k + "' must be a number");
    load[k] = v.get<double>();
  }
  // The ranges are the simulation's own (the scenario loader's), so that a bad load is a 400
  // now rather than a failed session later.
  LoadRequest r;
  r.mass_kg = load.value("mass_kg", 0.0);
  r.cog_height_m = load.value("cog_height_m", r.cog_height_m);
  r.lateral_m = load.value("lateral_m", r.lateral_m);
  if (const auto problem = load_request_problem(r, data_dir)) throw ApiError(400, "bad_request", *problem);
  return load;
}

}  // namespace forklift::server
