// The load on the forks: stick, slip along the forks, and the fall (load_on_forks.h).
#include "forklift/dynamics/load_on_forks.h"

#include <algorithm>
#include <cmath>

namespace forklift {

using Eigen::Vector3d;

namespace {
// A sliding load's place in the mass matrix follows it in steps this long: each is an integrator
// restart, and the mass a few millimetres off its place moves the truck's centre of gravity by
// less than a millimetre.
constexpr double kReattachSlideM = 0.005;
}  // namespace

const char* load_phase_name(LoadPhase phase) {
  switch (phase) {
    case LoadPhase::kNone: return "none";
    case LoadPhase::kStuck: return "stuck";
    case LoadPhase::kSliding: return "sliding";
    case LoadPhase::kFallen: return "fallen";
  }
  return "?";
}

LoadOnForksModel load_on_forks_model(const TruckParams& truck, const Load& load) {
  LoadOnForksModel m;
  m.load = load;
  const LoadContactParams& lc = truck.load_contact;
  m.mu_static = std::isnan(load.friction_static) ? lc.friction_static : load.friction_static;
  m.mu_kinetic = std::isnan(load.friction_kinetic) ? lc.friction_kinetic : load.friction_kinetic;
  m.mu_kinetic = std::min(m.mu_kinetic, m.mu_static);
  // A base of unknown length reaches back to the fork face; a shorter one may slide back to it.
  const double back = load.base_length_m > 0 ? load.cog_m.x() - 0.5 * load.base_length_m : 0.0;
  m.min_slide_m = -std::max(0.0, back);
  m.fork_tip_m = lc.fork_tip_m;
  m.tipped_over_rad = truck.tipped_over_rad;
  return m;
}

Load load_at(const LoadOnForksModel& model, const LoadOnForks& state) {
  Load l = model.load;
  l.cog_m.x() += state.attached_slide_m;
  return l;
}

bool truck_gone_over(const CoordVector& q, double tipped_over_rad) {
  return std::abs(q[kAuc]) > tipped_over_rad || std::abs(q[kAvc]) > tipped_over_rad;
}

LoadChangeInModel step_load(const LoadOnForksModel& model, LoadOnForks& st, const Outputs& out, const Vector3d& g,
                            double dt) {
  if (st.phase != LoadPhase::kStuck && st.phase != LoadPhase::kSliding) return LoadChangeInModel::kNone;
  const FrameMotion& c = out.carriage;
  const Vector3d fork_x = c.R.col(0);
  auto cog = [&] { return Vector3d(model.load.cog_m + st.slide_m * Vector3d::UnitX()); };
  auto fall = [&] {
    st.fell_at_m = c.p + c.R * cog();
    st.fell_velocity_m_s = c.velocity_at(cog()) + st.slide_rate_m_s * fork_x;
    st.phase = LoadPhase::kFallen;
    st.slide_rate_m_s = 0;
    st.push.force_N.setZero();
    return LoadChangeInModel::kRelease;
  };
  if (truck_gone_over(out.q, model.tipped_over_rad)) return fall();

  // Per unit mass, carriage axes: what the forks must hold, along them and pressing on them.
  const Vector3d s = c.R.transpose() * (g - c.acceleration_at(cog()));
  const double n = std::max(0.0, -s.z());  // lifted off the forks: no friction at all
  if (st.phase == LoadPhase::kStuck) {
    // Against the fork face it cannot start sliding backwards.
    const bool against_face = s.x() < 0 && st.slide_m <= model.min_slide_m;
    if (!(std::abs(s.x()) > model.mu_static * n) || against_face) return LoadChangeInModel::kNone;
    st.phase = LoadPhase::kSliding;
    st.slide_rate_m_s = 0;
    ++st.slips;
  }

  // Sliding: kinetic friction against the motion (or, from rest, against the demand).
  const double rate0 = st.slide_rate_m_s;
  const double dir = rate0 != 0 ? (rate0 > 0 ? 1.0 : -1.0) : (s.x() > 0 ? 1.0 : -1.0);
  const double relative = s.x() - dir * model.mu_kinetic * n;  // slide'', m/s^2
  double rate = rate0 + relative * dt;
  bool stops = false;
  if (rate * dir <= 0) {
    // Friction has stopped it within the step: it sticks if static friction holds it there (else
    // it starts back the other way next step, from rest).
    rate = 0;
    stops = std::abs(s.x()) <= model.mu_static * n;
  }
  st.slide_m += 0.5 * (rate0 + rate) * dt;
  st.slide_rate_m_s = rate;
  if (st.slide_m <= model.min_slide_m) {  // back against the fork face, which stops it
    st.slide_m = model.min_slide_m;
    st.slide_rate_m_s = 0;
    stops = true;
  }
  // Its centre of gravity past the fork tips: it tips over them and falls.
  if (cog().x() > model.fork_tip_m) return fall();
  if (stops) {
    st.phase = LoadPhase::kStuck;
    st.push.force_N.setZero();
  } else {
    // The mass matrix holds the load rigidly on the carriage, which would take the whole of
    // -m s_x from the forks; they take only friction, so the carriage gets back the difference,
    // -m slide'', along the forks at the load's centre of gravity.
    st.push.body = TruckBody::kCarriage;
    st.push.point_m = c.p + c.R * cog();
    st.push.force_N = -model.load.mass_kg * relative * fork_x;
  }
  // Where the mass matrix has it: moved with the slide, every few millimetres and when it stops.
  const double moved = std::abs(st.slide_m - st.attached_slide_m);
  if (moved > kReattachSlideM || (stops && moved > 0)) {
    st.attached_slide_m = st.slide_m;
    return LoadChangeInModel::kAttach;
  }
  return LoadChangeInModel::kNone;
}

}  // namespace forklift
