// The warehouse's other trucks: triggers, the drive along a route, and giving way.
#include "forklift/scene/traffic.h"

#include <cmath>

namespace forklift {
namespace {

int legs(const OtherTruckSpec& spec) { return int(spec.route.size()) - (spec.loop ? 0 : 1); }
const Eigen::Vector2d& leg_start(const OtherTruckSpec& spec, int leg) { return spec.route[size_t(leg)]; }
const Eigen::Vector2d& leg_end(const OtherTruckSpec& spec, int leg) {
  return spec.route[size_t(leg + 1) % spec.route.size()];
}

// Where a truck would be after `go_m` more along its route from `s` (leg, along, arrived only).
OtherTruckState advanced(const OtherTruckSpec& spec, OtherTruckState s, double go_m) {
  while (go_m > 0) {
    const double length = (leg_end(spec, s.leg) - leg_start(spec, s.leg)).norm();
    const double go = std::min(go_m, length - s.along_m);
    s.along_m += go;
    go_m -= go;
    if (s.along_m < length) break;
    if (s.leg == legs(spec) - 1 && !spec.loop) {
      s.arrived = true;
      s.along_m = length;
      break;
    }
    s.leg = (s.leg + 1) % legs(spec);
    s.along_m = 0;
  }
  const Eigen::Vector2d dir = (leg_end(spec, s.leg) - leg_start(spec, s.leg)).normalized();
  s.at_m = leg_start(spec, s.leg) + s.along_m * dir;
  s.heading_rad = std::atan2(dir.y(), dir.x());
  return s;
}

Eigen::Vector2d front_of(const OtherTruckSpec& spec, const OtherTruckState& s) {
  return s.at_m + 0.5 * spec.size_m.x() * Eigen::Vector2d(std::cos(s.heading_rad), std::sin(s.heading_rad));
}

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

// Whether the segments [a, b] and [c, d] meet (touching counts).
bool segments_meet(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c, const Eigen::Vector2d& d) {
  const double d1 = cross2(b - a, c - a), d2 = cross2(b - a, d - a), d3 = cross2(d - c, a - c), d4 = cross2(d - c, b - c);
  return ((d1 <= 0 && d2 >= 0) || (d1 >= 0 && d2 <= 0)) && ((d3 <= 0 && d4 >= 0) || (d3 >= 0 && d4 <= 0));
}

// Whether a truck's body, as its centre line from rear to front, is in the crossing's area.
bool in_crossing(const Crossing& x, const OtherTruckSpec& spec, const OtherTruckState& s) {
  const Eigen::Vector2d front = front_of(spec, s), rear = 2 * s.at_m - front;
  if (x.contains(front) || x.contains(rear)) return true;
  const size_t n = x.polygon.size();
  for (size_t i = 0; i < n; ++i)
    if (segments_meet(rear, front, x.polygon[i], x.polygon[(i + 1) % n])) return true;
  return false;
}

// Another truck's body in the crossing: the one that came first has it, and the others wait.
bool taken_by_another(const Crossing& x, const std::vector<OtherTruckSpec>& specs,
                      const std::vector<OtherTruckState>& states, size_t self) {
  for (size_t j = 0; j < specs.size(); ++j)
    if (j != self && in_crossing(x, specs[j], states[j])) return true;
  return false;
}

}  // namespace

std::vector<OtherTruckState> initial_trucks(const std::vector<OtherTruckSpec>& specs) {
  std::vector<OtherTruckState> out(specs.size());
  for (size_t i = 0; i < specs.size(); ++i) out[i] = advanced(specs[i], OtherTruckState{}, 0.0);
  return out;
}

void drive(const std::vector<OtherTruckSpec>& specs, const std::vector<Crossing>& crossings,
           std::vector<OtherTruckState>& states, const TruckOutline& outline, const BodyPoses& poses, double t_s,
           double dt_s) {
  for (size_t i = 0; i < specs.size(); ++i) {
    const OtherTruckSpec& spec = specs[i];
    OtherTruckState& s = states[i];
    s.speed_m_s = 0;
    s.giving_way = -1;
    s.stopped_for_truck = false;
    if (s.struck || s.arrived) continue;
    if (!s.started) {
      s.started = spec.start_truck_within_m ? distance_to_truck(outline, poses, s.at_m) <= *spec.start_truck_within_m
                                            : t_s >= spec.start_at_s;
      if (!s.started) continue;
    }
    const Eigen::Vector2d front = front_of(spec, s);
    if (spec.stop_within_m && distance_to_truck(outline, poses, front) <= *spec.stop_within_m) {
      s.stopped_for_truck = true;
      continue;
    }
    const OtherTruckState next = advanced(spec, s, spec.speed_m_s * dt_s);
    const Eigen::Vector2d next_front = front_of(spec, next);
    // Entering a crossing where the pupil goes first, with the pupil's truck near it, or one that
    // another truck's body is in (whatever the crossing's priority: the first there goes first):
    // wait short of it. The trucks move in the scene's order, so of two reaching it in the same
    // tick the one listed first goes.
    for (size_t c = 0; c < crossings.size() && s.giving_way < 0; ++c) {
      const Crossing& x = crossings[c];
      if (!x.contains(next_front) || x.contains(front)) continue;
      if ((x.priority == "pupil" && distance_to_truck(outline, poses, x.middle_m) <= x.watch_m) ||
          taken_by_another(x, specs, states, i))
        s.giving_way = int(c);
    }
    if (s.giving_way >= 0) continue;
    s = next;
    s.speed_m_s = spec.speed_m_s;
  }
}

Eigen::Isometry3d other_truck_pose(const OtherTruckSpec& spec, const OtherTruckState& state) {
  return standing_pose(state.at_m, state.heading_rad, spec.size_m.z());
}

}  // namespace forklift
