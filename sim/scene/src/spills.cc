#include "forklift/scene/spills.h"

#include "forklift/scene/falling.h"

namespace forklift {

std::vector<SpillState> initial_spills(const std::vector<Spill>& spills) {
  std::vector<SpillState> states(spills.size());
  for (size_t i = 0; i < spills.size(); ++i) states[i].appeared = !spills[i].triggered;
  return states;
}

void spread_spills(const std::vector<Spill>& spills, std::vector<SpillState>& states, const TruckOutline& outline,
                   const BodyPoses& poses, double t_s) {
  for (size_t i = 0; i < spills.size(); ++i) {
    SpillState& s = states[i];
    if (s.appeared) continue;
    const Spill& sp = spills[i];
    if (!trigger_fired(sp.start_truck_within_m, sp.start_at_s, outline, poses, sp.rect.center(), t_s)) continue;
    s.appeared = true;
    s.appeared_t_s = t_s;
  }
}

uint64_t absent_spills(const std::vector<Spill>& spills, const std::vector<SpillState>& states) {
  uint64_t absent = 0;
  for (size_t i = 0; i < spills.size() && i < kMaxTriggeredSpill; ++i)
    if (spills[i].triggered && !(i < states.size() && states[i].appeared)) absent |= uint64_t{1} << i;
  return absent;
}

}  // namespace forklift
