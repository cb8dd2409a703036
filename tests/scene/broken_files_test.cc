// Broken scenario, layout, truck and mesh files: every one is refused with the file and the key
// named, or loads and runs; none crashes, hangs or reaches FCL or the integrator with a number
// outside its schema's range (data/schema/). The mutations start from the shipped exam scenario,
// its warehouse layout and the training truck, and change one value each.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <map>
#include <set>
#include <variant>

#include "forklift/schema/data_file.h"
#include "forklift/session/session.h"
#include "support/ports.h"
#include "support/process.h"

using namespace forklift;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

const std::string kData = FORKLIFT_DATA_DIR;
const std::string kBin = FORKLIFT_BIN_DIR;

std::string temp_dir(const std::string& name) {
  const fs::path d = fs::path(testing::TempDir()) / ("broken_files_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d.string();
}

void write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

json read(const std::string& path) { return json::parse(std::ifstream(path)); }

// One value of a document: its path of keys and indices, and the dotted key loaders name it by.
struct Leaf {
  std::vector<std::variant<std::string, size_t>> path;
  std::string key;  // "objects[3].x_m"
  json value;
};

void leaves(const json& j, Leaf at, std::vector<Leaf>& out) {
  if (j.is_object()) {
    for (const auto& [k, v] : j.items()) {
      if (!k.empty() && k[0] == '_') continue;  // comments
      Leaf next = at;
      next.path.emplace_back(k);
      next.key += (next.key.empty() ? "" : ".") + k;
      leaves(v, next, out);
    }
  } else if (j.is_array()) {
    for (size_t i = 0; i < j.size(); ++i) {
      Leaf next = at;
      next.path.emplace_back(i);
      next.key += "[" + std::to_string(i) + "]";
      leaves(j[i], next, out);
    }
  } else {
    at.value = j;
    out.push_back(at);
  }
}

json& at(json& j, const Leaf& leaf) {
  json* p = &j;
  for (const auto& step : leaf.path) p = std::holds_alternative<std::string>(step) ? &(*p)[std::get<std::string>(step)] : &(*p)[std::get<size_t>(step)];
  return *p;
}

// The shipped exam: its scenario, the layout it includes and its truck, each as JSON.
struct Exam {
  json scenario = read(kData + "/scenarios/practical_exam.json");
  json layout = read(kData + "/" + scenario["include"].get<std::string>());
  json truck = read(kData + "/" + scenario["truck"].get<std::string>());
};

enum class Part { kScenario, kLayout, kTruck };
const char* part_name(Part p) { return p == Part::kScenario ? "scenario" : p == Part::kLayout ? "layout" : "truck"; }

// Every value of every part to mutate; of the layout's objects one of each kind (the rest are
// the same rules again).
std::vector<std::pair<Part, Leaf>> values_to_mutate(const Exam& exam) {
  std::vector<std::pair<Part, Leaf>> out;
  for (Part part : {Part::kScenario, Part::kLayout, Part::kTruck}) {
    const json& doc = part == Part::kScenario ? exam.scenario : part == Part::kLayout ? exam.layout : exam.truck;
    std::vector<Leaf> all;
    leaves(doc, {}, all);
    std::set<std::string> kinds_seen;
    std::set<size_t> objects_kept;
    for (const Leaf& l : all) {
      if (part == Part::kLayout && l.path.size() > 1 && std::get<std::string>(l.path[0]) == "objects") {
        const size_t i = std::get<size_t>(l.path[1]);
        const std::string kind = doc["objects"][i].value("kind", "");
        if (!objects_kept.count(i) && !kinds_seen.insert(kind).second) continue;
        objects_kept.insert(i);
      }
      out.emplace_back(part, l);
    }
  }
  return out;
}

// Writes the exam with `change` made to one part, the scenario naming the others by absolute
// path; returns the scenario's path and the changed part's.
std::pair<std::string, std::string> write_exam(const Exam& exam, const std::string& dir, Part part,
                                               const std::function<void(json&)>& change) {
  json scenario = exam.scenario, layout = exam.layout, truck = exam.truck;
  change(part == Part::kScenario ? scenario : part == Part::kLayout ? layout : truck);
  const std::string layout_path = dir + "/layout.json", truck_path = dir + "/truck.json", scenario_path = dir + "/scenario.json";
  write(layout_path, layout.dump());
  write(truck_path, truck.dump());
  if (scenario.is_object()) {
    scenario["include"] = layout_path;
    scenario["truck"] = truck_path;
  }
  write(scenario_path, scenario.dump());
  return {scenario_path, part == Part::kScenario ? scenario_path : part == Part::kLayout ? layout_path : truck_path};
}

// The error loading the session gives, or "" when it loads.
std::string load_error(const std::string& scenario_path) {
  try {
    SessionSpec spec;
    spec.scenario_file = scenario_path;
    const SessionModel model = load_session_model(spec, kData);
    initial_state(model);
    return "";
  } catch (const std::exception& e) {
    return e.what();
  }
}

// Loads and drives the session for 0.3 s (accelerating, steering and lifting): the outcome in a
// word, "refused" with the loader's message, or how the run ended.
std::string load_and_drive(const std::string& scenario_path, std::string& message) {
  std::optional<SessionModel> model;
  std::optional<SessionState> first;
  try {
    SessionSpec spec;
    spec.scenario_file = scenario_path;
    model.emplace(load_session_model(spec, kData));
    first.emplace(initial_state(*model));
  } catch (const std::exception& e) {
    message = e.what();
    return "refused";
  }
  InputChange drive;
  drive.inputs.driver.drive_torque_N_m = 0.3 * model->truck.drive.drive_torque_max_N_m;
  drive.inputs.driver.steer_rad = 0.1;
  drive.inputs.driver.lift_rate_m_s = 0.2 * model->truck.limits.lift_rate_max_m_s;
  const OfflineRun run = run_offline(*model, *first, {drive}, 300, EndReason::kDuration);
  message = run.failure;
  if (run.end_reason == EndReason::kNumericalFailure) return "numerical failure, counted";
  if (!run.final_state.x.allFinite()) return "non-finite state";  // must never happen
  return "ran";
}

}  // namespace

