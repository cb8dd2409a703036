// Reading and checking a rules file (data/evaluation/rules.json).
#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "forklift/evaluation/evaluation.h"
#include "rule_table.h"

namespace forklift {
namespace {

using nlohmann::json;
using evaluation::AppliesTo;
using evaluation::rule_specs;

[[noreturn]] void fail(const std::string& file, const std::string& key, const std::string& what) {
  throw RulesError(file + ": " + key + ": " + what);
}

// A JSON value with the file and the key path it came from, for messages.
struct Node {
  const json& j;
  std::string file, key;

  Node at(const std::string& k) const {
    if (!j.is_object()) fail(file, key, "must be an object");
    if (!j.contains(k)) fail(file, key.empty() ? k : key + "." + k, "is missing");
    return {j.at(k), file, key.empty() ? k : key + "." + k};
  }
  Node at(size_t i) const { return {j.at(i), file, key + "[" + std::to_string(i) + "]"}; }
  bool has(const std::string& k) const { return j.is_object() && j.contains(k); }
  // Keys starting with '_' are comments.
  void only(std::initializer_list<const char*> known) const {
    if (!j.is_object()) fail(file, key, "must be an object");
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (!it.key().empty() && it.key()[0] == '_') continue;
      bool ok = false;
      for (const char* k : known) ok = ok || it.key() == k;
      if (!ok) fail(file, key.empty() ? it.key() : key + "." + it.key(), "is not a known key");
    }
  }
  double number() const {
    if (!j.is_number()) fail(file, key, "must be a number");
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(file, key, "must be finite");
    return v;
  }
  double non_negative() const {
    const double v = number();
    if (v < 0) fail(file, key, "must not be negative");
    return v;
  }
  int integer() const {
    if (!j.is_number_integer()) fail(file, key, "must be an integer");
    return j.get<int>();
  }
  std::string string() const {
    if (!j.is_string()) fail(file, key, "must be a string");
    return j.get<std::string>();
  }
  bool boolean() const {
    if (!j.is_boolean()) fail(file, key, "must be true or false");
    return j.get<bool>();
  }
  size_t size() const {
    if (!j.is_array()) fail(file, key, "must be an array");
    return j.size();
  }
};

Scheme read_scheme(const Node& n) {
  n.only({"name", "source", "points_by_worry_level", "fail_above_points", "serious_worry_level",
          "max_same_serious_fault", "mark_start", "task_required", "parking_checked_on_end"});
  Scheme s;
  s.name = n.at("name").string();
  s.source = n.at("source").string();
  const Node pts = n.at("points_by_worry_level");
  if (!pts.j.is_object() || pts.j.empty()) fail(pts.file, pts.key, "must be an object of worry level: points");
  for (auto it = pts.j.begin(); it != pts.j.end(); ++it) {
    if (!it.key().empty() && it.key()[0] == '_') continue;
    size_t used = 0;
    int level = -1;
    try {
      level = std::stoi(it.key(), &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != it.key().size() || level < 0) fail(pts.file, pts.key + "." + it.key(), "must be a worry level (0, 1, ...)");
    const Node p = pts.at(it.key());
    const int points = p.integer();
    if (points < 0) fail(p.file, p.key, "must not be negative");
    s.points_by_worry_level[level] = points;
  }
  s.fail_above_points = n.at("fail_above_points").integer();
  s.serious_worry_level = n.at("serious_worry_level").integer();
  s.max_same_serious_fault = n.at("max_same_serious_fault").integer();
  if (s.fail_above_points < 0) fail(n.file, n.key + ".fail_above_points", "must not be negative");
  if (s.max_same_serious_fault < 0) fail(n.file, n.key + ".max_same_serious_fault", "must not be negative");
  if (!s.points_by_worry_level.count(s.serious_worry_level))
    fail(n.file, n.key + ".serious_worry_level", "is not in points_by_worry_level");
  s.mark_start = n.at("mark_start").non_negative();
  s.task_required = n.at("task_required").boolean();
  const Node ends = n.at("parking_checked_on_end");
  for (size_t i = 0; i < ends.size(); ++i) s.parking_checked_on_end.push_back(ends.at(i).string());
  return s;
}

void check_level(const Scheme& s, const Node& n, int level) {
  if (!s.points_by_worry_level.count(level))
    fail(n.file, n.key, "worry level " + std::to_string(level) + " is not in scheme.points_by_worry_level");
}

Rule read_rule(const Node& n, const Scheme& scheme) {
  // "title": the rule's name in a few words, for the pages and forklift-sim evaluate (optional).
  n.only({"id", "title", "description", "worry_level", "automatic_fail", "source", "applies_to", "thresholds"});
  Rule r;
  r.id = n.at("id").string();
  const auto& specs = rule_specs();
  const auto spec = std::find_if(specs.begin(), specs.end(), [&](const auto& s) { return r.id == s.id; });
  if (spec == specs.end()) fail(n.file, n.key + ".id", "'" + r.id + "' is not a rule the evaluator knows");
  if (n.has("title")) r.title = n.at("title").string();
  r.description = n.at("description").string();
  if (r.description.empty()) fail(n.file, n.key + ".description", "must not be empty");
  r.worry_level = n.at("worry_level").integer();
  check_level(scheme, n.at("worry_level"), r.worry_level);
  r.automatic_fail = n.at("automatic_fail").boolean();
  r.source = n.at("source").string();
  if (r.source.empty()) fail(n.file, n.key + ".source", "must not be empty: name the marking-sheet item or clause");
  const Node applies = n.at("applies_to");
  for (size_t i = 0; i < applies.size(); ++i) {
    const Node a = applies.at(i);
    const std::string kind = a.string();
    if (spec->applies == AppliesTo::kNothing) fail(a.file, a.key, "this rule applies to no object or zone kinds");
    if (spec->applies == AppliesTo::kObjectKinds && !parse_object_kind(kind))
      fail(a.file, a.key, "'" + kind + "' is not an object kind");
    if (spec->applies == AppliesTo::kMarkerKinds &&
        std::find(marker_kinds().begin(), marker_kinds().end(), kind) == marker_kinds().end())
      fail(a.file, a.key, "'" + kind + "' is not a marker kind (blind_corner, door, cross_aisle)");
    r.applies_to.push_back(kind);
  }
  const Node th = n.at("thresholds");
  if (!th.j.is_object()) fail(th.file, th.key, "must be an object");
  for (auto it = th.j.begin(); it != th.j.end(); ++it) {
    if (!it.key().empty() && it.key()[0] == '_') continue;
    const bool known = std::any_of(spec->thresholds.begin(), spec->thresholds.end(),
                                   [&](const char* k) { return it.key() == k; });
    if (!known) fail(th.file, th.key + "." + it.key(), "is not a threshold of " + r.id);
  }
  for (const char* k : spec->thresholds) r.thresholds[k] = th.at(k).non_negative();
  if (r.thresholds.count("hard_impact_worry_level")) {
    const double v = r.thresholds.at("hard_impact_worry_level");
    if (v != std::floor(v)) fail(th.file, th.key + ".hard_impact_worry_level", "must be a whole worry level");
    check_level(scheme, th.at("hard_impact_worry_level"), int(v));
  }
  return r;
}

}  // namespace

const Rule* Rules::find(const std::string& id) const {
  for (const Rule& r : rules)
    if (r.id == id) return &r;
  return nullptr;
}

const std::vector<std::string>& rule_ids() {
  static const std::vector<std::string> ids = [] {
    std::vector<std::string> v;
    for (const auto& s : rule_specs()) v.push_back(s.id);
    return v;
  }();
  return ids;
}

Rules load_rules(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw RulesError(path + ": cannot open the rules file");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::exception& e) {
    throw RulesError(path + ": not valid JSON: " + e.what());
  }
  const Node root{j, path, ""};
  root.only({"scheme", "measurement", "rules"});
  Rules rules;
  rules.file = path;
  rules.scheme = read_scheme(root.at("scheme"));
  const Node m = root.at("measurement");
  m.only({"acceleration_filter_time_constant_s"});
  rules.acceleration_filter_time_constant_s = m.at("acceleration_filter_time_constant_s").non_negative();

