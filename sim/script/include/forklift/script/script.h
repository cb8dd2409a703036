// A timed control script: CSV rows "t, steer, accelerator, brake, lift, tilt, shift[, parking]"
// (seconds, radians, and the normalised commands of protocol/idl/Forklift.idl; parking 0 or 1,
// the parking brake, 0 when the column is absent), optional header line.
#pragma once
#include <string>
#include <vector>

namespace forklift {

struct ScriptRow {
  double t = 0, steer = 0, accelerator = 0, brake = 0, lift = 0, tilt = 0, shift = 0;
  bool parking_brake = false;
};

// Throws std::runtime_error with the file and line number on a malformed row or times that go
// backwards. Values are not range-checked here: the worker is the one that must refuse them.
std::vector<ScriptRow> read_script(const std::string& path);

}  // namespace forklift
