// Reading scenario files (format: data/scenarios/README.md) and the truck's shape section.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <tuple>

#include "forklift/schema/data_file.h"
#include "forklift/scene/scene.h"
#include "mesh_builder.h"
#include "mesh_internal.h"
#include "forklift/units/units.h"
#include "forklift/session/vocabulary.h"

namespace forklift {
namespace {

using nlohmann::json;
// A file without "floor_m" (a manoeuvre on an empty floor) gets a square this far around the start.
constexpr double kDefaultFloorHalfSize_m = 100.0;
// Includes may nest this deep; deeper is taken for a cycle.
constexpr int kMaxIncludeDepth = 8;
// A pallet placed "on" a support may restate its z_m; it must agree to within this.
constexpr double kHeightTolerance_m = 1e-6;

[[noreturn]] void fail(const std::string& file, const std::string& key, const std::string& what) {
  throw SceneError(file + ": '" + key + "' " + what);
}

std::string resolve(const std::string& data_dir, const std::string& rel) {
  return (!rel.empty() && rel[0] == '/') ? rel : data_dir + "/" + rel;
}

// A scenario or layout file, checked against data/schema/scenario.schema.json before any of its
// numbers is read: what follows checks what a schema cannot say.
json read_scenario_json(const std::string& path) {
  try {
    return schema::read_checked_json(path, schema::Schema::kScenario);
  } catch (const schema::DataFileError& e) {
    throw SceneError(e.what());
  }
}

// Typed access to one JSON node, failing with the file and the dotted key.
class Node {
 public:
  Node(const json& j, std::string file, std::string key) : j_(j), file_(std::move(file)), key_(std::move(key)) {}

  const json& raw() const { return j_; }
  const std::string& file() const { return file_; }
  const std::string& key() const { return key_; }
  [[noreturn]] void fail(const std::string& what) const { forklift::fail(file_, key_, what); }

  bool has(const char* name) const { return j_.is_object() && j_.contains(name) && !j_.at(name).is_null(); }
  Node at(const char* name) const {
    if (!j_.is_object()) fail("must be an object");
    if (!has(name)) forklift::fail(file_, sub(name), "is missing");
    return Node(j_.at(name), file_, sub(name));
  }
  Node at(size_t i) const { return Node(j_.at(i), file_, key_ + "[" + std::to_string(i) + "]"); }
  size_t size() const { return j_.size(); }

  void require_object() const {
    if (!j_.is_object()) fail("must be an object");
  }
  size_t array(size_t min_size = 0) const {
    if (!j_.is_array()) fail("must be an array");
    if (j_.size() < min_size) fail("must have at least " + std::to_string(min_size) + " elements");
    return j_.size();
  }
  double number() const {
    if (!j_.is_number()) fail("is not a number");
    const double v = j_.get<double>();
    if (!std::isfinite(v)) fail("is not finite");
    return v;
  }
  double non_negative() const {
    const double v = number();
    if (v < 0) fail("must not be negative");
    return v;
  }
  double positive() const {
    const double v = number();
    if (v <= 0) fail("must be positive");
    return v;
  }
  int integer() const {
    if (!j_.is_number_integer()) fail("is not an integer");
    return j_.get<int>();
  }
  std::string string() const {
    if (!j_.is_string()) fail("is not a string");
    return j_.get<std::string>();
  }
  bool boolean() const {
    if (!j_.is_boolean()) fail("is not true or false");
    return j_.get<bool>();
  }
  Eigen::VectorXd numbers(size_t n) const {
    if (!j_.is_array() || j_.size() != n) fail("must be an array of " + std::to_string(n) + " numbers");
    Eigen::VectorXd v(n);
    for (size_t i = 0; i < n; ++i) v[i] = at(i).number();
    return v;
  }
  Eigen::Vector2d vec2() const { return numbers(2); }
  Eigen::Vector3d vec3() const { return numbers(3); }
  // [xmin, ymin, xmax, ymax] with min <= max.
  Eigen::AlignedBox2d box2() const {
    const Eigen::VectorXd v = numbers(4);
    if (v[0] > v[2] || v[1] > v[3]) fail("must be [xmin, ymin, xmax, ymax] with min <= max");
    return Eigen::AlignedBox2d(Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3]));
  }

  double number_or(const char* name, double def) const { return has(name) ? at(name).number() : def; }
  double non_negative_or(const char* name, double def) const { return has(name) ? at(name).non_negative() : def; }
  double positive_or(const char* name, double def) const { return has(name) ? at(name).positive() : def; }
  std::string string_or(const char* name, const std::string& def) const { return has(name) ? at(name).string() : def; }

  // Fails on keys not in `known` (comments start with "_").
  void only(std::initializer_list<const char*> known) const {
    require_object();
    for (auto it = j_.begin(); it != j_.end(); ++it) {
      if (!it.key().empty() && it.key()[0] == '_') continue;
      if (std::none_of(known.begin(), known.end(), [&](const char* k) { return it.key() == k; }))
        forklift::fail(file_, sub(it.key().c_str()), "is not a known key");
    }
  }

 private:
  std::string sub(const char* name) const { return key_.empty() ? std::string(name) : key_ + "." + name; }
  const json& j_;
  std::string file_, key_;
};

// The scenario after includes: plain keys (the last file to set one wins) and the concatenated
// lists, each element remembering the file and key it came from.
struct Merged {
  struct Item {
    json value;
    std::string file, key;
  };
  std::map<std::string, Item> keys;
  std::vector<Item> objects, zones, ramps, ground_steps, pedestrians, markers, spills, falling_pallets, trucks, crossings;
};

const std::set<std::string> kTopKeys = {"name",   "description", "truck",        "start",  "exam_course",
                                        "load",   "include",     "objects",      "zones",
                                        "ramps",  "ground_steps", "route",     "task",         "time_limit_s",
                                        "floor_m", "zone_speed_limits_m_s", "exclude_objects", "pedestrians",
                                        "markers", "spills", "falling_pallets", "manoeuvre", "duration_s",
                                        "trucks", "crossings"};

// Read by load_scenario (scenario.h) from the scenario file itself.
// An exam course is the scenario's own declaration: a layout may not make its includers exams.
const std::set<std::string> kOwnKeys = {"truck", "start", "load", "manoeuvre", "duration_s", "exam_course"};

