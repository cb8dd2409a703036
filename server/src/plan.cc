#include "plan.h"

#include <cmath>
#include <filesystem>

#include "forklift/scene/scene.h"
#include "forklift/session/vocabulary.h"

namespace forklift::server {
namespace {

using nlohmann::json;

// Millimetres are plenty for a drawing (the meshes are floats: 20.200000762939453).
double mm(double v) { return std::round(v * 1000) / 1000; }
json xy(const Eigen::Vector2d& p) { return json::array({mm(p.x()), mm(p.y())}); }
double deg(double rad) { return rad * 180 / M_PI; }

json make_plan(const std::string& file, const std::string& data_dir) {
  const Scene scene = load_scene(file, data_dir);
  json j;
  j["name"] = scene.name;
  j["description"] = scene.description;
  j["floor_m"] = scene.floor.isEmpty() ? json(nullptr)
                                       : json::array({scene.floor.min().x(), scene.floor.min().y(),
                                                      scene.floor.max().x(), scene.floor.max().y()});
  j["start"] = {{"x_m", scene.scenario.x_m}, {"y_m", scene.scenario.y_m}, {"yaw_deg", deg(scene.scenario.yaw_rad)}};
  j["time_limit_s"] = scene.time_limit_s > 0 ? json(scene.time_limit_s) : json(nullptr);
  j["zones"] = json::array();
  for (const Zone& z : scene.zones) {
    json poly = json::array();
    for (const auto& p : z.polygon) poly.push_back(xy(p));
    j["zones"].push_back({{"id", z.id}, {"kind", z.kind}, {"polygon", poly}, {"speed_limit_m_s", z.speed_limit_m_s}});
  }
  j["ramps"] = json::array();
  for (const Ramp& r : scene.ramps)
    j["ramps"].push_back({{"start_m", xy(r.start_m)}, {"heading_deg", deg(r.heading_rad)}, {"length_m", r.length_m},
                          {"width_m", r.width_m}, {"rise_m", r.rise_m}, {"plateau_m", r.plateau_m}});
  j["objects"] = json::array();
  for (const SceneObject& o : scene.objects) {
    // The footprint is the mesh's bounds in the object's own frame; the pose places it.
    const Eigen::Matrix3d r = o.pose.linear();
    json fp = nullptr;
    if (o.mesh && !o.mesh->bounds.isEmpty())
      fp = json::array({mm(o.mesh->bounds.min().x()), mm(o.mesh->bounds.min().y()), mm(o.mesh->bounds.max().x()),
                        mm(o.mesh->bounds.max().y())});
    j["objects"].push_back({{"id", o.id}, {"kind", object_kind_name(o.kind)}, {"x_m", mm(o.pose.translation().x())},
                            {"y_m", mm(o.pose.translation().y())}, {"yaw_deg", mm(deg(std::atan2(r(1, 0), r(0, 0))))},
                            {"footprint_m", fp}});
  }
  json route = json::array();
  for (const auto& p : scene.route.points) route.push_back(xy(p));
  j["route"] = {{"width_m", scene.route.width_m}, {"points", route}};
  json steps = json::array();
  for (const TaskStep& s : scene.task.steps) {
    json step = {{"kind", s.kind}, {"description", step_words(s.description)}};
    if (s.kind == "pass") { step["gate_a"] = xy(s.gate_a); step["gate_b"] = xy(s.gate_b); }
    else { step["point"] = xy(s.point); step["radius_m"] = s.radius_m > 0 ? s.radius_m : s.tolerance_m; }
    steps.push_back(step);
  }
  j["task"] = {{"summary", scene.task.summary}, {"steps", steps}};
  // The people who move: the paths they walk (where each is now comes with the live state and
  // the replay's samples).
  j["pedestrians"] = json::array();
  for (const PedestrianSpec& p : scene.pedestrians) {
    json path = json::array();
    for (const auto& q : p.path) path.push_back(xy(q));
    j["pedestrians"].push_back({{"id", p.id}, {"path", path}, {"speed_m_s", p.speed_m_s}, {"looks", p.looks},
                                {"size_m", {mm(p.size_m.x()), mm(p.size_m.y()), mm(p.size_m.z())}}});
  }
  // The other trucks' routes and the crossings, likewise.
  j["trucks"] = json::array();
  for (const OtherTruckSpec& t : scene.trucks) {
    json route = json::array();
    for (const auto& q : t.route) route.push_back(xy(q));
    j["trucks"].push_back({{"id", t.id}, {"route", route}, {"loop", t.loop}, {"speed_m_s", t.speed_m_s},
                           {"size_m", {mm(t.size_m.x()), mm(t.size_m.y()), mm(t.size_m.z())}}});
  }
  // The pallets that fall (the instructor may drop one): which, and where it stands.
  j["falling_pallets"] = json::array();
  for (const FallingPalletSpec& f : scene.falling_pallets) {
    const SceneObject* o = scene.find(f.pallet);
    j["falling_pallets"].push_back({{"pallet", f.pallet}, {"x_m", o ? mm(o->pose.translation().x()) : 0.0},
                                    {"y_m", o ? mm(o->pose.translation().y()) : 0.0}});
  }
  // The spills: where each is, how slippery, and whether it waits for a trigger (the instructor
  // may start one that does).
  j["spills"] = json::array();
  for (const Spill& sp : scene.spills)
    j["spills"].push_back({{"id", sp.id}, {"rect", {mm(sp.rect.min().x()), mm(sp.rect.min().y()), mm(sp.rect.max().x()), mm(sp.rect.max().y())}},
                           {"friction_scale", sp.friction_scale}, {"triggered", sp.triggered}});
  j["crossings"] = json::array();
  for (const Crossing& c : scene.crossings) {
    json poly = json::array();
    for (const auto& p : c.polygon) poly.push_back(xy(p));
    j["crossings"].push_back({{"id", c.id}, {"polygon", poly}, {"priority", c.priority}});
  }
  return j;
}

}  // namespace

nlohmann::json PlanCache::plan(const std::string& file) {
  std::error_code ec;
  const auto t = std::filesystem::last_write_time(file, ec);
  if (ec) throw std::runtime_error(file + ": " + ec.message());
  const long long stamp = static_cast<long long>(t.time_since_epoch().count());
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (auto it = plans_.find(file); it != plans_.end() && it->second.first == stamp) return it->second.second;
  }
  json j;
  try {
    j = make_plan(file, data_dir_);
  } catch (const SceneError& e) {
    throw std::runtime_error(e.what());
  }
  std::lock_guard<std::mutex> lock(mu_);
  plans_[file] = {stamp, j};
  return j;
}

}  // namespace forklift::server
