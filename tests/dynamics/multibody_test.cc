// Independent checks of the multibody core (sim/dynamics/src/dynamics.cc): the mass matrix, the
// velocity-product terms and gravity's generalised force, each against a computation that does not
// use the model's Jacobians or its bias accelerations.
//
// - The kinetic energy T(q, q') is rebuilt here from body_poses() alone: each body's CoG velocity
//   and angular velocity are the derivative of its world pose along q' (an 8th-order central
//   difference), its mass properties come straight from TruckParams and the Load. T is quadratic
//   in q', so M_ij follows from T at unit and pair velocity vectors (polarisation). The one term
//   no pose shows, the drivetrain inertia reflected to each front wheel's spin
//   (DriveParams::drivetrain_inertia_kg_m2), is added to those two diagonal entries from the field.
// - Lagrange: with no applied force (gravity zero, truck in the air: no wheel and no body contact
//   point on the ground; no drive or brake torque) the model's Q is
//   minus the velocity-product terms, Q = -(M' q' - dT/dq) = -(dM/dt q' - 1/2 q'^T dM/dq q'),
//   here from finite differences of the model's own M(q).
// - Gravity: Q = -dV/dq with V = -sum m g . c over the bodies (c from body_poses), by differences.
//
// Errors are measured in mass-normalised coordinates (coordinate i scaled by sqrt(M_ii)), so that
// metres, radians, the truck's tonnes and the wheels' 0.5 kg m^2 of spin inertia weigh alike:
//   mass matrix:  max_ij |dM_ij| / sqrt(M_ii M_jj)   (zero entries such as M(x, avr1) included),
//   forces:       max_i |dQ_i| / sqrt(M_ii)  over  max_i |Q_i| / sqrt(M_ii).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <random>
#include <vector>

#include "forklift/dynamics/dynamics.h"
#include "test_truck.h"

using namespace forklift;

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Eigen::VectorXd;
using Mat13 = Eigen::Matrix<double, kNumCoords, kNumCoords>;

// d/de f(e) at e = 0 by the 8th-order central difference (truncation ~ h^8 f^(9) / 630).
template <class T, class F>
T derivative8(const F& f, double h) {
  static constexpr double c[4] = {4.0 / 5, -1.0 / 5, 4.0 / 105, -1.0 / 280};
  T d = c[0] * (f(h) - f(-h));
  for (int k = 1; k < 4; ++k) d += c[k] * (f((k + 1) * h) - f(-(k + 1) * h));
  return d / h;
}
// Steps: poses and M(q) are built from sines, cosines and lever arms of a few metres, so with
// rates of order 1 the truncation at h = 0.02 is ~1e-14 and the rounding ~1e-14 x |position|.
constexpr double kPoseStep = 0.02;
constexpr double kMassMatrixStep = 0.02;

// One rigid body as this file sees it: which pose of body_poses() carries it, its mass, its CoG in
// that pose's frame and its inertia about the CoG in that pose's axes.
enum PoseId { kChassisPose, kMastPose, kCarriagePose, kWheelPose0 };
struct MassBody {
  int pose;
  double mass;
  Vector3d cog;
  Matrix3d inertia;
};

const Eigen::Isometry3d& pose_of(const BodyPoses& p, int id) {
  if (id == kChassisPose) return p.chassis;
  if (id == kMastPose) return p.mast;
  if (id == kCarriagePose) return p.carriage;
  return p.wheels[id - kWheelPose0];
}

