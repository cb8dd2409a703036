// What the worker publishes of a session: the truck's state for the cab's head-up display, and
// the session's score, as the IDL's samples. No DDS entity: the tests build them in-process.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "forklift/protocol/protocol.h"
#include "forklift/session/session_run.h"

namespace forklift::worker {

// The truck's state after the run's last tick: pose, speed, wheel loads, the head-up display's
// figures (fork height, speed limit, stability, task step, time left; in training, lining up with
// the pallet the task's step is about, or where it is, else with the nearest pallet ahead), the
// cab's sample applied and the dead man. `time_limit_s` <= 0: no limit; `aids`:
// the training aids granted (aids::Bit).
fk_TruckState truck_state(const SessionRun& run, const std::string& cab, const std::string& session, double time_limit_s,
                          uint8_t aids);

// The session's mark as the Score sample: its fault counts (at most the IDL's 64) point into
// `counts`, which must outlive the sample.
fk_Score score_sample(const std::string& session, const Score& score, std::vector<fk_FaultCount>& counts);

// What moves in the scene after the run's last tick, for a cab that draws its own picture: the
// truck's coordinates, every pallet's pose (at most the IDL's 1,024) and each pedestrian's place
// (at most 64). The sample's sequences point into `pallets` and `people`, which must outlive it.
fk_SceneMotion scene_motion(const SessionState& state, const std::string& cab, std::vector<fk_PalletPose>& pallets,
                            std::vector<fk_PedestrianPose>& people);

}  // namespace forklift::worker
