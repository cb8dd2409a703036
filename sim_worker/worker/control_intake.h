// The worker's intake of one cab's control samples: refuse what must not reach the integrator and
// what is not newer than the cab's newest sample (ControlSequence: a restarted cab program is taken
// after the dead-man interval of silence), keep the newest good sample, and a scripted cab's rows
// sent ahead of their time by the tick they apply at. Every refusal is counted; the first few of
// each kind are said (a flood of bad samples cannot fill the worker's log). No DDS: the worker
// hands in each sample it takes, the tests hand in their own.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "forklift/protocol/protocol.h"
#include "forklift/session/controls.h"

namespace forklift::worker {

// A sample as it came off the wire, onto this truck: the wheel's fraction of the end stops becomes
// the truck's angle (steer_from_fraction), before any check, so a fraction beyond 1 is refused as
// an angle beyond the truck's stops.
ControlSample control_sample(const fk_Controls& c, const TruckParams& truck);

class ControlIntake {
 public:
  using Clock = std::chrono::steady_clock;
  // What the cab's newest good sample asks to see (frames_wanted off: nothing).
  struct ViewRequest {
    int camera = 0;
    double look_yaw_rad = 0, look_pitch_rad = 0;
    bool see_through_mast = false, rear_view = false, fork_camera = false;
  };
  static constexpr long kRefusalsSaid = 5;             // of each kind
  static constexpr double kScheduleAheadMaxS = 2.0;    // a row may come this far ahead of the truck
  static constexpr size_t kScheduledMax = 512;

  // `say`: how a refusal or a restart is told (the worker's stderr).
  ControlIntake(std::string cab, const TruckParams& truck, double tick_s, double deadman_s,
                std::function<void(const std::string&)> say);

  // A sample from `from_cab`, arriving at `now` with the truck at `tick` (sim time `t_s`).
  void offer(const std::string& from_cab, const ControlSample& s, int64_t tick, double t_s, Clock::time_point now);

  bool heard() const { return heard_; }                      // a good sample has come
  Clock::time_point last_heard() const { return last_valid_; }
  double silence_s(Clock::time_point now) const { return std::chrono::duration<double>(now - last_valid_).count(); }

  // A scripted cab's rows sent ahead are its word until their time: the sim time of the last one
  // still scheduled (nullopt: none). Until then its silence is no reason for the dead man, so that
  // a cab held up for less than its lead (a loaded machine) drives the truck as the script says.
  std::optional<double> scheduled_until_s() const {
    if (scheduled_.empty()) return std::nullopt;
    return scheduled_.rbegin()->first * tick_s_;
  }

  // The newest good sample not yet applied, if any.
  bool has_pending() const { return pending_.has_value(); }
  std::optional<ControlSample> take_pending();
  // Moves the scheduled rows due at `tick` (the newest of them wins) to the pending sample;
  // returns whether there were any.
  bool take_scheduled(int64_t tick);
  // The dead man stopped the truck: a silent cab's sample, its rows sent ahead and its wish for
  // frames are forgotten.
  void forget();
  // The session went back in time (the instructor's rewind): the rows a scripted cab sent ahead
  // were for the time before it, and are dropped.
  void rewound();

  const std::optional<ViewRequest>& view_request() const { return view_; }
  // The tally of the cab's samples (the log's "controls" line and the worker's summary).
  std::vector<std::pair<std::string, long>> tally() const;
  const ControlSequence::Counts& sequence_counts() const { return sequence_.counts(); }
  long rejected_non_finite() const { return rejected_non_finite_; }
  long rejected_range() const { return rejected_range_; }
  long rejected_cab() const { return rejected_cab_; }

 private:
  void refuse(long nth_of_its_kind, const std::string& why) const;

  std::string cab_;
  const TruckParams& truck_;
  double tick_s_;
  std::function<void(const std::string&)> say_;
  ControlSequence sequence_;
  long rejected_non_finite_ = 0, rejected_range_ = 0, rejected_cab_ = 0;
  std::optional<ControlSample> pending_;
  // A scripted cab's samples sent ahead of their time, by the tick they apply at, and the tick of
  // the last one applied: a sample scheduled before it only keeps the cab alive, so a late resend
  // never undoes a newer row.
  std::map<int64_t, ControlSample> scheduled_;
  int64_t last_scheduled_tick_ = -1;
  Clock::time_point last_valid_{};
  bool heard_ = false;
  std::optional<ViewRequest> view_;
};

}  // namespace forklift::worker