// The load is kept as a body of its own on the carriage pose (rather than merged into the
// carriage): the kinetic energy of the pair is that of the merged body the model builds, so the
// merge (section 5) is checked too.
std::vector<MassBody> mass_bodies(const TruckParams& t, const Load* load) {
  std::vector<MassBody> b;
  // Chassis pose origin = geometry frame origin; its CoG sits at chassis_cog_geometry_m there.
  b.push_back({kChassisPose, t.chassis.mass_kg, t.chassis_cog_geometry_m, t.chassis.inertia_kg_m2});
  for (int w = 0; w < kNumWheels; ++w) {
    const WheelParams& wp = t.wheels[w];
    b.push_back({kWheelPose0 + w, wp.mass_kg, Vector3d::Zero(),
                 Vector3d(wp.transverse_inertia_kg_m2, wp.spin_inertia_kg_m2, wp.transverse_inertia_kg_m2).asDiagonal()});
  }
  b.push_back({kMastPose, t.mast.mass_kg, t.mast.cog_m, t.mast.inertia_kg_m2});             // from the pivot
  b.push_back({kCarriagePose, t.carriage.mass_kg, t.carriage.cog_m, t.carriage.inertia_kg_m2});  // from the heel
  if (load && load->mass_kg > 0) b.push_back({kCarriagePose, load->mass_kg, load->cog_m, load->inertia_kg_m2});
  return b;
}

// Every body's CoG (world) and rotation matrix, packed: 12 numbers a body.
VectorXd sample(const TruckParams& t, const std::vector<MassBody>& bodies, const CoordVector& q) {
  const BodyPoses p = body_poses(t, q);
  VectorXd s(12 * bodies.size());
  for (size_t i = 0; i < bodies.size(); ++i) {
    const Eigen::Isometry3d& T = pose_of(p, bodies[i].pose);
    s.segment<3>(12 * i) = T * bodies[i].cog;
    Eigen::Map<Matrix3d>(s.data() + 12 * i + 3) = T.linear();
  }
  return s;
}

// T(q, v): every body's CoG velocity and angular velocity from its pose differentiated along v.
double kinetic_energy(const TruckParams& t, const std::vector<MassBody>& bodies, const CoordVector& q,
                      const CoordVector& v) {
  const VectorXd s0 = sample(t, bodies, q);
  const VectorXd ds = derivative8<VectorXd>([&](double e) { return sample(t, bodies, q + e * v); }, kPoseStep);
  double T = 0;
  for (size_t i = 0; i < bodies.size(); ++i) {
    const Vector3d cdot = ds.segment<3>(12 * i);
    const Matrix3d R = Eigen::Map<const Matrix3d>(s0.data() + 12 * i + 3);
    const Matrix3d W = Eigen::Map<const Matrix3d>(ds.data() + 12 * i + 3) * R.transpose();  // [w]x
    const Vector3d w(0.5 * (W(2, 1) - W(1, 2)), 0.5 * (W(0, 2) - W(2, 0)), 0.5 * (W(1, 0) - W(0, 1)));
    T += 0.5 * bodies[i].mass * cdot.squaredNorm() + 0.5 * w.dot(R * bodies[i].inertia * R.transpose() * w);
  }
  return T;
}

// M from T by polarisation: M_ii = 2 T(e_i); for a pair, v = a e_i + b e_j with a, b chosen so that
// both coordinates carry about the same energy (keeps the cancellation small):
// M_ij = (2 T(v) - a^2 M_ii - b^2 M_jj) / (2 a b).
Mat13 kinetic_energy_hessian(const TruckParams& t, const std::vector<MassBody>& bodies, const CoordVector& q) {
  Mat13 K = Mat13::Zero();
  for (int i = 0; i < kNumCoords; ++i) K(i, i) = 2 * kinetic_energy(t, bodies, q, CoordVector::Unit(i));
  for (int i = 0; i < kNumCoords; ++i)
    for (int j = i + 1; j < kNumCoords; ++j) {
      const double si = 1 / std::sqrt(K(i, i)), sj = 1 / std::sqrt(K(j, j)), smax = std::max(si, sj);
      const double a = si / smax, b = sj / smax;
      const CoordVector v = a * CoordVector::Unit(i) + b * CoordVector::Unit(j);
      K(i, j) = K(j, i) = (2 * kinetic_energy(t, bodies, q, v) - a * a * K(i, i) - b * b * K(j, j)) / (2 * a * b);
    }
  return K;
}

double potential(const std::vector<MassBody>& bodies, const TruckParams& t, const CoordVector& q, const Vector3d& g) {
  const BodyPoses p = body_poses(t, q);
  double V = 0;
  for (const MassBody& b : bodies) V -= b.mass * g.dot(pose_of(p, b.pose) * b.cog);
  return V;
}

