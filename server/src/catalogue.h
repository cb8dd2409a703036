// The data folder's scenarios and trucks as the routes name them (by file stem), and the scenario
// each session ran.
#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>

#include "context.h"
#include "forklift/store/store.h"

namespace forklift::server {

// Every JSON file under data/manoeuvres/ and data/scenarios/: stem -> path.
std::map<std::string, std::string> scenarios(const std::string& data_dir);
// The file of the scenario `name`; ApiError 404 if there is none.
std::string scenario_file(const std::string& data_dir, const std::string& name);
// Every JSON file under data/trucks/: stem -> path.
std::map<std::string, std::string> trucks(const std::string& data_dir);
nlohmann::json read_json_file(const std::string& path);  // throws when unreadable

// What the web pages and the certificate say about a truck: its file's name and rating, and its
// OSHA class from data/theory/certification.json (the truck files do not carry one).
nlohmann::json truck_json(const std::string& data_dir, const std::string& stem);
// The truck and load a scenario (as run) sets: the truck file's stem, or null for the worker's
// default truck; the load object, or null for none.
std::pair<nlohmann::json, nlohmann::json> scenario_setup(const nlohmann::json& sc);
// Whether a scenario file's JSON declares it an exam course ("exam_course": only these start in
// exam mode, and only their exams count toward a licence).
bool is_exam_course(const nlohmann::json& scenario);

// A scenario's exam course: its top-level "exam_course" object (only an exam
// course can be a practical exam, and only an exam on one counts toward a licence), else null.
nlohmann::json exam_course(const nlohmann::json& scenario);
// The scenario a session ran, from the store alone: the copy kept with it, else the file of that
// name under `data_dir` (for sessions from before copies were kept); {} if neither is readable.
nlohmann::json scenario_as_run(store::SessionStore& db, const std::string& data_dir, const store::Session& s);

// The scenario a session ran: the copy kept with it (with the truck and load chosen), else, for
// sessions from before copies were kept, the scenario file of that name.
nlohmann::json session_scenario(Context& ctx, const store::Session& s);
// The file to hand the renderer or a worker for a session: the session's own copy if the
// truck or load were changed, else the scenario file.
std::string session_scenario_file(Context& ctx, const store::Session& s);

}  // namespace forklift::server
