// `forklift-sim validate`: every closed-form and ISO 22915 check that a truck file must pass
// before pupils drive it, each run on the model itself (statics, tilt table, cornering, brakes
// on a grade, stopping, coasting, top speed, steering rate, tip-over).
#pragma once

#include <string>
#include <vector>

#include "forklift/dynamics/truck.h"

namespace forklift {

struct ValidationCheck {
  std::string name;      // what is checked, in words
  double measured = 0;   // in `unit`
  std::string unit;
  std::string required;  // the bound, in words and the same unit
  bool pass = false;
};

// Runs every check on `truck` (a few seconds of simulated driving each; about a second of CPU
// in all). Throws std::runtime_error if the truck cannot even stand still on level ground.
std::vector<ValidationCheck> validate_truck(const TruckParams& truck);

}  // namespace forklift
