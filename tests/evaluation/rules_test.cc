// The rules file: the shipped one is complete and follows its conventions; broken ones are
// refused with the file and the key named.
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>

#include "evaluation/harness.h"

namespace {

using namespace evt;
using nlohmann::json;

json shipped() {
  std::ifstream in(data("evaluation/rules.json"));
  return json::parse(in);
}

size_t index_of(const json& j, const std::string& id) {
  for (size_t i = 0; i < j["rules"].size(); ++i)
    if (j["rules"][i]["id"] == id) return i;
  throw std::runtime_error("no rule " + id);
}

// Writes `j` to a temporary file and returns the error load_rules gives for it ("" if none).
std::string error_of(const json& j, const std::string& name) {
  const std::string path = testing::TempDir() + "/rules_" + name + ".json";
  std::ofstream(path) << j.dump(2);
  try {
    load_rules(path);
  } catch (const RulesError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind(path + ": ", 0), 0u) << "the message names the file: " << what;
    return what;
  }
  return "";
}

TEST(Rules, TheShippedFileHasEveryRuleWithWordsAndASource) {
  const Rules& r = rules();
  EXPECT_EQ(r.rules.size(), rule_ids().size());
  for (const std::string& id : rule_ids()) {
    const Rule* rule = r.find(id);
    ASSERT_NE(rule, nullptr) << id;
    EXPECT_GT(rule->description.size(), 20u) << id;
    EXPECT_GT(rule->source.size(), 20u) << id;
    EXPECT_TRUE(std::set<int>({0, 1, 3, 5}).count(rule->worry_level)) << id;
  }
  // The scheme of the UK basic operating skills test.
  EXPECT_EQ(r.scheme.points_by_worry_level, (std::map<int, int>{{0, 0}, {1, 1}, {3, 3}, {5, 5}}));
  EXPECT_EQ(r.scheme.fail_above_points, 40);
  EXPECT_EQ(r.scheme.max_same_serious_fault, 3);
  EXPECT_EQ(r.scheme.mark_start, 100);
  EXPECT_TRUE(r.scheme.task_required);
  for (const char* id : {"collision_pedestrian", "violent_collision", "tip_over", "load_dropped", "overload", "unsafe_stacking",
                         "time_limit"})
    EXPECT_TRUE(r.find(id)->automatic_fail) << id;
  EXPECT_EQ(r.find("stability_warning")->worry_level, 0);
}

TEST(Rules, EveryThresholdCarriesItsUnitInItsName) {
  const std::regex unit(".*_(s|m|m_s|m_s2|deg|N|kg|fraction|worry_level)$");
  for (const Rule& rule : rules().rules)
    for (const auto& [name, value] : rule.thresholds) {
      EXPECT_TRUE(std::regex_match(name, unit)) << rule.id << "." << name;
      EXPECT_GE(value, 0) << rule.id << "." << name;
    }
}

TEST(Rules, EveryObjectKindIsGradedByOneCollisionRule) {
  std::map<std::string, int> covered;
  for (const char* id : {"collision_pedestrian", "collision_rack", "collision_lorry", "collision_structure", "collision_cone",
                         "collision_pallet"})
    for (const std::string& kind : rules().find(id)->applies_to) ++covered[kind];
  for (int k = 0; k <= int(ObjectKind::kPedestrian); ++k) EXPECT_EQ(covered[object_kind_name(ObjectKind(k))], 1);
}

