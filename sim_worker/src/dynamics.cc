// The equations of motion of section 10: M(q) q'' = Q(q, q') with the 4 driven coordinates
// moved by their filters, solved as eq (13), the driven forces as eq (14).
//
// M and Q come from the kinematics of the six bodies (chassis, three wheels, mast, fork
// carriage with its load) on a tree of single-coordinate joints, one per generalised
// coordinate, so nothing symbolic is needed at run time:
//   M = sum_b  m_b Jv_b' Jv_b + Jw_b' I_b Jw_b
//   Q = sum of J' (applied forces)  -  sum_b [ Jv_b' m_b a0_b + Jw_b' (I_b alpha0_b + w_b x I_b w_b) ]
// where a0, alpha0 are each body's accelerations with q'' = 0 (the velocity-product terms).
// Rotations are exact (the paper linearises auc, avc and beta; a tilt table needs more).
#include "forklift/dynamics.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <cmath>

namespace forklift {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Jac = Eigen::Matrix<double, 3, kNumCoords>;
using MassMatrix = Eigen::Matrix<double, kNumCoords, kNumCoords>;

enum class JointType { kPrismatic, kRevolute };

// Joint j creates frame j; parents come before children.
struct Joint {
  int parent;        // frame index, -1 for the world
  JointType type;
  Vector3d axis;     // in the parent frame
  Vector3d offset;   // child origin in the parent frame (at zero coordinate)
  int coord;
};
inline constexpr int kNumFrames = kNumCoords;
inline constexpr int kChassisFrame = 5;
inline constexpr int kWheelFrame[kNumWheels] = {6, 7, 9};
inline constexpr int kMastFrame = 10;
inline constexpr int kCarriageFrame = 12;

struct Tree {
  std::array<Joint, kNumFrames> joints;
  std::array<unsigned, kNumFrames> path;  // bit j set if joint j lies between the world and frame
};

Tree build_tree(const TruckParams& t) {
  const Vector3d X = Vector3d::UnitX(), Y = Vector3d::UnitY(), Z = Vector3d::UnitZ(), O = Vector3d::Zero();
  Tree tree;
  tree.joints = {{
      {-1, JointType::kPrismatic, X, O, kX},
      {0, JointType::kPrismatic, Y, O, kY},
      {1, JointType::kPrismatic, Z, O, kZ},
      {2, JointType::kRevolute, Z, O, kAwc},   // yaw, then pitch, then roll: R = Rz Ry Rx
      {3, JointType::kRevolute, Y, O, kAvc},
      {4, JointType::kRevolute, X, O, kAuc},   // -> chassis frame, origin at the chassis CoG
      {kChassisFrame, JointType::kRevolute, Y, t.wheels[kFrontLeft].centre_m, kAvr1},
      {kChassisFrame, JointType::kRevolute, Y, t.wheels[kFrontRight].centre_m, kAvr2},
      {kChassisFrame, JointType::kRevolute, Z, t.wheels[kRear].centre_m, kAwr3},  // steer turntable
      {8, JointType::kRevolute, Y, O, kAvr3},
      {kChassisFrame, JointType::kRevolute, Y, t.mast_pivot_m, kBeta},
      {kMastFrame, JointType::kPrismatic, Z, t.fork_heel_from_pivot_m, kS},
      {11, JointType::kPrismatic, Y, O, kR},  // -> carriage frame, origin at the fork heel
  }};
  for (int f = 0; f < kNumFrames; ++f) {
    const int p = tree.joints[f].parent;
    tree.path[f] = (p < 0 ? 0u : tree.path[p]) | (1u << f);
  }
  return tree;
}

// Position, velocity and velocity-product ("bias") accelerations of every frame.
struct FrameState {
  Matrix3d R;
  Vector3d p, w, v, alpha0, a0;
  Vector3d u;  // the creating joint's axis in world axes
};

struct Kinematics {
  std::array<FrameState, kNumFrames> f;
};

void forward_kinematics(const Tree& tree, const CoordVector& q, const CoordVector& qd, Kinematics& k) {
  for (int j = 0; j < kNumFrames; ++j) {
    const Joint& jt = tree.joints[j];
    static const FrameState world{Matrix3d::Identity(), Vector3d::Zero(), Vector3d::Zero(),
                                  Vector3d::Zero(), Vector3d::Zero(), Vector3d::Zero(), Vector3d::Zero()};
    const FrameState& P = jt.parent < 0 ? world : k.f[jt.parent];
    FrameState& C = k.f[j];
    const double qj = q[jt.coord], qdj = qd[jt.coord];
    C.u = P.R * jt.axis;
    if (jt.type == JointType::kRevolute) {
      C.R = P.R * Eigen::AngleAxisd(qj, jt.axis).toRotationMatrix();
      C.p = P.p + P.R * jt.offset;
      const Vector3d r = C.p - P.p;
      C.w = P.w + C.u * qdj;
      C.v = P.v + P.w.cross(r);
      C.alpha0 = P.alpha0 + P.w.cross(C.u * qdj);
      C.a0 = P.a0 + P.alpha0.cross(r) + P.w.cross(P.w.cross(r));
    } else {
      C.R = P.R;
      C.p = P.p + P.R * (jt.offset + jt.axis * qj);
      const Vector3d r = C.p - P.p;
      C.w = P.w;
      C.v = P.v + P.w.cross(r) + C.u * qdj;
      C.alpha0 = P.alpha0;
      C.a0 = P.a0 + P.alpha0.cross(r) + P.w.cross(P.w.cross(r)) + 2.0 * P.w.cross(C.u * qdj);
    }
  }
}

// Linear and angular Jacobians of a point rigidly attached to `frame`, at world position x.
void point_jacobian(const Tree& tree, const Kinematics& k, int frame, const Vector3d& x, Jac& Jv, Jac& Jw) {
  Jv.setZero();
  Jw.setZero();
  for (int j = 0; j <= frame; ++j) {
    if (!(tree.path[frame] & (1u << j))) continue;
    const Joint& jt = tree.joints[j];
    const FrameState& F = k.f[j];
    if (jt.type == JointType::kRevolute) {
      Jv.col(jt.coord) = F.u.cross(x - F.p);
      Jw.col(jt.coord) = F.u;
    } else {
      Jv.col(jt.coord) = F.u;
    }
  }
}

struct Body {
  int frame;
  double mass;
  Vector3d cog;  // frame axes, from the frame origin
  Matrix3d inertia;  // about the CoG, frame axes
};

// Parallel-axis shift of an inertia about a point d away from the CoG.
Matrix3d shifted(const Matrix3d& I, double m, const Vector3d& d) {
  return I + m * (d.squaredNorm() * Matrix3d::Identity() - d * d.transpose());
}

std::array<Body, 6> bodies(const TruckParams& t, const std::optional<Load>& load) {
  auto wheel = [&](int w) {
    const WheelParams& wp = t.wheels[w];
    return Body{kWheelFrame[w], wp.mass_kg, Vector3d::Zero(),
                Vector3d(wp.transverse_inertia_kg_m2, wp.spin_inertia_kg_m2, wp.transverse_inertia_kg_m2).asDiagonal()};
  };
  Body carriage{kCarriageFrame, t.carriage.mass_kg, t.carriage.cog_m, t.carriage.inertia_kg_m2};
  if (load && load->mass_kg > 0) {
    // Section 5: the pitchfork's mass properties become those of carriage and load together.
    const double m = carriage.mass + load->mass_kg;
    const Vector3d c = (carriage.mass * carriage.cog + load->mass_kg * load->cog_m) / m;
    carriage.inertia = shifted(carriage.inertia, carriage.mass, carriage.cog - c) +
                       shifted(load->inertia_kg_m2, load->mass_kg, load->cog_m - c);
    carriage.mass = m;
    carriage.cog = c;
  }
  return {Body{kChassisFrame, t.chassis.mass_kg, Vector3d::Zero(), t.chassis.inertia_kg_m2},
          wheel(kFrontLeft), wheel(kFrontRight), wheel(kRear),
          Body{kMastFrame, t.mast.mass_kg, t.mast.cog_m, t.mast.inertia_kg_m2}, carriage};
}

CoordVector coords(const StateVector& x) {
  CoordVector q;
  q.head<kNumDynamic>() = x.segment<kNumDynamic>(StateIndex::kQ);
  for (int d = 0; d < kNumDriven; ++d) q[kNumDynamic + d] = x[StateIndex::kDriven + 3 * d];
  return q;
}
CoordVector rates(const StateVector& x) {
  CoordVector qd;
  qd.head<kNumDynamic>() = x.segment<kNumDynamic>(StateIndex::kQdot);
  for (int d = 0; d < kNumDriven; ++d) qd[kNumDynamic + d] = x[StateIndex::kDriven + 3 * d + 1];
  return qd;
}

// Local ground plane under a point: height and unit normal.
void ground_under(const Ground& g, const Vector3d& at, double& h, Vector3d& n) {
  h = g.height(at.x(), at.y());
  const Eigen::Vector2d grad = g.gradient(at.x(), at.y());
  n = Vector3d(-grad.x(), -grad.y(), 1.0).normalized();
}

double sign(double v) { return (v > 0) - (v < 0); }

// Section 6, eq (5): torque for wheel 1 (front left) and 2 (front right) from the total M and
// the rear-wheel angle phi. phi_c puts the instantaneous centre on a front wheel.
void torque_split(double M, double phi, double phi_c, double& M1, double& M2) {
  if (phi < -phi_c) {
    M1 = M * (phi + phi_c) / (M_PI - 2 * phi_c);
    M2 = M * (phi + M_PI - phi_c) / (M_PI - 2 * phi_c);
  } else if (phi <= phi_c) {
    M1 = M * (phi + phi_c) / (2 * phi_c);
    M2 = M * (phi_c - phi) / (2 * phi_c);
  } else {
    M1 = M * (M_PI - phi - phi_c) / (M_PI - 2 * phi_c);
    M2 = M * (phi_c - phi) / (M_PI - 2 * phi_c);
  }
}

// Everything evaluated at one state, shared by the derivative and the energy.
struct Evaluation {
  Kinematics kin;
  std::array<Body, 6> body;
  MassMatrix M;
  CoordVector Q;  // applied generalised forces minus the velocity-product terms
};

}  // namespace

