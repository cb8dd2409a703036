#include "load_request.h"

#include <cmath>

#include "api.h"

namespace forklift::server {

nlohmann::json check_load_request(const nlohmann::json& l) {
  if (!l.is_object()) throw ApiError(400, "bad_request", "'load' must be null (no load) or an object");
  // The limits are the worker's (sim/scene/src/scenario.cc, forklift-sim's options).
  json load = json::object();
  for (const auto& [k, v] : l.items()) {
    if (k != "mass_kg" && k != "cog_height_m" && k != "lateral_m") throw ApiError(400, "bad_request", "'load." + k + "' is not a load field");
    if (!v.is_number()) throw ApiError(400, "bad_request", "'load." + k + "' must be a number");
    load[k] = v.get<double>();
  }
  const auto in = [&](const char* k, double lo, double hi, bool open_lo) {
    if (!load.contains(k)) return true;
    const double v = load[k].get<double>();
    return std::isfinite(v) && (open_lo ? v > lo : v >= lo) && v <= hi;
  };
  if (!load.contains("mass_kg") || !in("mass_kg", 0, 20000, true)) throw ApiError(400, "bad_request", "'load.mass_kg' must be in (0, 20000]");
  if (!in("cog_height_m", 0, 10, false)) throw ApiError(400, "bad_request", "'load.cog_height_m' must be in [0, 10]");
  if (!in("lateral_m", -2, 2, false)) throw ApiError(400, "bad_request", "'load.lateral_m' must be in [-2, 2]");
  return load;
}

}  // namespace forklift::server