void merge(const std::string& path, const std::string& data_dir, Merged& m, int depth) {
  if (depth > kMaxIncludeDepth) throw SceneError(path + ": 'include' nested too deep (a cycle?)");
  const json j = read_scenario_json(path);
  if (j.contains("include")) {
    const Node inc(j.at("include"), path, "include");
    const std::string target = resolve(data_dir, inc.string());
    std::error_code ec;
    if (!std::filesystem::exists(target, ec)) inc.fail("names a missing file " + target);
    if (const auto problem = schema::file_problem(target, schema::kMaxJsonBytes)) inc.fail("names " + target + ", which " + *problem);
    merge(target, data_dir, m, depth + 1);
  }
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& k = it.key();
    if (k == "include" || (!k.empty() && k[0] == '_')) continue;
    if (!kTopKeys.count(k)) fail(path, k, "is not a known key");
    if (depth > 0 && kOwnKeys.count(k)) fail(path, k, "belongs in the scenario file itself, not in an included layout");
    if (k == "objects" || k == "zones" || k == "ramps" || k == "ground_steps" || k == "pedestrians" || k == "markers" ||
        k == "spills" || k == "falling_pallets" || k == "trucks" || k == "crossings") {
      const Node list(it.value(), path, k);
      list.array();
      auto& out = k == "objects" ? m.objects : k == "zones" ? m.zones : k == "ramps" ? m.ramps
                  : k == "ground_steps" ? m.ground_steps : k == "markers" ? m.markers : k == "spills" ? m.spills : k == "falling_pallets" ? m.falling_pallets
                  : k == "trucks" ? m.trucks : k == "crossings" ? m.crossings : m.pedestrians;
      for (size_t i = 0; i < list.size(); ++i) out.push_back({it.value()[i], path, k + "[" + std::to_string(i) + "]"});
    } else if (k == "exclude_objects") {
      const Node list(it.value(), path, k);
      list.array();
      for (size_t i = 0; i < list.size(); ++i) {
        const std::string id = list.at(i).string();
        auto found = std::find_if(m.objects.begin(), m.objects.end(), [&](const Merged::Item& o) {
          return o.value.is_object() && o.value.contains("id") && o.value.at("id") == id;
        });
        if (found == m.objects.end()) list.at(i).fail("names no object '" + id + "' to exclude");
        m.objects.erase(found);
      }
    } else {
      m.keys[k] = {it.value(), path, k};
    }
  }
}

Eigen::AlignedBox2d xy(const Eigen::AlignedBox3d& b) {
  return Eigen::AlignedBox2d(b.min().head<2>(), b.max().head<2>());
}

// The pallet's dimensions and pockets as its mesh has them: the solid parts' bounds, and the
// gaps between the "blocks_*" rows (y) in the blocks' height band.
PalletSpec pallet_from_mesh(const Mesh& mesh) {
  PalletSpec p;
  Eigen::AlignedBox3d solid, blocks;
  std::vector<Eigen::Vector2d> rows;
  for (const MeshPart& part : mesh.parts) {
    if (!part.solid) continue;
    solid.extend(part.bounds);
    if (part.name.rfind("blocks_", 0) == 0) {
      blocks.extend(part.bounds);
      rows.emplace_back(part.bounds.min().y(), part.bounds.max().y());
    }
  }
  if (solid.isEmpty()) return p;
  p.length_m = solid.sizes().x();
  p.width_m = solid.sizes().y();
  p.height_m = solid.sizes().z();
  if (rows.size() >= 2) {
    p.pocket_bottom_m = blocks.min().z() - solid.min().z();
    p.pocket_top_m = blocks.max().z() - solid.min().z();
    std::sort(rows.begin(), rows.end(), [](const auto& a, const auto& b) { return a.x() < b.x(); });
    for (size_t i = 1; i < rows.size(); ++i)
      if (rows[i].x() > rows[i - 1].y()) p.pockets_y_m.emplace_back(rows[i - 1].y(), rows[i].x());
  }
  return p;
}

PalletSpec read_pallet(const Node& n, PalletSpec p) {
  n.only({"length_m", "width_m", "height_m", "pocket_bottom_m", "pocket_top_m", "pockets_y_m", "pallet_mass_kg",
          "load_mass_kg", "load_size_m", "friction_static", "friction_kinetic"});
  p.length_m = n.positive_or("length_m", p.length_m);
  p.width_m = n.positive_or("width_m", p.width_m);
  p.height_m = n.positive_or("height_m", p.height_m);
  p.pocket_bottom_m = n.non_negative_or("pocket_bottom_m", p.pocket_bottom_m);
  p.pocket_top_m = n.positive_or("pocket_top_m", p.pocket_top_m);
  if (p.pocket_top_m <= p.pocket_bottom_m || p.pocket_top_m > p.height_m)
    n.fail("pocket_top_m must lie above pocket_bottom_m and within height_m");
  if (n.has("pockets_y_m")) {
    const Node list = n.at("pockets_y_m");
    list.array(1);
    p.pockets_y_m.clear();
    for (size_t i = 0; i < list.size(); ++i) {
      const Eigen::Vector2d v = list.at(i).vec2();
      if (v.x() >= v.y()) list.at(i).fail("must be [min, max] with min < max");
      p.pockets_y_m.push_back(v);
    }
  }
  p.pallet_mass_kg = n.positive_or("pallet_mass_kg", p.pallet_mass_kg);
  p.load_mass_kg = n.non_negative_or("load_mass_kg", p.load_mass_kg);
  if (n.has("load_size_m")) {
    const Node s = n.at("load_size_m");
    p.load_size_m = s.vec3();
    if ((p.load_size_m.array() < 0).any()) s.fail("must not be negative");
    const bool none = p.load_size_m.isZero(), all = (p.load_size_m.array() > 0).all();
    if (!none && !all) s.fail("must be all positive (a load) or all zero (none)");
  }
  if (p.load_mass_kg > 0 && p.load_size_m.isZero()) n.fail("has load_mass_kg but no load_size_m");
  p.friction_static = n.non_negative_or("friction_static", p.friction_static);
  p.friction_kinetic = n.non_negative_or("friction_kinetic", p.friction_kinetic);
  if (p.friction_kinetic > p.friction_static) n.fail("friction_kinetic must not exceed friction_static");
  return p;
}

Support read_support(const Node& n, const Mesh& mesh) {
  n.only({"name", "height_m", "footprint_m"});
  Support s;
  s.name = n.at("name").string();
  s.height_m = n.at("height_m").non_negative();
  s.footprint = n.has("footprint_m") ? n.at("footprint_m").box2() : xy(mesh.bounds);
  return s;
}

// A pallet to stand on its "on" support once every object exists (the support may come later).
struct PendingPlacement {
  size_t index;
  Node node;
};