StateVector make_state(const CoordVector& q, const CoordVector& qd) {
  StateVector x = StateVector::Zero();  // z'' of the filters, drive and brake torque all zero
  x.segment<kNumDynamic>(StateIndex::kQ) = q.head<kNumDynamic>();
  x.segment<kNumDynamic>(StateIndex::kQdot) = qd.head<kNumDynamic>();
  for (int d = 0; d < kNumDriven; ++d) {
    x[StateIndex::kDriven + 3 * d] = q[kNumDynamic + d];
    x[StateIndex::kDriven + 3 * d + 1] = qd[kNumDynamic + d];
  }
  return x;
}

// A random configuration; `lifted` puts the truck 1.5 m up so no wheel touches the flat ground.
CoordVector random_q(std::mt19937& rng, const TruckParams& t, bool lifted) {
  std::uniform_real_distribution<double> u(-1, 1);
  CoordVector q;
  q[kX] = 20 * u(rng);
  q[kY] = 20 * u(rng);
  q[kZ] = t.chassis_cog_geometry_m.z() + (lifted ? 1.5 : 0.0) + 0.1 * u(rng);
  q[kAwc] = M_PI * u(rng);
  q[kAuc] = 0.4 * u(rng);  // exact rotations: a tilt table's angles and beyond
  q[kAvc] = 0.4 * u(rng);
  for (int w = 0; w < kNumWheels; ++w) q[kAvr1 + w] = 10 * u(rng);
  q[kAwr3] = 1.5 * u(rng);
  const MastLimits& lim = t.limits;
  q[kBeta] = 0.5 * (lim.tilt_forward_max_rad - lim.tilt_backward_max_rad) +
             0.5 * (lim.tilt_forward_max_rad + lim.tilt_backward_max_rad) * u(rng);
  q[kS] = lim.lift_max_m * 0.5 * (1 + u(rng));
  q[kR] = lim.side_shift_max_m * u(rng);
  return q;
}

// Random rates of a driving, turning, lifting truck (driven coordinates included).
CoordVector random_qd(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  CoordVector qd;
  qd << 3 * u(rng), 3 * u(rng), 0.5 * u(rng), 1.0 * u(rng), 0.5 * u(rng), 0.5 * u(rng),
      20 * u(rng), 20 * u(rng), 25 * u(rng), 1.0 * u(rng), 0.1 * u(rng), 0.45 * u(rng), 0.1 * u(rng);
  return qd;
}

Matrix3d random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> n;
  return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
}

// A box of random mass, size and place on the forks; with `full_inertia` also turned on them, so
// that its inertia has products and the CoG leaves the fork plane's axes.
Load random_load(std::mt19937& rng, bool full_inertia) {
  std::uniform_real_distribution<double> u01(0, 1);
  Load l = box_load(200 + 1400 * u01(rng), 0.8 + 0.6 * u01(rng), 0.8 + 0.4 * u01(rng), 0.5 + 1.0 * u01(rng),
                    0.4 + 0.4 * u01(rng), 0.4 * (2 * u01(rng) - 1));
  if (full_inertia) {
    const Matrix3d R = random_rotation(rng);
    l.inertia_kg_m2 = R * l.inertia_kg_m2 * R.transpose();
    l.cog_m += Vector3d(0.1, -0.05, 0.2) * (2 * u01(rng) - 1);
  }
  return l;
}

// The shipped truck with its diagonal inertias turned (products of inertia everywhere) and the
// mast's and carriage's CoGs moved off their centre planes: conventions that a diagonal,
// symmetric truck would not reveal (R I R' against R' I R, a CoG's axes, signs of products).
TruckParams asymmetric_truck() {
  TruckParams t = shipped_truck();
  auto turn = [](Matrix3d& I, const Vector3d& rotvec) {
    const Matrix3d R = Eigen::AngleAxisd(rotvec.norm(), rotvec.normalized()).toRotationMatrix();
    I = R * I * R.transpose();
  };
  turn(t.chassis.inertia_kg_m2, Vector3d(0.3, -0.5, 0.7));
  turn(t.mast.inertia_kg_m2, Vector3d(-0.6, 0.2, 0.4));
  turn(t.carriage.inertia_kg_m2, Vector3d(0.5, 0.8, -0.3));
  t.mast.cog_m += Vector3d(0.04, 0.06, -0.1);
  t.carriage.cog_m += Vector3d(-0.05, -0.08, 0.12);
  t.drive.drivetrain_inertia_kg_m2 = 2.7;  // whatever the data file says: non-zero here
  return t;
}

