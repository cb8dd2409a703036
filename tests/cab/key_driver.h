// A pupil's fingers on the cab's keyboard, for tests: a closed-loop driver that reads only what a
// cab receives in TruckState (pose, speed, the rear wheel's angle on the dial, the forks' lift,
// tilt and side-shift, whether a load is on the forks, the task's step) and answers with keys,
// held or tapped, as X keysym names ("Up", "Left", "w"). The same driver types into a real cab's
// window under Xvfb (key_drive_test.cc) and into CabInput in-process (keyboard_test.cc), where the
// steering law can be the one the cab had before (the wheel springing back when let go).
//
// What it knows besides TruckState is what a pupil sees and is told: where the pallet to take
// stands and from which side its openings face, and the truck's build (the fork tips 2.15 m
// ahead of the start point, the front axle 0.75 m, a 1.25 m wheelbase; the Linde E16c's file).
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace key_driver {

using Eigen::Vector2d;

// What the driver reads: TruckState's fields, by their wire names.
struct Seen {
  double t_s = 0, x_m = 0, y_m = 0, yaw_rad = 0, speed_m_s = 0, steer_rad = 0;
  double lift_m = 0, tilt_rad = 0, side_shift_m = 0;
  bool load_attached = false;
  int task_steps_done = 0, task_steps_total = 0;
  std::string task_step;  // the step's words as the worker sends them
};

// What the fingers do until the next look: keys held down (others let go) and keys tapped once
// (down for `kTapS`, then up).
struct Fingers {
  std::set<std::string> held;
  std::vector<std::string> taps;
};
inline constexpr double kTapS = 0.05;    // a tap, s
inline constexpr double kLookS = 0.1;    // how often the driver looks and decides, s

// The truck's build as a pupil knows it (data/trucks/linde_e16c.json).
inline constexpr double kFrontAxleM = 0.75, kForkTipM = 2.15, kWheelbaseM = 1.25;
inline constexpr double kPalletHalfLengthM = 0.6, kForksM = 1.0;

inline double wrap(double a) { return std::atan2(std::sin(a), std::cos(a)); }

// A floor pallet to take: its centre, and the heading the truck faces to enter it.
struct Target {
  Vector2d centre;
  double heading_rad = 0;
  Vector2d dir() const { return {std::cos(heading_rad), std::sin(heading_rad)}; }
  Vector2d left() const { return {-std::sin(heading_rad), std::cos(heading_rad)}; }
};

// Drives to a pallet along a path and takes it: pure pursuit of the front axle (the point that
// does not slip sideways on a rear-steered truck) along the path, whose last leg is the pallet's
// axis; a stop with the fork tips 0.3 m from its face; the side-shift to centre the forks on the
// openings; in slowly with the wheel straight, and lift.
class Pick {
 public:
  // `path`: where the front axle goes, ending anywhere before the stand-off on the pallet's axis
  // (the axis is added as the last leg).
  Pick(Target target, std::vector<Vector2d> path) : t_(target), path_(std::move(path)) {
    const Vector2d stand_off = t_.centre - t_.dir() * (kPalletHalfLengthM + kStandOffM + kForkTipM - kFrontAxleM);
    path_.push_back(stand_off);
  }

  bool done() const { return phase_ == Phase::kDone; }
  // How the forks stood against the openings as the driver went in: + left, m; + left, rad.
  double entry_lateral_m = 0, entry_angle_rad = 0;
  int tries = 0;  // times backed off to come in squarer
  const char* phase() const {
    static const char* names[] = {"follow", "back", "square", "enter", "lift", "done"};
    return names[int(phase_)];
  }

  Fingers decide(const Seen& s) {
    Fingers f;
    const Vector2d p(s.x_m, s.y_m), h(std::cos(s.yaw_rad), std::sin(s.yaw_rad)), n(-h.y(), h.x());
    const Vector2d front = p + kFrontAxleM * h;
    const Vector2d tips = p + kForkTipM * h + s.side_shift_m * n;
    const double to_face = t_.dir().dot(t_.centre - kPalletHalfLengthM * t_.dir() - tips);  // + short of it
    const double lateral = t_.left().dot(tips - t_.centre);  // + the forks left of the openings
    const double heading_err = wrap(s.yaw_rad - t_.heading_rad);  // + turned left of the pallet's axis
    // Forks at the openings' height all the way in (a tap about 1 cm), the mast level.
    // Forks a hand's width up while driving, at the openings' height (a tap about 1 cm) from the
    // stand-off on; the mast level.
    const double fork_lift = phase_ == Phase::kFollow && (seg_ + 2 < path_.size() || to_face > 1.5) ? kTravelLiftM : kForkLiftM;
    if (phase_ != Phase::kLift) lever(f, s.lift_m, fork_lift, 0.006, "w", "s");
    lever(f, s.tilt_rad, 0.0, 0.3 * M_PI / 180, "d", "a");
    switch (phase_) {
      case Phase::kFollow: {
        const double remaining = remaining_m(front);
        const bool last_leg = seg_ + 2 >= path_.size();
        // A look 2 m on (past the stand-off along the pallet's axis, at the end), so that the
        // truck comes in square rather than cutting in; slower on the last leg.
        // Within 2 m of the stand-off and near the axis, square to the pallet first: the
        // side-shift takes up what is left sideways. Near the axis is the front axle's offset,
        // where the fork tips come to once the truck turns square (it turns about that axle), the
        // side-shift apart (it stays where the last try left it).
        const double square_up = std::atan(heading_err * kWheelbaseM / 0.8);
        const bool squaring = last_leg && to_face < kStandOffM + 2.0 && std::abs(t_.left().dot(front - t_.centre)) < 0.08;
        steer_to(f, s, squaring ? square_up : pursue(front, s.yaw_rad, 2.0));
        // 0.3 m/s on the last leg: at 0.35 the truck reached the stand-off too fast to stop square
        // (three back-offs with the training truck's CoG from its parts).
        speed(f, s, std::clamp(0.35 * remaining, 0.25, last_leg ? 0.3 : 1.0));
        if (remaining < 0.05 || (last_leg && to_face < kStandOffM)) phase_ = Phase::kSquare;
        break;
      }
      case Phase::kBack:  // straight back, to come in again squarer
        still_ = steady_ = 0;
        f.held.erase("Left");
        f.held.erase("Right");
        if (std::abs(s.steer_rad) > 0.5 * M_PI / 180) {  // the wheel straight first
          speed(f, s, 0);
          f.taps.push_back("Home");
        } else if (to_face < kStandOffM + 1.8) {
          if (s.speed_m_s > -0.3) f.held.insert("Up");
        } else if (std::abs(s.speed_m_s) > 0.02) {
          speed(f, s, 0);
        } else {
          f.taps.push_back("f");
          phase_ = Phase::kFollow;
        }
        break;
      case Phase::kSquare: {
        // What is seen is a little late: judge the truck once it has stood still a while, and
        // go in once the forks have stayed where they should for kSteadyLooks looks.
        speed(f, s, 0);
        still_ = std::abs(s.speed_m_s) < 0.02 ? still_ + 1 : 0;
        // Too far turned, or too far aside for the side-shift's 0.1 m either way: back off.
        if (still_ >= kSteadyLooks && (std::abs(heading_err) > 0.7 * M_PI / 180 || std::abs(s.side_shift_m - lateral) > 0.09)) {
          ++tries;
          f.taps.push_back("r");
          phase_ = Phase::kBack;
          break;
        }
        f.held.erase("Left");
        f.held.erase("Right");
        if (std::abs(s.steer_rad) > 0.5 * M_PI / 180 && still_ > 0) f.taps.push_back("Home");
        lever(f, lateral, 0.0, 0.006, "q", "e");
        const bool ready = still_ > 0 && std::abs(lateral) < 0.008 && std::abs(s.lift_m - kForkLiftM) < 0.012 &&
                           std::abs(s.steer_rad) < 1.0 * M_PI / 180;
        steady_ = ready ? steady_ + 1 : 0;
        if (steady_ >= kSteadyLooks) {
          phase_ = Phase::kEnter;
          entry_lateral_m = lateral;
          entry_angle_rad = heading_err;
        }
        break;
      }
      case Phase::kEnter:
        speed(f, s, 0.15);
        if (to_face < -(kForksM - 0.28)) phase_ = Phase::kLift;  // 0.72 m in: the heel clear of its face
        break;
      case Phase::kLift:
        speed(f, s, 0);
        if (std::abs(s.speed_m_s) < 0.02 && s.lift_m < kForkLiftM + 0.2) f.held.insert("w");
        if (s.load_attached && s.lift_m > kForkLiftM + 0.1) phase_ = Phase::kDone;
        break;
      case Phase::kDone:
        f.held.insert("Down");
        break;
    }
    return f;
  }

 private:
  enum class Phase { kFollow, kBack, kSquare, kEnter, kLift, kDone };
  static constexpr double kStandOffM = 0.3;   // fork tips to the pallet's face when squaring up
  static constexpr double kForkLiftM = 0.042;
  static constexpr double kTravelLiftM = 0.12;
  static constexpr int kSteadyLooks = 4;  // the forks' top 9 cm up: mid-opening (pockets 2.2-12.2 cm)

  // The path's length still ahead of the point nearest `front` (the search only moves on).
  double remaining_m(const Vector2d& front) {
    double best = 1e9;
    size_t best_seg = seg_;
    double best_u = 0;
    for (size_t i = seg_; i + 1 < path_.size(); ++i) {
      const Vector2d a = path_[i], b = path_[i + 1];
      const double len = (b - a).norm();
      const double u = std::clamp((front - a).dot(b - a) / (len * len), 0.0, 1.0);
      const double d = (a + u * (b - a) - front).norm();
      if (d < best) best = d, best_seg = i, best_u = u;
      if (i > seg_ + 1) break;
    }
    seg_ = best_seg;
    u_ = best_u;
    double left = (1 - u_) * (path_[seg_ + 1] - path_[seg_]).norm();
    for (size_t i = seg_ + 1; i + 1 < path_.size(); ++i) left += (path_[i + 1] - path_[i]).norm();
    return left;
  }
  // The rear wheel's angle (+ points it left, turning the truck right) that takes the front axle
  // through the path's point `look` metres on.
  double pursue(const Vector2d& front, double yaw, double look) const {
    double ahead = look;
    Vector2d at = path_[seg_] + u_ * (path_[seg_ + 1] - path_[seg_]);
    size_t i = seg_;
    while (true) {
      const Vector2d to = path_[i + 1];
      const double d = (to - at).norm();
      if (ahead <= d || i + 2 >= path_.size()) {
        const Vector2d dir = (to - path_[i]).normalized();
        at = at + dir * ahead;
        break;
      }
      ahead -= d;
      at = to;
      ++i;
    }
    const Vector2d r = at - front;
    const double alpha = wrap(std::atan2(r.y(), r.x()) - yaw);
    const double curvature = 2 * std::sin(alpha) / std::max(r.norm(), 0.3);
    return std::clamp(-std::atan(curvature * kWheelbaseM), -1.0, 1.0);
  }
  // The wheel towards `want` as the dial shows it: held for a big error, tapped for a small one.
  static void steer_to(Fingers& f, const Seen& s, double want) {
    const double err = want - s.steer_rad, deg = M_PI / 180;
    if (err > 8 * deg) f.held.insert("Right");
    else if (err < -8 * deg) f.held.insert("Left");
    else if (err > 0.7 * deg) f.taps.push_back("Right");
    else if (err < -0.7 * deg) f.taps.push_back("Left");
  }
  // Up and Down towards a speed (forward; the lever stays in forward).
  static void speed(Fingers& f, const Seen& s, double want) {
    if (want <= 0) {
      if (std::abs(s.speed_m_s) > 0.01) f.held.insert("Down");
      return;
    }
    if (s.speed_m_s < want - 0.05) f.held.insert("Up");
    else if (s.speed_m_s > want + 0.25) f.held.insert("Down");
  }
  // A lever's pair of keys towards `want`: tapped within 5 tolerances, held beyond.
  static void lever(Fingers& f, double now, double want, double tol, const char* up, const char* down) {
    const double err = want - now;
    if (err > 5 * tol) f.held.insert(up);
    else if (err < -5 * tol) f.held.insert(down);
    else if (err > tol) f.taps.push_back(up);
    else if (err < -tol) f.taps.push_back(down);
  }

  Target t_;
  std::vector<Vector2d> path_;
  size_t seg_ = 0;
  double u_ = 0;
  Phase phase_ = Phase::kFollow;
  int still_ = 0, steady_ = 0;  // looks in a row the truck has stood still; the forks have been ready
};

// The first lesson (data/scenarios/first_drive.json) as a pupil follows it: each step's words say
// what to do; the driver does it until the step counter moves on, and ends with the pick.
class Lesson {
 public:
  Lesson(Target pallet) : pallet_(pallet) {}
  bool done() const { return finished_ || (pick_ && pick_->done()); }
  Fingers decide(const Seen& s) {
    Fingers f;
    const std::string& w = s.task_step;
    const double deg = M_PI / 180;
    auto has = [&](const char* words) { return w.find(words) != std::string::npos; };
    finished_ = s.task_steps_total > 0 && s.task_steps_done >= s.task_steps_total;
    if (s.task_steps_done != step_) {  // a new step: hands off the keys it used
      step_ = s.task_steps_done;
      pressed_lever_ = false;
    }
    if (pick_) return pick_->decide(s);  // on to the lift, whatever the display says once it is on the forks
    if (has("pallet")) {  // the lever forward, then the pick from where the truck stands
      const Vector2d front = Vector2d(s.x_m, s.y_m) + kFrontAxleM * Vector2d(std::cos(s.yaw_rad), std::sin(s.yaw_rad));
      pick_.emplace(pallet_, std::vector<Vector2d>{front});
      f.taps.push_back("f");
      return f;
    }
    if (has("roll at")) {  // forward, gently
      once(f, "f");
      if (s.speed_m_s < 0.6) f.held.insert("Up");
    } else if (has("back up")) {
      once(f, "r");
      if (s.speed_m_s > -0.4) f.held.insert("Up");
    } else if (has("stands still") || has("stop with")) {
      f.held.insert("Down");
    } else if (has("wheel left")) {
      if (s.steer_rad > -22 * deg) f.held.insert("Left");
    } else if (has("Turn it right")) {
      if (s.steer_rad < 22 * deg) f.held.insert("Right");
    } else if (has("straight")) {
      once(f, "Home");
    } else if (has("Lift the forks")) {
      if (s.lift_m < 0.32) f.held.insert("w");
    } else if (has("Lower the forks")) {
      if (s.lift_m > 0.01) f.held.insert("s");
    } else if (has("Tilt the mast back")) {
      if (s.tilt_rad > -3.5 * deg) f.held.insert("a");
    } else if (has("level again")) {
      if (s.tilt_rad < -0.3 * deg) f.taps.push_back("d");
    }
    return f;
  }

 private:
  void once(Fingers& f, const char* key) {
    if (!pressed_lever_) f.taps.push_back(key);
    pressed_lever_ = true;
  }
  Target pallet_;
  int step_ = -1;
  bool pressed_lever_ = false;
  bool finished_ = false;  // the display says every step is done
  std::optional<Pick> pick_;
};

}  // namespace key_driver
