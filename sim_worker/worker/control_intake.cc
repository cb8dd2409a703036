#include "control_intake.h"

namespace forklift::worker {

ControlSample control_sample(const fk_Controls& c, const TruckParams& truck) {
  ControlSample s;
  s.seq = c.seq;
  s.steer_rad = steer_from_fraction(c.steer, truck);
  s.accelerator = c.accelerator, s.brake = c.brake, s.lift = c.lift, s.tilt = c.tilt, s.side_shift = c.side_shift;
  s.horn = c.horn, s.parking_brake = c.parking_brake;
  s.frames_wanted = c.frames_wanted, s.camera = c.camera, s.look_yaw_rad = c.look_yaw_rad;
  s.look_pitch_rad = c.look_pitch_rad, s.rear_view = c.rear_view, s.see_through_mast = c.see_through_mast;
  s.apply_at_sim_s = c.apply_at_sim_s;
  s.fork_camera = c.fork_camera;
  return s;
}

ControlIntake::ControlIntake(std::string cab, const TruckParams& truck, double tick_s, double deadman_s,
                             std::function<void(const std::string&)> say)
    : cab_(std::move(cab)), truck_(truck), tick_s_(tick_s), say_(std::move(say)), sequence_(deadman_s) {}

void ControlIntake::refuse(long nth_of_its_kind, const std::string& why) const {
  if (nth_of_its_kind <= kRefusalsSaid)
    say_(why + (nth_of_its_kind == kRefusalsSaid ? " (further refusals of this kind are counted, not logged)" : ""));
}

void ControlIntake::offer(const std::string& from_cab, const ControlSample& s, int64_t tick, double t_s,
                          Clock::time_point now) {
  const auto which = [&] { return "rejected control " + std::to_string(s.seq); };
  if (from_cab != cab_) return refuse(++rejected_cab_, which() + " from cab '" + from_cab + "'");
  if (const auto problem = control_problem(s, truck_)) {
    long& count = problem->find("finite") != std::string::npos ? rejected_non_finite_ : rejected_range_;
    return refuse(++count, which() + ": " + *problem);
  }
  const uint32_t newest = sequence_.newest();
  const double silence = silence_s(now);
  switch (sequence_.judge(s.seq, silence)) {
    case ControlSequence::Verdict::kDuplicate:
      return refuse(sequence_.counts().duplicate, which() + ": a duplicate of the newest sample");
    case ControlSequence::Verdict::kOld:
      return refuse(sequence_.counts().old, which() + ": older than the newest sample, " + std::to_string(newest));
    case ControlSequence::Verdict::kRestart:
      say_("control " + std::to_string(s.seq) + " after " + std::to_string(silence) + " s of silence (the newest was " +
           std::to_string(newest) + "): the cab program restarted");
      break;
    default: break;
  }
  if (s.apply_at_sim_s > 0) {
    const int64_t at = first_tick_at(s.apply_at_sim_s, tick_s_);
    if (s.apply_at_sim_s > t_s + kScheduleAheadMaxS)
      return refuse(++rejected_range_, which() + ": scheduled for t = " + std::to_string(s.apply_at_sim_s) +
                                           " s, more than 2 s ahead of the truck's " + std::to_string(t_s) + " s");
    if (at > tick) {
      if (scheduled_.size() >= kScheduledMax && !scheduled_.count(at))
        return refuse(++rejected_range_, which() + ": more than 512 samples scheduled ahead");
      scheduled_[at] = s;
    } else if (at >= last_scheduled_tick_) {
      last_scheduled_tick_ = at;
      pending_ = s;
    }  // else: an older row sent again; it keeps the cab alive and changes nothing
  } else {
    scheduled_.clear();  // a live sample: the newest word wins
    last_scheduled_tick_ = -1;
    pending_ = s;
  }
  last_valid_ = now;
  heard_ = true;
  view_.reset();
  if (s.frames_wanted)
    view_ = ViewRequest{s.camera, s.look_yaw_rad, s.look_pitch_rad, s.see_through_mast, s.rear_view, s.fork_camera};
}

std::optional<ControlSample> ControlIntake::take_pending() {
  std::optional<ControlSample> s = std::move(pending_);
  pending_.reset();
  return s;
}

bool ControlIntake::take_scheduled(int64_t tick) {
  if (scheduled_.empty() || scheduled_.begin()->first > tick) return false;
  while (!scheduled_.empty() && scheduled_.begin()->first <= tick) {
    last_scheduled_tick_ = scheduled_.begin()->first;
    pending_ = scheduled_.begin()->second;
    scheduled_.erase(scheduled_.begin());
  }
  return true;
}

void ControlIntake::rewound() {
  scheduled_.clear();
  last_scheduled_tick_ = -1;
}

void ControlIntake::forget() {
  pending_.reset();
  scheduled_.clear();
  view_.reset();
}

std::vector<std::pair<std::string, long>> ControlIntake::tally() const {
  const ControlSequence::Counts& n = sequence_.counts();
  return {{"accepted", n.accepted},         {"duplicate", n.duplicate},           {"old", n.old},
          {"jumps", n.jumps},               {"skipped", n.skipped},               {"restarts", n.restarts},
          {"non_finite", rejected_non_finite_}, {"out_of_range", rejected_range_}, {"wrong_cab", rejected_cab_}};
}

}  // namespace forklift::worker
