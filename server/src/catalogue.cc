#include "catalogue.h"

#include <filesystem>
#include <stdexcept>

#include "api.h"
#include "forklift/schema/data_file.h"

namespace forklift::server {

using nlohmann::json;

std::map<std::string, std::string> scenarios(const std::string& data_dir) {
  std::map<std::string, std::string> out;
  for (const char* dir : {"manoeuvres", "scenarios"}) {
    const std::filesystem::path d = std::filesystem::path(data_dir) / dir;
    if (!std::filesystem::is_directory(d)) continue;
    for (const auto& f : std::filesystem::directory_iterator(d))
      if (f.path().extension() == ".json") out[f.path().stem().string()] = f.path().string();
  }
  return out;
}

std::string scenario_file(const std::string& data_dir, const std::string& name) {
  const auto all = scenarios(data_dir);
  const auto it = all.find(name);
  if (it == all.end()) throw ApiError(404, "not_found", "no scenario '" + name + "'");
  return it->second;
}

std::map<std::string, std::string> trucks(const std::string& data_dir) {
  std::map<std::string, std::string> out;
  const std::filesystem::path d = std::filesystem::path(data_dir) / "trucks";
  if (std::filesystem::is_directory(d))
    for (const auto& f : std::filesystem::directory_iterator(d))
      if (f.path().extension() == ".json") out[f.path().stem().string()] = f.path().string();
  return out;
}

json read_json_file(const std::string& path) {
  // Only a regular file of a bounded size: a pipe left in data/ must not block a request.
  return schema::read_json(path);
}

json truck_json(const std::string& data_dir, const std::string& stem) {
  json j = {{"name", stem}, {"title", stem}, {"rated_capacity_kg", nullptr}, {"rated_load_centre_m", nullptr}, {"osha_class", nullptr}};
  try {
    const json t = read_json_file(data_dir + "/trucks/" + stem + ".json");
    j["title"] = t.value("name", stem);
    j["rated_capacity_kg"] = t.value("rated_capacity_kg", json(nullptr));
    j["rated_load_centre_m"] = t.value("rated_load_centre_m", json(nullptr));
    const json c = read_json_file(data_dir + "/theory/certification.json");
    if (c.contains("truck_classes") && c["truck_classes"].contains(stem)) j["osha_class"] = c["truck_classes"][stem];
  } catch (const std::exception&) {
    // an unreadable file leaves the defaults: the page still shows the name
  }
  return j;
}

bool is_exam_course(const json& scenario) { return scenario.is_object() && scenario.contains("exam_course") && scenario["exam_course"].is_object(); }

std::pair<json, json> scenario_setup(const json& sc) {
  json truck = nullptr, load = nullptr;
  if (sc.contains("truck") && sc["truck"].is_string())
    truck = std::filesystem::path(sc["truck"].get<std::string>()).stem().string();
  if (sc.contains("load") && sc["load"].is_object()) load = sc["load"];
  return {truck, load};
}

json exam_course(const json& scenario) {
  return scenario.is_object() && scenario.contains("exam_course") && scenario["exam_course"].is_object() ? scenario["exam_course"]
                                                                                                       : json(nullptr);
}

json scenario_as_run(store::SessionStore& db, const std::string& data_dir, const store::Session& s) {
  if (const auto kept = db.get_session_log(s.public_id, "scenario")) {
    json j = json::parse(*kept, nullptr, false);
    if (j.is_object()) return j;
  }
  const auto all = scenarios(data_dir);
  const auto it = all.find(s.scenario);
  if (it == all.end()) return json::object();
  try { return read_json_file(it->second); } catch (const std::exception&) { return json::object(); }
}

json session_scenario(Context& ctx, const store::Session& s) { return scenario_as_run(ctx.db(), ctx.data_dir, s); }

std::string session_scenario_file(Context& ctx, const store::Session& s) {
  const std::string own = ctx.fleet->config().log_dir + "/" + s.public_id + ".scenario.json";
  if (std::filesystem::exists(own)) return own;
  const auto all = scenarios(ctx.data_dir);
  const auto it = all.find(s.scenario);
  return it == all.end() ? std::string() : it->second;
}

}  // namespace forklift::server
