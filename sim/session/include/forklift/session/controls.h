// The cab's controls onto the truck: refusing what must not reach the integrator, scaling the
// normalised commands onto the truck's limits, and the dead-man response.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "forklift/dynamics/dynamics.h"
#include "forklift/scene/scene.h"  // kLookYawMaxRad, kLookPitchMaxRad

namespace forklift {

// One cab control sample, as received (protocol's fk_Controls without the strings).
struct ControlSample {
  uint32_t seq = 0;
  double steer_rad = 0, accelerator = 0, brake = 0, lift = 0, tilt = 0, side_shift = 0;
  bool horn = false;
  bool parking_brake = false;
  // What the cab's window shows (the renderer's business, never the integrator's).
  bool frames_wanted = false;
  int camera = 0;                 // 0 the driver's eye, 1 the chase camera
  double look_yaw_rad = 0;        // + left, within +-kLookYawMaxRad (scene.h)
  double look_pitch_rad = 0;      // + up, within +-kLookPitchMaxRad
  bool rear_view = false;
  bool see_through_mast = false;
};


// Why a sample must not reach the integrator, or nullopt if it is fine: a non-finite value or
// one outside its documented range (protocol/idl/Forklift.idl), the look angles and the camera
// (0 or 1) included.
std::optional<std::string> control_problem(const ControlSample& c, const TruckParams& truck);

// Normalised cab commands onto the truck's limits.
DriverInputs driver_inputs(const ControlSample& c, const TruckParams& truck);

// The dead-man response: no drive, full brake, levers still, steer held.
DriverInputs deadman_inputs(const DriverInputs& last, const TruckParams& truck);

}  // namespace forklift
