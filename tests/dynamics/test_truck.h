// Shared fixture data for the dynamics tests: the two shipped trucks.
#pragma once
#include <gtest/gtest.h>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include "forklift/dynamics/load_on_forks.h"
#include "forklift/dynamics/simulation.h"
#include "forklift/dynamics/truck.h"

// The calibrated training truck that pupils drive.
inline const forklift::TruckParams& shipped_truck() {
  static const forklift::TruckParams t = forklift::load_truck(std::string(FORKLIFT_DATA_DIR) + "/trucks/linde_e16c.json");
  return t;
}

// The SIMUCEL paper's truck, with its force laws, for section 11's manoeuvres.
inline const forklift::TruckParams& paper_truck() {
  static const forklift::TruckParams t = forklift::load_truck(std::string(FORKLIFT_DATA_DIR) + "/trucks/simucel_paper.json");
  return t;
}

// The truck data file `file` (under data/trucks/) with `edit` applied, written where the test may
// write; its path.
inline std::string truck_variant(const std::string& file, const std::string& name,
                                 const std::function<void(nlohmann::json&)>& edit) {
  std::ifstream in(std::string(FORKLIFT_DATA_DIR) + "/trucks/" + file);
  nlohmann::json j = nlohmann::json::parse(in);
  edit(j);
  const std::string path = testing::TempDir() + "/" + name + ".json";
  std::ofstream(path) << j.dump();
  return path;
}
inline std::string shipped_truck_variant(const std::string& name, const std::function<void(nlohmann::json&)>& edit) {
  return truck_variant("linde_e16c.json", name, edit);
}

// The training truck on the brush tyre without a grip peak, its tyre before the peak:
// data/tyres/linde_e16c_brush.json's ground_contact merged over its own (a JSON merge patch).
inline void with_brush_tyres(nlohmann::json& truck) {
  std::ifstream in(std::string(FORKLIFT_DATA_DIR) + "/tyres/linde_e16c_brush.json");
  truck["ground_contact"].merge_patch(nlohmann::json::parse(in)["ground_contact"]);
}
inline const forklift::TruckParams& brush_truck() {
  static const forklift::TruckParams t = forklift::load_truck(shipped_truck_variant("brush", with_brush_tyres));
  return t;
}

// What a sliding load adds to the truck model's energy: the model holds it where it was last
// attached, moving with the carriage, while it is further along the forks and moving along them.
inline double sliding_load_energy(const forklift::Simulation& sim) {
  const forklift::TruckDynamics& dyn = sim.dynamics();
  const forklift::LoadOnForks& l = sim.load_on_forks();
  if (l.phase != forklift::LoadPhase::kSliding || !sim.load() || !dyn.load()) return 0;
  const forklift::Outputs o = sim.outputs();
  const Eigen::Vector3d held = dyn.load()->cog_m;
  const Eigen::Vector3d cog = sim.load()->cog_m + l.slide_m * Eigen::Vector3d::UnitX();
  const Eigen::Vector3d v_held = o.carriage.velocity_at(held);
  const Eigen::Vector3d v = o.carriage.velocity_at(cog) + l.slide_rate_m_s * o.carriage.R.col(0);
  const Eigen::Vector3d g = dyn.environment().gravity_m_s2;
  return sim.load()->mass_kg * (0.5 * (v.squaredNorm() - v_held.squaredNorm()) - g.dot(o.carriage.R * (cog - held)));
}
