// The forklift truck's equations of motion (paper sections 3-10), as a const evaluator.
//
// The state is a plain vector (see StateIndex) that can be copied to replay or rewind; the
// evaluator holds only the constant truck, the environment, and the attached load (the
// paper's runtime parameter change, section 5).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "forklift/dynamics/truck.h"
#include "forklift/units/units.h"

namespace forklift {

// A straight ramp or dock plate: height rises smoothly (C1 smoothstep, so the steepest grade
// is 1.5 rise/length at mid-ramp) from 0 at `start_m` to `rise_m` after `length_m` along
// `heading_rad`, then stays at `rise_m` for `plateau_m`; zero outside its `width_m` band.
struct Ramp {
  Eigen::Vector2d start_m = Eigen::Vector2d::Zero();
  double heading_rad = 0;
  double length_m = 1;
  double width_m = 1;
  double rise_m = 0;
  double plateau_m = 0;
};

// A block of ground with vertical sides: a dock, a kerb, a lorry's bed, or (below the floor) the
// yard at the foot of a dock. Its footprint is a world-axis-aligned rectangle; its top is flat.
struct GroundStep {
  Eigen::AlignedBox2d footprint_m;  // world x, y
  double top_m = 0;                 // height of its top face; may be below the floor (a drop)
};

// A floor patch with less grip (a spill of oil or water): inside its footprint every tyre's
// friction is scaled by friction_scale (its static, sliding and peak values alike).
struct GripPatch {
  Eigen::AlignedBox2d footprint_m;  // world x, y
  double friction_scale = 1;        // (0, 1]
};

// Ground height as a function of position (x, y), not of time (beyond the paper's eq 7).
// The level is the highest top of the steps whose footprint holds (x, y), or the floor z = 0
// where none does; a ramp raises it where the ramp is higher. Steps' sides and ramps' sides and
// ends are true discontinuities: the wheels, the body's points and its edge boxes meet them as
// edges and faces (dynamics.cc), not as a height under a point.
class Ground {
 public:
  Ground() = default;
  explicit Ground(std::vector<Ramp> ramps, std::vector<GroundStep> steps = {}, std::vector<GripPatch> grip = {});
  double height(double x, double y) const;
  // The tyres' friction scale at (x, y): the lowest of the grip patches holding it, 1 elsewhere.
  // Bit i of `absent` set: patch i (i < 64) is not on the floor (yet), and holds nothing.
  double grip(double x, double y, uint64_t absent = 0) const;
  Eigen::Vector2d gradient(double x, double y) const;  // (dh/dx, dh/dy); zero on steps
  bool flat() const { return ramps_.empty() && steps_.empty(); }  // z = 0 everywhere
  const std::vector<Ramp>& ramps() const { return ramps_; }
  const std::vector<GroundStep>& steps() const { return steps_; }
  const std::vector<GripPatch>& grip_patches() const { return grip_; }