SceneObject read_object(const Node& n, const std::string& data_dir) {
  n.only({"id", "kind", "mesh", "x_m", "y_m", "z_m", "yaw_deg", "scale", "collidable", "levels_m",
          "support_footprint_m", "supports", "pallet", "load_mesh", "on", "level"});
  SceneObject o;
  o.id = n.at("id").string();
  if (o.id.empty()) n.at("id").fail("must not be empty");
  const std::string kind = n.at("kind").string();
  const auto k = parse_object_kind(kind);
  if (!k) n.at("kind").fail("is an unknown kind '" + kind + "'");
  o.kind = *k;
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();
  if (n.has("scale")) {
    scale = n.at("scale").vec3();
    if ((scale.array() <= 0).any()) n.at("scale").fail("must be positive");
  }
  const std::string mesh_rel = n.string_or("mesh", std::string("meshes/") + kind + ".obj");
  try {
    o.mesh = load_mesh_scaled(resolve(data_dir, mesh_rel), scale);
  } catch (const SceneError& e) {
    n.fail(std::string("mesh: ") + e.what());
  }
  const double x = n.at("x_m").number(), y = n.at("y_m").number();
  const double z = n.number_or("z_m", 0.0), yaw = n.number_or("yaw_deg", 0.0) * kDeg;
  o.pose = Eigen::Translation3d(x, y, z) * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ());
  if (n.has("collidable")) o.collidable = n.at("collidable").boolean();

  if (o.kind == ObjectKind::kRack) {
    const Node levels = n.at("levels_m");
    levels.array(1);
    const Eigen::AlignedBox2d footprint =
        n.has("support_footprint_m") ? n.at("support_footprint_m").box2() : xy(o.mesh->bounds);
    double below = 0;
    for (size_t i = 0; i < levels.size(); ++i) {
      const double h = levels.at(i).positive();
      if (h <= below) levels.at(i).fail("must be above the level below");
      below = h;
      o.supports.push_back({"level " + std::to_string(i + 1), static_cast<int>(i + 1), footprint, h});
    }
  } else if (n.has("levels_m")) {
    n.at("levels_m").fail("is for racks only");
  }
  if (n.has("supports")) {
    if (o.kind == ObjectKind::kRack) n.at("supports").fail("racks take levels_m instead");
    const Node list = n.at("supports");
    list.array(1);
    for (size_t i = 0; i < list.size(); ++i) o.supports.push_back(read_support(list.at(i), *o.mesh));
  }

  if (o.kind == ObjectKind::kPallet) {
    PalletSpec spec = pallet_from_mesh(*o.mesh);
    if (n.has("pallet")) spec = read_pallet(n.at("pallet"), spec);
    if (spec.pockets_y_m.empty()) n.fail("the pallet has no pockets: its mesh has no blocks_* rows and pallet.pockets_y_m is not given");
    if (!spec.load_size_m.isZero()) {
      const std::string load_rel = n.string_or("load_mesh", "meshes/load_box.obj");
      try {
        o.load_mesh = load_mesh_scaled(resolve(data_dir, load_rel), Eigen::Vector3d::Ones());
      } catch (const SceneError& e) {
        n.fail(std::string("load_mesh: ") + e.what());
      }
    }
    o.pallet = spec;
  } else {
    for (const char* key : {"pallet", "load_mesh", "on", "level"})
      if (n.has(key)) n.at(key).fail("is for pallets only");
  }
  return o;
}

// Stands a pallet on the support its "on" and "level" name: z from the support's height, and
// its centre must lie over the support's footprint.
void place_on_support(SceneObject& pallet, const Node& n, const Scene& scene) {
  const std::string on = n.at("on").string();
  const SceneObject* target = scene.find(on);
  if (!target) n.at("on").fail("names no object '" + on + "'");
  if (target->supports.empty()) n.at("on").fail("names '" + on + "', which has no supports");
  const Support* support = nullptr;
  const int level = n.has("level") ? n.at("level").integer() : 0;
  for (const Support& s : target->supports)
    if (s.level == level) support = &s;
  if (target->kind != ObjectKind::kRack && level == 0 && target->supports.size() != 1)
    n.at("on").fail("names '" + on + "', which has several supports");
  if (!support) forklift::fail(n.file(), n.key() + ".level", "is no level of '" + on + "'");
  const Eigen::Vector3d centre = target->pose.inverse() * pallet.pose.translation();
  if (!support->footprint.contains(centre.head<2>()))
    n.fail("stands beside '" + on + "' " + support->name + ": its centre is off the support");
  const double z = (target->pose * Eigen::Vector3d(centre.x(), centre.y(), support->height_m)).z();
  if (n.has("z_m") && std::abs(n.at("z_m").number() - z) > kHeightTolerance_m)
    n.at("z_m").fail("disagrees with the height of '" + on + "' " + support->name);
  pallet.pose.translation().z() = z;
  pallet.rests_on = on;
  pallet.rest_level = support->level;
}

// One pedestrian: a path walked once at a speed, waits at its points, what starts the walk, and
// whether the person looks out for the truck.
void read_trigger(const Node& t, std::optional<double>& truck_within_m, double& at_s);
PedestrianSpec read_pedestrian(const Node& n) {
  n.only({"id", "path", "speed_m_s", "waits", "trigger", "looks", "stop_within_m", "heeds_horn_within_m", "size_m"});
  PedestrianSpec p;
  p.id = n.at("id").string();
  const Node path = n.at("path");
  path.array(2);
  for (size_t i = 0; i < path.size(); ++i) {
    p.path.push_back(path.at(i).vec2());
    if (i > 0 && p.path[i] == p.path[i - 1]) path.at(i).fail("repeats the point before it");
  }
  p.speed_m_s = n.at("speed_m_s").positive();
  if (n.has("waits")) {
    const Node waits = n.at("waits");
    waits.array();
    for (size_t i = 0; i < waits.size(); ++i) {
      const Node w = waits.at(i);
      w.only({"at_point", "duration_s"});
      PedestrianWait pw{w.at("at_point").integer(), w.at("duration_s").non_negative()};
      if (pw.at_point < 0 || pw.at_point >= int(p.path.size()))
        w.at("at_point").fail("must name a point of the path, 0 to " + std::to_string(p.path.size() - 1));
      for (const PedestrianWait& o : p.waits)
        if (o.at_point == pw.at_point) w.at("at_point").fail("repeats a wait at point " + std::to_string(pw.at_point));
      p.waits.push_back(pw);
    }
  }
  if (n.has("trigger")) read_trigger(n.at("trigger"), p.start_truck_within_m, p.start_at_s);
  p.looks = n.has("looks") ? n.at("looks").boolean() : true;
  if (p.looks) p.stop_within_m = n.at("stop_within_m").positive();
  else if (n.has("stop_within_m")) n.at("stop_within_m").fail("is for one who looks (looks: true)");
  if (n.has("heeds_horn_within_m")) {
    if (p.looks) n.at("heeds_horn_within_m").fail("is for one who does not look (looks: false): one who looks stands anyway");
    p.heeds_horn_within_m = n.at("heeds_horn_within_m").positive();
  }
  if (n.has("size_m")) {
    p.size_m = n.at("size_m").vec3();
    for (int i = 0; i < 3; ++i)
      if (!(p.size_m[i] > 0)) n.at("size_m").at(size_t(i)).fail("must be positive");
  }
  return p;
}

