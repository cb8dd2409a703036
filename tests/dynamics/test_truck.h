// Shared fixture data for the dynamics tests: the two shipped trucks.
#pragma once
#include <string>
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
