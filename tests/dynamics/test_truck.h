// Shared fixture data for the dynamics tests: the shipped truck.
#pragma once
#include <string>
#include "forklift/truck.h"

inline const forklift::TruckParams& shipped_truck() {
  static const forklift::TruckParams t = forklift::load_truck(std::string(FORKLIFT_DATA_DIR) + "/trucks/linde_e16c.json");
  return t;
}