Ground::Ground(std::vector<Ramp> ramps) : ramps_(std::move(ramps)) {}

namespace {
// Height of one ramp and its gradient at (x, y): smoothstep rise, then a plateau.
double ramp_height(const Ramp& r, double x, double y, Eigen::Vector2d* grad) {
  const Eigen::Vector2d dir(std::cos(r.heading_rad), std::sin(r.heading_rad));
  const Eigen::Vector2d d = Eigen::Vector2d(x, y) - r.start_m;
  const double along = d.dot(dir), across = d.x() * -dir.y() + d.y() * dir.x();
  if (grad) grad->setZero();
  if (std::abs(across) > 0.5 * r.width_m || along <= 0 || along > r.length_m + r.plateau_m) return 0;
  if (along >= r.length_m) return r.rise_m;
  const double u = along / r.length_m;
  if (grad) *grad = dir * (r.rise_m * 6 * u * (1 - u) / r.length_m);
  return r.rise_m * u * u * (3 - 2 * u);
}
}  // namespace

double Ground::height(double x, double y) const {
  double h = 0;
  for (const Ramp& r : ramps_) h = std::max(h, ramp_height(r, x, y, nullptr));
  return h;
}

Eigen::Vector2d Ground::gradient(double x, double y) const {
  double h = 0;
  Eigen::Vector2d best = Eigen::Vector2d::Zero(), g;
  for (const Ramp& r : ramps_) {
    const double hr = ramp_height(r, x, y, &g);
    if (hr > h) { h = hr; best = g; }
  }
  return best;
}

