// The equations of motion of section 10: M(q) q'' = Q(q, q') with the 4 driven coordinates
// moved by their filters, solved as eq (13), the driven forces as eq (14).
//
// M and Q come from the kinematics of the six bodies (chassis, three wheels, mast, fork
// carriage with its load) on a tree of single-coordinate joints, one per generalised
// coordinate, so nothing symbolic is needed at run time. Both are built in world axes about one
// reference point o, the chassis CoG (so lever arms stay the truck's size wherever it drives),
// without point Jacobians (their 13x3 products were two thirds of the cost):
//   M: the composite-rigid-body algorithm. Each frame's subtree is summed into one composite
//      (mass m, first moment h about o, rotational inertia J about o); joint j's motion S_j
//      (axis u_j, velocity at o) gives the composite's momentum, whose power on each joint i from
//      the world to j is M_ij.
//   Q: every force is a wrench (f, moment about o) on the frame it acts on: the applied forces,
//      gravity and the velocity-product ("bias") terms -m a0 and -(I alpha0 + w x I w), with a0,
//      alpha0 each body's accelerations with q'' = 0. Summed from the leaves to the root, the
//      wrench on frame j's subtree gives Q_j = S_j . W_j: the transposed Jacobian times the
//      forces, along the tree path, in one pass.
// Rotations are exact (the paper linearises auc, avc and beta; a tilt table needs more).
#include "forklift/dynamics/dynamics.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <cmath>

#include "ground_contact.h"

