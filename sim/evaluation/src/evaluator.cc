// The Evaluator: every tick, the detectors in the order of the pipeline's outputs (contacts,
// speed, forks and mast, accelerations and stability, pallet handling, route, task, time), each
// turning a measured condition into at most one event per occurrence.
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <unordered_map>

#include "forklift/evaluation/evaluation.h"
#include "forklift/dynamics/stability.h"
#include "forklift/scene/pedestrians.h"
#include "geometry.h"
#include "rule_table.h"
#include "forklift/units/units.h"
#include "forklift/session/vocabulary.h"

namespace forklift {

using evaluation::Debounce;
using evaluation::RuleKey;
using nlohmann::json;
namespace ev = evaluation;

namespace {

// Our own bugs abort loudly (STYLE.md, three error tiers).
[[noreturn]] void bug(const char* what) {
  std::fprintf(stderr, "forklift evaluation: internal error: %s\n", what);
  std::abort();
}

// Six significant digits for the details' JSON (the double nearest the short decimal, which the
// JSON writer prints as that decimal); the values are reported, never reused.
double round6(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return std::strtod(buf, nullptr);
}

}  // namespace

Stability stability_margin(const Eigen::Vector3d& cog, const Eigen::Vector3d& g, const Eigen::Vector3d& front_left,
                           const Eigen::Vector3d& front_right, const Eigen::Vector3d& rear) {
  Stability s;
  Eigen::Vector3d n = (front_right - front_left).cross(rear - front_left);
  if (n.norm() <= 0) return s;
  n.normalize();
  if (n.z() < 0) n = -n;
  const double ng = n.dot(g);
  if (std::abs(ng) < 1e-9 * std::max(1.0, g.norm())) {  // gravity along the plane: no support at all
    s.margin_m = -std::numeric_limits<double>::infinity();
    s.fraction = -std::numeric_limits<double>::infinity();
    return s;
  }
  // The CoG slid along g onto the triangle's plane.
  const Eigen::Vector3d p = cog + g * (n.dot(front_left - cog) / ng);
  const std::array<std::array<const Eigen::Vector3d*, 3>, 3> edges{{{&front_left, &front_right, &rear},
                                                                    {&front_left, &rear, &front_right},
                                                                    {&front_right, &rear, &front_left}}};
  s.margin_m = std::numeric_limits<double>::infinity();
  for (int e = 0; e < 3; ++e) {
    const Eigen::Vector3d& a = *edges[e][0];
    const Eigen::Vector3d& b = *edges[e][1];
    const Eigen::Vector3d& o = *edges[e][2];
    Eigen::Vector3d m = n.cross(b - a);
    if (m.norm() <= 0) continue;
    m.normalize();
    if (m.dot(o - a) < 0) m = -m;  // towards the inside
    const double d = m.dot(p - a);
    if (d < s.margin_m) {
      s.margin_m = d;
      s.edge = e;
    }
  }
  s.cog_projection_m = p.head<2>();
  return s;
}

double derated_capacity_kg(const TruckParams& truck, double load_centre_m) {
  if (load_centre_m <= truck.rated_load_centre_m) return truck.rated_capacity_kg;
  return truck.rated_capacity_kg * truck.rated_load_centre_m / load_centre_m;
}

// --- the state: changes every tick (a session's copy of it is a rewind point) ---
struct EvaluationMemory::Data {
  bool primed = false;  // false: a memory never used, which starts as the evaluator's initial one
  std::vector<EvaluationEvent> events;
  int points = 0;
  bool finished = false;
  bool have_tick = false;
  double last_t = 0;
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();  // filtered chassis acceleration, world
  Stability stab;
  double min_fraction = 1;

  struct Episode {
    bool active = false;
    bool violent = false;
    double last_contact_t = 0;
    RuleKey rule = ev::kCollisionStructure;
  };
  std::vector<Episode> episodes;  // per scene object
  std::vector<int> active_episodes;
  std::vector<Episode> people_episodes;  // per walking pedestrian
  std::vector<Episode> truck_episodes;   // per other truck
  Debounce near_pedestrian, pedestrian_in_path, pedestrian_at_object, under_forks;
  // One passage through a marker (blind corner, door, cross aisle) from the truck's CoG entering
  // its area; leaving and entering again within the horn rule's clear_time_s is the same one.
  struct Passage {
    bool inside = false;
    bool judged = true;  // the horn rule has had its say (heard, or the event)
    double entered_t = 0, left_t = -std::numeric_limits<double>::infinity();
  };
  std::vector<Passage> passages;  // per scene marker
  std::vector<Passage> crossing_passages;  // per scene crossing (only inside and left_t are used)
  double last_horn_t = -std::numeric_limits<double>::infinity();  // the horn last sounded
  Debounce marker_speed;

  std::array<Debounce, 3> speed;  // by kSpeedRules order
  Debounce forks_high, forks_low, tilt_forward, turn, turn_raised, brake_raised, stability_warn, wheel_lift, off_route;
  bool tipped = false, time_reported = false, deadman = false;

  bool laden = false;
  Debounce overload;
  // The load on the forks (the truck model's): one slide occurrence runs from the slide passing
  // slide_min_m beyond `ref` until it has stood still for clear_time_s; a fall is one event.
  struct Slide {
    double ref = 0, last = 0, last_moved_t = 0;
    bool active = false;
  };
  Slide slide;
  bool load_fallen = false;

  size_t step = 0;
  Eigen::Vector2d prev_pos = Eigen::Vector2d::Zero();

  // the last tick, for finish()
  double lift_s = 0, speed_m_s = 0;
  DriverInputs last_inputs;
  Eigen::Vector2d pos = Eigen::Vector2d::Zero();

};

EvaluationMemory::EvaluationMemory() : d_(std::make_unique<Data>()) {}
EvaluationMemory::EvaluationMemory(const EvaluationMemory& o) : d_(std::make_unique<Data>(*o.d_)) {}
EvaluationMemory& EvaluationMemory::operator=(const EvaluationMemory& o) {
  *d_ = *o.d_;
  return *this;
}
EvaluationMemory::EvaluationMemory(EvaluationMemory&&) noexcept = default;
EvaluationMemory& EvaluationMemory::operator=(EvaluationMemory&&) noexcept = default;
EvaluationMemory::~EvaluationMemory() = default;
const std::vector<EvaluationEvent>& EvaluationMemory::events() const { return d_->events; }
int EvaluationMemory::points() const { return d_->points; }
const Stability& EvaluationMemory::stability() const { return d_->stab; }
int EvaluationMemory::steps_done() const { return int(d_->step); }

// The model (constant after construction) and the machinery; the memory it works on is its base,
// swapped with a session's own for the length of a call.
struct Evaluator::Impl : EvaluationMemory::Data {
  // --- the model ---
  Rules rules;
  Scene scene;
  TruckParams truck;
  double fork_length_m, fork_thickness_m;
  Mode mode;
  std::array<const Rule*, ev::kNumRules> rule{};
  double static_margin_m = 0;
  std::array<RuleKey, int(ObjectKind::kPedestrian) + 1> collision_rule{};
  std::unordered_map<std::string, int> object_index;  // scene object id -> index
  struct ZoneInfo {
    const Zone* zone;
    RuleKey speed_rule;
    bool near_counts;  // its limit applies within near_distance_m too (walkways)
    bool walkway;      // a collision here is collision_in_walkway
  };
  std::vector<ZoneInfo> zones;
  TruckOutline outline;  // for distances to people
  struct MarkerInfo {
    const Marker* marker;
    bool horn, speed;  // the horn and speed rules list its kind
  };
  std::vector<MarkerInfo> markers;
  // What a person can be pinned against: the floor footprints (world) of the collidable objects
  // that do not move or give (not pallets, cones or the standing figures).
  std::vector<std::pair<int, Eigen::AlignedBox2d>> fixed_footprints;