// Mass-normalised max-norm errors (see the file comment); D is the diagonal used to normalise.
double matrix_error(const Mat13& A, const Mat13& B, const CoordVector& D) {
  double e = 0;
  for (int i = 0; i < kNumCoords; ++i)
    for (int j = 0; j < kNumCoords; ++j) e = std::max(e, std::abs(A(i, j) - B(i, j)) / std::sqrt(D[i] * D[j]));
  return e;
}
double force_error(const CoordVector& Q, const CoordVector& Qref, const CoordVector& D) {
  const CoordVector s = D.cwiseSqrt().cwiseInverse();
  return (Q - Qref).cwiseProduct(s).cwiseAbs().maxCoeff() / Qref.cwiseProduct(s).cwiseAbs().maxCoeff();
}

bool in_the_air(const Outputs& o) {
  for (const WheelContact& c : o.wheels)
    if (c.on_ground || c.penetration_m >= 0 || c.fz_N != 0) return false;
  return o.body_points_on_ground == 0;
}

// The mass-matrix check on one truck at `n` random states (the first one unladen).
void check_mass_matrix(const TruckParams& truck, bool full_inertia_loads, unsigned seed, int n, const char* what) {
  std::mt19937 rng(seed);
  double worst = 0, worst_plain = 0;
  for (int k = 0; k < n; ++k) {
    TruckDynamics d(truck);
    std::optional<Load> load;
    if (k > 0) {
      load = random_load(rng, full_inertia_loads);
      d.attach_load(*load);
    }
    const CoordVector q = random_q(rng, truck, false);
    Mat13 M;
    CoordVector Q;
    d.mass_matrix_and_forces(make_state(q, random_qd(rng)), M, Q);
    Mat13 K = kinetic_energy_hessian(truck, mass_bodies(truck, load ? &*load : nullptr), q);

    // Motor rotors and gears reflected to the front wheels' spin (DriveParams): a constant that no
    // body pose shows, on the two spin diagonals alone. Added here from the truck's own field, so
    // the whole of M is compared; the rest of the two diagonals is still the wheels' own.
    K(kAvr1, kAvr1) += truck.drive.drivetrain_inertia_kg_m2;
    K(kAvr2, kAvr2) += truck.drive.drivetrain_inertia_kg_m2;
    const CoordVector D = K.diagonal();
    const double e = matrix_error(M, K, D);
    EXPECT_LT(e, 1e-8) << what << " state " << k << "\nmodel M:\n" << M << "\nKE Hessian:\n" << K;
    worst = std::max(worst, e);
    worst_plain = std::max(worst_plain, (M - K).cwiseAbs().maxCoeff() / K.cwiseAbs().maxCoeff());
  }
  std::printf("[ MultiBody ] %s: mass matrix vs KE Hessian, max normalised error %.2e (max |dM| / max |M| %.2e), "
              "drivetrain inertia %.3g kg m^2\n", what, worst, worst_plain, truck.drive.drivetrain_inertia_kg_m2);
}