  const Node list = root.at("rules");
  std::set<std::string> seen;
  for (size_t i = 0; i < list.size(); ++i) {
    Rule r = read_rule(list.at(i), rules.scheme);
    if (!seen.insert(r.id).second) fail(path, list.at(i).key + ".id", "repeats the rule '" + r.id + "'");
    rules.rules.push_back(std::move(r));
  }
  for (const auto& s : rule_specs())
    if (!seen.count(s.id)) fail(path, "rules", "has no rule '" + std::string(s.id) + "', which the evaluator needs");

  // Every object kind is graded by exactly one collision rule.
  for (int k = 0; k <= int(ObjectKind::kPedestrian); ++k) {
    const char* kind = object_kind_name(ObjectKind(k));
    int covered = 0;
    for (auto key : evaluation::kObjectCollisionRules)
      for (const std::string& a : rules.find(rule_specs()[key].id)->applies_to) covered += a == kind;
    if (covered != 1)
      fail(path, "rules", std::string("object kind '") + kind + "' must be in the applies_to of exactly one collision rule, is in " +
                              std::to_string(covered));
  }
  return rules;
}

const char* mode_name(Mode mode) { return name(mode); }

Mode parse_mode(const std::string& text) {
  if (const auto m = parse<Mode>(text)) return *m;
  throw std::invalid_argument("mode must be 'training' or 'exam', not '" + text + "'");
}

}  // namespace forklift