  Impl(const Rules& r, const Scene& s, const TruckParams& t, const TruckShape& shape, Mode m)
      : rules(r), scene(s), truck(t), fork_length_m(shape.fork_length_m), fork_thickness_m(shape.fork_thickness_m), mode(m) {
    // Rules from load_rules pass these checks; rules built or edited in code are checked here.
    const auto scored = [&](double level) { return rules.scheme.points_by_worry_level.count(int(level)) > 0; };
    for (int k = 0; k < ev::kNumRules; ++k) {
      const char* id = ev::rule_specs()[k].id;
      rule[k] = rules.find(id);
      if (!rule[k]) throw RulesError(rules.file + ": rules: has no rule '" + id + "'");
      for (const char* name : ev::rule_specs()[k].thresholds)
        if (!rule[k]->thresholds.count(std::string_view(name)))
          throw RulesError(rules.file + ": rule " + id + ": has no threshold " + name);
      if (!scored(rule[k]->worry_level) ||
          (rule[k]->thresholds.count("hard_impact_worry_level") && !scored(rule[k]->thresholds.at("hard_impact_worry_level"))))
        throw RulesError(rules.file + ": rule " + id + ": a worry level the scheme does not score");
    }
    for (int k = 0; k <= int(ObjectKind::kPedestrian); ++k) {
      bool found = false;
      for (RuleKey key : ev::kObjectCollisionRules)
        for (const std::string& a : rule[key]->applies_to)
          if (a == object_kind_name(ObjectKind(k))) { collision_rule[k] = key; found = true; }
      if (!found) throw RulesError(rules.file + ": rules: no collision rule applies to '" + object_kind_name(ObjectKind(k)) + "'");
    }
    for (size_t i = 0; i < scene.objects.size(); ++i) object_index.emplace(scene.objects[i].id, int(i));
    episodes.resize(scene.objects.size());
    people_episodes.resize(scene.pedestrians.size());
    truck_episodes.resize(scene.trucks.size());
    crossing_passages.resize(scene.crossings.size());
    outline = truck_outline(shape);
    active_episodes.reserve(scene.objects.size());
    for (const Zone& z : scene.zones) {
      ZoneInfo info{&z, ev::kSpeedOpenAisle, false, false};
      bool found = false;
      for (RuleKey key : ev::kSpeedRules)
        for (const std::string& a : rule[key]->applies_to)
          if (a == z.kind) { info.speed_rule = key; found = true; }
      if (!found)
        throw RulesError(rules.file + ": no speed rule applies to zone kind '" + z.kind + "' (zone " + z.id + " of " + scene.file + ")");
      info.near_counts = info.speed_rule == ev::kSpeedNearWalkway;
      for (const std::string& a : rule[ev::kCollisionInWalkway]->applies_to) info.walkway = info.walkway || a == z.kind;
      zones.push_back(info);
    }
    const auto lists = [&](RuleKey k, const std::string& kind) {
      const std::vector<std::string>& a = rule[k]->applies_to;
      return std::find(a.begin(), a.end(), kind) != a.end();
    };
    for (const Marker& m : scene.markers) markers.push_back({&m, lists(ev::kHornAtMarker, m.kind), lists(ev::kSpeedAtMarker, m.kind)});
    passages.resize(scene.markers.size());
    for (size_t i = 0; i < scene.objects.size(); ++i) {
      const SceneObject& o = scene.objects[i];
      if (!o.collidable || !o.mesh || o.kind == ObjectKind::kPallet || o.kind == ObjectKind::kCone ||
          o.kind == ObjectKind::kPedestrian)
        continue;
      Eigen::AlignedBox2d box;
      for (int c = 0; c < 8; ++c) box.extend((o.pose * o.mesh->bounds.corner(Eigen::AlignedBox3d::CornerType(c))).head<2>());
      fixed_footprints.emplace_back(int(i), box);
    }
    // The reference: the unladen truck at rest on level ground, forks down.
    const StaticReport st = static_report(truck, std::nullopt, 0.0);
    const auto c3 = [&](int w) { return Eigen::Vector3d(st.wheel_contact_m[w].x(), st.wheel_contact_m[w].y(), 0.0); };
    static_margin_m = stability_margin(st.cog_m, Eigen::Vector3d(0, 0, -kGravity_m_s2), c3(kFrontLeft), c3(kFrontRight), c3(kRear)).margin_m;
    if (!(static_margin_m > 0)) throw std::runtime_error(truck.name + ": the unladen truck has no static stability margin");
    events.reserve(64);
    prev_pos = Eigen::Vector2d(scene.scenario.x_m, scene.scenario.y_m);
  }

  // A threshold (load_rules guarantees every name the rule table lists).
  double th(RuleKey k, const char* name) const {
    const auto it = rule[k]->thresholds.find(std::string_view(name));
    if (it == rule[k]->thresholds.end()) bug("a threshold the rule table does not list");
    return it->second;
  }
  int level_points(int level) const {
    const auto it = rules.scheme.points_by_worry_level.find(level);
    if (it == rules.scheme.points_by_worry_level.end()) bug("worry level without points (load_rules checks this)");
    return it->second;
  }

  // Appends one event; `details` gets the rule's description and source.
  void emit(RuleKey k, double t, const Eigen::Vector2d& where, json details, std::vector<EvaluationEvent>& out,
            int level = -1) {
    const Rule& r = *rule[k];
    EvaluationEvent e;
    e.seq = uint32_t(events.size() + 1);
    e.t_s = t;
    e.rule = r.id;
    e.worry_level = level >= 0 ? level : r.worry_level;
    e.points = level_points(e.worry_level);
    e.automatic_fail = r.automatic_fail;
    e.x_m = where.x();
    e.y_m = where.y();
    details["description"] = r.description;
    details["source"] = r.source;
    e.details = details.dump();
    points += e.points;
    events.push_back(e);
    out.push_back(std::move(e));
  }

  // --- detectors ---

  bool in_walkway(const Eigen::Vector2d& p) const {
    for (const ZoneInfo& z : zones)
      if (z.walkway && z.zone->contains(p)) return true;
    return false;
  }

  void collisions(const TickInput& in, std::vector<EvaluationEvent>& out) {
    const double violent = th(ev::kViolentCollision, "impact_speed_m_s");
    for (const Contact& c : in.report.contacts) {
      if (c.pedestrian >= 0) {
        struck(in, c, out);
        continue;
      }
      if (c.other_truck >= 0) {
        truck_struck(in, c, out);
        continue;
      }
      const auto it = object_index.find(c.object_id);
      if (it == object_index.end()) continue;  // not a scene object (cannot happen with the Warehouse)
      Episode& ep = episodes[it->second];
      ep.last_contact_t = in.t_s;
      const Eigen::Vector2d at = c.point_m.head<2>();
      const double v = c.relative_speed_m_s;
      // Built only for an event: a touch lasting many ticks allocates nothing.
      const auto details = [&] {
        return json{{"object", c.object_id},
                    {"object_kind", object_kind_name(c.object_kind)},
                    {"truck_part", c.truck_part},
                    {"measured", {{"impact_speed_m_s", round6(v)}, {"depth_m", round6(c.depth_m)}}}};
      };
      if (!ep.active) {
        json d = details();
        ep.active = true;
        ep.violent = false;
        active_episodes.push_back(it->second);
        RuleKey k = collision_rule[int(c.object_kind)];
        const bool fork = c.truck_part == "fork_left" || c.truck_part == "fork_right";
        if (k == ev::kCollisionPallet && fork) k = ev::kForkStrikePallet;
        if (k != ev::kCollisionPedestrian && v >= violent) {
          k = ev::kViolentCollision;
          ep.violent = true;
          d["thresholds"] = {{"impact_speed_m_s", violent}};
        } else if (k != ev::kCollisionPedestrian && (in_walkway(at) || in_walkway(in.out.q.head<2>()))) {
          k = ev::kCollisionInWalkway;
          d["zone"] = "walkway";
        }
        int level = -1;
        if (rule[k]->thresholds.count("hard_impact_speed_m_s")) {
          const double hard = th(k, "hard_impact_speed_m_s");
          d["thresholds"] = {{"hard_impact_speed_m_s", hard}};
          if (v >= hard) {
            level = int(th(k, "hard_impact_worry_level"));
            d["grade"] = "hard impact";
          } else {
            d["grade"] = "touch";
          }
        }
        ep.rule = k;
        emit(k, in.t_s, at, std::move(d), out, level);
      } else if (!ep.violent && ep.rule != ev::kCollisionPedestrian && v >= violent) {
        ep.violent = true;
        json d = details();
        d["thresholds"] = {{"impact_speed_m_s", violent}};
        emit(ev::kViolentCollision, in.t_s, at, std::move(d), out);
      }
    }
    // Episodes end after clear_time_s without a contact with that object.
    for (size_t i = 0; i < active_episodes.size();) {
      Episode& ep = episodes[active_episodes[i]];
      const double clear = rule[ep.rule]->thresholds.count("clear_time_s") ? th(ep.rule, "clear_time_s")
                                                                            : th(ev::kCollisionStructure, "clear_time_s");
      if (in.t_s - ep.last_contact_t >= clear) {
        ep.active = false;
        active_episodes[i] = active_episodes.back();
        active_episodes.pop_back();
      } else {
        ++i;
      }
    }
  }