// Lagrange's velocity-product terms against the model's Q on one truck, gravity off, in the air.
void check_velocity_products(const TruckParams& truck, unsigned seed, int n, const char* what) {
  std::mt19937 rng(seed);
  Environment env;
  env.gravity_m_s2.setZero();
  double worst = 0;
  for (int k = 0; k < n; ++k) {
    TruckDynamics d(truck, env);
    d.attach_load(random_load(rng, true));
    const CoordVector q = random_q(rng, truck, true), qd = random_qd(rng);
    Mat13 M;
    CoordVector Q;
    Outputs out;
    d.mass_matrix_and_forces(make_state(q, qd), M, Q, &out);
    ASSERT_TRUE(in_the_air(out)) << what << " state " << k;

    auto mass_matrix = [&](const CoordVector& qq) {
      Mat13 Mq;
      CoordVector Qq;
      d.mass_matrix_and_forces(make_state(qq, CoordVector::Zero()), Mq, Qq);
      return Mq;
    };
    // dM/dt = dM/dq . q', as one directional derivative along q' (scaled to unit max-norm).
    const double speed = qd.cwiseAbs().maxCoeff();
    const CoordVector dir = qd / speed;
    const Mat13 Mdot = speed * derivative8<Mat13>([&](double e) { return mass_matrix(q + e * dir); }, kMassMatrixStep);
    CoordVector dTdq;
    for (int i = 0; i < kNumCoords; ++i) {
      const Mat13 dMi = derivative8<Mat13>([&](double e) { return mass_matrix(q + e * CoordVector::Unit(i)); }, kMassMatrixStep);
      dTdq[i] = 0.5 * qd.dot(dMi * qd);
    }
    const CoordVector Qref = -(Mdot * qd - dTdq);
    const double e = force_error(Q, Qref, M.diagonal());
    EXPECT_LT(e, 1e-7) << what << " state " << k << "\nmodel Q:    " << Q.transpose() << "\nLagrange Q: " << Qref.transpose();
    worst = std::max(worst, e);
  }
  std::printf("[ MultiBody ] %s: velocity-product terms vs Lagrange, max normalised error %.2e\n", what, worst);
}

// Gravity's generalised force against -dV/dq, truck in the air, at rest, gravity tilted.
void check_gravity(const TruckParams& truck, unsigned seed, int n, const char* what) {
  std::mt19937 rng(seed);
  Environment env;
  env.gravity_m_s2 = Vector3d(1.3, -0.9, -9.68);  // a tilt table, x and y both
  double worst = 0;
  for (int k = 0; k < n; ++k) {
    TruckDynamics d(truck, env);
    const Load load = random_load(rng, true);
    d.attach_load(load);
    const CoordVector q = random_q(rng, truck, true);
    Mat13 M;
    CoordVector Q;
    Outputs out;
    d.mass_matrix_and_forces(make_state(q, CoordVector::Zero()), M, Q, &out);
    ASSERT_TRUE(in_the_air(out)) << what << " state " << k;
    const std::vector<MassBody> bodies = mass_bodies(truck, &load);
    CoordVector Qref;
    for (int i = 0; i < kNumCoords; ++i)
      Qref[i] = -derivative8<double>(
          [&](double e) { return potential(bodies, truck, q + e * CoordVector::Unit(i), env.gravity_m_s2); }, kPoseStep);
    const double e = force_error(Q, Qref, M.diagonal());
    EXPECT_LT(e, 1e-8) << what << " state " << k << "\nmodel Q: " << Q.transpose() << "\n-dV/dq:  " << Qref.transpose();
    worst = std::max(worst, e);
  }
  std::printf("[ MultiBody ] %s: gravity vs -dV/dq, max normalised error %.2e\n", what, worst);
}

}  // namespace

TEST(MultiBody, MassMatrixIsTheKineticEnergyHessian) {
  check_mass_matrix(shipped_truck(), false, 20240611u, 16, "shipped truck");
  check_mass_matrix(paper_truck(), false, 20240612u, 8, "paper truck");
}

TEST(MultiBody, MassMatrixIsTheKineticEnergyHessianWithProductsOfInertia) {
  check_mass_matrix(asymmetric_truck(), true, 777u, 16, "asymmetric truck");
}

TEST(MultiBody, VelocityProductTermsFollowLagrange) {
  check_velocity_products(shipped_truck(), 31337u, 12, "shipped truck");
  check_velocity_products(paper_truck(), 31338u, 6, "paper truck");
  check_velocity_products(asymmetric_truck(), 4242u, 12, "asymmetric truck");
}

TEST(MultiBody, GravityIsMinusThePotentialGradient) {
  check_gravity(shipped_truck(), 99u, 8, "shipped truck");
  check_gravity(paper_truck(), 98u, 4, "paper truck");
  check_gravity(asymmetric_truck(), 100u, 8, "asymmetric truck");
}
