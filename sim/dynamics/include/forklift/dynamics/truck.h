// The truck's parameters: loaded once from a data file, converted to SI, then const.
// Frames: x forward, y left, z up. Positions in the "geometry frame" (origin on the
// ground below the middle of the front axle) are converted on load to the chassis
// frame, whose origin is the chassis centre of gravity (paper section 3).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <string>
#include <vector>

namespace forklift {

// Indices of the 13 generalised coordinates, named and ordered as in the paper (section 3).
// The first 9 are the dynamic degrees of freedom (DDOF), the last 4 the driven coordinates (DC).
enum Coord : int {
  kX = 0, kY, kZ,          // chassis centre of gravity, world frame, m
  kAwc, kAuc, kAvc,        // chassis yaw (about W), roll (about U), pitch (about V), rad
  kAvr1, kAvr2, kAvr3,     // spin of front-left, front-right and rear wheel about their axles, rad
  kAwr3, kBeta, kS, kR,    // rear-wheel steer, mast tilt (+ forward), fork lift, side-shift (+ left)
};
inline constexpr int kNumCoords = 13;
inline constexpr int kNumDynamic = 9;
inline constexpr int kNumDriven = 4;

// Wheel numbering of the paper: 1 front left, 2 front right (both driven), 3 rear (steered).
enum Wheel : int { kFrontLeft = 0, kFrontRight = 1, kRear = 2 };
inline constexpr int kNumWheels = 3;
const char* wheel_name(int wheel);  // "front_left", "front_right", "rear"

struct RigidBodyParams {
  double mass_kg = 0;
  Eigen::Vector3d cog_m = Eigen::Vector3d::Zero();  // in the frame its owner documents
  Eigen::Matrix3d inertia_kg_m2 = Eigen::Matrix3d::Zero();  // about the CoG, body axes
};

struct WheelParams {
  Eigen::Vector3d centre_m;  // chassis frame
  double radius_m = 0;       // Z0 of eq (7)
  double mass_kg = 0;
  double spin_inertia_kg_m2 = 0;
  double transverse_inertia_kg_m2 = 0;
};

// How the tyre's Fx and Fy arise from the contact's slip (section 7).
enum class TyreModel {
  kPaper,    // eqs (8)-(10): Fx from the slip speed, Fy from the slip angle; nothing sticks at rest
  kBristle,  // an averaged LuGre brush: the contact sticks below the friction limit (it holds a
             // braked truck on a slope), gives slip-proportional forces when rolling, and slides
             // at mu Fz on a friction circle (Canudas de Wit et al. 2003, the lumped LuGre tyre)
  kGripPeak, // the same brush, but its grip follows the slip as Pacejka's and TMeasy's curves do: it
             // rises with the slip stiffness to a peak mu_peak Fz, holds it to slip_peak, and falls
             // to mu_sliding Fz by slip_sliding, so sliding is a distinct event that loses grip
};

struct ContactParams {
  double stiffness_N_m = 0;           // K, eq (7)
  double damping_N_s_m = 0;           // C, eq (7)
  TyreModel tyre = TyreModel::kPaper;
  // kPaper
  double fx_slip_gain_s_m = 0;        // k, eq (8)
  double fx_max_N = 0;                // eq (8)
  double fy_mu = 0;                   // mu, eq (10)
  double fy_alpha0_rad = 0;           // alpha0, eq (10)
  double slip_angle_speed_floor_m_s = 0;
  // kBristle: F_i = -Fz (sigma0_i z_i + sigma1 z_i'), z_i' = v_i - (sigma0_i |v| / g(|v|) + |w r| / L) z_i,
  // g(v) = mu_sliding + (mu_static - mu_sliding) exp(-(v / v_stribeck)^2); v the contact's slip velocity.
  double mu_static = 0, mu_sliding = 0, stribeck_speed_m_s = 0;
  double bristle_stiffness_x_per_m = 0, bristle_stiffness_y_per_m = 0;  // sigma0, per unit Fz
  double bristle_damping_s_m = 0;                                         // sigma1, per unit Fz
  double relaxation_length_m = 0;                                         // L: slip stiffness = sigma0 L
  // kGripPeak: mu_static is the peak; the slip s = |v| / (|w r| + slip_angle_speed_floor) sets the
  // grip mu(s): mu_static up to slip_peak, a smoothstep down to mu_sliding at slip_sliding and beyond.
  double slip_peak = 0, slip_sliding = 0;
  // Rolling resistance: the paper's viscous k of eq (6), and a Coulomb part C_rr Fz r (smoothed
  // through zero over `rolling_resistance_speed_rad_s`) that brings a coasting truck to rest.
  double rolling_resistance_N_m_s = 0;
  double rolling_resistance_coefficient = 0;
  double rolling_resistance_speed_rad_s = 0.1;
};

// The truck's rigid bodies that forces from the scene or the ground can act on.
enum class TruckBody { kChassis, kMast, kCarriage };

// Parts of the body that meet the ground when the truck tips (chassis corners, overhead guard,
// counterweight, mast, fork tips; and the corners of a load): penalty contact with friction.
struct BodyContactPoint {
  TruckBody body = TruckBody::kChassis;
  Eigen::Vector3d point_m = Eigen::Vector3d::Zero();  // chassis frame / from the mast pivot / from the fork heel
  std::string name;
};
// A box of the body (the chassis' belly, a fork) that the ground steps' top edges press on where
// an edge passes between the fixed points: a truck sliding over a dock's edge on its belly.
struct BodyEdgeBox {
  TruckBody body = TruckBody::kChassis;
  Eigen::Vector3d min_m = Eigen::Vector3d::Zero(), max_m = Eigen::Vector3d::Zero();  // frame as the points'
  std::string name;
};
struct BodyGroundContact {
  double stiffness_N_m = 0, damping_N_s_m = 0, mu = 0;
  double friction_speed_m_s = 0.01;  // the friction's smoothing through zero slip
  std::vector<BodyContactPoint> points;
  std::vector<BodyEdgeBox> edge_boxes;
};

// How fixed scene objects (racks, walls, docks, lorries) push back on the truck where it is inside
// them: a penalty force k depth + c speed-into along the contact normal (collision module).
struct SceneContactParams {
  double stiffness_N_m = 0;
  double damping_N_s_m = 0;
};

struct DriveParams {
  double drive_torque_max_N_m = 0;  // total, at full accelerator
  double brake_torque_max_N_m = 0;  // per front wheel, at full pedal
  double torque_lag_s = 0;
  double brake_lag_s = 0;
  // The paper's brake (section 8): T = -b tanh(w / w_fade), nothing at standstill. Used when
  // brake_stick_angle_rad is 0.
  double brake_fade_speed_rad_s = 0;
  // A brake that holds: friction in the brake and drivetrain as a bristle of angular compliance
  // phi: T = -b (s + tau s'), s' = (w - |w| s) / phi, so |T| <= b sliding and a spring at rest.
  double brake_stick_angle_rad = 0;
  double brake_stick_damping_s = 0;    // tau
  double parking_brake_torque_N_m = 0; // per front wheel, when the parking brake is set
  // Traction drive (one motor per front wheel): torque and power limits per motor and a speed
  // governor that fades the torque out over the last `speed_governor_band_m_s` before the cap
  // (and brakes above it). Infinite where the data file sets none: the paper's free torque.
  double motor_torque_max_N_m = INFINITY;
  double motor_power_max_W = INFINITY;
  double speed_max_m_s = INFINITY;
  double speed_governor_band_m_s = 0.3;
  double drivetrain_inertia_kg_m2 = 0;  // motor and gears reflected to each front wheel's spin
};

// The steering actuator: end stops, and a rate limit at the wheel. Without a rate limit the
// rear-wheel angle follows the cab through the paper's smoothing filter alone.
struct SteerParams {
  double max_rad = 0;
  double rate_max_rad_s = INFINITY;
  double bandwidth_rad_s = 0;
};

// The load on the forks as a body of its own (load_on_forks.h): friction between a load's base and
// the forks' top faces, and where the forks end. Absent from a truck file (friction infinite): the
// load is welded to the carriage, as the paper's model has it (section 5).
struct LoadContactParams {
  double friction_static = INFINITY;   // default for a load that gives none (Load::friction_*)
  double friction_kinetic = INFINITY;
  double fork_tip_m = INFINITY;        // the fork tips, carriage frame x (from the fork face)
  bool welded() const { return !std::isfinite(friction_static); }
};

struct MastLimits {
  double tilt_forward_max_rad = 0, tilt_backward_max_rad = 0;
  double lift_max_m = 0, side_shift_max_m = 0;
  double lift_rate_max_m_s = 0, tilt_rate_max_rad_s = 0, side_shift_rate_max_m_s = 0;
};

// A part of the chassis (battery, counterweight, frame, ...) as the truck file lists it.
struct MassPart {
  std::string name;
  double mass_kg = 0;
  Eigen::Vector3d cog_geometry_m = Eigen::Vector3d::Zero();  // geometry frame
};

// The constant model. Built by load_truck(); never changed during a run.
struct TruckParams {
  std::string name;
  double service_mass_kg = 0;
  double tipped_over_rad = 0;  // roll or pitch beyond which the truck has gone over
  double rated_capacity_kg = 0;
  double rated_load_centre_m = 0;

