// The cab's controls onto the truck: refusing what must not reach the integrator, scaling the
// normalised commands onto the truck's limits, and the dead-man response.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "forklift/dynamics/dynamics.h"
#include "forklift/scene/scene.h"  // kLookYawMaxRad, kLookPitchMaxRad

namespace forklift {

// One cab control sample, as received (protocol's fk_Controls without the strings), its steer
// already scaled onto the truck (steer_from_fraction).
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
  // A scripted cab's row time (sim s): applied from the first tick at or after it; 0: at once.
  double apply_at_sim_s = 0;
  bool fork_camera = false;  // what the window shows, as rear_view
};


// The first tick at or after sim time `t_s`: where a script row, a scheduled sample
// (apply_at_sim_s) or an end time lands. One rule for the worker and the offline model, so that a
// scripted drive is the same drive in both (1e-6 of a tick absorbs t_s's rounding).
int64_t first_tick_at(double t_s, double tick_s);

// Why a sample must not reach the integrator, or nullopt if it is fine: a non-finite value or
// one outside its documented range (protocol/idl/Forklift.idl), the look angles and the camera
// (0 or 1) included.
std::optional<std::string> control_problem(const ControlSample& c, const TruckParams& truck);

// The wire's steer, a fraction of the truck's end stops (fk_Controls.steer, + points the rear wheel
// left), as the rear wheel's angle on this truck: the one place a cab's wheel meets a truck's stops.
inline double steer_from_fraction(double fraction, const TruckParams& truck) { return fraction * truck.steer.max_rad; }

// Normalised cab commands onto the truck's limits.
DriverInputs driver_inputs(const ControlSample& c, const TruckParams& truck);

// The dead-man response: no drive, full brake, levers still, steer held.
DriverInputs deadman_inputs(const DriverInputs& last, const TruckParams& truck);

// The same inputs bit for bit (-0.0 is not 0.0): a sample that asks for no change need not be
// logged, since a replay that holds the logged inputs then applies exactly what the worker did.
bool identical(const DriverInputs& a, const DriverInputs& b);

// The order of one cab's samples (fk_Controls.seq rises by one per sample a cab program sends).
// A sample is judged against the newest one accepted:
//  - newer (a higher seq): accepted; a jump over missing numbers is counted (samples are lost on
//    the wire, and a reader drops those it had no time to take when more than its history of 256
//    wait), never refused;
//  - not newer (the same seq: a duplicate; a lower one: old, a replay): refused and counted,
//  - unless the cab has been silent for at least `restart_after_s` (the dead-man interval: the
//    truck has been stopped for its silence): then it is the first sample of a restarted cab
//    program, accepted, and counted as a restart. A cab is never locked out for good, and a
//    stale sample never moves a truck whose cab is speaking.
// The first sample is accepted whatever its seq. Only the seqs of good samples (control_problem
// says nothing, the cab is this one) are judged.
class ControlSequence {
 public:
  enum class Verdict { kAccepted, kJump, kRestart, kDuplicate, kOld };
  struct Counts {
    long accepted = 0;   // samples accepted (jumps and restarts included)
    long jumps = 0;      // accepted with a higher seq than the next one expected
    long skipped = 0;    // the seq numbers those jumps passed over
    long restarts = 0;   // accepted, not newer, after restart_after_s of silence
    long duplicate = 0;  // refused: the newest accepted seq again
    long old = 0;        // refused: a lower seq
  };
  explicit ControlSequence(double restart_after_s) : restart_after_s_(restart_after_s) {}
  // Judges `seq`, `silence_s` after the newest accepted sample arrived, and counts the verdict.
  Verdict judge(uint32_t seq, double silence_s);
  static bool accepted(Verdict v) { return v != Verdict::kDuplicate && v != Verdict::kOld; }
  const Counts& counts() const { return counts_; }
  uint32_t newest() const { return newest_; }  // the newest accepted seq (0 before the first)

 private:
  double restart_after_s_;
  bool any_ = false;
  uint32_t newest_ = 0;
  Counts counts_;
};

// When the worker sends TruckState, whatever the cab sends. Sim time is cut into state periods
// (1/rate) and each period has one state: at the end of the period, or earlier, right after the
// tick that applied a change of the cab's inputs (so the cab sees its command's effect within a
// tick); the early state takes the period's place. A second change within one period may have
// its state early too, from an allowance of kExtraPerS per second of sim time (kExtraBurst saved
// up at most): enough for a key let go just after a lever sample, too little for a flood to
// matter. So any second of sim time holds at most max_per_s(rate) states, at any control rate
// (and the worker sends one more when the session ends).
class StatePacer {
 public:
  static constexpr double kExtraPerS = 10, kExtraBurst = 3;
  static double max_per_s(double rate_hz) { return rate_hz + 1 + kExtraPerS + kExtraBurst; }
  explicit StatePacer(double rate_hz) : period_s_(1.0 / rate_hz) {}
  // After each tick, ending at sim time t: whether a state period ends with it and, if so,
  // whether its state went out early or is owed (it goes now). The next period starts.
  enum class PeriodEnd { kNotYet, kStateSent, kStateOwed };
  PeriodEnd period_ends(double t);
  // After a tick ending at t that applied a change of inputs no state has shown yet: true if its
  // state may go out now.
  bool early(double t);
  // The session's time went back to t (the instructor's rewind): periods start again from there.
  void restart(double t);
  // Sim time at which the current period ends: the next state owed (a loop may sleep till then).
  double period_end_s() const { return period_end_s_; }

 private:
  void refill(double t);
  double period_s_, period_end_s_ = 0, extra_ = kExtraBurst, t_s_ = 0;
  bool sent_ = false;  // the current period has had its state
};

}  // namespace forklift
