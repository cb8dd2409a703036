#include "forklift/session/controls.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>

namespace forklift {

std::optional<std::string> control_problem(const ControlSample& c, const TruckParams& truck) {
  struct Field { const char* name; double value, lo, hi; };
  const double stop = truck.steer.max_rad;  // the truck file's end stops
  const Field fields[] = {{"steer_rad", c.steer_rad, -stop, stop},  {"accelerator", c.accelerator, -1, 1},
                          {"brake", c.brake, 0, 1},               {"lift", c.lift, -1, 1},
                          {"tilt", c.tilt, -1, 1},                {"side_shift", c.side_shift, -1, 1},
                          {"look_yaw_rad", c.look_yaw_rad, -kLookYawMaxRad, kLookYawMaxRad},
                          {"look_pitch_rad", c.look_pitch_rad, -kLookPitchMaxRad, kLookPitchMaxRad}};
  for (const Field& f : fields) {
    if (!std::isfinite(f.value)) return std::string(f.name) + " is not finite";
    if (f.value < f.lo || f.value > f.hi) {
      std::ostringstream s;
      s << f.name << " = " << f.value << " is outside [" << f.lo << ", " << f.hi << "]";
      return s.str();
    }
  }
  if (!std::isfinite(c.apply_at_sim_s)) return std::string("apply_at_sim_s is not finite");
  if (c.apply_at_sim_s < 0) return "apply_at_sim_s = " + std::to_string(c.apply_at_sim_s) + " is before the session's start";
  if (c.camera != 0 && c.camera != 1) return "camera = " + std::to_string(c.camera) + " is neither 0 (driver) nor 1 (chase)";
  return std::nullopt;
}

int64_t first_tick_at(double t_s, double tick_s) { return static_cast<int64_t>(std::ceil(t_s / tick_s - 1e-6)); }

DriverInputs driver_inputs(const ControlSample& c, const TruckParams& t) {
  DriverInputs u;
  u.drive_torque_N_m = c.accelerator * t.drive.drive_torque_max_N_m;
  u.brake_torque_N_m = c.brake * t.drive.brake_torque_max_N_m;
  u.steer_rad = c.steer_rad;
  u.lift_rate_m_s = c.lift * t.limits.lift_rate_max_m_s;
  u.tilt_rate_rad_s = c.tilt * t.limits.tilt_rate_max_rad_s;
  u.shift_rate_m_s = c.side_shift * t.limits.side_shift_rate_max_m_s;
  u.parking_brake = c.parking_brake;
  u.horn = c.horn;
  return u;
}

DriverInputs deadman_inputs(const DriverInputs& last, const TruckParams& t) {
  DriverInputs u;
  u.steer_rad = last.steer_rad;
  u.brake_torque_N_m = t.drive.brake_torque_max_N_m;
  return u;
}

bool identical(const DriverInputs& a, const DriverInputs& b) {
  auto same = [](double x, double y) { return std::memcmp(&x, &y, sizeof x) == 0; };
  return same(a.drive_torque_N_m, b.drive_torque_N_m) && same(a.brake_torque_N_m, b.brake_torque_N_m) &&
         same(a.steer_rad, b.steer_rad) && same(a.tilt_rate_rad_s, b.tilt_rate_rad_s) &&
         same(a.lift_rate_m_s, b.lift_rate_m_s) && same(a.shift_rate_m_s, b.shift_rate_m_s) &&
         a.parking_brake == b.parking_brake && a.horn == b.horn;
}

ControlSequence::Verdict ControlSequence::judge(uint32_t seq, double silence_s) {
  Verdict v = Verdict::kAccepted;
  if (any_ && seq <= newest_) {
    if (silence_s < restart_after_s_) {
      ++(seq == newest_ ? counts_.duplicate : counts_.old);
      return seq == newest_ ? Verdict::kDuplicate : Verdict::kOld;
    }
    v = Verdict::kRestart;
    ++counts_.restarts;
  } else if (any_ && seq - newest_ > 1) {
    v = Verdict::kJump;
    ++counts_.jumps;
    counts_.skipped += seq - newest_ - 1;
  }
  any_ = true;
  newest_ = seq;
  ++counts_.accepted;
  return v;
}

void StatePacer::refill(double t) {
  extra_ = std::min(kExtraBurst, extra_ + (t - t_s_) * kExtraPerS);
  t_s_ = t;
}

StatePacer::PeriodEnd StatePacer::period_ends(double t) {
  refill(t);
  if (t + 1e-12 < period_end_s_) return PeriodEnd::kNotYet;
  const PeriodEnd end = sent_ ? PeriodEnd::kStateSent : PeriodEnd::kStateOwed;
  sent_ = false;
  period_end_s_ += period_s_;
  return end;
}

void StatePacer::restart(double t) {
  period_end_s_ = (std::floor(t / period_s_ + 1e-9) + 1) * period_s_;
  t_s_ = t;
  sent_ = false;
}

bool StatePacer::early(double t) {
  refill(t);
  if (!sent_) return sent_ = true;  // the period's state, sent early
  if (extra_ < 1) return false;     // it waits for the next period, which comes within period_s_
  extra_ -= 1;
  return true;
}

}  // namespace forklift