TruckDynamics::TruckDynamics(const TruckParams& truck, Environment env)
    : truck_(truck), env_(std::move(env)) {}

void TruckDynamics::attach_load(const Load& load) { load_ = load; }
void TruckDynamics::release_load() { load_.reset(); }

namespace {

void evaluate(const TruckParams& t, const Environment& env, const std::optional<Load>& load,
              const StateVector& x, Evaluation& e, Outputs* out) {
  const Tree tree = build_tree(t);  // 13 joints on the stack: cheaper than any cache
  const CoordVector q = coords(x), qd = rates(x);
  forward_kinematics(tree, q, qd, e.kin);
  e.body = bodies(t, load);
  e.M.setZero();
  e.Q.setZero();
  Jac Jv, Jw;
  double mass = 0;
  Vector3d mass_moment = Vector3d::Zero();
  for (const Body& b : e.body) {
    const FrameState& F = e.kin.f[b.frame];
    const Vector3d rho = F.R * b.cog;
    const Vector3d c = F.p + rho;
    point_jacobian(tree, e.kin, b.frame, c, Jv, Jw);
    const Matrix3d I = F.R * b.inertia * F.R.transpose();
    e.M.noalias() += b.mass * Jv.transpose() * Jv + Jw.transpose() * I * Jw;
    const Vector3d a0 = F.a0 + F.alpha0.cross(rho) + F.w.cross(F.w.cross(rho));
    const Vector3d iw = I * F.w;
    e.Q.noalias() -= Jv.transpose() * (b.mass * a0) + Jw.transpose() * (I * F.alpha0 + F.w.cross(iw));
    e.Q.noalias() += Jv.transpose() * (b.mass * env.gravity_m_s2);
    mass += b.mass;
    mass_moment += b.mass * c;
  }

  // Ground-to-wheel forces, section 7, each applied at its contact point to the wheel.
  const ContactParams& cp = t.contact;
  std::array<WheelContact, kNumWheels> wc{};
  for (int w = 0; w < kNumWheels; ++w) {
    const FrameState& F = e.kin.f[kWheelFrame[w]];
    WheelContact& c = wc[w];
    double h;
    Vector3d n;
    ground_under(env.ground, F.p, h, n);
    const double height_over_ground = (F.p - Vector3d(F.p.x(), F.p.y(), h)).dot(n);
    c.penetration_m = t.wheels[w].radius_m - height_over_ground;
    c.contact_point_m = F.p - height_over_ground * n;
    const Vector3d axle = F.R.col(1);
    const Vector3d xw = axle.cross(n).normalized(), yw = n.cross(xw);
    const Vector3d vs = F.v + F.w.cross(c.contact_point_m - F.p);  // VS: the contact point on the wheel
    c.slip_x_m_s = vs.dot(xw);
    c.slip_y_m_s = vs.dot(yw);
    const double vwx = F.v.dot(xw), vwy = F.v.dot(yw);
    const double vfloor = cp.slip_angle_speed_floor_m_s;
    c.slip_angle_rad = sign(vwy) * std::atan(std::abs(vwy) / std::sqrt(vwx * vwx + vfloor * vfloor));
    if (c.penetration_m > 0) {
      // eq (7); the damper may not pull the wheel into the ground.
      c.fz_N = std::max(0.0, cp.stiffness_N_m * c.penetration_m - cp.damping_N_s_m * F.v.dot(n));
    }
    c.on_ground = c.fz_N > 0;
    Vector3d force = c.fz_N * n;
    if (env.chock_anchors_m) {
      const Eigen::Vector2d dp = c.contact_point_m.head<2>() - (*env.chock_anchors_m)[w];
      constexpr double kChockStiffness = 2e6, kChockDamping = 2e4;  // a rigid chock, numerically soft
      force.head<2>() += -kChockStiffness * dp - kChockDamping * vs.head<2>();
    } else if (c.on_ground) {
      c.fx_N = std::clamp(-c.fz_N * cp.fx_slip_gain_s_m * c.slip_x_m_s, -cp.fx_max_N, cp.fx_max_N);  // eq (8)
      const double a0 = cp.fy_alpha0_rad;  // eq (10)
      c.fy_N = std::abs(c.slip_angle_rad) <= a0 ? -cp.fy_mu * c.fz_N * std::sin(M_PI * c.slip_angle_rad / (2 * a0))
                                                : -cp.fy_mu * c.fz_N * sign(c.slip_angle_rad);
      force += c.fx_N * xw + c.fy_N * yw;
    }
    point_jacobian(tree, e.kin, kWheelFrame[w], c.contact_point_m, Jv, Jw);
    e.Q.noalias() += Jv.transpose() * force;
    // eq (6), rolling resistance, a torque from the ground on the wheel; it fades in with the
    // first 1000 N of load so that it vanishes, continuously, as the wheel leaves the ground.
    c.rolling_torque_N_m = -cp.rolling_resistance_N_m_s * qd[kAvr1 + w] * std::min(1.0, c.fz_N / 1000.0);
    e.Q.noalias() += Jw.transpose() * (c.rolling_torque_N_m * axle);
  }

  // The scene pushing back where the truck touches it (contacts, held for the tick).
  for (const ExternalForce& f : env.external_forces) {
    const int frame = f.body == TruckBody::kChassis ? kChassisFrame : f.body == TruckBody::kMast ? kMastFrame : kCarriageFrame;
    point_jacobian(tree, e.kin, frame, f.point_m, Jv, Jw);
    e.Q.noalias() += Jv.transpose() * f.force_N;
  }

  // Drive torque (section 6) and brake torque (section 8) act between chassis and front wheels,
  // so they are generalised forces on the wheels' relative spin coordinates alone.
  const double M = x[StateIndex::kTorque];
  const double phi_c = std::atan(2 * t.wheelbase_m() / t.front_track_m());
  double m1, m2;
  torque_split(M, q[kAwr3], phi_c, m1, m2);
  // "also weighed up by the ratio of the total Fz exerted to that wheel", keeping |M1|+|M2| = |M|.
  const double fz_front = wc[kFrontLeft].fz_N + wc[kFrontRight].fz_N;
  if (fz_front > 0) {
    const double w1 = wc[kFrontLeft].fz_N / fz_front, w2 = wc[kFrontRight].fz_N / fz_front;
    const double den = std::abs(m1 * w1) + std::abs(m2 * w2);
    if (den > 1e-12) { m1 = std::abs(M) * m1 * w1 / den; m2 = std::abs(M) * m2 * w2 / den; }
  }
  wc[kFrontLeft].drive_torque_N_m = m1;
  wc[kFrontRight].drive_torque_N_m = m2;
  const double b = std::max(0.0, x[StateIndex::kBrake]);
  for (int w : {kFrontLeft, kFrontRight}) {
    wc[w].brake_torque_N_m = -b * std::tanh(qd[kAvr1 + w] / t.drive.brake_fade_speed_rad_s);
    e.Q[kAvr1 + w] += wc[w].drive_torque_N_m + wc[w].brake_torque_N_m;
  }

  if (out) {
    out->q = q;
    out->qdot = qd;
    out->wheels = wc;
    out->total_mass_kg = mass;
    out->cog_m = mass_moment / mass;
    const double yaw = q[kAwc];
    out->forward_speed_m_s = std::cos(yaw) * qd[kX] + std::sin(yaw) * qd[kY];
  }
}

// Velocity input filtered to z'' continuous, with soft end stops: the command fades to zero
// over the last `band` before a limit it pushes towards.
double limited_rate(double rate, double rate_max, double z, double lo, double hi, double band) {
  rate = std::clamp(rate, -rate_max, rate_max);
  if (rate > 0) rate *= std::clamp((hi - z) / band, 0.0, 1.0);
  if (rate < 0) rate *= std::clamp((z - lo) / band, 0.0, 1.0);
  return rate;
}

}  // namespace