// A zone's or a marker's area: exactly one of `rect` and `polygon`, stored counter-clockwise.
std::vector<Eigen::Vector2d> read_area(const Node& n) {
  std::vector<Eigen::Vector2d> polygon;
  if (n.has("polygon") == n.has("rect")) n.fail("needs exactly one of polygon and rect");
  if (n.has("rect")) {
    const Eigen::AlignedBox2d b = n.at("rect").box2();
    polygon = {b.corner(Eigen::AlignedBox2d::BottomLeft), b.corner(Eigen::AlignedBox2d::BottomRight),
               b.corner(Eigen::AlignedBox2d::TopRight), b.corner(Eigen::AlignedBox2d::TopLeft)};
  } else {
    const Node poly = n.at("polygon");
    poly.array(3);
    for (size_t i = 0; i < poly.size(); ++i) polygon.push_back(poly.at(i).vec2());
  }
  double area2 = 0;
  for (size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++)
    area2 += polygon[j].x() * polygon[i].y() - polygon[i].x() * polygon[j].y();
  if (!(std::abs(area2) > 0)) n.fail("has no area");
  if (area2 < 0) std::reverse(polygon.begin(), polygon.end());
  return polygon;
}

Zone read_zone(const Node& n, const Node* speed_limits) {
  n.only({"id", "kind", "polygon", "rect", "speed_limit_m_s"});
  Zone z;
  z.id = n.at("id").string();
  z.kind = n.at("kind").string();
  z.polygon = read_area(n);
  if (n.has("speed_limit_m_s")) {
    z.speed_limit_m_s = n.at("speed_limit_m_s").positive();
  } else if (speed_limits && speed_limits->has(z.kind.c_str())) {
    z.speed_limit_m_s = speed_limits->at(z.kind.c_str()).positive();
  } else {
    n.fail("has no speed_limit_m_s and zone_speed_limits_m_s has none for kind '" + z.kind + "'");
  }
  return z;
}

// A hazard's trigger: {truck_within_m} or {at_s}, exactly one.
void read_trigger(const Node& t, std::optional<double>& truck_within_m, double& at_s) {
  t.only({"truck_within_m", "at_s"});
  if (t.has("truck_within_m") == t.has("at_s")) t.fail("must give one of truck_within_m and at_s");
  if (t.has("truck_within_m")) truck_within_m = t.at("truck_within_m").positive();
  else at_s = t.at("at_s").non_negative();
}

// A pallet that falls: it must stand on a support above the floor (a rack level, a bed).
FallingPalletSpec read_falling_pallet(const Node& n, const Scene& scene) {
  n.only({"pallet", "trigger", "toward_deg", "throw_m"});
  FallingPalletSpec f;
  f.pallet = n.at("pallet").string();
  const SceneObject* o = scene.find(f.pallet);
  if (!o || o->kind != ObjectKind::kPallet) n.at("pallet").fail("names no pallet '" + f.pallet + "'");
  if (o->rests_on.empty() || !(o->pose.translation().z() > 0))
    n.at("pallet").fail("names pallet '" + f.pallet + "', which stands on the floor: only one on a support above it can fall");
  read_trigger(n.at("trigger"), f.start_truck_within_m, f.start_at_s);
  f.toward_rad = n.at("toward_deg").number() * kDeg;
  f.throw_m = n.non_negative_or("throw_m", f.throw_m);
  return f;
}

Spill read_spill(const Node& n) {
  n.only({"id", "rect", "friction_scale", "trigger"});
  Spill sp;
  sp.id = n.at("id").string();
  sp.rect = n.at("rect").box2();
  if (!(sp.rect.sizes().minCoeff() > 0)) n.at("rect").fail("must have xmax > xmin and ymax > ymin");
  sp.friction_scale = n.at("friction_scale").positive();
  if (sp.friction_scale > 1) n.at("friction_scale").fail("must be at most 1 (a spill grips less, never more)");
  if (n.has("trigger")) {
    sp.triggered = true;
    read_trigger(n.at("trigger"), sp.start_truck_within_m, sp.start_at_s);
  }
  return sp;
}

Marker read_marker(const Node& n) {
  n.only({"id", "kind", "polygon", "rect"});
  Marker mk;
  mk.id = n.at("id").string();
  mk.kind = n.at("kind").string();
  const std::vector<std::string>& kinds = marker_kinds();
  if (std::find(kinds.begin(), kinds.end(), mk.kind) == kinds.end())
    n.at("kind").fail("must be blind_corner, door or cross_aisle (found " + mk.kind + ")");
  mk.polygon = read_area(n);
  return mk;
}

// Another truck on its route: the route driven at a speed, once or round and round, from its trigger.
OtherTruckSpec read_other_truck(const Node& n) {
  n.only({"id", "route", "speed_m_s", "loop", "trigger", "stop_within_m", "size_m"});
  OtherTruckSpec t;
  t.id = n.at("id").string();
  const Node route = n.at("route");
  route.array(2);
  for (size_t i = 0; i < route.size(); ++i) {
    t.route.push_back(route.at(i).vec2());
    if (i > 0 && t.route[i] == t.route[i - 1]) route.at(i).fail("repeats the point before it");
  }
  t.loop = n.has("loop") ? n.at("loop").boolean() : false;
  if (t.loop && t.route.back() == t.route.front()) route.fail("ends where it starts: a loop closes itself (loop: true)");
  t.speed_m_s = n.at("speed_m_s").positive();
  if (n.has("trigger")) read_trigger(n.at("trigger"), t.start_truck_within_m, t.start_at_s);
  if (n.has("stop_within_m")) t.stop_within_m = n.at("stop_within_m").positive();
  if (n.has("size_m")) {
    t.size_m = n.at("size_m").vec3();
    for (int i = 0; i < 3; ++i)
      if (!(t.size_m[i] > 0)) n.at("size_m").at(size_t(i)).fail("must be positive");
  }
  return t;
}

Crossing read_crossing(const Node& n) {
  n.only({"id", "polygon", "rect", "priority", "watch_m"});
  Crossing c;
  c.id = n.at("id").string();
  c.polygon = read_area(n);
  for (const Eigen::Vector2d& p : c.polygon) c.middle_m += p / double(c.polygon.size());
  c.priority = n.at("priority").string();
  if (c.priority != "pupil" && c.priority != "traffic")
    n.at("priority").fail("must be pupil (the other trucks give way) or traffic (the pupil gives way) (found " + c.priority + ")");
  if (c.priority == "pupil") c.watch_m = n.at("watch_m").positive();
  else if (n.has("watch_m")) n.at("watch_m").fail("is for a crossing where the other trucks give way (priority: pupil)");
  return c;
}

Ramp read_ramp(const Node& n) {
  n.only({"id", "start_m", "heading_deg", "length_m", "width_m", "rise_m", "plateau_m"});
  Ramp r;
  r.start_m = n.at("start_m").vec2();
  r.heading_rad = n.at("heading_deg").number() * kDeg;
  r.length_m = n.at("length_m").positive();
  r.width_m = n.at("width_m").positive();
  r.rise_m = n.at("rise_m").number();
  r.plateau_m = n.non_negative_or("plateau_m", 0.0);
  return r;
}