 private:
  std::vector<Ramp> ramps_;
  std::vector<GroundStep> steps_;
  std::vector<GripPatch> grip_;
};

// A force from the scene on one of the truck's rigid bodies at a world point: a contact pushing
// back (the collision module finds the contacts; the session turns them into these).
struct ExternalForce {
  TruckBody body = TruckBody::kChassis;
  Eigen::Vector3d point_m = Eigen::Vector3d::Zero();  // world
  Eigen::Vector3d force_N = Eigen::Vector3d::Zero();  // world
};

struct Environment {
  Ground ground;
  Eigen::Vector3d gravity_m_s2{0, 0, -kGravity_m_s2};  // world frame; a tilt table tilts this vector
  // Chocks: when set, each wheel's contact point is held to its anchor by a stiff horizontal
  // spring instead of the tyre's Fx and Fy (the tilt-table test, where sliding is prevented).
  std::optional<std::array<Eigen::Vector2d, kNumWheels>> chock_anchors_m;
  // Held from one physics tick to the next: the scene's push-back on the truck.
  std::vector<ExternalForce> external_forces;
  // The grip patches not on the floor now (Ground::grip's `absent`): a spill that appears at a
  // trigger or at the instructor's word is absent until then. Held from one tick to the next.
  uint64_t grip_patches_absent = 0;
};

// What the truck's controller is asked for, in physical units. Out-of-range values are clamped
// to the truck's limits; non-finite values must be refused before they get here.
struct DriverInputs {
  double drive_torque_N_m = 0;  // total for the two front motors, + forward
  double brake_torque_N_m = 0;  // on each front wheel, >= 0
  double steer_rad = 0;         // rear-wheel angle awr3 (+ points the wheel left: the truck turns right going forward)
  double tilt_rate_rad_s = 0;   // mast tilt lever, + forward
  double lift_rate_m_s = 0;     // lift lever, + up
  double shift_rate_m_s = 0;    // side-shift lever, + left
  bool parking_brake = false;   // holds the front wheels with the truck's parking-brake torque
  bool horn = false;            // sounding: the evaluation and the people hear it; the dynamics do not
};

// Layout of the ODE state vector.
struct StateIndex {
  static constexpr int kQ = 0;          // 9 dynamic coordinates, in Coord order
  static constexpr int kQdot = 9;       // their rates
  static constexpr int kDriven = 18;    // per driven coordinate d (0..3): z, z', z'' at kDriven + 3 d
  static constexpr int kTorque = 30;    // drive torque after the lag, N m
  static constexpr int kBrake = 31;     // brake torque per wheel after the lag, N m
  static constexpr int kTyre = 32;      // bristle deflection of wheel w: x at kTyre + 2 w, y next, m
  static constexpr int kBrakeStick = 38;  // front wheel w's brake bristle s (0 left, 1 right), -1..1
  static constexpr int kSize = 40;
};
using StateVector = Eigen::Matrix<double, StateIndex::kSize, 1>;
using CoordVector = Eigen::Matrix<double, kNumCoords, 1>;

// Ground-to-wheel quantities of one wheel (section 7), in its contact frame:
// x rolling direction, y lateral (along the axle), z the ground normal.
struct WheelContact {
  bool on_ground = false;
  Eigen::Vector3d contact_point_m = Eigen::Vector3d::Zero();  // world
  // The deepest contact's depth. A wheel against a step's edge may touch it and the level below at
  // once: fz_N is then the magnitude of their summed normal forces, and `normal` their direction.
  double penetration_m = 0;
  double spring_energy_J = 0;  // sum of K depth^2 / 2 over its contacts
  double tread_energy_J = 0;   // the brush's deflected tread: Fz (sigma0x zx^2 + sigma0y zy^2) / 2
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double fz_N = 0, fx_N = 0, fy_N = 0;
  double slip_x_m_s = 0, slip_y_m_s = 0;  // sx, sy: contact point velocity on the wheel axes
  double slip_angle_rad = 0;              // alpha, eq (9)
  double drive_torque_N_m = 0, brake_torque_N_m = 0, rolling_torque_N_m = 0;
  double friction_use = 0;  // |(Fx, Fy)| / (mu Fz), mu the grip at this slip: 1 sliding (bristle tyre; 0 off the ground)
  // How much of the tyre's grip peak the force uses: |(Fx, Fy)| / (peak mu Fz) (the brush's
  // mu_static, the grip-peak tyre's mu_peak; the paper's tyre: the larger of |Fx| / Fx_max and
  // |Fy| / (mu Fz)). 0 off the ground. It reaches 1 only at the peak, whatever the tyre rolls at.
  double grip_share = 0;
};

// A rigid frame's motion, world axes: orientation, origin, and the origin's velocity and
// acceleration, the frame's angular velocity and acceleration.
struct FrameMotion {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero(), v = Eigen::Vector3d::Zero(), a = Eigen::Vector3d::Zero();
  Eigen::Vector3d w = Eigen::Vector3d::Zero(), alpha = Eigen::Vector3d::Zero();
  // Acceleration of the frame's point at `local` (frame axes, from the origin), world.
  Eigen::Vector3d acceleration_at(const Eigen::Vector3d& local) const {
    const Eigen::Vector3d r = R * local;
    return a + alpha.cross(r) + w.cross(w.cross(r));
  }
  Eigen::Vector3d velocity_at(const Eigen::Vector3d& local) const { return v + w.cross(R * local); }
};

// Everything the evaluator computes beside the derivative, for output and tests.
struct Outputs {
  CoordVector q = CoordVector::Zero(), qdot = CoordVector::Zero(), qddot = CoordVector::Zero();
  std::array<WheelContact, kNumWheels> wheels;
  // Generalised force each actuator applies on its driven coordinate: steering torque (N m),
  // tilt torque (N m), lift force (N), side-shift force (N). This is -lambda of eq (14), so at
  // rest the lift force equals the weight of carriage and load (times cos of the tilt).
  Eigen::Vector4d driven_force = Eigen::Vector4d::Zero();
  double forward_speed_m_s = 0;  // chassis CoG velocity along the heading
  double total_mass_kg = 0;
  Eigen::Vector3d cog_m = Eigen::Vector3d::Zero();  // whole truck and load, world
  // Body parts on the ground (a tipped truck): how many touch, and the deepest into the floor.
  int body_points_on_ground = 0;
  double body_penetration_max_m = 0;
  // Power of every force but gravity (ground, tyres, brakes, drive, scene, actuators), W: the
  // rate of change of kinetic plus gravitational energy (a work-energy balance closes on it).
  double applied_power_W = 0;
  // The fork carriage (BodyPoses::carriage: origin at the fork heel, forks along x, their top at
  // z = 0): what a load on the forks rides on.
  FrameMotion carriage;
};

// World poses of the truck's rigid parts at coordinates q, for the scene, collision and renderer.
// chassis: origin at the geometry frame's origin (ground below the middle of the front axle when
// the truck stands level), axes of the chassis; mast: origin at the tilt pivot; carriage: origin at
// the fork heel (forks along +x, their top face at z = 0); wheels: at each wheel centre, y the axle.
struct BodyPoses {
  Eigen::Isometry3d chassis, mast, carriage;
  std::array<Eigen::Isometry3d, kNumWheels> wheels;
};
BodyPoses body_poses(const TruckParams& truck, const CoordVector& q);
// The 13 coordinates held in a state vector (the driven ones from their filters).
CoordVector coordinates(const StateVector& x);
// The chassis CoG's velocity along the heading (Outputs::forward_speed_m_s).
double forward_speed(const StateVector& x);

class TruckDynamics {
 public:
  TruckDynamics(const TruckParams& truck, Environment env = {});