void TruckDynamics::mass_matrix_and_forces(const StateVector& x, MassMatrix& M, CoordVector& Q,
                                           Outputs* out) const {
  Evaluation e;
  evaluate(truck_, env_, load_, x, e, out);
  M = e.M;
  Q = e.Q;
}

bool TruckDynamics::derivative(const StateVector& x, const DriverInputs& u, StateVector& dx,
                               Outputs* out) const {
  if (!x.allFinite()) return false;
  Evaluation e;
  evaluate(truck_, env_, load_, x, e, out);

  // Driven coordinates: third-order filters so that z, z', z'' stay continuous (section 12).
  const MastLimits& lim = truck_.limits;
  Eigen::Vector4d zdd;
  const double ws = truck_.steer_bandwidth_rad_s, wl = truck_.lever_bandwidth_rad_s;
  const double steer_max = 88.0 * M_PI / 180.0;
  for (int d = 0; d < kNumDriven; ++d) {
    const int i = StateIndex::kDriven + 3 * d;
    const double z = x[i], zd = x[i + 1], za = x[i + 2];
    dx[i] = zd;
    dx[i + 1] = za;
    if (d == 0) {  // steer, driven by position
      const double target = std::clamp(u.steer_rad, -steer_max, steer_max);
      dx[i + 2] = ws * ws * ws * (target - z) - 3 * ws * ws * zd - 3 * ws * za;
    } else {  // tilt, lift, side-shift, driven by velocity
      double rate = 0;
      // Each band is about a third of a second of travel at full rate, long beside the filter's
      // lag (2 / bandwidth = 0.1 s), so the coordinate stops at its limit without overshoot.
      if (d == 1) rate = limited_rate(u.tilt_rate_rad_s, lim.tilt_rate_max_rad_s, z, -lim.tilt_backward_max_rad, lim.tilt_forward_max_rad, lim.tilt_rate_max_rad_s / 3);
      if (d == 2) rate = limited_rate(u.lift_rate_m_s, lim.lift_rate_max_m_s, z, 0.0, lim.lift_max_m, lim.lift_rate_max_m_s / 3);
      if (d == 3) rate = limited_rate(u.shift_rate_m_s, lim.side_shift_rate_max_m_s, z, -lim.side_shift_max_m, lim.side_shift_max_m, lim.side_shift_rate_max_m_s / 3);
      dx[i + 2] = wl * wl * (rate - zd) - 2 * wl * za;
    }
    zdd[d] = za;
  }

  // Eq (13): M_ii q_i'' = Q_i - M_id z''.
  const auto Mii = e.M.topLeftCorner<kNumDynamic, kNumDynamic>();
  const auto Mid = e.M.topRightCorner<kNumDynamic, kNumDriven>();
  Eigen::LLT<Eigen::Matrix<double, kNumDynamic, kNumDynamic>> llt(Mii);
  if (llt.info() != Eigen::Success) return false;
  const Eigen::Matrix<double, kNumDynamic, 1> qdd = llt.solve(e.Q.head<kNumDynamic>() - Mid * zdd);

  dx.segment<kNumDynamic>(StateIndex::kQ) = x.segment<kNumDynamic>(StateIndex::kQdot);
  dx.segment<kNumDynamic>(StateIndex::kQdot) = qdd;

  // First-order lags on the drive and brake demands (section 8).
  const DriveParams& dp = truck_.drive;
  const double torque = std::clamp(u.drive_torque_N_m, -dp.drive_torque_max_N_m, dp.drive_torque_max_N_m);
  const double brake = std::clamp(u.brake_torque_N_m, 0.0, dp.brake_torque_max_N_m);
  dx[StateIndex::kTorque] = (torque - x[StateIndex::kTorque]) / dp.torque_lag_s;
  dx[StateIndex::kBrake] = (brake - x[StateIndex::kBrake]) / dp.brake_lag_s;

  if (out) {
    out->qddot.head<kNumDynamic>() = qdd;
    out->qddot.tail<kNumDriven>() = zdd;
    // Eq (14) with the actuator's sign: the force it must apply to follow z''.
    out->driven_force = e.M.bottomLeftCorner<kNumDriven, kNumDynamic>() * qdd +
                        e.M.bottomRightCorner<kNumDriven, kNumDriven>() * zdd - e.Q.tail<kNumDriven>();
  }
  return dx.allFinite();
}

