// forklift-sim's model commands as a school or a vendor runs them: validate, tilt --iso,
// static --grade, and --truck where it applies; in words for a person, JSON with --json.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>

#include "support/process.h"

using nlohmann::json;

namespace {

const std::string kSim = std::string(FORKLIFT_BIN_DIR) + "/forklift-sim";
const std::string kData = FORKLIFT_DATA_DIR;
const std::string kPaper = kData + "/trucks/simucel_paper.json";

struct SimRun {
  int status;
  std::string out, err;
};
SimRun sim(const std::vector<std::string>& args, const std::string& name) {
  std::vector<std::string> all = {kSim};
  all.insert(all.end(), args.begin(), args.end());
  Process p(all, testing::TempDir() + "/sim_cli_" + name);
  const int status = p.wait(60);
  return {status, p.out(), p.err()};
}

}  // namespace

TEST(SimCli, ValidateTellsAGoodTruckFileFromOneThatCannotHoldOnARamp) {
  const SimRun good = sim({"validate", "--json"}, "validate_good");
  ASSERT_EQ(good.status, 0) << good.err;
  const json g = json::parse(good.out);
  EXPECT_EQ(g["failed"], 0);
  EXPECT_GE(g["checks"].size(), 35u);
  for (const json& c : g["checks"]) EXPECT_TRUE(c["pass"].get<bool>()) << c.dump();

  const SimRun paper = sim({"validate", "--truck", kPaper}, "validate_paper");  // --truck after the command too
  EXPECT_EQ(paper.status, 3);
  EXPECT_NE(paper.out.find("NO    unladen, 15 % grade"), std::string::npos) << paper.out;
  EXPECT_NE(paper.out.find(" failed"), std::string::npos);
}

TEST(SimCli, ValidateFailsATruckFileWhoseCoGIsNotWhereItsPartsPutItAndSaysWhy) {
  // The training truck's file with its chassis' CoG put 0.3 m above where its parts put it.
  std::ifstream in(kData + "/trucks/linde_e16c.json");
  json truck = json::parse(in);
  truck["chassis"]["cog_m"] = {-0.8, 0.0, 0.83};
  const std::string path = testing::TempDir() + "/sim_cli_high_cog.json";
  std::ofstream(path) << truck.dump();
  const SimRun high = sim({"--truck", path, "validate", "--json"}, "validate_high_cog");
  EXPECT_EQ(high.status, 3) << high.err;
  const json h = json::parse(high.out);
  std::vector<std::string> failed;
  for (const json& c : h["checks"])
    if (!c["pass"].get<bool>()) failed.push_back(c["check"].get<std::string>());
  auto failed_one = [&](const std::string& part) {
    return std::any_of(failed.begin(), failed.end(), [&](const std::string& f) { return f.find(part) != std::string::npos; });
  };
  EXPECT_TRUE(failed_one("statics, unladen: CoG height weighed"));
  EXPECT_TRUE(failed_one("ISO 22915-2 test 4 (lateral travelling): tilt angle"));
  EXPECT_TRUE(failed_one("against the stability triangle's g d / h"));
  // Every check says where its bound comes from, in the table too.
  for (const json& c : h["checks"]) EXPECT_FALSE(c["source"].get<std::string>().empty()) << c.dump();
  const SimRun table = sim({"--truck", path, "validate"}, "validate_high_cog_table");
  EXPECT_NE(table.out.find("source: ISO 22915-2"), std::string::npos) << table.out;
}

TEST(SimCli, TiltIsoPrintsTheFourTestsWithTheirMargins) {
  const SimRun r = sim({"tilt", "--iso", "--json"}, "tilt_iso");
  ASSERT_EQ(r.status, 0) << r.err;
  const json j = json::parse(r.out);
  ASSERT_EQ(j["tests"].size(), 4u);
  for (const json& t : j["tests"]) {
    EXPECT_NEAR(t["margin_deg"].get<double>(), t["critical_angle_deg"].get<double>() - t["required_deg"].get<double>(), 1e-9);
    EXPECT_TRUE(t["pass"].get<bool>()) << t.dump();
  }
  EXPECT_EQ(j["tests"][3]["load_kg"], 0);  // lateral travelling is unladen
}

