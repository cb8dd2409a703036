// Private: small plane geometry for the detectors (world x, y, metres), and the debouncer that
// makes one event of one occurrence.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace forklift::evaluation {

// Distance from p to the segment ab.
inline double segment_distance(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double s = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + s * ab - p).norm();
}

// Distance from p to a polyline (open) or a polygon's boundary (closed).
inline double polyline_distance(const Eigen::Vector2d& p, const std::vector<Eigen::Vector2d>& pts, bool closed) {
  double d = std::numeric_limits<double>::infinity();
  const size_t n = pts.size();
  if (n == 1) return (pts[0] - p).norm();
  for (size_t i = 0; i + 1 < n; ++i) d = std::min(d, segment_distance(p, pts[i], pts[i + 1]));
  if (closed && n > 2) d = std::min(d, segment_distance(p, pts[n - 1], pts[0]));
  return d;
}

inline double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

// Whether the step p0 -> p1 crosses the gate ab (touching counts; moving along it does not).
inline bool crosses(const Eigen::Vector2d& p0, const Eigen::Vector2d& p1, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const double d1 = cross2(b - a, p0 - a), d2 = cross2(b - a, p1 - a);
  const double d3 = cross2(p1 - p0, a - p0), d4 = cross2(p1 - p0, b - p0);
  return ((d1 <= 0 && d2 >= 0) || (d1 >= 0 && d2 <= 0)) && ((d3 <= 0 && d4 >= 0) || (d3 >= 0 && d4 <= 0)) &&
         !(d1 == 0 && d2 == 0);
}

// One occurrence of a fault from a condition sampled every tick: it starts once `on` has held for
// `min_on_s` (update returns true on that tick only) and ends once `on` has been false for
// `min_off_s`. Hysteresis is the caller's: pass the entry test while inactive, the stay test while
// active.
class Debounce {
 public:
  bool active() const { return active_; }
  bool update(bool on, double t, double min_on_s, double min_off_s) {
    if (!active_) {
      if (!on) {
        on_since_ = kNever;
        return false;
      }
      if (on_since_ == kNever) on_since_ = t;
      if (t - on_since_ + 1e-12 < min_on_s) return false;
      active_ = true;
      off_since_ = kNever;
      return true;
    }
    if (on) {
      off_since_ = kNever;
      return false;
    }
    if (off_since_ == kNever) off_since_ = t;
    if (t - off_since_ + 1e-12 >= min_off_s) {
      active_ = false;
      on_since_ = kNever;
    }
    return false;
  }

 private:
  static constexpr double kNever = -std::numeric_limits<double>::infinity();
  bool active_ = false;
  double on_since_ = kNever, off_since_ = kNever;
};

}  // namespace forklift::evaluation