  RigidBodyParams chassis;                 // cog_m is zero by definition of the chassis frame
  Eigen::Vector3d chassis_cog_geometry_m;  // where the chassis frame sits in the geometry frame
  // The chassis' parts where the file lists them (empty otherwise): the chassis CoG is their mean
  // unless the file gives chassis.cog_m; `validate` weighs the truck against them either way.
  std::vector<MassPart> chassis_parts;
  std::array<WheelParams, kNumWheels> wheels;
  Eigen::Vector3d mast_pivot_m;            // chassis frame
  RigidBodyParams mast;                    // cog_m from the pivot, mast frame
  Eigen::Vector3d fork_heel_from_pivot_m;  // mast frame, at s = r = 0: where the fork face meets
                                           // the top of the forks; loads are placed from here
  RigidBodyParams carriage;                // cog_m from the fork heel, mast frame
  double fork_face_from_pivot_m = 0;       // fork_heel_from_pivot_m.x()
  MastLimits limits;
  ContactParams contact;
  SceneContactParams scene_contact;
  DriveParams drive;
  SteerParams steer;
  BodyGroundContact body_contact;
  LoadContactParams load_contact;
  double lever_bandwidth_rad_s = 0;
  // The seated driver's reference point (geometry frame) where ISO 22915's 98 kg operator sits.
  Eigen::Vector3d operator_seat_m = Eigen::Vector3d::Zero();