  // A contact at `t` with a body that moves (a person, another truck): whether it begins an
  // episode, which ends after `clear_s` without one.
  static bool new_episode(Episode& ep, double t, double clear_s) {
    const bool was_active = ep.active && t - ep.last_contact_t < clear_s;
    ep.active = true;
    ep.last_contact_t = t;
    return !was_active;
  }

  // A walking person struck: one event per person per contact episode (an episode ends after
  // clear_time_s without a contact with that person); never graded down to a touch.
  void struck(const TickInput& in, const Contact& c, std::vector<EvaluationEvent>& out) {
    const RuleKey k = ev::kPedestrianStruck;
    if (!new_episode(people_episodes[c.pedestrian], in.t_s, th(k, "clear_time_s"))) return;
    const PedestrianSpec& p = scene.pedestrians[c.pedestrian];
    emit(k, in.t_s, c.point_m.head<2>(),
         {{"pedestrian", p.id},
          {"looks", p.looks},
          {"truck_part", c.truck_part},
          {"measured", {{"impact_speed_m_s", round6(c.relative_speed_m_s)}, {"depth_m", round6(c.depth_m)}}}},
         out);
  }

  // Another truck struck: one event per truck per contact episode (an episode ends after
  // clear_time_s without a contact with it), graded by the impact's speed as the course's objects
  // (violent_collision from its impact speed).
  void truck_struck(const TickInput& in, const Contact& c, std::vector<EvaluationEvent>& out) {
    const RuleKey k = ev::kCollisionTruck;
    if (!new_episode(truck_episodes[c.other_truck], in.t_s, th(k, "clear_time_s"))) return;
    const double hard = th(k, "hard_impact_speed_m_s"), violent = th(ev::kViolentCollision, "impact_speed_m_s");
    const bool is_hard = c.relative_speed_m_s >= hard;
    if (c.relative_speed_m_s >= violent) {
      emit(ev::kViolentCollision, in.t_s, c.point_m.head<2>(),
           {{"object", scene.trucks[c.other_truck].id},
            {"object_kind", "truck"},
            {"truck_part", c.truck_part},
            {"measured", {{"impact_speed_m_s", round6(c.relative_speed_m_s)}, {"depth_m", round6(c.depth_m)}}},
            {"thresholds", {{"impact_speed_m_s", violent}}}},
           out);
      return;
    }
    emit(k, in.t_s, c.point_m.head<2>(),
         {{"truck", scene.trucks[c.other_truck].id},
          {"truck_part", c.truck_part},
          {"grade", is_hard ? "hard impact" : "touch"},
          {"measured", {{"impact_speed_m_s", round6(c.relative_speed_m_s)}, {"depth_m", round6(c.depth_m)}}},
          {"thresholds", {{"hard_impact_speed_m_s", hard}}}},
         out, is_hard ? int(th(k, "hard_impact_worry_level")) : -1);
  }

  // Giving way at a crossing where the traffic goes first: the truck's CoG entering its area while
  // another truck that is driving or waiting to (started, not arrived, not struck), not yet past
  // the crossing's middle, has its body within priority_within_m of that middle. A truck that
  // leaves and enters again within clear_time_s is on the same passage.
  void crossings(const TickInput& in, bool first, std::vector<EvaluationEvent>& out) {
    if (scene.crossings.empty()) return;
    const RuleKey k = ev::kGiveWayAtCrossing;
    const Eigen::Vector2d p = in.out.q.head<2>();
    for (size_t i = 0; i < scene.crossings.size(); ++i) {
      const Crossing& x = scene.crossings[i];
      Passage& ps = crossing_passages[i];
      const bool inside = x.contains(p);
      const bool entering = inside && !ps.inside && !first && in.t_s - ps.left_t >= th(k, "clear_time_s");
      if (!inside && ps.inside) ps.left_t = in.t_s;
      ps.inside = inside;
      if (!entering || x.priority != "traffic" || !in.trucks) continue;
      int who = -1;
      double nearest = std::numeric_limits<double>::infinity();
      for (size_t t = 0; t < in.trucks->size(); ++t) {
        const OtherTruckState& o = (*in.trucks)[t];
        if (!o.started || o.arrived || o.struck) continue;
        const double half = 0.5 * scene.trucks[t].size_m.x();
        const Eigen::Vector2d to = x.middle_m - o.at_m;
        if (to.dot(Eigen::Vector2d(std::cos(o.heading_rad), std::sin(o.heading_rad))) < -half) continue;  // past it
        const double d = std::max(0.0, to.norm() - half);
        if (d <= th(k, "priority_within_m") && d < nearest) {
          nearest = d;
          who = int(t);
        }
      }
      if (who >= 0)
        emit(k, in.t_s, p,
             {{"crossing", x.id},
              {"truck", scene.trucks[who].id},
              {"measured", {{"distance_m", round6(nearest)}, {"truck_speed_m_s", round6((*in.trucks)[who].speed_m_s)}}},
              {"thresholds", {{"priority_within_m", th(k, "priority_within_m")}}}},
             out);
    }
  }

  // Speed near a person: faster than speed_max_m_s with the truck's outline within
  // near_distance_m of any pedestrian, for min_duration_s.
  void speed_near_people(const TickInput& in, double ground_speed, std::vector<EvaluationEvent>& out) {
    if (!in.pedestrians || in.pedestrians->empty()) return;
    const RuleKey k = ev::kSpeedNearPedestrian;
    const double near = th(k, "near_distance_m");
    double nearest = std::numeric_limits<double>::infinity();
    int who = -1;
    for (size_t i = 0; i < in.pedestrians->size(); ++i) {
      const double d = distance_to_truck(outline, in.poses, (*in.pedestrians)[i].at_m);
      if (d < nearest) {
        nearest = d;
        who = int(i);
      }
    }
    const bool on = nearest <= near && ground_speed > th(k, "speed_max_m_s");
    if (near_pedestrian.update(on, in.t_s, th(k, "min_duration_s"), th(k, "clear_time_s")))
      emit(k, in.t_s, in.out.q.head<2>(),
           {{"pedestrian", scene.pedestrians[who].id},
            {"measured", {{"speed_m_s", round6(ground_speed)}, {"distance_m", round6(nearest)}}},
            {"thresholds", {{"speed_max_m_s", th(k, "speed_max_m_s")}, {"near_distance_m", near}}}},
           out);
  }

