// `forklift-sim validate`: every closed-form and ISO 22915 check that a truck file must pass
// before pupils drive it, each a measurement on the model (statics, tilt table, cornering, brakes
// on a grade, stopping, coasting, top speed, tip-over) against a number from outside the model:
// a standard, a data sheet, or a closed form computed apart from the model's code (the truck
// weighed from its parts' masses by moments about the axles).
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
  std::string source;    // where the bound comes from: a standard, a data sheet, physics
  bool pass = false;
};

// The numbers from outside the truck file that the checks measure against, each with its source
// (data/validation/).
struct ValidationReferences {
  double top_speed_m_s = 0, top_speed_tolerance_m_s = 0;
  std::string top_speed_source;
  double rolling_resistance_min = 0, rolling_resistance_max = 0;
  std::string rolling_resistance_source;
};
// Reads a references file; throws std::runtime_error naming the file and the key it lacks.
ValidationReferences load_validation_references(const std::string& path);

// Runs every check on `truck` (a few seconds of simulated driving each; about a second of CPU
// in all). Throws std::runtime_error if the truck cannot even stand still on level ground.
std::vector<ValidationCheck> validate_truck(const TruckParams& truck, const ValidationReferences& references);

}  // namespace forklift