GroundStep read_ground_step(const Node& n) {
  n.only({"id", "rect", "top_m"});
  GroundStep g;
  g.footprint_m = n.at("rect").box2();
  if (!(g.footprint_m.sizes().minCoeff() > 0)) n.at("rect").fail("must have xmax > xmin and ymax > ymin");
  g.top_m = n.at("top_m").number();
  return g;
}

TaskStep read_step(const Node& n, const Scene& scene) {
  TaskStep s;
  s.kind = n.at("kind").string();
  if (s.kind == "reach") {
    n.only({"kind", "description", "point", "radius_m"});
    s.point = n.at("point").vec2();
    s.radius_m = n.at("radius_m").positive();
  } else if (s.kind == "pass") {
    n.only({"kind", "description", "gate_a", "gate_b"});
    s.gate_a = n.at("gate_a").vec2();
    s.gate_b = n.at("gate_b").vec2();
    if ((s.gate_a - s.gate_b).norm() <= 0) n.fail("gate_a and gate_b must differ");
  } else if (s.kind == "take") {
    n.only({"kind", "description", "pallet"});
    s.pallet = n.at("pallet").string();
    const SceneObject* p = scene.find(s.pallet);
    if (!p || p->kind != ObjectKind::kPallet) n.at("pallet").fail("names no pallet '" + s.pallet + "'");
  } else if (s.kind == "control") {
    n.only({"kind", "description", "action", "speed_m_s", "angle_deg", "height_m"});
    s.action = n.at("action").string();
    const ControlAction* a = find_control_action(s.action);
    if (!a) {
      std::string names;
      for (const ControlAction& c : control_actions()) names += std::string(names.empty() ? "" : ", ") + c.name;
      n.at("action").fail("must be one of " + names + " (found " + s.action + ")");
    }
    for (const char* key : {"speed_m_s", "angle_deg", "height_m"})
      if (n.has(key) && std::string(key) != a->key) n.at(key).fail("is not a measure of '" + s.action + "' (" + a->key + " is)");
    s.amount = n.at(a->key).non_negative() * (std::string(a->key) == "angle_deg" ? kDeg : 1.0);
  } else if (s.kind == "move") {
    n.only({"kind", "description", "pallet", "to_object", "to_level", "point", "area", "tolerance_m", "yaw_deg",
            "yaw_tolerance_deg"});
    s.pallet = n.at("pallet").string();
    const SceneObject* p = scene.find(s.pallet);
    if (!p || p->kind != ObjectKind::kPallet) n.at("pallet").fail("names no pallet '" + s.pallet + "'");
    s.to_object = n.string_or("to_object", "");
    s.to_level = n.has("to_level") ? n.at("to_level").integer() : 0;
    if (s.to_object.empty()) {
      if (!n.has("area")) n.fail("needs to_object or area");
      s.area = n.at("area").box2();
      if (s.to_level != 0) n.at("to_level").fail("must be 0 for the floor");
      s.point = s.area.center();
    } else {
      const SceneObject* o = scene.find(s.to_object);
      if (!o) n.at("to_object").fail("names no object '" + s.to_object + "'");
      if (o->supports.empty()) n.at("to_object").fail("names '" + s.to_object + "', which has no supports");
      const bool found = std::any_of(o->supports.begin(), o->supports.end(),
                                     [&](const Support& sp) { return sp.level == s.to_level; });
      if (!found) forklift::fail(n.file(), n.key() + ".to_level", "is no level of '" + s.to_object + "'");
      if (o->kind != ObjectKind::kRack && o->supports.size() != 1)
        n.at("to_object").fail("names '" + s.to_object + "', which has several supports");
      if (n.has("area")) s.area = n.at("area").box2();
      // The target's centre: the support footprint's middle unless a point is given.
      const Support& sp = *std::find_if(o->supports.begin(), o->supports.end(),
                                        [&](const Support& x) { return x.level == s.to_level; });
      const Eigen::Vector2d c = sp.footprint.center();
      s.point = (o->pose * Eigen::Vector3d(c.x(), c.y(), sp.height_m)).head<2>();
    }
    if (n.has("point")) s.point = n.at("point").vec2();
    s.tolerance_m = n.positive_or("tolerance_m", s.tolerance_m);
    if (n.has("yaw_deg") != n.has("yaw_tolerance_deg")) n.fail("needs both yaw_deg and yaw_tolerance_deg, or neither");
    if (n.has("yaw_deg")) {
      s.yaw_rad = n.at("yaw_deg").number() * kDeg;
      s.yaw_tolerance_rad = n.at("yaw_tolerance_deg").positive() * kDeg;
    }
  } else {
    n.at("kind").fail("is an unknown step kind '" + s.kind + "' (reach, pass, take, move, control)");
  }
  s.description = n.string_or("description", "");
  // Each brace names a control, so that no cab's display and no debrief shows "{lfit}": the
  // controls' words hold no brace, so one left in the words is unknown or never closed.
  const std::string words = step_words(s.description);
  if (const size_t open = words.find('{'); open != std::string::npos)
    n.at("description").fail("names '" + words.substr(open, words.find('}', open) + 1 - open) +
                             "', which is no control (accelerator, brake, steer_left, steer_right, centre, forward, "
                             "neutral, reverse, lift, lower, tilt_back, tilt_forward, parking_brake, horn)");
  return s;
}

// --- the truck's shape ---------------------------------------------------------------------

// The shape section's keys that named OBJ files before the meshes were built from the truck file.
constexpr const char* kOldMeshKeys[] = {"chassis_mesh", "mast_mesh", "carriage_mesh", "front_wheel_mesh",
                                        "rear_wheel_mesh"};

// [lo, hi] with lo < hi, as floats (the meshes' precision).
std::pair<float, float> span(const Node& n) {
  const Eigen::Vector2d v = n.vec2();
  if (!(v[0] < v[1])) n.fail("must be [from, to] with from < to");
  return {static_cast<float>(v[0]), static_cast<float>(v[1])};
}
float length(const Node& n) { return static_cast<float>(n.positive()); }
Eigen::Vector3f clearance(const Node& n) {
  const Eigen::Vector3d v = n.vec3();
  if ((v.array() < 0).any()) n.fail("must not be negative");
  return v.cast<float>();
}

// Fails naming `key` unless lo < hi: a derived part of the body would have no room.
void fits(const Node& n, const char* key, double lo, double hi, const std::string& what) {
  if (!(lo < hi)) {
    std::ostringstream msg;
    msg << "leaves no room: " << what << " (" << lo << " m is not below " << hi << " m)";
    n.at(key).fail(msg.str());
  }
}

struct TruckModel {
  meshgen::TruckDrawing drawing;
  Eigen::Vector3d eye_m;
};