  // Driving on towards a person in the truck's path nearer than it could stop: a person ahead of
  // its front (the fork tips; reversing: behind its counterweight), within its width and
  // lateral_margin_m either side, closer than the distance it needs to stop from its speed
  // (reaction_time_s at that speed, then braking at braking_deceleration_m_s2, plus margin_m).
  void people_in_path(const TickInput& in, double v, std::vector<EvaluationEvent>& out) {
    if (!in.pedestrians || in.pedestrians->empty()) return;
    const RuleKey k = ev::kPedestrianInPath;
    const double speed = std::abs(v);
    const double need = speed * th(k, "reaction_time_s") + speed * speed / (2 * th(k, "braking_deceleration_m_s2")) +
                        th(k, "margin_m");
    double gap = std::numeric_limits<double>::infinity();
    int who = -1;
    if (speed >= th(k, "travel_speed_min_m_s")) {
      const Eigen::Isometry3d to_chassis = in.poses.chassis.inverse();
      const Eigen::Vector3d tips = to_chassis * (in.poses.carriage * Eigen::Vector3d(outline.forks_m.max().x(), 0, 0));
      const double front = std::max(outline.chassis_m.max().x(), tips.x()), rear = outline.chassis_m.min().x();
      const double half_width = std::max(-outline.chassis_m.min().y(), outline.chassis_m.max().y()) + th(k, "lateral_margin_m");
      const double z = in.poses.chassis.translation().z();
      for (size_t i = 0; i < in.pedestrians->size(); ++i) {
        const Eigen::Vector2d at = (*in.pedestrians)[i].at_m;
        const Eigen::Vector3d p = to_chassis * Eigen::Vector3d(at.x(), at.y(), z);
        if (std::abs(p.y()) > half_width) continue;
        const double d = v > 0 ? p.x() - front : rear - p.x();
        if (d >= 0 && d < gap) {
          gap = d;
          who = int(i);
        }
      }
    }
    if (pedestrian_in_path.update(gap < need, in.t_s, th(k, "min_duration_s"), th(k, "clear_time_s")))
      emit(k, in.t_s, in.out.q.head<2>(),
           {{"pedestrian", scene.pedestrians[who].id},
            {"direction", v > 0 ? "forward" : "reverse"},
            {"measured", {{"speed_m_s", round6(speed)}, {"distance_m", round6(gap)}, {"stopping_distance_m", round6(need)}}},
            {"thresholds", {{"reaction_time_s", th(k, "reaction_time_s")},
                            {"braking_deceleration_m_s2", th(k, "braking_deceleration_m_s2")},
                            {"margin_m", th(k, "margin_m")}}}},
           out);
  }

  // Blind corners, doors and cross aisles: the horn heard from horn_before_s before the CoG
  // entered the marker to horn_after_s after (one event per passage that had none), and walking
  // pace inside it. A truck that starts inside a marker has not entered it.
  void marked_places(const TickInput& in, bool first, double ground_speed, std::vector<EvaluationEvent>& out) {
    if (in.inputs.horn) last_horn_t = in.t_s;
    if (markers.empty()) return;
    const RuleKey h = ev::kHornAtMarker, k = ev::kSpeedAtMarker;
    const Eigen::Vector2d p = in.out.q.head<2>();
    int fast = -1;
    for (size_t i = 0; i < markers.size(); ++i) {
      const MarkerInfo& m = markers[i];
      Passage& ps = passages[i];
      const bool inside = m.marker->contains(p);
      if (inside && !ps.inside && !first && in.t_s - ps.left_t >= th(h, "clear_time_s")) {
        ps.judged = !m.horn;
        ps.entered_t = in.t_s;
      }
      if (!inside && ps.inside) ps.left_t = in.t_s;
      ps.inside = inside;
      if (!ps.judged) {
        if (last_horn_t >= ps.entered_t - th(h, "horn_before_s")) {
          ps.judged = true;
        } else if (!inside || in.t_s - ps.entered_t >= th(h, "horn_after_s")) {
          ps.judged = true;
          emit(h, in.t_s, p,
               {{"marker", m.marker->id},
                {"marker_kind", m.marker->kind},
                {"measured", {{"speed_m_s", round6(ground_speed)}}},
                {"thresholds", {{"horn_before_s", th(h, "horn_before_s")}, {"horn_after_s", th(h, "horn_after_s")}}}},
               out);
        }
      }
      if (inside && m.speed && fast < 0 && ground_speed > th(k, "walking_pace_m_s")) fast = int(i);
    }
    if (marker_speed.update(fast >= 0, in.t_s, th(k, "min_duration_s"), th(k, "clear_time_s")))
      emit(k, in.t_s, p,
           {{"marker", markers[fast].marker->id},
            {"marker_kind", markers[fast].marker->kind},
            {"measured", {{"speed_m_s", round6(ground_speed)}}},
            {"thresholds", {{"walking_pace_m_s", th(k, "walking_pace_m_s")}}}},
           out);
  }

  // A person ahead in the truck's path (as people_in_path: ahead of its front, or behind it
  // reversing, within its width and lateral_margin_m either side), standing, within
  // near_distance_m, with a fixed object within object_within_m of him on his far side: driven
  // towards at travel_speed_min_m_s or more, he has nowhere to go.
  void people_at_fixed_objects(const TickInput& in, double v, std::vector<EvaluationEvent>& out) {
    if (!in.pedestrians || in.pedestrians->empty()) return;
    const RuleKey k = ev::kPedestrianAtFixedObject;
    const double speed = std::abs(v);
    int who = -1, what = -1;
    double gap = 0, behind = 0;
    if (speed >= th(k, "travel_speed_min_m_s") && !fixed_footprints.empty()) {
      const Eigen::Isometry3d to_chassis = in.poses.chassis.inverse();
      const Eigen::Vector3d tips = to_chassis * (in.poses.carriage * Eigen::Vector3d(outline.forks_m.max().x(), 0, 0));
      const double front = std::max(outline.chassis_m.max().x(), tips.x()), rear = outline.chassis_m.min().x();
      const double half_width = std::max(-outline.chassis_m.min().y(), outline.chassis_m.max().y()) + th(k, "lateral_margin_m");
      const double z = in.poses.chassis.translation().z();
      for (size_t i = 0; i < in.pedestrians->size() && who < 0; ++i) {
        const PedestrianState& st = (*in.pedestrians)[i];
        if (st.speed_m_s > 0) continue;  // walking: he can step out of the way
        const Eigen::Vector3d p = to_chassis * Eigen::Vector3d(st.at_m.x(), st.at_m.y(), z);
        if (std::abs(p.y()) > half_width) continue;
        const double d = v > 0 ? p.x() - front : rear - p.x();
        if (d < 0 || d > th(k, "near_distance_m")) continue;
        for (const auto& [index, box] : fixed_footprints) {
          const double off = box.exteriorDistance(st.at_m);
          if (off > th(k, "object_within_m")) continue;
          // On his far side: the object's nearest point to him no nearer the truck than he is.
          const Eigen::Vector2d c = st.at_m.cwiseMax(box.min()).cwiseMin(box.max());
          const Eigen::Vector3d pc = to_chassis * Eigen::Vector3d(c.x(), c.y(), z);
          if (v > 0 ? pc.x() < p.x() : pc.x() > p.x()) continue;
          who = int(i);
          what = index;
          gap = d;
          behind = off;
          break;
        }
      }
    }
    if (pedestrian_at_object.update(who >= 0, in.t_s, th(k, "min_duration_s"), th(k, "clear_time_s")))
      emit(k, in.t_s, in.out.q.head<2>(),
           {{"pedestrian", scene.pedestrians[who].id},
            {"object", scene.objects[what].id},
            {"object_kind", object_kind_name(scene.objects[what].kind)},
            {"measured", {{"speed_m_s", round6(speed)}, {"distance_m", round6(gap)}, {"object_distance_m", round6(behind)}}},
            {"thresholds", {{"near_distance_m", th(k, "near_distance_m")}, {"object_within_m", th(k, "object_within_m")}}}},
           out);
  }