double TruckDynamics::energy(const StateVector& x) const {
  Evaluation e;
  Outputs out;
  evaluate(truck_, env_, load_, x, e, &out);
  const CoordVector qd = rates(x);
  double energy = 0.5 * qd.dot(e.M * qd);
  for (const Body& b : e.body) {
    const FrameState& F = e.kin.f[b.frame];
    energy -= b.mass * env_.gravity_m_s2.dot(F.p + F.R * b.cog);
  }
  for (const WheelContact& c : out.wheels)
    if (c.penetration_m > 0) energy += 0.5 * truck_.contact.stiffness_N_m * c.penetration_m * c.penetration_m;
  return energy;
}

StateVector TruckDynamics::rest_state(double x, double y, double yaw, double steer, double tilt,
                                      double lift, double shift) const {
  StateVector s = StateVector::Zero();
  s[StateIndex::kQ + kX] = x;
  s[StateIndex::kQ + kY] = y;
  // Start from the static deflection of three equally loaded wheels: at zero penetration the
  // wheels carry nothing and Newton's method in settle_static would have no slope to follow.
  double mass = truck_.service_mass_kg + (load_ ? load_->mass_kg : 0.0);
  s[StateIndex::kQ + kZ] = truck_.chassis_cog_geometry_m.z() + env_.ground.height(x, y) -
                           mass * std::abs(env_.gravity_m_s2.z()) / (kNumWheels * truck_.contact.stiffness_N_m);
  s[StateIndex::kQ + kAwc] = yaw;
  const double driven[kNumDriven] = {steer, tilt, lift, shift};
  for (int d = 0; d < kNumDriven; ++d) s[StateIndex::kDriven + 3 * d] = driven[d];
  return s;
}