// The drawing's dimensions: the shape section, then the wheels and the mast from the sections
// load_truck reads, then the checks that the body still fits around them.
TruckModel read_truck_model(const std::string& truck_file) {
  json root;
  try {
    root = schema::read_json(truck_file);
  } catch (const schema::DataFileError& e) {
    throw SceneError(e.what());
  }
  const Node n = Node(root, truck_file, "").at("shape");
  n.require_object();
  // The whole file against data/schema/truck.schema.json (load_truck below checks it again).
  if (const auto problem = schema::schema_problem(root, schema::Schema::kTruck)) throw SceneError(truck_file + ": " + *problem);
  for (const char* old : kOldMeshKeys)
    if (n.has(old))
      n.at(old).fail("is no longer read: the truck's meshes are built from this file's dimensions (remove the key; "
                     "`forklift-sim meshes --truck FILE --out DIR` writes them as OBJ)");
  n.only({"body", "seat", "steering_wheel", "overhead_guard", "mast", "carriage", "wheels", "fork_length_m",
          "fork_width_m", "fork_thickness_m", "fork_centres_y_m", "eye_m"});
  TruckModel model;
  meshgen::TruckDrawing& d = model.drawing;

  const Node body = n.at("body");
  body.only({"x_m", "width_m", "underside_m", "hood_m", "top_m", "cowl_bottom_m", "front_frame_top_m",
             "front_wheel_well_clearance_m", "rear_wheel_well_clearance_m"});
  std::tie(d.body.rear, d.body.front) = span(body.at("x_m"));
  d.body.half_width = 0.5f * length(body.at("width_m"));
  d.body.underside = length(body.at("underside_m"));
  d.body.hood = length(body.at("hood_m"));
  d.body.top = length(body.at("top_m"));
  d.body.cowl_bottom = length(body.at("cowl_bottom_m"));
  d.body.front_frame_top = length(body.at("front_frame_top_m"));
  d.body.front_well_clearance = clearance(body.at("front_wheel_well_clearance_m"));
  d.body.rear_well_clearance = clearance(body.at("rear_wheel_well_clearance_m"));
  fits(body, "hood_m", d.body.underside, d.body.hood, "the battery between the underside and the hood");
  fits(body, "top_m", d.body.hood, d.body.top, "the hood below the top");
  fits(body, "cowl_bottom_m", d.body.cowl_bottom, d.body.top, "the cowl below the top");
  fits(body, "front_frame_top_m", d.body.underside, d.body.front_frame_top, "the front frame above the underside");

  const Node seat = n.at("seat");
  seat.only({"x_m", "width_m", "cushion_m", "back_x_m", "back_top_m"});
  std::tie(d.seat.rear, d.seat.front) = span(seat.at("x_m"));
  d.seat.half_width = 0.5f * length(seat.at("width_m"));
  d.seat.cushion = length(seat.at("cushion_m"));
  std::tie(d.seat.back_rear, d.seat.back_front) = span(seat.at("back_x_m"));
  d.seat.back_top = length(seat.at("back_top_m"));
  fits(seat, "cushion_m", d.body.hood, d.seat.cushion, "the seat standing on the hood (body.hood_m)");
  fits(seat, "back_top_m", d.seat.cushion, d.seat.back_top, "the backrest above the cushion");

  const Node steer = n.at("steering_wheel");
  steer.only({"x_m", "diameter_m", "z_m", "column_x_m", "column_width_m"});
  std::tie(d.steering.rear, d.steering.front) = span(steer.at("x_m"));
  d.steering.radius = 0.5f * length(steer.at("diameter_m"));
  std::tie(d.steering.bottom, d.steering.top) = span(steer.at("z_m"));
  std::tie(d.steering.column_rear, d.steering.column_front) = span(steer.at("column_x_m"));
  d.steering.column_half_width = 0.5f * length(steer.at("column_width_m"));
  fits(steer, "z_m", d.body.top, d.steering.bottom, "the column from the cowl (body.top_m) up to the wheel");

  const Node guard = n.at("overhead_guard");
  guard.only({"x_m", "roof_z_m", "post_m", "front_posts_x_m", "slats", "slat_pitch_m", "slat_width_m",
              "slat_thickness_m", "first_slat_m"});
  std::tie(d.guard.rear, d.guard.front) = span(guard.at("x_m"));
  std::tie(d.guard.roof_bottom, d.guard.roof_top) = span(guard.at("roof_z_m"));
  d.guard.post = length(guard.at("post_m"));
  d.guard.front_post_rear = static_cast<float>(guard.at("front_posts_x_m").number());
  d.guard.slats = guard.at("slats").integer();
  if (d.guard.slats < 0) guard.at("slats").fail("must not be negative");
  d.guard.slat_pitch = length(guard.at("slat_pitch_m"));
  d.guard.slat_width = length(guard.at("slat_width_m"));
  d.guard.slat_thickness = length(guard.at("slat_thickness_m"));
  d.guard.first_slat = static_cast<float>(guard.at("first_slat_m").non_negative());
  fits(guard, "post_m", d.guard.post, d.body.half_width, "posts narrower than half the body (body.width_m)");
  fits(guard, "roof_z_m", d.body.top, d.guard.roof_bottom, "the roof above the cowl (body.top_m)");
  if (d.guard.slat_thickness > d.guard.roof_top - d.guard.roof_bottom)
    guard.at("slat_thickness_m").fail("must not exceed the roof's depth (roof_z_m)");

  const Node mast = n.at("mast");
  mast.only({"foot_above_floor_m", "built_height_m", "channel_x_m", "channel_y_m", "cross_member_depth_m",
             "top_cross_member_m", "middle_cross_member_z_m", "cylinder_x_m", "cylinder_width_m", "cylinder_z_m",
             "cylinder_y_m"});
  d.mast.foot = static_cast<float>(mast.at("foot_above_floor_m").non_negative());
  d.mast.built_height = length(mast.at("built_height_m"));
  std::tie(d.mast.channel_rear, d.mast.channel_front) = span(mast.at("channel_x_m"));
  std::tie(d.mast.channel_inner_y, d.mast.channel_outer_y) = span(mast.at("channel_y_m"));
  d.mast.cross_member_depth = length(mast.at("cross_member_depth_m"));
  d.mast.top_cross_member = length(mast.at("top_cross_member_m"));
  std::tie(d.mast.middle_cross_member_bottom, d.mast.middle_cross_member_top) = span(mast.at("middle_cross_member_z_m"));
  std::tie(d.mast.cylinder_rear, d.mast.cylinder_front) = span(mast.at("cylinder_x_m"));
  d.mast.cylinder_half_width = 0.5f * length(mast.at("cylinder_width_m"));
  std::tie(d.mast.cylinder_bottom, d.mast.cylinder_top) = span(mast.at("cylinder_z_m"));
  // Older files have one cylinder in the middle; a clear-view mast names where its two are.
  if (mast.has("cylinder_y_m")) {
    d.mast.cylinder_axis_y = static_cast<float>(mast.at("cylinder_y_m").non_negative());
    if (d.mast.cylinder_axis_y > 0)
      fits(mast, "cylinder_y_m", d.mast.cylinder_half_width, d.mast.cylinder_axis_y,
           "two cylinders apart, each clear of the middle (cylinder_width_m)");
  }
  fits(mast, "built_height_m", d.mast.foot, d.mast.built_height, "the channels from the foot up to the built height");

  const Node carriage = n.at("carriage");
  carriage.only({"width_m", "plate_depth_m", "plate_height_m", "backrest_height_m", "backrest_frame_m",
                 "backrest_bars_y_m", "backrest_bar_width_m", "inner_mast_x_m", "inner_mast_y_m",
                 "inner_mast_bottom_m", "inner_mast_top_member_m"});
  d.carriage.half_width = 0.5f * length(carriage.at("width_m"));
  d.carriage.plate_depth = length(carriage.at("plate_depth_m"));
  d.carriage.plate_height = length(carriage.at("plate_height_m"));
  d.carriage.backrest_height = length(carriage.at("backrest_height_m"));
  d.carriage.backrest_frame = length(carriage.at("backrest_frame_m"));
  const Node bars = carriage.at("backrest_bars_y_m");
  bars.array();
  for (size_t i = 0; i < bars.size(); ++i) d.carriage.backrest_bars_y.push_back(static_cast<float>(bars.at(i).number()));
  d.carriage.backrest_bar_width = length(carriage.at("backrest_bar_width_m"));
  std::tie(d.carriage.inner_mast_rear, d.carriage.inner_mast_front) = span(carriage.at("inner_mast_x_m"));
  std::tie(d.carriage.inner_mast_inner_y, d.carriage.inner_mast_outer_y) = span(carriage.at("inner_mast_y_m"));
  d.carriage.inner_mast_bottom = static_cast<float>(carriage.at("inner_mast_bottom_m").number());
  d.carriage.inner_mast_top_member = length(carriage.at("inner_mast_top_member_m"));
  fits(carriage, "backrest_height_m", d.carriage.plate_height, d.carriage.backrest_height - d.carriage.backrest_frame,
       "the backrest's frame above the plate");

  const Node wheels = n.at("wheels");
  wheels.only({"front_width_m", "rear_width_m", "hub_radius_share", "hub_proud_m"});
  d.front.width = length(wheels.at("front_width_m"));
  d.rear.width = length(wheels.at("rear_width_m"));
  d.hub_radius_share = length(wheels.at("hub_radius_share"));
  if (d.hub_radius_share >= 1) wheels.at("hub_radius_share").fail("must be below 1 (the hub inside its tyre)");
  d.hub_proud = static_cast<float>(wheels.at("hub_proud_m").non_negative());

  d.fork_length = length(n.at("fork_length_m"));
  d.fork_width = length(n.at("fork_width_m"));
  d.fork_thickness = length(n.at("fork_thickness_m"));
  d.fork_centres_y = length(n.at("fork_centres_y_m"));
  if (d.fork_centres_y <= d.fork_width) n.at("fork_centres_y_m").fail("must exceed fork_width_m (the forks would overlap)");
  model.eye_m = n.at("eye_m").vec3();

  // The wheels, the mast pivot and the fork heel as the dynamics have them (geometry frame).
  TruckParams truck;
  try {
    truck = load_truck(truck_file);
  } catch (const std::runtime_error& e) {
    throw SceneError(e.what());  // names the file and the key already
  }
  const Eigen::Vector3d to_geometry = truck.chassis_cog_geometry_m;
  const WheelParams& fl = truck.wheels[kFrontLeft];
  const WheelParams& fr = truck.wheels[kFrontRight];
  if (fl.radius_m != fr.radius_m)
    fail(truck_file, "wheels.front_right.radius_m", "differs from front_left's: both front wheels are drawn with one mesh");
  d.front.centre = (fl.centre_m + to_geometry).cast<float>();
  d.front.radius = static_cast<float>(fl.radius_m);
  d.rear.centre = (truck.wheels[kRear].centre_m + to_geometry).cast<float>();
  d.rear.radius = static_cast<float>(truck.wheels[kRear].radius_m);
  d.mast_pivot = (truck.mast_pivot_m + to_geometry).cast<float>();
  d.fork_heel_from_pivot = truck.fork_heel_from_pivot_m.cast<float>();

  // The wells around the wheels must still fit inside the body.
  const meshgen::TruckDrawing::Body& b = d.body;
  const float front_well_back = d.front.centre.x() - d.front.radius - b.front_well_clearance.x();
  const float rear_well_front = d.rear.centre.x() + d.rear.radius + b.rear_well_clearance.x();
  const float rear_well_back = d.rear.centre.x() - d.rear.radius - b.rear_well_clearance.x();
  fits(body, "front_wheel_well_clearance_m", rear_well_front, front_well_back,
       "the battery between the rear wheel's well and the front wheels' wells");
  fits(body, "rear_wheel_well_clearance_m", b.rear, rear_well_back, "the counterweight behind the rear wheel's well");
  fits(body, "front_wheel_well_clearance_m", 0, d.front.centre.y() - 0.5f * d.front.width - b.front_well_clearance.y(),
       "the front frame between the front wheels");
  fits(body, "cowl_bottom_m", d.front.centre.z() + d.front.radius + b.front_well_clearance.z(), b.cowl_bottom,
       "the fenders above the front wheels");
  fits(body, "rear_wheel_well_clearance_m", d.rear.centre.y() + d.rear.radius + b.rear_well_clearance.y(), b.half_width,
       "the counterweight beside the rear wheel's well");
  fits(body, "top_m", d.rear.centre.z() + d.rear.radius + b.rear_well_clearance.z(), b.top,
       "the counterweight above the rear wheel's well");
  return model;
}

}  // namespace

