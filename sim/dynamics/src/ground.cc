// The ground's height (ramps and steps) and where the truck's parts meet its discontinuities.
#include <algorithm>
#include <cmath>

#include "forklift/dynamics/dynamics.h"
#include "ground_contact.h"

namespace forklift {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

// A ramp's own frame: along its heading from its start, and across it (+ left).
struct RampFrame {
  Vector2d dir, start;
  Vector2d local(const Vector2d& p) const {
    const Vector2d d = p - start;
    return {d.dot(dir), d.x() * -dir.y() + d.y() * dir.x()};
  }
  Vector2d local_direction(const Vector2d& d) const { return {d.dot(dir), d.x() * -dir.y() + d.y() * dir.x()}; }
};
RampFrame ramp_frame(const Ramp& r) { return {Vector2d(std::cos(r.heading_rad), std::sin(r.heading_rad)), r.start_m}; }

// Height of one ramp and its gradient at (x, y): smoothstep rise, then a plateau; -inf outside
// its band (so that it never fills a drop beside it).
double ramp_height(const Ramp& r, double x, double y, Vector2d* grad) {
  const RampFrame f = ramp_frame(r);
  const Vector2d l = f.local(Vector2d(x, y));
  const double along = l.x(), across = l.y();
  if (grad) grad->setZero();
  if (std::abs(across) > 0.5 * r.width_m || along <= 0 || along > r.length_m + r.plateau_m) return -INFINITY;
  if (along >= r.length_m) return r.rise_m;
  const double u = along / r.length_m;
  if (grad) *grad = f.dir * (r.rise_m * 6 * u * (1 - u) / r.length_m);
  return r.rise_m * u * u * (3 - 2 * u);
}

// The steps' level at (x, y): the highest top of the steps holding it, else the floor's 0.
double step_level(const std::vector<GroundStep>& steps, double x, double y) {
  double h = -INFINITY;
  const Vector2d p(x, y);
  for (const GroundStep& s : steps)
    if (s.footprint_m.contains(p)) h = std::max(h, s.top_m);
  return std::isfinite(h) ? h : 0.0;
}

// Narrows [t0, t1] to the parameters where o + t d lies inside the box [lo, hi] (the slabs
// method, in 2 or 3 dimensions); false if nothing is left.
template <int N>
bool clip(const Eigen::Matrix<double, N, 1>& o, const Eigen::Matrix<double, N, 1>& d,
          const Eigen::Matrix<double, N, 1>& lo, const Eigen::Matrix<double, N, 1>& hi, double& t0, double& t1) {
  for (int i = 0; i < N; ++i) {
    if (std::abs(d[i]) < 1e-12) {
      if (o[i] < lo[i] || o[i] > hi[i]) return false;
      continue;
    }
    double a = (lo[i] - o[i]) / d[i], b = (hi[i] - o[i]) / d[i];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
    if (t0 > t1) return false;
  }
  return true;
}

// The parameters [t0, t1] where the line o + t d crosses the rectangle [lo, hi].
bool clip_line(const Vector2d& o, const Vector2d& d, const Vector2d& lo, const Vector2d& hi, double& t0, double& t1) {
  t0 = -INFINITY;
  t1 = INFINITY;
  return clip<2>(o, d, lo, hi, t0, t1);
}

}  // namespace

Ground::Ground(std::vector<Ramp> ramps, std::vector<GroundStep> steps, std::vector<GripPatch> grip)
    : ramps_(std::move(ramps)), steps_(std::move(steps)), grip_(std::move(grip)) {}

double Ground::grip(double x, double y, uint64_t absent) const {
  double scale = 1;
  for (size_t i = 0; i < grip_.size(); ++i) {
    if (i < 64 && (absent >> i & 1u)) continue;
    const GripPatch& g = grip_[i];
    if (g.footprint_m.contains(Vector2d(x, y))) scale = std::min(scale, g.friction_scale);
  }
  return scale;
}

double Ground::height(double x, double y) const {
  double h = step_level(steps_, x, y);
  for (const Ramp& r : ramps_) h = std::max(h, ramp_height(r, x, y, nullptr));
  return h;
}

Eigen::Vector2d Ground::gradient(double x, double y) const {
  double h = step_level(steps_, x, y);
  Vector2d best = Vector2d::Zero(), g;
  for (const Ramp& r : ramps_) {
    const double hr = ramp_height(r, x, y, &g);
    if (hr > h) {
      h = hr;
      best = g;
    }
  }
  return best;
}