bool TruckDynamics::settle_static(StateVector& x) const {
  // Newton's method on the generalised forces of the free chassis coordinates, all rates zero.
  std::vector<int> free = {kZ, kAuc, kAvc};
  if (env_.chock_anchors_m) free = {kX, kY, kZ, kAwc, kAuc, kAvc};
  const int n = static_cast<int>(free.size());
  x.segment<kNumDynamic>(StateIndex::kQdot).setZero();
  for (int d = 0; d < kNumDriven; ++d) x[StateIndex::kDriven + 3 * d + 1] = x[StateIndex::kDriven + 3 * d + 2] = 0;
  auto residual = [&](const StateVector& s) {
    Evaluation e;
    evaluate(truck_, env_, load_, s, e, nullptr);
    // Solve for accelerations so the residual is well scaled (m/s^2, rad/s^2).
    Eigen::VectorXd r(n);
    const Eigen::Matrix<double, kNumDynamic, 1> a =
        e.M.topLeftCorner<kNumDynamic, kNumDynamic>().llt().solve(e.Q.head<kNumDynamic>());
    for (int i = 0; i < n; ++i) r[i] = a[free[i]];
    return r;
  };
  for (int iter = 0; iter < 100; ++iter) {
    const Eigen::VectorXd r = residual(x);
    if (!r.allFinite()) return false;
    if (r.norm() < 1e-8) break;
    Eigen::MatrixXd J(n, n);
    for (int i = 0; i < n; ++i) {
      StateVector xp = x;
      const double h = 1e-7;
      xp[StateIndex::kQ + free[i]] += h;
      J.col(i) = (residual(xp) - r) / h;
    }
    Eigen::VectorXd dq = J.fullPivLu().solve(-r);
    if (!dq.allFinite()) return false;
    const double step = dq.cwiseAbs().maxCoeff();
    if (step > 0.01) dq *= 0.01 / step;  // wheels leave the ground beyond small moves
    for (int i = 0; i < n; ++i) x[StateIndex::kQ + free[i]] += dq[i];
    if (iter == 99) return false;
  }
  Outputs out;
  StateVector dx;
  derivative(x, DriverInputs{}, dx, &out);
  for (const WheelContact& c : out.wheels) if (!c.on_ground) return false;
  return true;
}

CoordVector coordinates(const StateVector& x) { return coords(x); }

BodyPoses body_poses(const TruckParams& truck, const CoordVector& q) {
  const Tree tree = build_tree(truck);
  Kinematics k;
  forward_kinematics(tree, q, CoordVector::Zero(), k);
  auto pose = [&](int frame, const Vector3d& origin_offset) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = k.f[frame].R;
    T.translation() = k.f[frame].p + k.f[frame].R * origin_offset;
    return T;
  };
  BodyPoses p;
  p.chassis = pose(kChassisFrame, -truck.chassis_cog_geometry_m);
  p.mast = pose(kMastFrame, Vector3d::Zero());
  p.carriage = pose(kCarriageFrame, Vector3d::Zero());
  for (int w = 0; w < kNumWheels; ++w) p.wheels[w] = pose(kWheelFrame[w], Vector3d::Zero());
  return p;
}

}  // namespace forklift