TEST(SimCli, StaticSettlesOnARampOnlyWithBrakesThatHold) {
  const SimRun r = sim({"static", "--grade", "10", "--json"}, "static_grade");
  ASSERT_EQ(r.status, 0) << r.err;
  const json j = json::parse(r.out);
  EXPECT_TRUE(j["settled"].get<bool>());
  EXPECT_LT(j["drift_m"].get<double>(), 1e-3);
  const SimRun paper = sim({"--truck", kPaper, "static", "--grade", "10", "--json"}, "static_paper");
  EXPECT_EQ(paper.status, 3);
  EXPECT_NE(paper.err.find("does not come to rest on this grade"), std::string::npos) << paper.err;
  EXPECT_FALSE(json::parse(paper.out)["settled"].get<bool>());
}

TEST(SimCli, ManoeuvresRunOnThePaperTruckAndReportBothStopThresholds) {
  const SimRun r = sim({"manoeuvre", "5", "--json"}, "manoeuvre5");
  ASSERT_EQ(r.status, 0) << r.err;
  const json stop = json::parse(r.out)["stop_time_s"];
  EXPECT_NEAR(stop["below_0.1_m_s"].get<double>(), 2.0, 0.3);  // the paper's 2 s, on its truck
  EXPECT_GT(stop["below_0.05_m_s"].get<double>(), stop["below_0.1_m_s"].get<double>());
}

// FCL and assimp are modules loaded on first use (forklift/module/module.h), so that the model's
// commands do not pay their loading: ld.so's trace of the files a run loads shows which it did.
TEST(SimCli, TheModelsCommandsLoadNeitherFclNorAssimp) {
  auto libraries_loaded = [](const std::vector<std::string>& args, const std::string& name) {
    std::string command = "LD_DEBUG=files exec '" + kSim + "'";
    for (const std::string& a : args) command += " '" + a + "'";
    Process p({"/bin/sh", "-c", command}, testing::TempDir() + "/sim_cli_" + name);
    EXPECT_EQ(p.wait(60), 0) << p.err();
    return p.err();  // "file=libfcl.so.0.7 [0];  needed by ..." for each library
  };
  const std::string manoeuvre = libraries_loaded({"manoeuvre", "4"}, "libs_manoeuvre");
  EXPECT_NE(manoeuvre.find("file=libsundials_cvode"), std::string::npos) << manoeuvre;  // the trace is there
  EXPECT_EQ(manoeuvre.find("libfcl"), std::string::npos) << manoeuvre;
  EXPECT_EQ(manoeuvre.find("libassimp"), std::string::npos) << manoeuvre;
  // Writing meshes loads assimp, through its module.
  const std::string out = testing::TempDir() + "/sim_cli_libs_meshes_out";
  const std::string meshes = libraries_loaded({"meshes", "--out", out}, "libs_meshes");
  EXPECT_NE(meshes.find("file=libassimp"), std::string::npos) << meshes;
  EXPECT_NE(meshes.find("libforklift_mesh_module.so"), std::string::npos) << meshes;
  EXPECT_TRUE(std::filesystem::exists(out + "/rack.obj"));
  // Without its module, a command that needs assimp says so, and fails as on bad data.
  Process missing({"/bin/sh", "-c", "FORKLIFT_MESH_MODULE=/nonexistent/mesh.so exec '" + kSim + "' meshes --out '" + out + "'"},
                  testing::TempDir() + "/sim_cli_libs_missing");
  EXPECT_EQ(missing.wait(60), 2);
  EXPECT_NE(missing.err().find("cannot read or write mesh files: cannot load /nonexistent/mesh.so"), std::string::npos)
      << missing.err();
}

