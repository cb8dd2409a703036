#include "load_request.h"

#include <cmath>

#include "forklift/scene/scenario.h"

#include "api.h"

namespace forklift::server {

nlohmann::json check_load_request(const nlohmann::json& l, const std::string& data_dir) {
  // Its fields, their types and ranges as server/openapi.yaml's Load has them: body_json checked.
  json load = json::object();
  for (const auto& [k, v] : l.items()) load[k] = v.get<double>();
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