namespace forklift {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
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
    if (jt.type == JointType::kRevolute) {
      // Every axis is the parent's X, Y or Z (build_tree): the child turns the other two columns of R by qj
      // (a general angle-axis matrix and a 3x3 product cost ten times as much).
      const int a = jt.axis.x() != 0 ? 0 : jt.axis.y() != 0 ? 1 : 2, a1 = (a + 1) % 3, a2 = (a + 2) % 3;
      const double s = std::sin(qj), c = std::cos(qj);
      C.u = P.R.col(a);
      C.R.col(a) = P.R.col(a);
      C.R.col(a1) = c * P.R.col(a1) + s * P.R.col(a2);
      C.R.col(a2) = c * P.R.col(a2) - s * P.R.col(a1);
      C.p = P.p + P.R * jt.offset;
      const Vector3d r = C.p - P.p;
      C.w = P.w + C.u * qdj;
      C.v = P.v + P.w.cross(r);
      C.alpha0 = P.alpha0 + P.w.cross(C.u * qdj);
      C.a0 = P.a0 + P.alpha0.cross(r) + P.w.cross(P.w.cross(r));
    } else {
      C.u = P.R * jt.axis;
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

// Forces on the truck gathered per frame as a wrench about the reference point o.
struct Wrench {
  Vector3d f = Vector3d::Zero(), n = Vector3d::Zero();  // force, moment about o
};
using Wrenches = std::array<Wrench, kNumFrames>;

// Force f at world point x, on `frame`.
void add_force(Wrenches& w, int frame, const Vector3d& o, const Vector3d& x, const Vector3d& f) {
  w[frame].f += f;
  w[frame].n += (x - o).cross(f);
}

// Generalised forces of per-frame wrenches: summed into each frame's subtree (children come
// after parents), then projected on the joint's motion. Consumes `w`.
void generalised_forces(const Tree& tree, const Kinematics& k, const Vector3d& o, Wrenches& w, CoordVector& Q) {
  for (int j = kNumFrames - 1; j >= 0; --j) {
    const Joint& jt = tree.joints[j];
    const FrameState& F = k.f[j];
    Q[jt.coord] = jt.type == JointType::kRevolute ? F.u.dot(w[j].n - (F.p - o).cross(w[j].f)) : F.u.dot(w[j].f);
    if (jt.parent >= 0) {
      w[jt.parent].f += w[j].f;
      w[jt.parent].n += w[j].n;
    }
  }
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

// A wheel on the ground (section 7): where it touches, how deep, how the contact point slips,
// and the normal force, eq (7); the tyre's friction forces are the evaluation's.
struct ContactFrame {
  Vector3d n, axle, xw, yw, vs;  // ground normal, axle, rolling and lateral directions, slip velocity
  bool upright = false;          // a wheel lying flat has no rolling direction
};
ContactFrame wheel_on_ground(const FrameState& F, double radius, const Ground& ground, const ContactParams& cp,
                             WheelContact& c) {
  ContactFrame cf;
  double h;
  ground_under(ground, F.p, h, cf.n);
  cf.axle = F.R.col(1);
  const Vector3d& axle = cf.axle;
  const double height_over_ground = (F.p - Vector3d(F.p.x(), F.p.y(), h)).dot(cf.n);
  // The disc's lowest point lies the radius times the cosine of the camber below its centre, a
  // little to one side: a wheel lying on its side reaches no lower than its centre.
  const Vector3d down = -(cf.n - cf.n.dot(axle) * axle);
  const double reach = radius * down.norm();
  c.penetration_m = reach - height_over_ground;
  c.contact_point_m = F.p - height_over_ground * cf.n;
  if (reach > 1e-9 * radius) c.contact_point_m += radius * down / down.norm() + reach * cf.n;
  c.spring_energy_J = 0;
  if (c.penetration_m > 0) {
    // eq (7); the damper may not pull the wheel into the ground.
    c.fz_N = std::max(0.0, cp.stiffness_N_m * c.penetration_m - cp.damping_N_s_m * F.v.dot(cf.n));
    c.spring_energy_J = 0.5 * cp.stiffness_N_m * c.penetration_m * c.penetration_m;
  }
  // The rim against the edges and faces of steps and ramps beside the level under the centre: each
  // touch is a spring-damper of its own (a wheel against a kerb rests on the floor and on the
  // kerb's edge), and the tyre works on their resultant. Every touch's force points at the wheel's
  // centre, so the resultant is applied on the line through the centre, at the touches' mean
  // distance from it: it puts no torque on the wheel's spin.
  GroundTouch touch[kMaxGroundTouches];
  const int touches = ground.flat() ? 0 : wheel_edge_touches(ground, F.p, axle, reach, touch);
  if (touches > 0) {
    Vector3d force = c.fz_N * cf.n;
    double total = c.fz_N, distance = c.fz_N * (F.p - c.contact_point_m).norm();
    for (int i = 0; i < touches; ++i) {
      const GroundTouch& g = touch[i];
      const double f = std::max(0.0, cp.stiffness_N_m * g.depth_m - cp.damping_N_s_m * F.v.dot(g.normal));
      c.spring_energy_J += 0.5 * cp.stiffness_N_m * g.depth_m * g.depth_m;
      c.penetration_m = std::max(c.penetration_m, g.depth_m);
      force += f * g.normal;
      distance += f * (F.p - g.point_m).norm();
      total += f;
    }
    const double magnitude = force.norm();
    if (total > 0 && magnitude > 0) {
      c.fz_N = magnitude;
      cf.n = force / magnitude;
      c.contact_point_m = F.p - distance / total * cf.n;
    }
  }
  c.normal = cf.n;
  const Vector3d rolling = axle.cross(cf.n);
  cf.upright = rolling.norm() > 1e-6;
  cf.xw = cf.upright ? Vector3d(rolling.normalized()) : Vector3d(F.R.col(0));
  cf.yw = cf.n.cross(cf.xw);
  cf.vs = F.v + F.w.cross(c.contact_point_m - F.p);  // VS: the contact point on the wheel
  c.slip_x_m_s = cf.vs.dot(cf.xw);
  c.slip_y_m_s = cf.vs.dot(cf.yw);
  const double vwx = F.v.dot(cf.xw), vwy = F.v.dot(cf.yw);
  const double vfloor = cp.slip_angle_speed_floor_m_s;
  c.slip_angle_rad = sign(vwy) * std::atan(std::abs(vwy) / std::sqrt(vwx * vwx + vfloor * vfloor + 1e-12));
  c.on_ground = c.fz_N > 0;
  return cf;
}

// Everything evaluated at one state, shared by the derivative and the energy.
struct Evaluation {
  Kinematics kin;
  std::array<Body, 6> body;
  MassMatrix M;
  CoordVector Q;  // applied generalised forces minus the velocity-product terms
  CoordVector Q_applied;  // the part of Q from every force but gravity
  std::array<Eigen::Vector2d, kNumWheels> tyre_rate;  // bristle deflection rates (kBristle)
  std::array<double, 2> brake_stick_rate;              // brake bristle rates (front wheels)
};

double sq(double v) { return v * v; }

int frame_of(TruckBody body) {
  return body == TruckBody::kChassis ? kChassisFrame : body == TruckBody::kMast ? kMastFrame : kCarriageFrame;
}

}  // namespace

TruckDynamics::TruckDynamics(const TruckParams& truck, Environment env)
    : truck_(truck), env_(std::move(env)) {}

void TruckDynamics::attach_load(const Load& load) { load_ = load; }
void TruckDynamics::release_load() { load_.reset(); }

namespace {

// With `mass_only`, e.M alone (and the kinematics): the rest of e is left unset.
void evaluate(const TruckParams& t, const Environment& env, const std::optional<Load>& load,
              const StateVector& x, Evaluation& e, Outputs* out, bool mass_only = false) {
  const Tree tree = build_tree(t);  // 13 joints on the stack: cheaper than any cache
  const CoordVector q = coords(x), qd = rates(x);
  forward_kinematics(tree, q, qd, e.kin);
  e.body = bodies(t, load);
  e.M.setZero();
  e.Q.setZero();
  CoordVector& Qa = e.Q_applied;
  Qa.setZero();
  const Vector3d o = e.kin.f[kChassisFrame].p;  // the reference point of every wrench and inertia
  // Composite bodies per frame: mass, first moment about o, rotational inertia about o.
  std::array<double, kNumFrames> cm{};
  std::array<Vector3d, kNumFrames> ch;
  std::array<Matrix3d, kNumFrames> cJ;
  for (int j = 0; j < kNumFrames; ++j) { ch[j].setZero(); cJ[j].setZero(); }
  Wrenches inertial{}, applied{};  // -(bias) + gravity; everything else
  double mass = 0;
  Vector3d mass_moment = Vector3d::Zero();
  for (const Body& b : e.body) {
    const FrameState& F = e.kin.f[b.frame];
    const Vector3d rho = F.R * b.cog;
    const Vector3d c = F.p + rho, r = c - o;
    const Matrix3d I = F.R.lazyProduct(b.inertia).lazyProduct(F.R.transpose());
    cm[b.frame] += b.mass;
    ch[b.frame] += b.mass * r;
    cJ[b.frame] += I + b.mass * (r.squaredNorm() * Matrix3d::Identity() - r * r.transpose());
    const Vector3d a0 = F.a0 + F.alpha0.cross(rho) + F.w.cross(F.w.cross(rho));
    const Vector3d iw = I * F.w;
    const Vector3d f = b.mass * (env.gravity_m_s2 - a0);
    inertial[b.frame].f += f;
    inertial[b.frame].n += r.cross(f) - (I * F.alpha0 + F.w.cross(iw));
    mass += b.mass;
    mass_moment += b.mass * c;
  }
  // Composite-rigid-body algorithm: subtree composites from the leaves, then M_ij for each joint
  // i on the path from the world to j from the momentum of j's composite moving with joint j.
  for (int j = kNumFrames - 1; j > 0; --j) {
    const int p = tree.joints[j].parent;
    cm[p] += cm[j];
    ch[p] += ch[j];
    cJ[p] += cJ[j];
  }
  for (int j = 0; j < kNumFrames; ++j) {
    const Joint& jt = tree.joints[j];
    const FrameState& F = e.kin.f[j];
    Vector3d L, H;  // momentum of the composite moving with joint j at unit rate: linear, about o
    if (jt.type == JointType::kRevolute) {
      const Vector3d v = (F.p - o).cross(F.u);  // velocity of the point at o
      L = cm[j] * v + F.u.cross(ch[j]);
      H = cJ[j] * F.u + ch[j].cross(v);
    } else {
      L = cm[j] * F.u;
      H = ch[j].cross(F.u);
    }
    for (int i = 0; i <= j; ++i) {
      if (!(tree.path[j] & (1u << i))) continue;
      const Joint& ji = tree.joints[i];
      const FrameState& Fi = e.kin.f[i];
      const double mij = ji.type == JointType::kRevolute ? Fi.u.dot(H - (Fi.p - o).cross(L)) : Fi.u.dot(L);
      e.M(ji.coord, jt.coord) = e.M(jt.coord, ji.coord) = mij;
    }
  }
  // Motor rotors and gears spin with the front wheels relative to the chassis (section 6's two
  // motors): their inertia, reflected through the gear ratio, sits on the wheels' own coordinates.
  e.M(kAvr1, kAvr1) += t.drive.drivetrain_inertia_kg_m2;
  e.M(kAvr2, kAvr2) += t.drive.drivetrain_inertia_kg_m2;
  if (mass_only) return;
  generalised_forces(tree, e.kin, o, inertial, e.Q);

  // Ground-to-wheel forces, section 7, each applied at its contact point to the wheel.
  const ContactParams& cp = t.contact;
  const bool bristle = cp.tyre != TyreModel::kPaper, peak = cp.tyre == TyreModel::kGripPeak;
  std::array<WheelContact, kNumWheels> wc{};
  for (int w = 0; w < kNumWheels; ++w) {
    const FrameState& F = e.kin.f[kWheelFrame[w]];
    WheelContact& c = wc[w];
    const double radius = t.wheels[w].radius_m;
    const ContactFrame cf = wheel_on_ground(F, radius, env.ground, cp, c);
    const Vector3d &n = cf.n, &axle = cf.axle, &xw = cf.xw, &yw = cf.yw, &vs = cf.vs;
    const bool upright = cf.upright;
    // A spill under the tyre scales its friction, whichever tyre law is in use.
    const double grip = env.ground.grip(c.contact_point_m.x(), c.contact_point_m.y(), env.grip_patches_absent);
    e.tyre_rate[w].setZero();
    double stribeck = 0, mu = 0;
    if (bristle) {
      // The averaged LuGre brush: the deflection z builds with the slip and relaxes while sliding
      // (|v| / g) and while rolling (over the relaxation length), so it is a spring at rest.
      const Eigen::Vector2d z = x.segment<2>(StateIndex::kTyre + 2 * w);
      const double v = std::hypot(c.slip_x_m_s, c.slip_y_m_s);
      stribeck = std::exp(-sq(v / cp.stribeck_speed_m_s));
      const double rolling = std::abs(F.w.dot(axle) * radius);
      const double relax = rolling / cp.relaxation_length_m;
      if (peak) {
        // Grip as a function of the slip (Pacejka's and TMeasy's shape): the peak up to slip_peak,
        // a smoothstep down to the sliding value. The bristle relaxes by whichever is faster,
        // sliding or rolling (a rounded maximum, |.|_4), so the steady force is the brush's
        // sigma0 L s below the grip and the grip above it, with a rounded corner between.
        const double s = v / (rolling + cp.slip_angle_speed_floor_m_s);
        const double u = std::clamp((s - cp.slip_peak) / (cp.slip_sliding - cp.slip_peak), 0.0, 1.0);
        mu = grip * (cp.mu_static - (cp.mu_static - cp.mu_sliding) * u * u * (3 - 2 * u));
        auto rate = [&](double sigma0) {
          const double slide = sigma0 * v / mu;
          return std::sqrt(std::sqrt(sq(sq(slide)) + sq(sq(relax))));
        };
        e.tyre_rate[w] = Eigen::Vector2d(c.slip_x_m_s - rate(cp.bristle_stiffness_x_per_m) * z.x(),
                                         c.slip_y_m_s - rate(cp.bristle_stiffness_y_per_m) * z.y());
      } else {
        mu = grip * (cp.mu_sliding + (cp.mu_static - cp.mu_sliding) * stribeck);
        e.tyre_rate[w] = Eigen::Vector2d(c.slip_x_m_s - (cp.bristle_stiffness_x_per_m * v / mu + relax) * z.x(),
                                         c.slip_y_m_s - (cp.bristle_stiffness_y_per_m * v / mu + relax) * z.y());
      }
    }
    Vector3d force = c.fz_N * n;
    if (env.chock_anchors_m) {
      const Eigen::Vector2d dp = c.contact_point_m.head<2>() - (*env.chock_anchors_m)[w];
      constexpr double kChockStiffness = 2e6, kChockDamping = 2e4;  // a rigid chock, numerically soft
      force.head<2>() += -kChockStiffness * dp - kChockDamping * vs.head<2>();
    } else if (c.on_ground && upright) {
      if (bristle) {
        const Eigen::Vector2d z = x.segment<2>(StateIndex::kTyre + 2 * w), zd = e.tyre_rate[w];
        const double damping = cp.bristle_damping_s_m * stribeck;  // damps sticking, not sliding
        c.fx_N = -c.fz_N * (cp.bristle_stiffness_x_per_m * z.x() + damping * zd.x());
        c.fy_N = -c.fz_N * (cp.bristle_stiffness_y_per_m * z.y() + damping * zd.y());
        c.friction_use = std::hypot(c.fx_N, c.fy_N) / (mu * c.fz_N);
        c.grip_share = std::hypot(c.fx_N, c.fy_N) / (grip * cp.mu_static * c.fz_N);
      } else {
        const double fx_max = grip * cp.fx_max_N, fy_mu = grip * cp.fy_mu;
        c.fx_N = std::clamp(-c.fz_N * cp.fx_slip_gain_s_m * c.slip_x_m_s, -fx_max, fx_max);  // eq (8)
        const double a0 = cp.fy_alpha0_rad;  // eq (10)
        c.fy_N = std::abs(c.slip_angle_rad) <= a0 ? -fy_mu * c.fz_N * std::sin(M_PI * c.slip_angle_rad / (2 * a0))
                                                  : -fy_mu * c.fz_N * sign(c.slip_angle_rad);
        c.grip_share = std::max(std::abs(c.fx_N) / fx_max, std::abs(c.fy_N) / (fy_mu * c.fz_N));
      }
      force += c.fx_N * xw + c.fy_N * yw;
    }
    if (bristle) {
      // The brush's force is its load times its deflection, so a load rising on a deflected tyre
      // would raise the force, and the energy Fz sigma0 z^2 / 2 it holds, out of nothing. Where the
      // patch grows, new tread enters it undeflected: the mean deflection falls as Fz' / Fz (Fz'
      // taken as the spring's K pen', which keeps the rate below K / C), and the force holds. Off
      // the ground there is no patch: the tread springs back, in the vertical contact's C / K.
      const Eigen::Vector2d z = x.segment<2>(StateIndex::kTyre + 2 * w);
      if (!env.chock_anchors_m && c.on_ground && upright)  // where the tread's force acts
        c.tread_energy_J = 0.5 * c.fz_N * (cp.bristle_stiffness_x_per_m * sq(z.x()) + cp.bristle_stiffness_y_per_m * sq(z.y()));
      if (c.on_ground)
        e.tyre_rate[w] -= cp.stiffness_N_m * std::max(0.0, -F.v.dot(n)) / c.fz_N * z;
      else if (cp.damping_N_s_m > 0)
        e.tyre_rate[w] = -cp.stiffness_N_m / cp.damping_N_s_m * z;
    }
    add_force(applied, kWheelFrame[w], o, c.contact_point_m, force);
    // eq (6), rolling resistance, a torque from the ground on the wheel; the viscous part fades in
    // with the first 1000 N of load so that it vanishes, continuously, as the wheel leaves the
    // ground; the Coulomb part is proportional to the load.
    const double spin = qd[kAvr1 + w];
    c.rolling_torque_N_m = -cp.rolling_resistance_N_m_s * spin * std::min(1.0, c.fz_N / 1000.0) -
                           cp.rolling_resistance_coefficient * c.fz_N * radius *
                               std::tanh(spin / cp.rolling_resistance_speed_rad_s);
    applied[kWheelFrame[w]].n += c.rolling_torque_N_m * axle;
  }

  // The body on the ground: a tipped truck rests on its guard, counterweight, mast or forks.
  const BodyGroundContact& bc = t.body_contact;
  int touching = 0;
  double deepest = 0;
  // A penalty force with friction where a part of body `frame` is `g.depth_m` into the ground.
  auto press = [&](int frame, const GroundTouch& g) {
    const FrameState& F = e.kin.f[frame];
    const Vector3d& p = g.point_m;
    const Vector3d& n = g.normal;
    ++touching;
    deepest = std::max(deepest, g.depth_m);
    const Vector3d v = F.v + F.w.cross(p - F.p);
    const double vn = v.dot(n);
    const double fn = std::max(0.0, bc.stiffness_N_m * g.depth_m - bc.damping_N_s_m * vn);  // never pulls
    const Vector3d vt = v - vn * n;
    const Vector3d f = fn * n - bc.mu * fn / std::sqrt(vt.squaredNorm() + sq(bc.friction_speed_m_s)) * vt;
    add_force(applied, frame, o, p, f);
  };
  auto touch = [&](int frame, const Vector3d& local) {
    const FrameState& F = e.kin.f[frame];
    GroundTouch g;
    if (point_touch(env.ground, F.p + F.R * local, g)) press(frame, g);
  };
  // Steps' top edges passing between the points: a belly on a dock's edge, a fork across a kerb.
  if (bc.stiffness_N_m > 0 && !env.ground.steps().empty())
    for (const BodyEdgeBox& b : bc.edge_boxes) {
      const int frame = frame_of(b.body);
      GroundTouch g[kMaxGroundTouches];
      const int n = box_edge_touches(env.ground, e.kin.f[frame].R, e.kin.f[frame].p, b.min_m, b.max_m, g);
      for (int i = 0; i < n; ++i) press(frame, g[i]);
    }
  if (bc.stiffness_N_m > 0) {
    for (const BodyContactPoint& p : bc.points)
      touch(frame_of(p.body), p.point_m);
    if (load && load->mass_kg > 0 && load->size_m.minCoeff() > 0)
      for (int k = 0; k < 8; ++k)
        touch(kCarriageFrame, load->cog_m + 0.5 * Vector3d(k & 1 ? 1 : -1, k & 2 ? 1 : -1, k & 4 ? 1 : -1)
                                                     .cwiseProduct(load->size_m));
  }

  // The scene pushing back where the truck touches it (contacts, held for the tick).
  for (const ExternalForce& f : env.external_forces) add_force(applied, frame_of(f.body), o, f.point_m, f.force_N);
  generalised_forces(tree, e.kin, o, applied, Qa);

  // Drive torque (section 6) and brake torque (section 8) act between chassis and front wheels,
  // so they are generalised forces on the wheels' relative spin coordinates alone.
  const DriveParams& dp = t.drive;
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
  const double forward_speed = forklift::forward_speed(x);
  // The speed governor: full torque up to the band below the cap, none at it, braking above.
  const double governor =
      std::isfinite(dp.speed_max_m_s)
          ? std::clamp((dp.speed_max_m_s - sign(M) * forward_speed) / dp.speed_governor_band_m_s, -1.0, 1.0)
          : 1.0;
  wc[kFrontLeft].drive_torque_N_m = m1 * governor;
  wc[kFrontRight].drive_torque_N_m = m2 * governor;
  const double b = std::max(0.0, x[StateIndex::kBrake]);
  for (int w : {kFrontLeft, kFrontRight}) {
    const double spin = qd[kAvr1 + w];
    double& drive = wc[w].drive_torque_N_m;
    drive = std::clamp(drive, -dp.motor_torque_max_N_m, dp.motor_torque_max_N_m);
    if (drive * spin > 0) drive = sign(drive) * std::min(std::abs(drive), dp.motor_power_max_W / std::abs(spin));
    if (dp.brake_stick_angle_rad > 0) {
      const double s = x[StateIndex::kBrakeStick + w];
      e.brake_stick_rate[w] = (spin - std::abs(spin) * s) / dp.brake_stick_angle_rad;
      wc[w].brake_torque_N_m = -b * (s + dp.brake_stick_damping_s * e.brake_stick_rate[w]);
    } else {
      e.brake_stick_rate[w] = 0;
      wc[w].brake_torque_N_m = -b * std::tanh(spin / dp.brake_fade_speed_rad_s);
    }
    Qa[kAvr1 + w] += drive + wc[w].brake_torque_N_m;
  }
  e.Q += Qa;

  if (out) {
    out->q = q;
    out->qdot = qd;
    out->wheels = wc;
    out->total_mass_kg = mass;
    out->cog_m = mass_moment / mass;
    out->forward_speed_m_s = forward_speed;
    out->body_points_on_ground = touching;
    out->body_penetration_max_m = deepest;
    out->applied_power_W = Qa.dot(qd);
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

// Eigen's allFinite() on a state, in one vectorised sum: x - x is 0 for a finite entry and NaN
// otherwise (its unrolled compare-and-reduce cost 2% of an evaluation, twice per call).
bool all_finite(const StateVector& x) { return (x - x).sum() == 0; }

// M = L L^T for the 9 dynamic coordinates (M symmetric positive definite, its lower triangle
// read), unrolled: Eigen's LLT took a fifth of an evaluation in its blocked and triangular-solve
// kernels at this size.
class Cholesky9 {
 public:
  static constexpr int n = kNumDynamic;
  using Vector = Eigen::Matrix<double, n, 1>;

  // False if M is not positive definite.
  template <typename Lower>
  bool factorise(const Lower& M) {
    for (int j = 0; j < n; ++j) {
      double d = M(j, j);
      for (int k = 0; k < j; ++k) d -= L_[j][k] * L_[j][k];
      if (!(d > 0)) return false;
      const double inv = 1.0 / std::sqrt(d);
      inv_diag_[j] = inv;
      for (int i = j + 1; i < n; ++i) {
        double v = M(i, j);
        for (int k = 0; k < j; ++k) v -= L_[i][k] * L_[j][k];
        L_[i][j] = v * inv;
      }
    }
    return true;
  }

  // M x = b, in place.
  void solve(Vector& b) const {
    for (int i = 0; i < n; ++i) {  // L y = b
      double v = b[i];
      for (int k = 0; k < i; ++k) v -= L_[i][k] * b[k];
      b[i] = v * inv_diag_[i];
    }
    for (int i = n - 1; i >= 0; --i) {  // L^T x = y
      double v = b[i];
      for (int k = i + 1; k < n; ++k) v -= L_[k][i] * b[k];
      b[i] = v * inv_diag_[i];
    }
  }

 private:
  double L_[n][n];
  double inv_diag_[n];
};

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
  if (!all_finite(x)) return false;
  Evaluation e;
  evaluate(truck_, env_, load_, x, e, out);

  // Driven coordinates: third-order filters so that z, z', z'' stay continuous (section 12).
  const MastLimits& lim = truck_.limits;
  Eigen::Vector4d zdd;
  const SteerParams& steer = truck_.steer;
  const double ws = steer.bandwidth_rad_s, wl = truck_.lever_bandwidth_rad_s;
  for (int d = 0; d < kNumDriven; ++d) {
    const int i = StateIndex::kDriven + 3 * d;
    const double z = x[i], zd = x[i + 1], za = x[i + 2];
    dx[i] = zd;
    dx[i + 1] = za;
    if (d == 0) {  // steer, driven by position
      const double target = std::clamp(u.steer_rad, -steer.max_rad, steer.max_rad);
      if (std::isfinite(steer.rate_max_rad_s)) {
        // A rate-limited servo: the rate asked for is the position error times ws / 8 (a gain
        // that keeps the loop's three poles real, so the wheel never overshoots an end stop),
        // clamped to the limit; the rate follows it through a critically damped filter, whose
        // non-negative impulse response keeps |z'| within the limit too.
        const double rate = std::clamp(ws / 8 * (target - z), -steer.rate_max_rad_s, steer.rate_max_rad_s);
        dx[i + 2] = ws * ws * (rate - zd) - 2 * ws * za;
      } else {
        dx[i + 2] = ws * ws * ws * (target - z) - 3 * ws * ws * zd - 3 * ws * za;
      }
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
  Eigen::Matrix<double, kNumDynamic, 1> qdd = e.Q.head<kNumDynamic>() - Mid * zdd;
  Cholesky9 chol;
  if (!chol.factorise(Mii)) return false;
  chol.solve(qdd);

  dx.segment<kNumDynamic>(StateIndex::kQ) = x.segment<kNumDynamic>(StateIndex::kQdot);
  dx.segment<kNumDynamic>(StateIndex::kQdot) = qdd;

  // First-order lags on the drive and brake demands (section 8).
  const DriveParams& dp = truck_.drive;
  const double torque = std::clamp(u.drive_torque_N_m, -dp.drive_torque_max_N_m, dp.drive_torque_max_N_m);
  double brake = std::clamp(u.brake_torque_N_m, 0.0, dp.brake_torque_max_N_m);
  if (u.parking_brake) brake = std::max(brake, dp.parking_brake_torque_N_m);
  dx[StateIndex::kTorque] = (torque - x[StateIndex::kTorque]) / dp.torque_lag_s;
  dx[StateIndex::kBrake] = (brake - x[StateIndex::kBrake]) / dp.brake_lag_s;
  for (int w = 0; w < kNumWheels; ++w) dx.segment<2>(StateIndex::kTyre + 2 * w) = e.tyre_rate[w];
  dx[StateIndex::kBrakeStick] = e.brake_stick_rate[0];
  dx[StateIndex::kBrakeStick + 1] = e.brake_stick_rate[1];

  if (out) {
    out->qddot.head<kNumDynamic>() = qdd;
    out->qddot.tail<kNumDriven>() = zdd;
    // Eq (14) with the actuator's sign: the force it must apply to follow z''.
    out->driven_force = e.M.bottomLeftCorner<kNumDriven, kNumDynamic>() * qdd +
                        e.M.bottomRightCorner<kNumDriven, kNumDriven>() * zdd - e.Q.tail<kNumDriven>();
    out->applied_power_W += out->driven_force.dot(out->qdot.tail<kNumDriven>());
    // The carriage's acceleration: its velocity-product part plus each joint on its path's
    // acceleration, now known.
    const Tree tree = build_tree(truck_);
    const FrameState& C = e.kin.f[kCarriageFrame];
    FrameMotion& m = out->carriage;
    m = FrameMotion{C.R, C.p, C.v, C.a0, C.w, C.alpha0};
    for (int j = 0; j < kNumFrames; ++j) {
      if (!(tree.path[kCarriageFrame] & (1u << j))) continue;
      const Joint& jt = tree.joints[j];
      const FrameState& F = e.kin.f[j];
      const double acc = out->qddot[jt.coord];
      if (jt.type == JointType::kRevolute) {
        m.alpha += F.u * acc;
        m.a += F.u.cross(C.p - F.p) * acc;
      } else {
        m.a += F.u * acc;
      }
    }
  }
  return all_finite(dx);
}

bool TruckDynamics::driven_coupling(const StateVector& x,
                                    Eigen::Matrix<double, kNumDynamic, kNumDriven>& dqdd_dzdd) const {
  if (!all_finite(x)) return false;
  Evaluation e;
  evaluate(truck_, env_, load_, x, e, nullptr, /*mass_only=*/true);
  Cholesky9 chol;
  if (!chol.factorise(e.M.topLeftCorner<kNumDynamic, kNumDynamic>())) return false;
  for (int d = 0; d < kNumDriven; ++d) {
    Cholesky9::Vector c = -e.M.block<kNumDynamic, 1>(0, kNumDynamic + d);
    chol.solve(c);
    dqdd_dzdd.col(d) = c;
  }
  return dqdd_dzdd.allFinite();
}

double TruckDynamics::energy(const StateVector& x, bool with_ground_springs) const {
  Evaluation e;
  Outputs out;
  evaluate(truck_, env_, load_, x, e, &out);
  const CoordVector qd = rates(x);
  double energy = 0.5 * qd.dot(e.M * qd);
  for (const Body& b : e.body) {
    const FrameState& F = e.kin.f[b.frame];
    energy -= b.mass * env_.gravity_m_s2.dot(F.p + F.R * b.cog);
  }
  if (with_ground_springs)
    for (const WheelContact& c : out.wheels) energy += c.spring_energy_J + c.tread_energy_J;
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
    // Accelerations of the free coordinates with every other one held (wheels locked, and the
    // truck held in place unless chocked), so the residual is well scaled (m/s^2, rad/s^2).
    Eigen::MatrixXd Mff(n, n);
    Eigen::VectorXd Qf(n);
    for (int i = 0; i < n; ++i) {
      Qf[i] = e.Q[free[i]];
      for (int j = 0; j < n; ++j) Mff(i, j) = e.M(free[i], free[j]);
    }
    return Eigen::VectorXd(Mff.llt().solve(Qf));
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

double forward_speed(const StateVector& x) {
  const double yaw = x[StateIndex::kQ + kAwc];
  return std::cos(yaw) * x[StateIndex::kQdot + kX] + std::sin(yaw) * x[StateIndex::kQdot + kY];
}

std::array<double, kNumWheels> TruckDynamics::wheel_loads_N(const StateVector& x) const {
  const Tree tree = build_tree(truck_);
  Kinematics k;
  forward_kinematics(tree, coords(x), rates(x), k);
  std::array<double, kNumWheels> fz;
  for (int w = 0; w < kNumWheels; ++w) {
    WheelContact c;
    wheel_on_ground(k.f[kWheelFrame[w]], truck_.wheels[w].radius_m, env_.ground, truck_.contact, c);
    fz[w] = c.fz_N;
  }
  return fz;
}

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