  // A person under the raised forks or load: the forks' heel above raised_fork_height_m and a
  // person's middle within margin_m of the forks' outline (tips included) or of the pallet they
  // carry, on the floor.
  void people_under_forks(const TickInput& in, double heel_height, std::vector<EvaluationEvent>& out) {
    if (!in.pedestrians || in.pedestrians->empty()) return;
    const RuleKey k = ev::kPersonUnderForks;
    const double margin = th(k, "margin_m");
    int who = -1;
    if (heel_height > th(k, "raised_fork_height_m")) {
      const Eigen::Isometry3d to_carriage = in.poses.carriage.inverse();
      const double z = in.poses.carriage.translation().z();
      Eigen::AlignedBox2d forks = outline.forks_m;
      forks.min().array() -= margin;
      forks.max().array() += margin;
      const PalletState* carried = nullptr;
      const PalletSpec* spec = nullptr;
      for (const PalletState& ps : in.pallets)
        if (ps.on_forks) {
          const auto it = object_index.find(ps.id);
          if (it != object_index.end() && scene.objects[it->second].pallet) {
            carried = &ps;
            spec = &*scene.objects[it->second].pallet;
          }
        }
      for (size_t i = 0; i < in.pedestrians->size() && who < 0; ++i) {
        const Eigen::Vector2d at = (*in.pedestrians)[i].at_m;
        const Eigen::Vector3d pc = to_carriage * Eigen::Vector3d(at.x(), at.y(), z);
        bool under = forks.contains(pc.head<2>());
        if (!under && carried) {
          const Eigen::Vector3d pl = carried->pose.inverse() * Eigen::Vector3d(at.x(), at.y(), carried->pose.translation().z());
          const double hl = std::max(spec->length_m, spec->load_size_m.x()) / 2 + margin;
          const double hw = std::max(spec->width_m, spec->load_size_m.y()) / 2 + margin;
          under = std::abs(pl.x()) <= hl && std::abs(pl.y()) <= hw;
        }
        if (under) who = int(i);
      }
    }
    if (under_forks.update(who >= 0, in.t_s, th(k, "min_duration_s"), th(k, "clear_time_s")))
      emit(k, in.t_s, (*in.pedestrians)[who].at_m,
           {{"pedestrian", scene.pedestrians[who].id},
            {"measured", {{"fork_height_m", round6(heel_height)}}},
            {"thresholds", {{"raised_fork_height_m", th(k, "raised_fork_height_m")}, {"margin_m", margin}}}},
           out);
  }

  void speeding(const TickInput& in, double v, std::vector<EvaluationEvent>& out) {
    const Eigen::Vector2d p = in.out.q.head<2>();
    const double near = th(ev::kSpeedNearWalkway, "near_distance_m");
    const ZoneInfo* gov = nullptr;
    for (const ZoneInfo& z : zones) {
      if (gov && z.zone->speed_limit_m_s > gov->zone->speed_limit_m_s) continue;
      bool in_zone = z.zone->contains(p);
      if (!in_zone && z.near_counts) in_zone = ev::polyline_distance(p, z.zone->polygon, true) <= near;
      if (!in_zone) continue;
      if (!gov || z.zone->speed_limit_m_s < gov->zone->speed_limit_m_s ||
          rule[z.speed_rule]->worry_level > rule[gov->speed_rule]->worry_level)
        gov = &z;
    }
    for (size_t i = 0; i < ev::kSpeedRules.size(); ++i) {
      const RuleKey k = ev::kSpeedRules[i];
      bool on = false;
      if (gov && gov->speed_rule == k) {
        const double limit = gov->zone->speed_limit_m_s;
        on = speed[i].active() ? v > limit : v > limit + th(k, "over_limit_m_s");
      }
      if (speed[i].update(on, in.t_s, th(k, "min_duration_s"), th(k, "clear_time_s")))
        emit(k, in.t_s, p,
             {{"zone", gov->zone->id},
              {"zone_kind", gov->zone->kind},
              {"measured", {{"speed_m_s", round6(v)}}},
              {"thresholds", {{"speed_limit_m_s", gov->zone->speed_limit_m_s}, {"over_limit_m_s", th(k, "over_limit_m_s")}}}},
             out);
    }
  }

  void forks_and_mast(const TickInput& in, double v, double heel_height, std::vector<EvaluationEvent>& out) {
    const Eigen::Isometry3d& C = in.poses.carriage;
    const Eigen::Vector2d p = in.out.q.head<2>();
    // The forks' underside at the heel and at the tips, above the floor below each.
    double clearance = std::numeric_limits<double>::infinity();
    for (double x : {0.0, fork_length_m}) {
      const Eigen::Vector3d b = C * Eigen::Vector3d(x, 0, -fork_thickness_m);
      clearance = std::min(clearance, b.z() - scene.ground.height(b.x(), b.y()));
    }
    const double speed = std::abs(v);
    {
      const RuleKey k = ev::kTravelForksHigh;
      const bool on = speed >= th(k, "travel_speed_min_m_s") && heel_height > th(k, "fork_height_max_m");
      if (forks_high.update(on, in.t_s, th(k, "min_duration_s"), th(k, "clear_time_s")))
        emit(k, in.t_s, p,
             {{"measured", {{"fork_height_m", round6(heel_height)}, {"speed_m_s", round6(speed)}}},
              {"thresholds", {{"fork_height_max_m", th(k, "fork_height_max_m")}, {"travel_speed_min_m_s", th(k, "travel_speed_min_m_s")}}}},
             out);
    }
    {
      const RuleKey k = ev::kTravelForksLow;
      const bool on = speed >= th(k, "travel_speed_min_m_s") && clearance < th(k, "fork_clearance_min_m");
      if (forks_low.update(on, in.t_s, th(k, "min_duration_s"), th(k, "clear_time_s")))
        emit(k, in.t_s, p,
             {{"measured", {{"fork_clearance_m", round6(clearance)}, {"speed_m_s", round6(speed)}}},
              {"thresholds", {{"fork_clearance_min_m", th(k, "fork_clearance_min_m")}, {"travel_speed_min_m_s", th(k, "travel_speed_min_m_s")}}}},
             out);
    }
    {
      const RuleKey k = ev::kTravelTiltedForwardLaden;
      const double tilt_deg = in.out.q[kBeta] / kDeg;
      const bool on = laden && speed >= th(k, "travel_speed_min_m_s") && tilt_deg > th(k, "tilt_forward_max_deg");
      if (tilt_forward.update(on, in.t_s, th(k, "min_duration_s"), th(k, "clear_time_s")))
        emit(k, in.t_s, p,
             {{"measured", {{"tilt_forward_deg", round6(tilt_deg)}, {"speed_m_s", round6(speed)}}},
              {"thresholds", {{"tilt_forward_max_deg", th(k, "tilt_forward_max_deg")}, {"travel_speed_min_m_s", th(k, "travel_speed_min_m_s")}}}},
             out);
    }
  }