TEST(DataFiles, EveryShippedFileHoldsItsSchema) {
  size_t files = 0;
  for (const char* dir : {"scenarios", "scenes", "manoeuvres"})
    for (const auto& f : fs::directory_iterator(kData + "/" + dir))
      if (f.path().extension() == ".json") {
        EXPECT_EQ(schema::schema_problem(read(f.path()), schema::Schema::kScenario), std::nullopt) << f.path();
        ++files;
      }
  for (const auto& f : fs::directory_iterator(kData + "/trucks")) {
    EXPECT_EQ(schema::schema_problem(read(f.path()), schema::Schema::kTruck), std::nullopt) << f.path();
    ++files;
  }
  EXPECT_GE(files, 20u);
}

// The finding: a scenario object at x = 1e308 or scale 1e300 crashed forklift-sim and the worker
// inside FCL. Now every number of the exam's three files, set far out of range either way, is
// refused before anything is built, naming its file and key.
TEST(DataFiles, EveryNumberFarOutOfRangeIsRefusedNamingItsFileAndKey) {
  const Exam exam;
  const std::string dir = temp_dir("far");
  size_t cases = 0;
  for (const auto& [part, leaf] : values_to_mutate(exam)) {
    if (!leaf.value.is_number()) continue;
    for (const double far : {1e308, -1e308, 1e300}) {
      const auto [scenario, changed] = write_exam(exam, dir, part, [&](json& j) { at(j, leaf) = far; });
      const std::string error = load_error(scenario);
      ++cases;
      EXPECT_NE(error.find(changed + ": '" + leaf.key), std::string::npos) << part_name(part) << " " << leaf.key << " = " << far << ": " << error;
    }
  }
  std::cout << cases << " files with one number far out of range, each refused naming it\n";
  EXPECT_GT(cases, 900u);
  fs::remove_all(dir);
}

// Every value of the three files made zero, negative, tiny, huge, or of another type, one at a
// time: each file is refused with a message that starts with the file it names, or the session
// loads and runs 0.3 s of driving to a finite state (or to a counted numerical failure).
// In four shards (every fourth value each): one run of all of them is a minute and more of
// loading and driving, which a parallel run finished alone at its end when it came last.
constexpr size_t kBrokenValueShards = 4;
class EveryOtherBrokenValue : public testing::TestWithParam<size_t> {};