  double wheelbase_m() const;    // L: front axle to rear axle
  double front_track_m() const;  // H: between the front wheels
};

// Reads a truck data file (see data/trucks/). Throws std::runtime_error naming the file and
// the key when a value is missing, not a number, or physically impossible (negative mass,
// inertia not positive definite, ...).
TruckParams load_truck(const std::string& path);

// A load on the forks (section 5): any mass, CoG and inertia, attached or released at run time.
struct Load {
  double mass_kg = 0;
  Eigen::Vector3d cog_m = Eigen::Vector3d::Zero();  // from the fork face at the heel of the forks
                                                    // (x forward along the forks, y left, z up)
  Eigen::Matrix3d inertia_kg_m2 = Eigen::Matrix3d::Zero();  // about its CoG
  // Its bounding box about the CoG, carriage axes (0: unknown): its corners meet the ground in a tip.
  Eigen::Vector3d size_m = Eigen::Vector3d::Zero();
  // Its base on the forks: its length along them (0: unknown, taken as reaching back to the fork
  // face), and its own friction against them (NaN: the truck's load_contact friction).
  double base_length_m = 0;
  double friction_static = NAN, friction_kinetic = NAN;
};

// A uniform box load: mass, size (l along the forks, w, h), CoG at its centre, resting on the
// forks with its centre `load_centre_m` ahead of the fork face and offset `lateral_m` left.
Load box_load(double mass_kg, double length_m, double width_m, double height_m,
              double load_centre_m, double lateral_m);

// The truck with a mass added rigidly to its chassis at `at_geometry_m` (ISO 22915's operator):
// the chassis CoG, the chassis-frame offsets and the inertia move accordingly.
TruckParams with_chassis_mass(const TruckParams& truck, double mass_kg, const Eigen::Vector3d& at_geometry_m);

}  // namespace forklift