  void dynamics(const TickInput& in, double v, double heel_height, std::vector<EvaluationEvent>& out) {
    const Eigen::Vector2d p = in.out.q.head<2>();
    const double yaw = in.out.q[kAwc];
    const Eigen::Vector3d fwd(std::cos(yaw), std::sin(yaw), 0), left(-std::sin(yaw), std::cos(yaw), 0);
    const double a_lat = accel.dot(left);
    const double decel = std::abs(v) > 0.1 ? -accel.dot(fwd) * (v > 0 ? 1 : -1) : 0.0;
    {
      const RuleKey k = ev::kTurnAtSpeed;
      const bool on = std::abs(a_lat) > th(k, "lateral_acceleration_max_m_s2");
      if (turn.update(on, in.t_s, th(k, "min_duration_s"), th(k, "clear_time_s")))
        emit(k, in.t_s, p,
             {{"measured", {{"lateral_acceleration_m_s2", round6(a_lat)}, {"speed_m_s", round6(v)}}},
              {"thresholds", {{"lateral_acceleration_max_m_s2", th(k, "lateral_acceleration_max_m_s2")}}}},
             out);
    }
    {
      const RuleKey k = ev::kTurnAtSpeedLoadRaised;
      const bool on = laden && heel_height > th(k, "raised_fork_height_m") && std::abs(a_lat) > th(k, "lateral_acceleration_max_m_s2");
      if (turn_raised.update(on, in.t_s, th(k, "min_duration_s"), th(k, "clear_time_s")))
        emit(k, in.t_s, p,
             {{"measured", {{"lateral_acceleration_m_s2", round6(a_lat)}, {"fork_height_m", round6(heel_height)}, {"speed_m_s", round6(v)}}},
              {"thresholds", {{"lateral_acceleration_max_m_s2", th(k, "lateral_acceleration_max_m_s2")}, {"raised_fork_height_m", th(k, "raised_fork_height_m")}}}},
             out);
    }
    {
      const RuleKey k = ev::kHarshBrakingLoadRaised;
      const bool on = laden && heel_height > th(k, "raised_fork_height_m") && decel > th(k, "deceleration_max_m_s2");
      if (brake_raised.update(on, in.t_s, th(k, "min_duration_s"), th(k, "clear_time_s")))
        emit(k, in.t_s, p,
             {{"measured", {{"deceleration_m_s2", round6(decel)}, {"fork_height_m", round6(heel_height)}, {"speed_m_s", round6(v)}}},
              {"thresholds", {{"deceleration_max_m_s2", th(k, "deceleration_max_m_s2")}, {"raised_fork_height_m", th(k, "raised_fork_height_m")}}}},
             out);
    }
    // The stability triangle, with the CoG projected along the apparent gravity.
    const Outputs& o = in.out;
    stab = stability_margin(o.cog_m, in.gravity_m_s2 - accel, o.wheels[kFrontLeft].contact_point_m,
                            o.wheels[kFrontRight].contact_point_m, o.wheels[kRear].contact_point_m);
    stab.fraction = stab.margin_m / static_margin_m;
    min_fraction = std::min(min_fraction, stab.fraction);
    {
      const RuleKey k = ev::kStabilityWarning;
      const bool on = stability_warn.active() ? stab.fraction < th(k, "clear_above_fraction")
                                              : stab.fraction < th(k, "warn_below_fraction");
      static const char* kEdges[] = {"front axle (tipping forward)", "left side (tipping left)", "right side (tipping right)"};
      if (stability_warn.update(on, in.t_s, th(k, "min_duration_s"), th(k, "clear_time_s")))
        emit(k, in.t_s, p,
             {{"edge", stab.edge >= 0 ? kEdges[stab.edge] : "none"},
              {"measured", {{"margin_m", round6(stab.margin_m)}, {"margin_fraction", round6(stab.fraction)}}},
              {"thresholds", {{"warn_below_fraction", th(k, "warn_below_fraction")}, {"static_margin_m", round6(static_margin_m)}}}},
             out);
    }
    {
      const RuleKey k = ev::kWheelLift;
      int lifted = -1;
      for (int w = 0; w < kNumWheels; ++w)
        if (o.wheels[w].fz_N < th(k, "wheel_load_min_N") && (lifted < 0 || o.wheels[w].fz_N < o.wheels[lifted].fz_N)) lifted = w;
      if (wheel_lift.update(lifted >= 0, in.t_s, th(k, "min_duration_s"), th(k, "clear_time_s")))
        emit(k, in.t_s, p,
             {{"wheel", wheel_name(lifted)},
              {"measured", {{"wheel_load_N", round6(o.wheels[lifted].fz_N)}, {"margin_fraction", round6(stab.fraction)}}},
              {"thresholds", {{"wheel_load_min_N", th(k, "wheel_load_min_N")}}}},
             out);
    }
    {
      const RuleKey k = ev::kTipOver;
      const double roll = o.q[kAuc] / kDeg, pitch = o.q[kAvc] / kDeg;
      const double limit = truck.tipped_over_rad / kDeg;  // the truck file's: one number for handling and marking
      if (!tipped && std::max(std::abs(roll), std::abs(pitch)) > limit) {
        tipped = true;
        emit(k, in.t_s, p,
             {{"measured", {{"roll_deg", round6(roll)}, {"pitch_deg", round6(pitch)}}},
              {"thresholds", {{"roll_or_pitch_max_deg", round6(limit)}}}},
             out);
      }
    }
  }

  // The load on the forks against the capacity plate: one event per occurrence (a load set down
  // and taken again at once is the same one).
  void capacity(const TickInput& in, std::vector<EvaluationEvent>& out) {
    laden = bool(in.load);
    const RuleKey k = ev::kOverload;
    const double centre = laden ? in.load->cog_m.x() : 0.0;
    const double cap = derated_capacity_kg(truck, centre);
    const bool over = laden && in.load->mass_kg > cap * (1 + th(k, "tolerance_fraction"));
    if (overload.update(over, in.t_s, 0.0, th(k, "clear_time_s")))
      emit(k, in.t_s, in.out.q.head<2>(),
           {{"measured", {{"load_mass_kg", round6(in.load->mass_kg)}, {"load_centre_m", round6(centre)}}},
            {"thresholds", {{"capacity_at_load_centre_kg", round6(cap)}, {"rated_capacity_kg", truck.rated_capacity_kg},
                            {"rated_load_centre_m", truck.rated_load_centre_m}, {"tolerance_fraction", th(k, "tolerance_fraction")}}}},
           out);
  }

  // A set-down judged against the task's move step for that pallet. Returns whether it completed
  // the current step.
  bool judge_set_down(const TickInput& in, const HandlingEvent& h, std::vector<EvaluationEvent>& out) {
    const std::vector<TaskStep>& steps = scene.task.steps;
    size_t i = step;
    while (i < steps.size() && !(steps[i].kind == "move" && steps[i].pallet == h.pallet)) ++i;
    if (i == steps.size()) return false;  // not a pallet the rest of the task moves
    const TaskStep& s = steps[i];
    const Eigen::Vector2d at = h.where_m.head<2>();
    const bool right_support = s.to_object.empty() ? h.on_object.empty() && s.area.contains(at)
                                                   : h.on_object == s.to_object && h.level == s.to_level;
    const double dist = (at - s.point).norm();
    // Square to the step's heading, either way round (a pallet has two faces).
    double yaw_off = 0;
    if (s.yaw_rad) {
      const PalletState* st = nullptr;
      for (const PalletState& p : in.pallets)
        if (p.id == h.pallet) st = &p;
      const Eigen::Vector3d axis = st ? Eigen::Vector3d(st->pose.linear().col(0)) : Eigen::Vector3d::UnitX();
      const double off = std::remainder(std::atan2(axis.y(), axis.x()) - *s.yaw_rad, M_PI);
      yaw_off = std::abs(off);
    }
    const bool square = !s.yaw_rad || yaw_off <= s.yaw_tolerance_rad;
    if (right_support && dist <= s.tolerance_m && square) return i == step;
    json measured = {{"object", h.on_object}, {"level", h.level}, {"distance_m", round6(dist)}};
    json thresholds = {{"tolerance_m", s.tolerance_m}};
    if (s.yaw_rad) {
      measured["off_square_deg"] = round6(yaw_off * 180 / M_PI);
      thresholds["yaw_tolerance_deg"] = round6(s.yaw_tolerance_rad * 180 / M_PI);
    }
    emit(ev::kSetDownOffPlace, in.t_s, at,
         {{"pallet", h.pallet},
          {"step", i + 1},
          {"expected", {{"object", s.to_object}, {"level", s.to_level}, {"point_m", {s.point.x(), s.point.y()}}}},
          {"measured", measured},
          {"thresholds", thresholds}},
         out);
    return false;
  }

