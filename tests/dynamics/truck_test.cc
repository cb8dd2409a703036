#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "test_truck.h"

using namespace forklift;

namespace {

std::string write_variant(const std::string& name, const std::function<void(nlohmann::json&)>& edit) {
  std::ifstream in(std::string(FORKLIFT_DATA_DIR) + "/trucks/linde_e16c.json");
  nlohmann::json j = nlohmann::json::parse(in);
  edit(j);
  const std::string path = testing::TempDir() + "/" + name + ".json";
  std::ofstream(path) << j.dump();
  return path;
}

std::string load_error(const std::string& path) {
  try {
    load_truck(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Truck, ShippedFileGivesTheClassGeometryAndMass) {
  const TruckParams& t = shipped_truck();
  double mass = t.chassis.mass_kg + t.mast.mass_kg + t.carriage.mass_kg;
  for (const WheelParams& w : t.wheels) mass += w.mass_kg;
  EXPECT_NEAR(mass, 3200.0, 1e-9);
  EXPECT_NEAR(t.wheelbase_m(), 1.25, 1e-12);
  EXPECT_NEAR(t.front_track_m(), 0.90, 1e-12);
  EXPECT_DOUBLE_EQ(t.contact.stiffness_N_m, 1.2e6);  // section 9
  EXPECT_DOUBLE_EQ(t.contact.fx_max_N, 4500);
  EXPECT_NEAR(t.contact.fy_alpha0_rad, 7.5 * M_PI / 180, 1e-15);
  // Positions are converted to the chassis frame: the chassis CoG is its origin.
  EXPECT_NEAR(t.wheels[kFrontLeft].centre_m.x(), 0.75, 1e-12);
}

TEST(Truck, MissingKeyIsNamed) {
  const std::string p = write_variant("missing", [](nlohmann::json& j) { j["ground_contact"].erase("fx_max_N"); });
  EXPECT_NE(load_error(p).find("ground_contact.fx_max_N' is missing"), std::string::npos) << load_error(p);
}

TEST(Truck, ImpossibleValuesAreRefused) {
  EXPECT_NE(load_error(write_variant("neg", [](nlohmann::json& j) { j["mast"]["mass_kg"] = -5; })).find("must be positive"),
            std::string::npos);
  EXPECT_NE(load_error(write_variant("inertia", [](nlohmann::json& j) { j["chassis"]["inertia_kg_m2"]["xy"] = 5000; }))
                .find("not positive definite"),
            std::string::npos);
  EXPECT_NE(load_error(write_variant("type", [](nlohmann::json& j) { j["wheels"]["rear"]["radius_m"] = "big"; }))
                .find("is not a number"),
            std::string::npos);
  EXPECT_NE(load_error(write_variant("heavy", [](nlohmann::json& j) { j["service_mass_kg"] = 300; })).find("less than"),
            std::string::npos);
}

TEST(Truck, BrokenFilesAreRefused) {
  const std::string p = testing::TempDir() + "/broken.json";
  std::ofstream(p) << "{ \"name\": ";
  EXPECT_NE(load_error(p).find("not valid JSON"), std::string::npos);
  EXPECT_NE(load_error("/nonexistent/truck.json").find("cannot open"), std::string::npos);
}

TEST(Truck, BoxLoadInertiaIsThatOfAUniformBox) {
  const Load l = box_load(1200, 1.2, 0.8, 1.0, 0.5, 0.1);
  EXPECT_NEAR(l.inertia_kg_m2(0, 0), 100 * (0.64 + 1.0), 1e-9);
  EXPECT_NEAR(l.inertia_kg_m2(2, 2), 100 * (1.44 + 0.64), 1e-9);
  EXPECT_EQ(l.cog_m, Eigen::Vector3d(0.5, 0.1, 0.5));
}