// A rise smaller than this at a boundary is no edge (floating-point noise where ramps meet).
constexpr double kEdgeM = 1e-4;

int wheel_edge_touches(const Ground& ground, const Vector3d& centre, const Vector3d& axle, double reach,
                       GroundTouch* out) {
  const Vector3d across = axle.cross(Vector3d::UnitZ());  // horizontal, in the wheel's plane
  const double norm = across.norm();
  // A wheel tipped past about 70 degrees of camber has no rim profile to speak of: its plane contact alone.
  if (norm < 0.3 || reach <= 0) return 0;
  const Vector2d c = centre.head<2>(), d = across.head<2>() / norm;
  // Where the profile crosses a step's or a ramp's boundary within the rim's reach.
  constexpr int kMaxBreaks = 32;
  double t[kMaxBreaks];
  int n = 0;
  auto add = [&](double a, double b) {
    for (double v : {a, b})
      if (v > -reach && v < reach && n < kMaxBreaks) t[n++] = v;
  };
  double t0, t1;
  for (const GroundStep& s : ground.steps())
    if (clip_line(c, d, s.footprint_m.min(), s.footprint_m.max(), t0, t1)) add(t0, t1);
  for (const Ramp& r : ground.ramps()) {
    // Far from its band (beyond a circle round its start that holds it), no trigonometry.
    if ((c - r.start_m).norm() > r.length_m + r.plateau_m + 0.5 * r.width_m + reach) continue;
    const RampFrame f = ramp_frame(r);
    if (clip_line(f.local(c), f.local_direction(d), Vector2d(0, -0.5 * r.width_m),
                  Vector2d(r.length_m + r.plateau_m, 0.5 * r.width_m), t0, t1))
      add(t0, t1);
  }
  if (n == 0) return 0;
  std::sort(t, t + n);
  int count = 0;
  const double level_under = ground.height(c.x(), c.y());
  for (int side : {-1, 1}) {
    // Outward from the centre: a level counts where it rises above every level nearer the centre;
    // the rim meets its face between those two levels, or its corner when the centre is higher.
    double highest = level_under;
    for (int k = side > 0 ? 0 : n - 1; k >= 0 && k < n; k += side) {
      const double tb = t[k];
      if (tb * side <= 0) continue;
      const Vector2d beyond = c + (tb + side * 1e-7) * d, before = c + (tb - side * 1e-7) * d;
      const double level = ground.height(beyond.x(), beyond.y());
      if (level <= highest) continue;
      // Where the ground goes on without a step (a ramp's foot, its crest onto the plateau), the
      // plane contact under the centre follows it: no corner there.
      const bool step = level > ground.height(before.x(), before.y()) + kEdgeM;
      if (!step) {
        highest = level;
        continue;
      }
      const Vector3d corner(c.x() + tb * d.x(), c.y() + tb * d.y(), std::clamp(centre.z(), highest, level));
      highest = level;
      const Vector3d gap = centre - corner;
      const double dist = gap.norm();
      if (dist < reach && dist > 1e-9 && count < kMaxGroundTouches) out[count++] = {reach - dist, gap / dist, corner};
    }
  }
  return count;
}

bool point_touch(const Ground& ground, const Vector3d& p, GroundTouch& t) {
  const double h = ground.height(p.x(), p.y());
  const Vector2d grad = ground.gradient(p.x(), p.y());
  const Vector3d n = Vector3d(-grad.x(), -grad.y(), 1.0).normalized();
  const double depth = (Vector3d(p.x(), p.y(), h) - p).dot(n);
  if (depth <= 0) return false;
  t = {depth, n, p};
  // Sideways through a step's side, where that is shorter than up and the ground beyond is lower.
  for (const GroundStep& s : ground.steps()) {
    const Vector2d lo = s.footprint_m.min(), hi = s.footprint_m.max();
    if (p.x() < lo.x() - t.depth_m || p.x() > hi.x() + t.depth_m || p.y() < lo.y() - t.depth_m ||
        p.y() > hi.y() + t.depth_m)
      continue;
    for (int axis = 0; axis < 2; ++axis)
      for (double side : {lo[axis], hi[axis]}) {
        const double dist = std::abs(p[axis] - side);
        if (dist >= t.depth_m) continue;
        const double dir = p[axis] < side ? 1.0 : -1.0;  // across the side's line
        Vector3d q = p;
        q[axis] = side + dir * 1e-7;
        if (ground.height(q.x(), q.y()) >= p.z()) continue;
        Vector3d out = Vector3d::Zero();
        out[axis] = dir;
        t = {dist, out, p};
      }
  }
  return true;
}