  void unsafe_stack(const TickInput& in, const HandlingEvent& h, std::vector<EvaluationEvent>& out) {
    if (h.on_object.empty()) return;
    const SceneObject* on = scene.find(h.on_object);
    const SceneObject* pallet = scene.find(h.pallet);
    if (!on || !pallet || !pallet->pallet) return;
    const Support* sup = nullptr;
    for (const Support& s : on->supports)
      if (s.level == h.level) sup = &s;
    const PalletState* st = nullptr;
    for (const PalletState& p : in.pallets)
      if (p.id == h.pallet) st = &p;
    if (!sup || !st) return;
    double overhang = 0;
    for (double sx : {-0.5, 0.5})
      for (double sy : {-0.5, 0.5}) {
        const Eigen::Vector3d c = on->pose.inverse() * (st->pose * Eigen::Vector3d(sx * pallet->pallet->length_m, sy * pallet->pallet->width_m, 0));
        const double dx = std::max({sup->footprint.min().x() - c.x(), 0.0, c.x() - sup->footprint.max().x()});
        const double dy = std::max({sup->footprint.min().y() - c.y(), 0.0, c.y() - sup->footprint.max().y()});
        overhang = std::max(overhang, std::hypot(dx, dy));
      }
    const RuleKey k = ev::kUnsafeStacking;
    if (overhang > th(k, "overhang_max_m"))
      emit(k, in.t_s, h.where_m.head<2>(),
           {{"pallet", h.pallet}, {"object", h.on_object}, {"level", h.level},
            {"measured", {{"overhang_m", round6(overhang)}}}, {"thresholds", {{"overhang_max_m", th(k, "overhang_max_m")}}}},
           out);
  }

  void handling(const TickInput& in, std::vector<EvaluationEvent>& out) {
    const double steer_deg = in.out.q[kAwr3] / kDeg;
    for (const HandlingEvent& h : in.report.handling) {
      const Eigen::Vector2d at = h.where_m.head<2>();
      switch (h.kind) {
        case HandlingEvent::Kind::kPickedUp:
        case HandlingEvent::Kind::kSetDown: {
          const RuleKey k = ev::kWheelsNotStraightStacking;
          if (std::abs(steer_deg) > th(k, "steer_max_deg"))
            emit(k, in.t_s, at,
                 {{"pallet", h.pallet}, {"when", handling_event_name(h.kind)},
                  {"measured", {{"steer_deg", round6(steer_deg)}}}, {"thresholds", {{"steer_max_deg", th(k, "steer_max_deg")}}}},
                 out);
          if (h.kind == HandlingEvent::Kind::kSetDown) {
            unsafe_stack(in, h, out);
            if (judge_set_down(in, h, out)) ++step;
          } else if (step < scene.task.steps.size() && scene.task.steps[step].kind == "take" &&
                     scene.task.steps[step].pallet == h.pallet) {
            ++step;  // de-stacked: the pallet the current step names is on the forks
          }
          break;
        }
        case HandlingEvent::Kind::kDropped:  // judged from the truck's model, below
        case HandlingEvent::Kind::kSliding:
          break;
      }
    }
  }

  // What happened to the load on the forks, as the truck's model has it (load_on_forks.h): it
  // fell off them, or slid along them (a pallet's or a scenario's load alike).
  void load_on_forks(const TickInput& in, std::vector<EvaluationEvent>& out) {
    const LoadOnForks& l = in.load_on_forks;
    // The pallet it is, if it is one: the one on the forks, or the one handling dropped.
    auto pallet = [&] {
      for (const HandlingEvent& h : in.report.handling)
        if (h.kind == HandlingEvent::Kind::kDropped) return h.pallet;
      for (const PalletState& p : in.pallets)
        if (p.on_forks) return p.id;
      return std::string();
    };
    const bool fallen = l.phase == LoadPhase::kFallen;
    if (fallen && !load_fallen)
      emit(ev::kLoadDropped, in.t_s, l.fell_at_m.head<2>(),
           {{"pallet", pallet()}, {"measured", {{"slide_m", round6(l.slide_m)}}}}, out);
    load_fallen = fallen;
    if (l.phase != LoadPhase::kStuck && l.phase != LoadPhase::kSliding) {
      slide = Slide{};  // none on the forks: the next one starts afresh
      return;
    }
    const RuleKey k = ev::kLoadSlid;
    Slide& sl = slide;
    if (l.slide_m != sl.last) sl.last_moved_t = in.t_s;
    sl.last = l.slide_m;
    if (!sl.active && std::abs(l.slide_m - sl.ref) >= th(k, "slide_min_m")) {
      sl.active = true;
      const Eigen::Vector3d at = in.poses.carriage * (in.load ? in.load->cog_m : Eigen::Vector3d::Zero());
      emit(k, in.t_s, at.head<2>(),
           {{"pallet", pallet()}, {"measured", {{"slide_m", round6(l.slide_m)}, {"from_m", round6(sl.ref)}}},
            {"thresholds", {{"slide_min_m", th(k, "slide_min_m")}}}},
           out);
    } else if (sl.active && in.t_s - sl.last_moved_t >= th(k, "clear_time_s")) {
      sl.active = false;
      sl.ref = l.slide_m;
    }
  }

  void route(const TickInput& in, std::vector<EvaluationEvent>& out) {
    const Route& r = scene.route;
    if (r.width_m <= 0 || r.points.empty()) return;
    const Eigen::Vector2d p = in.out.q.head<2>();
    const double d = ev::polyline_distance(p, r.points, false);
    const RuleKey k = ev::kOffRoute;
    const double edge = 0.5 * r.width_m;
    const bool on = off_route.active() ? d > edge : d > edge + th(k, "beyond_edge_m");
    if (off_route.update(on, in.t_s, th(k, "min_duration_s"), th(k, "clear_time_s")))
      emit(k, in.t_s, p,
           {{"measured", {{"distance_from_route_m", round6(d)}}},
            {"thresholds", {{"route_half_width_m", edge}, {"beyond_edge_m", th(k, "beyond_edge_m")}}}},
           out);
  }

  // How far a lesson's control step's action has gone at this tick, in its amount's unit: the
  // speed forward or back, the rear wheel turned for a left or right turn (going forward: + of the
  // coordinate points the rear wheel left, turning the truck right), the lift, the tilt.
  static double control_measure(const std::string& action, const Outputs& o) {
    const double v = o.forward_speed_m_s, steer = o.q[kAwr3], tilt = o.q[kBeta];
    if (action == "forward") return v;
    if (action == "reverse") return -v;
    if (action == "stop") return std::abs(v);
    if (action == "steer_left") return -steer;
    if (action == "steer_right") return steer;
    if (action == "steer_straight") return std::abs(steer);
    if (action == "lift" || action == "lower") return o.q[kS];
    if (action == "tilt_back") return -tilt;
    if (action == "tilt_forward") return tilt;
    return std::abs(tilt);  // tilt_level: the scene loader lets no other action through
  }

  // reach, pass and control steps, in order (take and move steps complete in handling()). A
  // control step is judged only once it is the current one, so each action of a lesson counts
  // only after the one before it is done.
  void task(const TickInput& in) {
    const Eigen::Vector2d p = in.out.q.head<2>();
    const std::vector<TaskStep>& steps = scene.task.steps;
    while (step < steps.size()) {
      const TaskStep& s = steps[step];
      bool done = false;
      if (s.kind == "reach") done = (p - s.point).norm() <= s.radius_m;
      else if (s.kind == "pass") done = ev::crosses(prev_pos, p, s.gate_a, s.gate_b);
      else if (s.kind == "control") {
        const double m = control_measure(s.action, in.out);
        done = find_control_action(s.action)->at_least ? m >= s.amount : m <= s.amount;
      }
      if (!done) break;
      ++step;
    }
    prev_pos = p;
  }

