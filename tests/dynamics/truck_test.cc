#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "forklift/dynamics/stability.h"
#include "test_truck.h"

using namespace forklift;

namespace {

std::string write_variant(const std::string& name, const std::function<void(nlohmann::json&)>& edit) {
  return shipped_truck_variant(name, edit);
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

TEST(Truck, ShippedFilesGiveTheClassGeometryAndAxleLoads) {
  for (const TruckParams* t : {&shipped_truck(), &paper_truck()}) {
    SCOPED_TRACE(t->name);
    EXPECT_NEAR(t->wheelbase_m(), 1.25, 1e-12);
    EXPECT_NEAR(t->front_track_m(), 0.90, 1e-12);
    // Positions are converted to the chassis frame: the chassis CoG is its origin.
    EXPECT_NEAR(t->wheels[kFrontLeft].centre_m.x(), -t->chassis_cog_geometry_m.x(), 1e-12);
    // Unladen axle loads within the class's data sheets (about 1.5 t front, 1.6-1.7 t rear).
    const StaticReport r = static_report(*t, std::nullopt, 0);
    const double front_kg = (r.fz_N[kFrontLeft] + r.fz_N[kFrontRight]) / kGravity_m_s2, rear_kg = r.fz_N[kRear] / kGravity_m_s2;
    EXPECT_GT(front_kg, 1400);
    EXPECT_LT(front_kg, 1750);
    EXPECT_GT(rear_kg, 1450);
    EXPECT_LT(rear_kg, 1800);
  }
  const TruckParams& p = paper_truck();  // section 9
  EXPECT_EQ(p.contact.tyre, TyreModel::kPaper);
  EXPECT_DOUBLE_EQ(p.contact.stiffness_N_m, 1.2e6);
  EXPECT_DOUBLE_EQ(p.contact.fx_max_N, 4500);
  EXPECT_DOUBLE_EQ(p.contact.fy_mu, 0.1);
  EXPECT_NEAR(p.contact.fy_alpha0_rad, 7.5 * M_PI / 180, 1e-15);
  EXPECT_EQ(shipped_truck().contact.tyre, TyreModel::kGripPeak);
  EXPECT_DOUBLE_EQ(shipped_truck().contact.mu_static, 0.9);  // the peak
  EXPECT_DOUBLE_EQ(shipped_truck().contact.mu_sliding, 0.75);
  EXPECT_EQ(brush_truck().contact.tyre, TyreModel::kBristle);
  EXPECT_DOUBLE_EQ(brush_truck().contact.mu_static, 0.75);
  EXPECT_DOUBLE_EQ(brush_truck().contact.mu_sliding, 0.7);
}

TEST(Truck, MissingKeyIsNamed) {
  std::string p = write_variant("missing", [](nlohmann::json& j) { with_brush_tyres(j); j["ground_contact"].erase("mu_static"); });
  EXPECT_NE(load_error(p).find("ground_contact.mu_static' is missing"), std::string::npos) << load_error(p);
  p = write_variant("missing_peak", [](nlohmann::json& j) { j["ground_contact"].erase("mu_peak"); });
  EXPECT_NE(load_error(p).find("ground_contact.mu_peak' is missing"), std::string::npos) << load_error(p);
  p = write_variant("tyre", [](nlohmann::json& j) { j["ground_contact"]["tyre_model"] = "magic"; });
  EXPECT_NE(load_error(p).find("tyre_model"), std::string::npos) << load_error(p);
  p = write_variant("point", [](nlohmann::json& j) { j["body_ground_contact"]["points"]["x"] = {{"body", "wheel"}, {"at_m", {0, 0, 0}}}; });
  EXPECT_NE(load_error(p).find("must be chassis, mast or carriage"), std::string::npos) << load_error(p);
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
  // A grip that rises again after its peak, or a sliding grip above the peak, is no tyre.
  EXPECT_NE(load_error(write_variant("slip", [](nlohmann::json& j) { j["ground_contact"]["slip_sliding"] = 0.1; }))
                .find("slip_sliding' must exceed slip_peak"),
            std::string::npos);
  EXPECT_NE(load_error(write_variant("grip", [](nlohmann::json& j) { j["ground_contact"]["mu_sliding"] = 1.0; }))
                .find("mu_sliding' must not exceed mu_peak"),
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
