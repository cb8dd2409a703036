// A timed control script: CSV rows "t, steer, accelerator, brake, lift, tilt, shift[, parking[, horn]]"
// (seconds, radians, and the normalised commands of protocol/idl/Forklift.idl; parking 0 or 1,
// the parking brake, and horn 0 or 1, sounding, each 0 when its column is absent), optional header line.
#pragma once
#include <string>
#include <vector>

namespace forklift {

struct ScriptRow {
  double t = 0, steer = 0, accelerator = 0, brake = 0, lift = 0, tilt = 0, shift = 0;
  bool parking_brake = false;
  bool horn = false;
};

// A row's steer is the rear wheel's angle; on the wire (fk_Controls.steer) it goes as a fraction of
// the truck's end stops, which the worker scales back by its truck file (steer_from_fraction in
// forklift/session/controls.h). A scripted cab sends this; the offline model passes a row through it
// too, so that a scripted drive is the same drive live and offline, bit for bit.
inline double steer_fraction(double steer_rad, double lock_rad) { return steer_rad / lock_rad; }

// Throws std::runtime_error with the file and line number on a malformed row or times that go
// backwards. Values are not range-checked here: the worker is the one that must refuse them.
std::vector<ScriptRow> read_script(const std::string& path);

}  // namespace forklift