  void tick(const TickInput& in, std::vector<EvaluationEvent>& out) {
    if (finished) bug("Evaluator::tick after finish");
    const Outputs& o = in.out;
    const double dt = have_tick ? in.t_s - last_t : 0.0;
    const double tau = rules.acceleration_filter_time_constant_s;
    if (dt > 0) accel += (dt / (tau + dt)) * (o.qddot.head<3>() - accel);
    const bool first = !have_tick;
    have_tick = true;
    last_t = in.t_s;

    // A truck on its side is the end of the exam: nothing after it is the driver's to mark.
    if (tipped) return;
    const double v = o.forward_speed_m_s;
    const double ground_speed = o.qdot.head<2>().norm();
    const Eigen::Vector3d heel = in.poses.carriage.translation();
    const double heel_height = heel.z() - scene.ground.height(heel.x(), heel.y());

    capacity(in, out);
    // Before the tip-over rule: a load that falls as the truck goes over is marked, and the tip,
    // after which nothing is, comes last.
    load_on_forks(in, out);
    collisions(in, out);
    speeding(in, ground_speed, out);
    speed_near_people(in, ground_speed, out);
    people_in_path(in, v, out);
    people_at_fixed_objects(in, v, out);
    people_under_forks(in, heel_height, out);
    marked_places(in, first, ground_speed, out);
    crossings(in, first, out);
    forks_and_mast(in, v, heel_height, out);
    dynamics(in, v, heel_height, out);
    handling(in, out);
    route(in, out);
    task(in);
    if (scene.time_limit_s > 0 && !time_reported && in.t_s > scene.time_limit_s) {
      time_reported = true;
      emit(ev::kTimeLimit, in.t_s, o.q.head<2>(), {{"measured", {{"time_s", round6(in.t_s)}}}, {"thresholds", {{"time_limit_s", scene.time_limit_s}}}}, out);
    }
    if (in.deadman && !deadman) emit(ev::kDeadmanStop, in.t_s, o.q.head<2>(), json::object(), out);
    deadman = in.deadman;

    lift_s = o.q[kS];
    speed_m_s = v;
    last_inputs = in.inputs;
    pos = o.q.head<2>();
  }

  Score finish(const std::string& reason, std::vector<EvaluationEvent>& out) {
    if (finished) bug("Evaluator::finish called twice");
    finished = true;
    const Scheme& sc = rules.scheme;
    const int total = int(scene.task.steps.size());
    const bool complete = int(step) >= total;
    // The truck is judged as left only when the pupil left it: after an end the pupil can make,
    // with the task done. A session stopped mid-task (by the time it was given, the time limit,
    // the instructor's abort) is not charged for the state it was stopped in.
    const bool parking = complete && std::find(sc.parking_checked_on_end.begin(), sc.parking_checked_on_end.end(), reason) !=
                                         sc.parking_checked_on_end.end();
    if (parking && have_tick && !tipped) {
      if (lift_s > th(ev::kParkedForksRaised, "lift_max_m"))
        emit(ev::kParkedForksRaised, last_t, pos,
             {{"measured", {{"lift_m", round6(lift_s)}}}, {"thresholds", {{"lift_max_m", th(ev::kParkedForksRaised, "lift_max_m")}}}}, out);
      const RuleKey k = ev::kParkedControlsNotNeutral;
      const double frac = th(k, "control_max_fraction");
      const DriverInputs& u = last_inputs;
      const MastLimits& lim = truck.limits;
      json wrong = json::array();
      if (std::abs(speed_m_s) > th(k, "speed_max_m_s")) wrong.push_back("still moving");
      if (std::abs(u.drive_torque_N_m) > frac * truck.drive.drive_torque_max_N_m) wrong.push_back("accelerator");
      if (u.brake_torque_N_m < frac * truck.drive.brake_torque_max_N_m) wrong.push_back("brake not set");
      if (std::abs(u.lift_rate_m_s) > frac * lim.lift_rate_max_m_s) wrong.push_back("lift lever");
      if (std::abs(u.tilt_rate_rad_s) > frac * lim.tilt_rate_max_rad_s) wrong.push_back("tilt lever");
      if (std::abs(u.shift_rate_m_s) > frac * lim.side_shift_rate_max_m_s) wrong.push_back("side-shift lever");
      if (!wrong.empty())
        emit(k, last_t, pos,
             {{"not_neutral", wrong},
              {"measured", {{"speed_m_s", round6(speed_m_s)},
                            {"accelerator", round6(u.drive_torque_N_m / truck.drive.drive_torque_max_N_m)},
                            {"brake", round6(u.brake_torque_N_m / truck.drive.brake_torque_max_N_m)}}},
              {"thresholds", {{"speed_max_m_s", th(k, "speed_max_m_s")}, {"control_max_fraction", frac}}}},
             out);
    }
    if (!complete) {
      json left = json::array();
      for (size_t i = step; i < scene.task.steps.size(); ++i) left.push_back(step_words(scene.task.steps[i].description));
      emit(ev::kTaskIncomplete, last_t, pos, {{"steps_done", step}, {"steps_total", total}, {"steps_left", left}}, out);
    }

    Score s;
    s.end_reason = reason;
    s.mode = mode_name(mode);
    s.points = points;
    s.mark = std::max(0.0, sc.mark_start - points);
    s.task_completed = complete;
    s.steps_done = int(step);
    s.steps_total = total;
    s.min_stability_fraction = min_fraction;
    std::map<std::string, int> serious;
    for (const EvaluationEvent& e : events) {
      ++s.counts[e.rule];
      if (e.automatic_fail && std::find(s.automatic_failures.begin(), s.automatic_failures.end(), e.rule) == s.automatic_failures.end())
        s.automatic_failures.push_back(e.rule);
      if (e.worry_level == sc.serious_worry_level) ++serious[e.rule];
    }
    for (const auto& [id, n] : serious)
      if (n > sc.max_same_serious_fault) s.automatic_failures.push_back("repeated:" + id);
    // A task left undone is not passed in training either: the summary, the store and the pupil
    // read one decision.
    s.passed = s.points <= sc.fail_above_points && s.automatic_failures.empty() && (!sc.task_required || complete);
    return s;
  }
};

Evaluator::Evaluator(const Rules& rules, const Scene& scene, const TruckParams& truck, const TruckShape& shape, Mode mode)
    : impl_(std::make_unique<Impl>(rules, scene, truck, shape, mode)) {
  *initial_.d_ = static_cast<const EvaluationMemory::Data&>(*impl_);
  initial_.d_->primed = true;
}
Evaluator::~Evaluator() = default;

namespace {
// Puts a session's memory in the evaluator for one call, and back afterwards (an exception too).
struct Borrow {
  EvaluationMemory::Data& mine;
  EvaluationMemory::Data& theirs;
  Borrow(EvaluationMemory::Data& m, EvaluationMemory::Data& t, const EvaluationMemory::Data& initial) : mine(m), theirs(t) {
    if (!theirs.primed) theirs = initial;
    std::swap(mine, theirs);
  }
  ~Borrow() { std::swap(mine, theirs); }
};
}  // namespace

void Evaluator::tick(EvaluationMemory& memory, const TickInput& in, std::vector<EvaluationEvent>& out) {
  Borrow b(*impl_, *memory.d_, *initial_.d_);
  impl_->tick(in, out);
}
Score Evaluator::finish(EvaluationMemory& memory, const std::string& end_reason, std::vector<EvaluationEvent>& out) {
  Borrow b(*impl_, *memory.d_, *initial_.d_);
  return impl_->finish(end_reason, out);
}

}  // namespace forklift
