// Engagement of the forks in a pallet's pockets, and the pallet's mass properties on the forks.
#include "pallet_handling.h"

#include <algorithm>
#include <cmath>

namespace forklift::handling {
namespace {

using Eigen::Isometry3d;
using Eigen::Matrix3d;
using Eigen::Vector3d;

// Inertia of a uniform box about its centre, box axes.
Matrix3d box_inertia(double m, const Vector3d& size) {
  const Vector3d s2 = size.cwiseProduct(size);
  return (m / 12.0 * Vector3d(s2.y() + s2.z(), s2.x() + s2.z(), s2.x() + s2.y())).asDiagonal();
}

// Parallel-axis shift of an inertia about a point d away from the CoG.
Matrix3d shifted(const Matrix3d& I, double m, const Vector3d& d) {
  return I + m * (d.squaredNorm() * Matrix3d::Identity() - d * d.transpose());
}

struct Part {
  double mass;
  Vector3d cog;  // pallet frame
  Matrix3d inertia;
};

std::array<Part, 2> parts(const PalletSpec& s) {
  const Vector3d pallet_size(s.length_m, s.width_m, s.height_m);
  const Vector3d load_size = s.load_size_m.cwiseMax(0.0);
  return {Part{s.pallet_mass_kg, Vector3d(0, 0, 0.5 * s.height_m), box_inertia(s.pallet_mass_kg, pallet_size)},
          Part{s.load_mass_kg, Vector3d(0, 0, s.height_m + 0.5 * load_size.z()), box_inertia(s.load_mass_kg, load_size)}};
}

// One fork against the pockets: inside a pocket (its index) or -1; the length inside the
// pallet's footprint and the highest point of its top face there.
struct ForkFit {
  int pocket = -1;
  double inserted_m = 0;
  double top_m = -1e9;
};

ForkFit fit(const PalletSpec& spec, const Isometry3d& pallet_from_fork, const Vector3d& half) {
  ForkFit f;
  const Vector3d c = pallet_from_fork.translation();
  const Vector3d ax = pallet_from_fork.linear().col(0), ay = pallet_from_fork.linear().col(1),
                 az = pallet_from_fork.linear().col(2);
  // The part of the fork's axis, t in [-half.x, half.x], within |x| <= length / 2.
  double t0 = -half.x(), t1 = half.x();
  const double hl = 0.5 * spec.length_m;
  if (std::abs(ax.x()) < 1e-9) {
    if (std::abs(c.x()) > hl) return f;
  } else {
    double a = (-hl - c.x()) / ax.x(), b = (hl - c.x()) / ax.x();
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  if (t1 <= t0) return f;
  f.inserted_m = t1 - t0;

  // The fork is a box and the pocket a box in this frame: the corners of the inserted part's
  // two end sections decide whether it lies inside.
  double ylo = 1e9, yhi = -1e9, zlo = 1e9, zhi = -1e9;
  for (double t : {t0, t1})
    for (double sy : {-1.0, 1.0})
      for (double sz : {-1.0, 1.0}) {
        const Vector3d p = c + t * ax + sy * half.y() * ay + sz * half.z() * az;
        ylo = std::min(ylo, p.y());
        yhi = std::max(yhi, p.y());
        zlo = std::min(zlo, p.z());
        zhi = std::max(zhi, p.z());
        if (sz > 0) f.top_m = std::max(f.top_m, p.z());
      }
  const double tol = kPocketToleranceM;
  if (zlo < spec.pocket_bottom_m - tol || zhi > spec.pocket_top_m + tol) return f;
  for (size_t k = 0; k < spec.pockets_y_m.size(); ++k) {
    const Eigen::Vector2d& pk = spec.pockets_y_m[k];
    if (ylo >= pk.x() - tol && yhi <= pk.y() + tol) { f.pocket = int(k); break; }
  }
  return f;
}

}  // namespace

Engagement engagement(const PalletSpec& spec, const Isometry3d& pallet_from_carriage,
                      const std::array<collision::LocalBox, 2>& forks) {
  Engagement e;
  // Forks along the pallet's x axis (either way: forks enter through either end face).
  const Vector3d fork_axis = pallet_from_carriage.linear().col(0);
  const bool aligned = std::abs(fork_axis.x()) >= std::cos(kForkAxisMaxAngleRad);
  std::array<ForkFit, 2> f;
  for (int i = 0; i < 2; ++i) {
    f[i] = fit(spec, pallet_from_carriage * forks[i].centre, forks[i].half);
    e.fork_top_m = std::max(e.fork_top_m, f[i].top_m);
  }
  const double need = kMinInsertion * spec.length_m;
  e.engaged = aligned && f[0].pocket >= 0 && f[1].pocket >= 0 && f[0].pocket != f[1].pocket &&
              f[0].inserted_m >= need && f[1].inserted_m >= need;
  return e;
}

Vector3d pallet_cog(const PalletSpec& spec) {
  const auto p = parts(spec);
  const double m = p[0].mass + p[1].mass;
  if (!(m > 0)) return p[0].cog;
  return (p[0].mass * p[0].cog + p[1].mass * p[1].cog) / m;
}

Load pallet_load(const PalletSpec& spec, const Isometry3d& carriage_from_pallet) {
  const auto p = parts(spec);
  Load load;
  load.mass_kg = p[0].mass + p[1].mass;
  const Vector3d c = pallet_cog(spec);
  Matrix3d I = Matrix3d::Zero();
  for (const Part& part : p) I += shifted(part.inertia, part.mass, part.cog - c);
  const Matrix3d R = carriage_from_pallet.linear();
  load.cog_m = carriage_from_pallet * c;
  load.inertia_kg_m2 = R * I * R.transpose();
  // Engaged, its x axis lies along the forks (either way): its length is its base's.
  load.base_length_m = spec.length_m;
  load.friction_static = spec.friction_static;
  load.friction_kinetic = spec.friction_kinetic;
  return load;
}

}  // namespace forklift::handling