TEST(Rules, BrokenFilesAreRefusedNamingTheKey) {
  const json good = shipped();
  EXPECT_EQ(error_of(good, "good"), "");
  {
    json j = good;
    j["rules"].erase(index_of(j, "tip_over"));
    EXPECT_NE(error_of(j, "missing_rule").find("rules: has no rule 'tip_over'"), std::string::npos);
  }
  {
    json j = good;
    const size_t i = index_of(j, "off_route");
    j["rules"][i]["thresholds"]["bogus_m"] = 1;
    EXPECT_NE(error_of(j, "unknown_threshold").find("rules[" + std::to_string(i) + "].thresholds.bogus_m: is not a threshold"),
              std::string::npos);
  }
  {
    json j = good;
    const size_t i = index_of(j, "off_route");
    j["rules"][i]["thresholds"].erase("clear_time_s");
    EXPECT_NE(error_of(j, "missing_threshold").find("rules[" + std::to_string(i) + "].thresholds.clear_time_s: is missing"),
              std::string::npos);
  }
  {
    json j = good;
    const size_t i = index_of(j, "off_route");
    j["rules"][i]["thresholds"]["min_duration_s"] = -1;
    EXPECT_NE(error_of(j, "negative").find("thresholds.min_duration_s: must not be negative"), std::string::npos);
  }
  {
    json j = good;
    const size_t i = index_of(j, "turn_at_speed");
    j["rules"][i]["worry_level"] = 2;
    EXPECT_NE(error_of(j, "level").find("rules[" + std::to_string(i) + "].worry_level: worry level 2 is not in"),
              std::string::npos);
  }
  {
    json j = good;
    j["rules"].push_back(j["rules"][0]);
    EXPECT_NE(error_of(j, "repeated").find("repeats the rule 'collision_pedestrian'"), std::string::npos);
  }
  {
    json j = good;
    j["rules"][0]["id"] = "honking";
    EXPECT_NE(error_of(j, "unknown_rule").find("rules[0].id: 'honking' is not a rule the evaluator knows"), std::string::npos);
  }
  {
    json j = good;
    j["rules"][index_of(j, "collision_cone")]["applies_to"].push_back("rack");
    EXPECT_NE(error_of(j, "kind_twice").find("object kind 'rack' must be in the applies_to of exactly one collision rule"),
              std::string::npos);
  }
  {
    json j = good;
    j["rules"][index_of(j, "collision_cone")]["applies_to"].push_back("giraffe");
    EXPECT_NE(error_of(j, "kind_unknown").find("'giraffe' is not an object kind"), std::string::npos);
  }
  {
    json j = good;
    j["scheme"].erase("fail_above_points");
    EXPECT_NE(error_of(j, "scheme").find("scheme.fail_above_points: is missing"), std::string::npos);
  }
  {
    json j = good;
    j["rules"][1]["source"] = "";
    EXPECT_NE(error_of(j, "no_source").find("rules[1].source: must not be empty"), std::string::npos);
  }
  {
    json j = good;
    j["colour"] = "red";
    EXPECT_NE(error_of(j, "top_key").find("colour: is not a known key"), std::string::npos);
  }
  const std::string bad = testing::TempDir() + "/rules_bad.json";
  std::ofstream(bad) << "{ not json";
  EXPECT_THROW(load_rules(bad), RulesError);
  EXPECT_THROW(load_rules(testing::TempDir() + "/no_such_rules.json"), RulesError);
}

TEST(Rules, AZoneKindNoSpeedRuleCoversIsRefusedByTheEvaluator) {
  Scene sc = scene("zones.json");
  sc.zones.push_back({"Z_mezz", "mezzanine", {{0, 0}, {1, 0}, {1, 1}}, 1.0});
  const TruckParams truck = load_truck(sc.scenario.truck_file);
  const TruckShape shape = load_truck_shape(sc.scenario.truck_file, FORKLIFT_DATA_DIR);
  try {
    Evaluator e(rules(), sc, truck, shape, Mode::kExam);
    FAIL() << "accepted a zone kind no rule covers";
  } catch (const RulesError& e) {
    EXPECT_NE(std::string(e.what()).find("zone kind 'mezzanine' (zone Z_mezz"), std::string::npos) << e.what();
  }
}

TEST(Rules, RulesEditedInCodeAreCheckedByTheEvaluator) {
  const Scene sc = scene("zones.json");
  const TruckParams truck = load_truck(sc.scenario.truck_file);
  const TruckShape shape = load_truck_shape(sc.scenario.truck_file, FORKLIFT_DATA_DIR);
  Rules r = rules();
  for (Rule& rule : r.rules)
    if (rule.id == "off_route") rule.thresholds.erase("clear_time_s");
  EXPECT_THROW(Evaluator(r, sc, truck, shape, Mode::kExam), RulesError);
  r = rules();
  for (Rule& rule : r.rules)
    if (rule.id == "off_route") rule.worry_level = 4;
  EXPECT_THROW(Evaluator(r, sc, truck, shape, Mode::kExam), RulesError);
}

TEST(Rules, Modes) {
  EXPECT_EQ(parse_mode("exam"), Mode::kExam);
  EXPECT_EQ(parse_mode("training"), Mode::kTraining);
  EXPECT_STREQ(mode_name(Mode::kExam), "exam");
  EXPECT_THROW(parse_mode("Exam"), std::invalid_argument);
}

}  // namespace
