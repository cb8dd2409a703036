// The load a request to start a session asks for (POST /api/sessions, "load"), checked against the
// simulation's own limits (load_request_problem) so that a bad load is a 400 now rather than a failed session later.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace forklift::server {

// `load` (an object of mass_kg, and optionally cog_height_m and lateral_m, as the Load schema of
// server/openapi.yaml has it: body_json has checked that) within the simulation's own limits;
// throws ApiError(400) naming the first bad key. A null load (none) is the caller's business.
nlohmann::json check_load_request(const nlohmann::json& load, const std::string& data_dir);

}  // namespace forklift::server