  const TruckParams& truck() const { return truck_; }
  const Environment& environment() const { return env_; }
  Environment& environment() { return env_; }

  // Section 5: the carriage's mass properties change at run time; the mass matrix is rebuilt
  // every evaluation, so this costs nothing. The integrator must be restarted after it.
  void attach_load(const Load& load);
  void release_load();
  const std::optional<Load>& load() const { return load_; }

  // d(state)/dt at time t under inputs u. Returns false (and leaves dstate unspecified) if the
  // state is not finite or the mass matrix is not positive definite; never throws, never
  // allocates. `out` may be null.
  bool derivative(const StateVector& x, const DriverInputs& u, StateVector& dx,
                  Outputs* out = nullptr) const;

  // The full mass matrix M(q) (13x13) and the generalised force vector Q(q, q') of eq (12),
  // including gravity, ground forces, drive and brake torques and the velocity-product terms.
  void mass_matrix_and_forces(const StateVector& x, Eigen::Matrix<double, kNumCoords, kNumCoords>& M,
                              CoordVector& Q, Outputs* out = nullptr) const;

  // How the dynamic coordinates' accelerations answer the driven ones' in eq (13):
  // d q''/d z'' = -M_ii^-1 M_id, exact because q'' is linear in z'' (no forces are evaluated).
  // False if x is not finite or M_ii not positive definite.
  bool driven_coupling(const StateVector& x, Eigen::Matrix<double, kNumDynamic, kNumDriven>& dqdd_dzdd) const;

  // Kinetic + gravitational + ground-spring energy (J), the tyres' deflected tread included:
  // conserved when there is no friction, damping or torque and the driven coordinates are still.
  // Without the ground springs: kinetic + gravitational only, whose rate is Outputs::applied_power_W.
  double energy(const StateVector& x, bool with_ground_springs = true) const;

  // The wheels' normal forces (WheelContact::fz_N of derivative()'s Outputs, the same bits)
  // without the rest of the evaluation: for a sampler that needs the loads alone.
  std::array<double, kNumWheels> wheel_loads_N(const StateVector& x) const;

  // A state at rest at (x, y, yaw) with the driven coordinates given, wheels at their free
  // radius above the ground (not yet settled: see settle_static).
  StateVector rest_state(double x, double y, double yaw, double steer = 0, double tilt = 0,
                         double lift = 0, double shift = 0) const;

  // Moves z, roll and pitch (and x, y, yaw when chocked) to static equilibrium under gravity
  // with every velocity zero. Returns false if no equilibrium with all wheels down was found.
  bool settle_static(StateVector& x) const;

 private:
  TruckParams truck_;
  Environment env_;
  std::optional<Load> load_;
};

}  // namespace forklift
