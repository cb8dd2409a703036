// The scene's small queries; loading lives in scene_file.cc and mesh.cc.
#include "forklift/scene/scene.h"

#include <array>
#include <utility>

namespace forklift {
namespace {

constexpr std::array<std::pair<ObjectKind, const char*>, 9> kKindNames{{
    {ObjectKind::kRack, "rack"},
    {ObjectKind::kPallet, "pallet"},
    {ObjectKind::kWall, "wall"},
    {ObjectKind::kDoor, "door"},
    {ObjectKind::kDock, "dock"},
    {ObjectKind::kLorry, "lorry"},
    {ObjectKind::kCone, "cone"},
    {ObjectKind::kObstacle, "obstacle"},
    {ObjectKind::kPedestrian, "pedestrian"},
}};

}  // namespace

const char* object_kind_name(ObjectKind kind) {
  for (const auto& [k, name] : kKindNames)
    if (k == kind) return name;
  return "unknown";
}

std::optional<ObjectKind> parse_object_kind(const std::string& name) {
  for (const auto& [k, n] : kKindNames)
    if (name == n) return k;
  return std::nullopt;
}

namespace {
// Even-odd ray crossing; points on an edge may fall either way, which a speed limit or a marker tolerates.
bool polygon_contains(const std::vector<Eigen::Vector2d>& polygon, const Eigen::Vector2d& p) {
  bool inside = false;
  const size_t n = polygon.size();
  for (size_t i = 0, j = n - 1; i < n; j = i++) {
    const Eigen::Vector2d& a = polygon[i];
    const Eigen::Vector2d& b = polygon[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
      inside = !inside;
  }
  return inside;
}
}  // namespace

bool Zone::contains(const Eigen::Vector2d& p) const { return polygon_contains(polygon, p); }
bool Marker::contains(const Eigen::Vector2d& p) const { return polygon_contains(polygon, p); }
bool Crossing::contains(const Eigen::Vector2d& p) const { return polygon_contains(polygon, p); }

const std::vector<std::string>& marker_kinds() {
  static const std::vector<std::string> kinds{"blind_corner", "door", "cross_aisle"};
  return kinds;
}

const SceneObject* Scene::find(const std::string& id) const {
  for (const SceneObject& o : objects)
    if (o.id == id) return &o;
  return nullptr;
}

std::optional<double> Scene::speed_limit(const Eigen::Vector2d& p) const {
  std::optional<double> limit;
  for (const Zone& z : zones)
    if (z.contains(p) && (!limit || z.speed_limit_m_s < *limit)) limit = z.speed_limit_m_s;
  return limit;
}

const std::vector<ControlAction>& control_actions() {
  static const std::vector<ControlAction> actions = {
      {"forward", "speed_m_s", true},       {"stop", "speed_m_s", false},      {"reverse", "speed_m_s", true},
      {"steer_left", "angle_deg", true},    {"steer_right", "angle_deg", true}, {"steer_straight", "angle_deg", false},
      {"lift", "height_m", true},           {"lower", "height_m", false},       {"tilt_back", "angle_deg", true},
      {"tilt_forward", "angle_deg", true},  {"tilt_level", "angle_deg", false},
  };
  return actions;
}

const ControlAction* find_control_action(const std::string& name) {
  for (const ControlAction& a : control_actions())
    if (name == a.name) return &a;
  return nullptr;
}

std::string not_an_exam_course(const std::string& what) {
  return what + " is not an exam course: an exam runs only on a scenario laid out as a practical test and "
                "marked \"exam_course\" (the paper's manoeuvres and the training scenarios are for practice)";
}

}  // namespace forklift