// How much deeper one end of an edge's segment in a box must lie than the other for the push to
// act at that end rather than at the middle: a millimetre, small beside the boxes.
constexpr double kEdgeSkew_m = 1e-3;

int box_edge_touches(const Ground& ground, const Eigen::Matrix3d& R, const Vector3d& origin, const Vector3d& lo,
                     const Vector3d& hi, GroundTouch* out) {
  const Vector3d centre = origin + R * (0.5 * (lo + hi)), extent = R.cwiseAbs() * (0.5 * (hi - lo));
  const Vector3d wlo = centre - extent, whi = centre + extent;  // the box's world bounds
  int count = 0;
  for (const GroundStep& s : ground.steps()) {
    const Vector2d slo = s.footprint_m.min(), shi = s.footprint_m.max();
    if (s.top_m < wlo.z() || s.top_m > whi.z() || shi.x() < wlo.x() || slo.x() > whi.x() || shi.y() < wlo.y() ||
        slo.y() > whi.y())
      continue;
    // The four top edges, counter-clockwise, each with the outward normal of its side.
    const Vector2d corner[4] = {slo, Vector2d(shi.x(), slo.y()), shi, Vector2d(slo.x(), shi.y())};
    const Vector2d outward[4] = {Vector2d(0, -1), Vector2d(1, 0), Vector2d(0, 1), Vector2d(-1, 0)};
    for (int e = 0; e < 4; ++e) {
      const Vector3d a = R.transpose() * (Vector3d(corner[e].x(), corner[e].y(), s.top_m) - origin);
      const Vector3d b = R.transpose() * (Vector3d(corner[(e + 1) % 4].x(), corner[(e + 1) % 4].y(), s.top_m) - origin);
      double u0 = 0, u1 = 1;  // the part of the edge inside the box
      if (!clip<3>(a, Vector3d(b - a), lo, hi, u0, u1)) continue;
      const Vector3d p0 = a + u0 * (b - a), p1 = a + u1 * (b - a), mid = 0.5 * (p0 + p1);
      const Vector3d at = origin + R * mid;
      // An edge only where the ground beyond the side is lower and no higher step covers it.
      const Vector2d o = outward[e] * 1e-7;
      if (ground.height(at.x() + o.x(), at.y() + o.y()) >= s.top_m) continue;
      if (ground.height(at.x() - o.x(), at.y() - o.y()) > s.top_m) continue;
      // The box leaves the edge through the face nearest it, moving away from the step's solid
      // (up or out over the side), never into it.
      const Vector3d away = R.transpose() * Vector3d(outward[e].x(), outward[e].y(), 1.0);
      double best = INFINITY;
      Vector3d push = Vector3d::Zero(), deepest = mid;
      for (int axis = 0; axis < 3; ++axis)
        for (double sign : {-1.0, 1.0}) {
          if (-sign * away[axis] <= 0) continue;
          const double face = sign > 0 ? hi[axis] : lo[axis];
          const double d0 = sign * (face - p0[axis]), d1 = sign * (face - p1[axis]);
          const double depth = std::max(d0, d1);
          if (depth < best) {
            best = depth;
            push = Vector3d::Zero();
            push[axis] = -sign;
            // The force acts where the depth is measured, so that it does the work the depth's
            // spring energy says (at the segment's middle its moment was another point's: 500 J
            // out of nothing in a truck falling off a dock's side). Where both ends lie about
            // equally deep (an edge along the face), it moves there smoothly from the middle.
            const double skew = std::abs(d0 - d1);
            deepest = mid + skew / (skew + kEdgeSkew_m) * ((d0 > d1 ? p0 : p1) - mid);
          }
        }
      // Where the edge lies just inside a face it cannot leave through (a fork's top at the kerb's
      // height), the points on that face take the contact over as the edge leaves the box: the
      // edge's depth fades to zero there, so the force does not jump as it crosses.
      const Vector3d along = (b - a).normalized();
      for (int axis = 0; axis < 3; ++axis)
        if (std::abs(along[axis]) < 0.5)  // a face the edge crosses, not one its clipped ends lie on
          best = std::min({best, mid[axis] - lo[axis], hi[axis] - mid[axis]});
      if (best > 0 && std::isfinite(best) && count < kMaxGroundTouches) out[count++] = {best, R * push, origin + R * deepest};
    }
  }
  return count;
}

}  // namespace forklift