TEST_P(EveryOtherBrokenValue, IsRefusedOrRunsSafely) {
  const Exam exam;
  const std::string dir = temp_dir("broken" + std::to_string(GetParam()));
  const auto cases = values_to_mutate(exam);
  std::map<std::string, size_t> outcomes;
  for (size_t i = GetParam(); i < cases.size(); i += kBrokenValueShards) {
    const auto& [part, leaf] = cases[i];
    std::vector<json> values = {"x", nullptr, json::array(), json::object(), true};
    if (leaf.value.is_number()) {
      const double v = leaf.value.get<double>();
      for (const double w : {0.0, -1.0, 1e-300, -v, 1000 * v, 1e6}) values.push_back(w);
    }
    for (const json& value : values) {
      const auto [scenario, changed] = write_exam(exam, dir, part, [&](json& j) { at(j, leaf) = value; });
      std::string message;
      const std::string outcome = load_and_drive(scenario, message);
      ++outcomes[outcome];
      const std::string what = std::string(part_name(part)) + " " + leaf.key + " = " + value.dump();
      EXPECT_NE(outcome, "non-finite state") << what;
      if (outcome == "refused") {
        EXPECT_EQ(message.rfind("/", 0), 0u) << what << ": " << message;  // starts with the path it names
      }
    }
  }
  size_t total = 0;
  for (const auto& [outcome, n] : outcomes) {
    std::cout << n << " " << outcome << "\n";
    total += n;
  }
  EXPECT_GT(total, 5000u / kBrokenValueShards);
  fs::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(DataFiles, EveryOtherBrokenValue, testing::Range(size_t{0}, kBrokenValueShards),
                         [](const testing::TestParamInfo<size_t>& i) { return "shard" + std::to_string(i.param + 1); });

// Files that are not what they say: a pipe, a device, a folder, a file too big, JSON nested too
// deep, an include that names a pipe, meshes with a non-finite or far vertex, too many vertices,
// or a material file that is a pipe. Each through the real forklift-sim evaluate: exit 2, within
// seconds, with the problem in words (a pipe must not block it).
TEST(DataFiles, FilesThatAreNotDataFilesAreRefusedWithoutBlocking) {
  const std::string dir = temp_dir("odd");
  const std::string script = dir + "/short.csv";
  write(script, "t,steer,accelerator,brake,lift,tilt,shift\n0,0,0.3,0,0,0,0\n0.2,0,0,0,0,0,0\n");
  const std::string fifo = dir + "/fifo.json";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const std::string big = dir + "/big.json";
  fs::resize_file((std::ofstream(big), big), schema::kMaxJsonBytes + 1);
  std::string deep(100000, '[');
  deep += std::string(100000, ']');
  write(dir + "/deep.json", deep);
  const std::string cone = R"({"objects": [{"id": "c", "kind": "cone", "x_m": 1, "y_m": 1, "mesh": "MESH"}]})";
  auto with_mesh = [&](const std::string& name, const std::string& obj) {
    write(dir + "/" + name + ".obj", obj);
    std::string text = cone;
    text.replace(text.find("MESH"), 4, dir + "/" + name + ".obj");
    write(dir + "/" + name + ".json", text);
    return dir + "/" + name + ".json";
  };
  const std::string tri = "f 1 2 3\n";
  std::string many;  // 1,000,002 distinct vertices in 333,334 triangles
  for (int i = 0; i < 1000002; ++i) many += "v " + std::to_string(i * 1e-4) + " " + std::to_string(i % 3) + " 0\n";
  for (int i = 0; i < 1000002; i += 3) many += "f " + std::to_string(i + 1) + " " + std::to_string(i + 2) + " " + std::to_string(i + 3) + "\n";
  const std::string mtl_fifo = dir + "/pipe.mtl";
  ASSERT_EQ(mkfifo(mtl_fifo.c_str(), 0600), 0);

  struct Case {
    std::string name, scenario, says;
  };
  const std::vector<Case> cases = {
      {"a pipe", fifo, "not a regular file"},
      {"a device", "/dev/zero", "not a regular file"},
      {"a folder", dir, "directory"},  // CLI11 refuses it before the loader would
      {"too big", big, "more than the 16 MiB"},
      {"nested too deep", dir + "/deep.json", "more than 64 deep"},
      {"an include that is a pipe", (write(dir + "/inc.json", R"({"include": ")" + fifo + R"("})"), dir + "/inc.json"),
       "not a regular file"},
      {"a truck that is a device", (write(dir + "/dev_truck.json", R"({"truck": "/dev/zero"})"), dir + "/dev_truck.json"),
       "not a regular file"},
      {"a NaN vertex", with_mesh("nan", "v 0 0 0\nv nan 0 0\nv 0 1 0\n" + tri), "not finite"},
      {"a far vertex", with_mesh("far", "v 0 0 0\nv 1e30 0 0\nv 0 1 0\n" + tri), "not finite or lies more than 1000 m"},
      {"too many vertices", with_mesh("many", many), "more than the 1000000"},
      {"a material that is a pipe", with_mesh("mtl", "mtllib pipe.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl x\n" + tri), "pipe.mtl"},
  };
  for (const Case& c : cases) {
    Process p({kBin + "/forklift-sim", "evaluate", "--scenario", c.scenario, "--script", script}, dir + "/run");
    // A bound for a hang, not a measure of speed: each takes well under a second.
    EXPECT_EQ(p.wait(120), 2) << c.name << ": " << p.err();
    EXPECT_NE(p.err().find(c.says), std::string::npos) << c.name << ": " << p.err();
  }
  fs::remove_all(dir);
}

// The worker refuses a broken scenario as bad input: exit 2, naming the file and the key.
TEST(DataFiles, TheWorkerRefusesABrokenScenarioWithExit2) {
  const Exam exam;
  const std::string dir = temp_dir("worker");
  const auto [scenario, changed] = write_exam(exam, dir, Part::kLayout, [](json& j) { j["objects"][0]["x_m"] = 1e308; });
  Process w({kBin + "/forklift-worker", "--cab", "cabx", "--session", "broken", "--scenario", scenario, "--log-dir", dir,
             "--dds-domain", std::to_string(forklift::test::free_domain()), "--start-timeout", "5"},
            dir + "/worker");
  EXPECT_EQ(w.wait(60), 2) << w.err();
  EXPECT_NE(w.err().find(changed + ": 'objects[0].x_m' must be at most 10000"), std::string::npos) << w.err();
  fs::remove_all(dir);
}