Scene load_scene(const std::string& path, const std::string& data_dir) {
  Merged m;
  merge(path, data_dir, m, 0);
  auto key = [&](const char* k) -> const Merged::Item* {
    auto it = m.keys.find(k);
    return it == m.keys.end() || it->second.value.is_null() ? nullptr : &it->second;
  };
  auto node = [](const Merged::Item& item) { return Node(item.value, item.file, item.key); };

  Scene scene;
  scene.file = path;
  scene.name = key("name") ? node(*key("name")).string() : std::filesystem::path(path).stem().string();
  if (key("description")) scene.description = node(*key("description")).string();
  if (key("exam_course")) {
    const Node e = node(*key("exam_course"));
    e.only({"title", "standard"});
    scene.exam_course = ExamCourse{e.at("title").string(), e.at("standard").string()};
  }
  // load_scenario reads these; checked here first so that a bad one is named by its key.
  if (key("truck")) node(*key("truck")).string();
  if (key("start")) {
    const Node st = node(*key("start"));
    st.only({"x_m", "y_m", "yaw_deg"});
    for (const char* k : {"x_m", "y_m", "yaw_deg"})
      if (st.has(k)) st.at(k).number();
  }
  if (key("load")) {
    const Node l = node(*key("load"));
    l.only({"mass_kg", "lateral_m", "cog_height_m"});
    l.at("mass_kg").positive();
    for (const char* k : {"lateral_m", "cog_height_m"})
      if (l.has(k)) l.at(k).number();
  }
  try {
    scene.scenario = load_scenario(path, data_dir);
  } catch (const SceneError&) {
    throw;
  } catch (const std::exception& e) {
    throw SceneError(e.what());  // names the file already
  }

  for (const Merged::Item& item : m.ramps) scene.ramps.push_back(read_ramp(node(item)));
  for (const Merged::Item& item : m.ground_steps) scene.ground_steps.push_back(read_ground_step(node(item)));
  std::set<std::string> spill_ids;
  std::vector<GripPatch> grip;
  for (const Merged::Item& item : m.spills) {
    const Node n = node(item);
    Spill sp = read_spill(n);
    if (!spill_ids.insert(sp.id).second) n.at("id").fail("repeats the spill id '" + sp.id + "'");
    if (sp.triggered && scene.spills.size() >= kMaxTriggeredSpill)
      n.at("trigger").fail("is for the first " + std::to_string(kMaxTriggeredSpill) + " spills only: list this one earlier");
    grip.push_back({sp.rect, sp.friction_scale});
    scene.spills.push_back(std::move(sp));
  }
  scene.ground = Ground(scene.ramps, scene.ground_steps, std::move(grip));

  std::set<std::string> ids;
  std::vector<PendingPlacement> placements;
  for (const Merged::Item& item : m.objects) {
    const Node n = node(item);
    SceneObject o = read_object(n, data_dir);
    if (!ids.insert(o.id).second) n.at("id").fail("repeats the id '" + o.id + "'");
    if (o.kind == ObjectKind::kPallet && n.has("on")) placements.push_back({scene.objects.size(), n});
    scene.objects.push_back(std::move(o));
  }
  for (const PendingPlacement& p : placements) place_on_support(scene.objects[p.index], p.node, scene);

  std::optional<Node> limits;
  if (key("zone_speed_limits_m_s")) {
    limits.emplace(node(*key("zone_speed_limits_m_s")));
    limits->require_object();
  }
  std::set<std::string> zone_ids;
  for (const Merged::Item& item : m.zones) {
    const Node n = node(item);
    Zone z = read_zone(n, limits ? &*limits : nullptr);
    if (!zone_ids.insert(z.id).second) n.at("id").fail("repeats the zone id '" + z.id + "'");
    scene.zones.push_back(std::move(z));
  }
  std::set<std::string> marker_ids;
  for (const Merged::Item& item : m.markers) {
    const Node n = node(item);
    Marker mk = read_marker(n);
    if (!marker_ids.insert(mk.id).second) n.at("id").fail("repeats the marker id '" + mk.id + "'");
    scene.markers.push_back(std::move(mk));
  }

  for (const Merged::Item& item : m.pedestrians) {
    const Node n = node(item);
    PedestrianSpec p = read_pedestrian(n);
    if (!ids.insert(p.id).second) n.at("id").fail("repeats the id '" + p.id + "'");
    scene.pedestrians.push_back(std::move(p));
  }
  for (const Merged::Item& item : m.trucks) {
    const Node n = node(item);
    OtherTruckSpec t = read_other_truck(n);
    if (!ids.insert(t.id).second) n.at("id").fail("repeats the id '" + t.id + "'");
    scene.trucks.push_back(std::move(t));
  }
  std::set<std::string> crossing_ids;
  for (const Merged::Item& item : m.crossings) {
    const Node n = node(item);
    Crossing c = read_crossing(n);
    if (!crossing_ids.insert(c.id).second) n.at("id").fail("repeats the crossing id '" + c.id + "'");
    scene.crossings.push_back(std::move(c));
  }
  std::set<std::string> falling_ids;
  for (const Merged::Item& item : m.falling_pallets) {
    const Node n = node(item);
    FallingPalletSpec f = read_falling_pallet(n, scene);
    if (!falling_ids.insert(f.pallet).second) n.at("pallet").fail("repeats the falling pallet '" + f.pallet + "'");
    scene.falling_pallets.push_back(std::move(f));
  }

  if (key("route")) {
    const Node r = node(*key("route"));
    r.only({"width_m", "points"});
    scene.route.width_m = r.at("width_m").non_negative();
    const Node pts = r.at("points");
    pts.array(2);
    for (size_t i = 0; i < pts.size(); ++i) scene.route.points.push_back(pts.at(i).vec2());
  }
  if (key("task")) {
    const Node t = node(*key("task"));
    t.only({"summary", "steps"});
    scene.task.summary = t.string_or("summary", "");
    if (t.has("steps")) {
      const Node steps = t.at("steps");
      steps.array();
      for (size_t i = 0; i < steps.size(); ++i) scene.task.steps.push_back(read_step(steps.at(i), scene));
    }
  }
  if (key("time_limit_s")) scene.time_limit_s = node(*key("time_limit_s")).non_negative();
  if (key("floor_m")) {
    scene.floor = node(*key("floor_m")).box2();
  } else {
    const Eigen::Vector2d start(scene.scenario.x_m, scene.scenario.y_m);
    const Eigen::Vector2d half = Eigen::Vector2d::Constant(kDefaultFloorHalfSize_m);
    scene.floor = Eigen::AlignedBox2d(start - half, start + half);
  }
  return scene;
}

