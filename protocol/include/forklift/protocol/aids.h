// The training aids a session may allow a cab (never an exam's): their bits in
// TruckState.aids and their names in forklift-worker --aids and the API's "aids" list.
#pragma once

#include <cstdint>
#include <string_view>

namespace forklift::aids {

enum Bit : uint8_t { kRearView = 1, kSeeThroughMast = 2, kChaseCamera = 4, kForkCamera = 8 };
inline constexpr uint8_t kAll = kRearView | kSeeThroughMast | kChaseCamera | kForkCamera;

struct Named {
  const char* name;
  Bit bit;
};
inline constexpr Named kNamed[] = {
    {"rear_view", kRearView}, {"see_through_mast", kSeeThroughMast}, {"chase_camera", kChaseCamera}, {"fork_camera", kForkCamera}};
// For messages: the names a list may hold.
inline constexpr const char* kNameList = "rear_view, see_through_mast, chase_camera, fork_camera";

// The aid's bit, or 0 for a name that is no aid.
inline uint8_t bit_of(std::string_view name) {
  for (const Named& n : kNamed)
    if (name == n.name) return n.bit;
  return 0;
}

}  // namespace forklift::aids