TEST(SimCli, BadUsageIsRefusedWithStatusTwo) {
  EXPECT_EQ(sim({"static", "--grade", "80"}, "grade_range").status, 2);
  EXPECT_EQ(sim({"--truck", "/nonexistent.json", "validate"}, "no_truck").status, 2);
  const SimRun meshes = sim({"meshes", "--out", testing::TempDir() + "/m", "--truck", kData + "/scenarios/slalom.json"},
                            "meshes_not_a_truck");
  EXPECT_EQ(meshes.status, 2);
  EXPECT_NE(meshes.err.find("'shape' is missing"), std::string::npos) << meshes.err;
}

// The truck's meshes are built from its file at load time; `meshes --truck` exports them.
TEST(SimCli, MeshesExportsTheTrucksMeshesBuiltFromItsFile) {
  const std::string out = testing::TempDir() + "/meshes_export";
  const SimRun r = sim({"meshes", "--out", out, "--truck", kPaper, "--json"}, "meshes_truck");
  ASSERT_EQ(r.status, 0) << r.err;
  const json files = json::parse(r.out)["meshes"];
  for (const char* f : {"rack.obj", "truck_chassis.obj", "truck_mast.obj", "truck_carriage.obj", "truck_wheel_front.obj",
                        "truck_wheel_rear.obj"}) {
    EXPECT_NE(std::find(files.begin(), files.end(), f), files.end()) << f << " not in " << files.dump();
    EXPECT_TRUE(std::filesystem::is_regular_file(out + "/" + f)) << f;
  }
  // Without --truck: the warehouse's meshes alone, as data/meshes/ holds them.
  const SimRun plain = sim({"meshes", "--out", out + "_plain"}, "meshes_plain");
  ASSERT_EQ(plain.status, 0) << plain.err;
  EXPECT_FALSE(std::filesystem::exists(out + "_plain/truck_chassis.obj"));
}

// Each model command speaks to a person by default: words and units, no JSON, no hex float, no
// null, no key such as front_left or stop_time_s; the same run with --json is JSON.
TEST(SimCli, TheModelCommandsPrintWordsAndJsonOnlyWhenAsked) {
  const std::string out = testing::TempDir() + "/sim_cli_words_meshes";
  const std::vector<std::vector<std::string>> commands = {
      {"manoeuvre", "14"}, {"static", "--grade", "10"}, {"static", "--load-mass", "500", "--load-height", "1"},
      {"tilt", "--iso"}, {"tilt", "--axis", "lateral", "--load-mass", "500", "--load-height", "2"}, {"meshes", "--out", out}};
  int n = 0;
  for (const std::vector<std::string>& args : commands) {
    const SimRun r = sim(args, "words_" + std::to_string(++n));
    SCOPED_TRACE(args[0] + ":\n" + r.out);
    ASSERT_EQ(r.status, 0) << r.err;
    for (const char* bad : {"{", "}", "0x", "\"", "null", "nan"}) EXPECT_EQ(r.out.find(bad), std::string::npos) << "has " << bad;
    std::string text = r.out;  // the folder and the mesh files' names are files, not codes
    for (size_t at; (at = text.find(out)) != std::string::npos;) text.erase(at, out.size());
    text = std::regex_replace(text, std::regex("[a-z_]+\\.obj"), "");
    std::smatch code;
    EXPECT_FALSE(std::regex_search(text, code, std::regex("\\b[a-z]+_[a-z_]+\\b"))) << "has the code " << code.str();
    EXPECT_EQ(text.find("-0.0"), std::string::npos) << "a negative zero";
    std::vector<std::string> with_json = args;
    with_json.push_back("--json");
    EXPECT_NO_THROW((void)json::parse(sim(with_json, "words_json_" + std::to_string(n)).out));
  }
  EXPECT_NE(sim({"manoeuvre", "5"}, "words_stop").out.find("below 0.1 m/s after 2."), std::string::npos);
}