TruckShape load_truck_shape(const std::string& truck_file, const std::string& data_dir) {
  (void)data_dir;  // the meshes are built from the truck file; nothing is read from data_dir
  const TruckModel model = read_truck_model(truck_file);
  TruckShape s;
  try {
    std::vector<std::shared_ptr<const Mesh>> meshes;
    for (const meshgen::MeshSpec& spec : meshgen::truck_meshes(model.drawing))
      meshes.push_back(mesh_from_spec(spec, truck_file + "#" + spec.file));
    s.chassis = meshes[0];
    s.mast = meshes[1];
    s.carriage = meshes[2];
    s.front_wheel = meshes[3];
    s.rear_wheel = meshes[4];
  } catch (const SceneError& e) {
    throw SceneError(truck_file + ": 'shape' " + e.what());
  }
  const meshgen::TruckDrawing& d = model.drawing;
  s.fork_length_m = d.fork_length;
  s.fork_width_m = d.fork_width;
  s.fork_thickness_m = d.fork_thickness;
  s.fork_centres_y_m = d.fork_centres_y;
  s.eye_m = model.eye_m;
  return s;
}

std::vector<std::string> write_truck_meshes(const std::string& truck_file, const std::string& dir) {
  return write_mesh_specs(meshgen::truck_meshes(read_truck_model(truck_file).drawing), dir);
}

}  // namespace forklift
