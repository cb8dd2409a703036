#include "forklift/evaluation/event_words.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <utility>
#include <vector>

#include "forklift/units/decimals.h"

namespace forklift {
namespace {

using nlohmann::json;

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() > tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// Units by the suffix the evaluator gives every number, longest first ("_m_s2" before "_m_s").
const std::vector<std::pair<std::string, std::string>> kUnits = {
    {"_m_s2", "m/s2"}, {"_m_s", "m/s"}, {"_fraction", "fraction"}, {"_deg", "deg"}, {"_kg", "kg"},
    {"_N", "N"},       {"_s", "s"},     {"_m", "m"}};

// Nicer names for the keys whose words alone read badly.
const std::map<std::string, std::string> kNames = {
    {"over_limit", "allowed over the limit"},  {"travel_speed_min", "counted from a speed of"},
    {"fork_height_max", "highest fork height"}, {"fork_clearance_min", "lowest fork clearance"},
    {"tilt_forward_max", "most forward tilt"},  {"lateral_acceleration_max", "highest sideways acceleration"},
    {"deceleration_max", "hardest braking"},    {"raised_fork_height", "counted from a fork height of"},
    {"warn_below", "warned below"},             {"margin", "stability margin"},
    {"wheel_load_min", "least wheel load"},     {"roll_or_pitch_max", "most roll or pitch"},
    {"hard_impact_speed", "hard impact from"},  {"impact_speed", "impact speed"},
    {"load_centre", "load centre"},             {"capacity_at_load_centre", "capacity at that load centre"},
    {"lift_max", "highest fork lift when parked"}, {"overhang_max", "most overhang"},
    {"steer_max", "most steering angle"},       {"speed_max", "highest speed when parked"},
    {"control_max", "most control deflection"}, {"beyond_edge", "beyond the route's edge"},
    {"time_limit", "time limit"},               {"slide_min", "counted from a slide of"},
    {"tolerance", "tolerance"},                 {"time", "time"}};

// Where one rule's number means something else than the same name in the others ("margin" is the
// stability margin but for the people's rules; "speed_max" a parked truck's but near a person).
const std::map<std::string, std::string> kNamesOfKind = {
    {"pedestrian_in_path:margin", "distance to spare"},
    {"speed_near_pedestrian:speed_max", "highest speed near a person"},
    {"person_under_forks:margin", "counted from beside the forks within"},
    {"horn_at_marker:horn_before", "horn counted from before entering"},
    {"horn_at_marker:horn_after", "horn counted until after entering"},
    {"give_way_at_crossing:distance", "the truck with priority from the crossing's middle"},
    {"give_way_at_crossing:truck_speed", "that truck's speed"},
    {"give_way_at_crossing:priority_within", "counted for a truck with priority within"}};

std::string name_of(const std::string& kind, const std::string& bare) {
  if (const auto own = kNamesOfKind.find(kind + ":" + bare); own != kNamesOfKind.end()) return own->second;
  const auto it = kNames.find(bare);
  if (it != kNames.end()) return it->second;
  std::string words = bare;
  for (char& c : words)
    if (c == '_') c = ' ';
  return words;
}

json quantities(const json& group, const std::string& kind) {
  json out = json::array();
  if (!group.is_object()) return out;
  for (const auto& [key, v] : group.items()) {
    if (!v.is_number()) continue;
    std::string bare = key;
    for (const auto& [suffix, unit] : kUnits)
      if (ends_with(key, suffix)) {
        bare = key.substr(0, key.size() - suffix.size());
        break;
      }
    out.push_back({{"what", name_of(kind, bare)}, {"value", quantity_words(key, v.get<double>())}});
  }
  return out;
}

std::string listed(const json& items) {
  std::string s;
  for (const json& i : items) s += (s.empty() ? "" : ", ") + i["what"].get<std::string>() + " " + i["value"].get<std::string>();
  return s;
}

// The pallet-handling and other information events, which have no rule.
const std::map<std::string, std::string> kInformation = {
    {"picked_up", "Load picked up"}, {"set_down", "Load set down"}, {"sliding", "Load sliding"},
    {"dropped", "Load fell off the forks"}};

}  // namespace

std::string worry_words(int level) {
  switch (level) {
    case 0: return "information";
    case 1: return "minor";
    case 3: return "medium";
    case 5: return "serious";
    default: return "level " + std::to_string(level);
  }
}

std::string quantity_words(const std::string& key, double v) {
  if (ends_with(key, "_m_s2")) return fixed_decimals(v, 2) + " m/s²";
  if (ends_with(key, "_m_s")) return fixed_decimals(v, 2) + " m/s (" + fixed_decimals(v * 3.6, 1) + " km/h)";
  if (ends_with(key, "_fraction")) return fixed_decimals(v * 100, 0) + " %";
  if (ends_with(key, "_deg")) return fixed_decimals(v, 1) + "°";
  if (ends_with(key, "_kg")) return fixed_decimals(v, 0) + " kg";
  if (ends_with(key, "_N")) return std::abs(v) >= 1000 ? fixed_decimals(v / 1000, 1) + " kN" : fixed_decimals(v, 0) + " N";
  if (ends_with(key, "_s")) return fixed_decimals(v, 1) + " s";
  if (ends_with(key, "_m")) return std::abs(v) < 1 ? fixed_decimals(v * 100, 0) + " cm" : fixed_decimals(v, 2) + " m";
  return fixed_decimals(v, 2);  // a control's deflection, a count: no unit
}

json event_words(const std::string& rule_title, const std::string& kind, const std::string& details) {
  std::string title = rule_title;
  if (title.empty()) {
    if (const auto info = kInformation.find(kind); info != kInformation.end()) title = info->second;
    else {
      title = kind;
      for (char& c : title)
        if (c == '_') c = ' ';
    }
  }
  const json d = json::parse(details, nullptr, false);
  const json measured = quantities(d.is_object() ? d.value("measured", json()) : json(), kind);
  const json limits = quantities(d.is_object() ? d.value("thresholds", json()) : json(), kind);
  std::string summary;
  if (!measured.empty()) summary = "Measured: " + listed(measured) + ".";
  if (!limits.empty()) summary += std::string(summary.empty() ? "" : " ") + "Limit: " + listed(limits) + ".";
  return {{"title", title}, {"measured", measured}, {"limits", limits}, {"summary", summary}};
}

}  // namespace forklift
