// Loading and validating a truck data file; conversion to the chassis frame and SI units.
#include "forklift/truck.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

namespace forklift {
namespace {

using nlohmann::json;
constexpr double kDeg = M_PI / 180.0;

class Reader {
 public:
  Reader(const std::string& path, const json& root) : path_(path), root_(root) {}

  const json& node(const std::string& dotted) const {
    const json* j = &root_;
    size_t start = 0;
    while (true) {
      size_t dot = dotted.find('.', start);
      std::string key = dotted.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
      if (!j->is_object() || !j->contains(key)) fail(dotted, "is missing");
      j = &(*j)[key];
      if (dot == std::string::npos) return *j;
      start = dot + 1;
    }
  }
  double number(const std::string& key) const {
    const json& j = node(key);
    if (!j.is_number()) fail(key, "is not a number");
    double v = j.get<double>();
    if (!std::isfinite(v)) fail(key, "is not finite");
    return v;
  }
  double positive(const std::string& key) const {
    double v = number(key);
    if (v <= 0) fail(key, "must be positive");
    return v;
  }
  double non_negative(const std::string& key) const {
    double v = number(key);
    if (v < 0) fail(key, "must not be negative");
    return v;
  }
  Eigen::Vector3d vec3(const std::string& key) const {
    const json& j = node(key);
    if (!j.is_array() || j.size() != 3) fail(key, "must be an array of 3 numbers");
    Eigen::Vector3d v;
    for (int i = 0; i < 3; ++i) {
      if (!j[i].is_number()) fail(key, "must be an array of 3 numbers");
      v[i] = j[i].get<double>();
      if (!std::isfinite(v[i])) fail(key, "is not finite");
    }
    return v;
  }
  Eigen::Matrix3d inertia(const std::string& key) const {
    Eigen::Matrix3d I;
    I << number(key + ".xx"), number(key + ".xy"), number(key + ".xz"),
         number(key + ".xy"), number(key + ".yy"), number(key + ".yz"),
         number(key + ".xz"), number(key + ".yz"), number(key + ".zz");
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(I);
    if (eig.eigenvalues().minCoeff() <= 0) fail(key, "is not positive definite");
    return I;
  }
  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw std::runtime_error(path_ + ": '" + key + "' " + what);
  }

 private:
  std::string path_;
  const json& root_;
};

}  // namespace

const char* wheel_name(int wheel) {
  static const char* const names[kNumWheels] = {"front_left", "front_right", "rear"};
  return (wheel >= 0 && wheel < kNumWheels) ? names[wheel] : "?";
}

double TruckParams::wheelbase_m() const {
  return 0.5 * (wheels[kFrontLeft].centre_m.x() + wheels[kFrontRight].centre_m.x()) -
         wheels[kRear].centre_m.x();
}

double TruckParams::front_track_m() const {
  return wheels[kFrontLeft].centre_m.y() - wheels[kFrontRight].centre_m.y();
}

TruckParams load_truck(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open truck file");
  json root;
  try {
    root = json::parse(in);
  } catch (const json::parse_error& e) {
    throw std::runtime_error(path + ": not valid JSON: " + e.what());
  }
  Reader r(path, root);
  TruckParams t;
  t.name = r.node("name").is_string() ? r.node("name").get<std::string>() : path;
  t.service_mass_kg = r.positive("service_mass_kg");
  t.rated_capacity_kg = r.positive("rated_capacity_kg");
  t.rated_load_centre_m = r.positive("rated_load_centre_m");

  // Everything is read in the geometry frame first, then shifted to the chassis CoG.
  const Eigen::Vector3d chassis_cog = r.vec3("chassis.cog_m");
  t.chassis_cog_geometry_m = chassis_cog;
  double other_mass = 0;
  for (int w = 0; w < kNumWheels; ++w) {
    const std::string k = std::string("wheels.") + wheel_name(w);
    WheelParams& wp = t.wheels[w];
    wp.centre_m = r.vec3(k + ".centre_m") - chassis_cog;
    wp.radius_m = r.positive(k + ".radius_m");
    wp.mass_kg = r.positive(k + ".mass_kg");
    wp.spin_inertia_kg_m2 = r.positive(k + ".spin_inertia_kg_m2");
    wp.transverse_inertia_kg_m2 = r.positive(k + ".transverse_inertia_kg_m2");
    other_mass += wp.mass_kg;
  }
  if (t.wheels[kFrontLeft].centre_m.y() <= t.wheels[kFrontRight].centre_m.y())
    r.fail("wheels.front_left.centre_m", "must be to the left (+y) of front_right");
  if (t.wheelbase_m() <= 0) r.fail("wheels.rear.centre_m", "must be behind the front axle");

  t.mast_pivot_m = r.vec3("mast.tilt_pivot_m") - chassis_cog;
  t.mast.cog_m = r.vec3("mast.cog_from_pivot_m");
  t.mast.mass_kg = r.positive("mast.mass_kg");
  t.mast.inertia_kg_m2 = r.inertia("mast.inertia_kg_m2");
  t.limits.tilt_forward_max_rad = r.non_negative("mast.tilt_forward_max_deg") * kDeg;
  t.limits.tilt_backward_max_rad = r.non_negative("mast.tilt_backward_max_deg") * kDeg;

  t.fork_face_from_pivot_m = 0;  // superseded by the fork heel below
  t.carriage.mass_kg = r.positive("carriage.mass_kg");
  t.carriage.inertia_kg_m2 = r.inertia("carriage.inertia_kg_m2");
  // The carriage's cog_m is kept relative to the fork heel; fork_heel holds the heel's offset.
  t.carriage.cog_m = r.vec3("carriage.cog_from_fork_heel_m");
  t.fork_heel_from_pivot_m = r.vec3("carriage.fork_heel_from_pivot_m");
  t.fork_face_from_pivot_m = t.fork_heel_from_pivot_m.x();
  t.limits.lift_max_m = r.positive("carriage.lift_max_m");
  t.limits.side_shift_max_m = r.non_negative("carriage.side_shift_max_m");
  t.limits.lift_rate_max_m_s = r.positive("carriage.lift_rate_max_m_s");
  t.limits.tilt_rate_max_rad_s = r.positive("carriage.tilt_rate_max_deg_s") * kDeg;
  t.limits.side_shift_rate_max_m_s = r.positive("carriage.side_shift_rate_max_m_s");
  other_mass += t.mast.mass_kg + t.carriage.mass_kg;

  t.chassis.mass_kg = t.service_mass_kg - other_mass;
  if (t.chassis.mass_kg <= 0) r.fail("service_mass_kg", "is less than the wheels, mast and carriage together");
  t.chassis.cog_m = Eigen::Vector3d::Zero();
  t.chassis.inertia_kg_m2 = r.inertia("chassis.inertia_kg_m2");

  ContactParams& c = t.contact;
  c.stiffness_N_m = r.positive("ground_contact.vertical_stiffness_N_m");
  c.damping_N_s_m = r.non_negative("ground_contact.vertical_damping_N_s_m");
  c.fx_slip_gain_s_m = r.non_negative("ground_contact.fx_slip_gain_s_m");
  c.fx_max_N = r.non_negative("ground_contact.fx_max_N");
  c.fy_mu = r.non_negative("ground_contact.fy_mu");
  c.fy_alpha0_rad = r.positive("ground_contact.fy_alpha0_deg") * kDeg;
  c.rolling_resistance_N_m_s = r.non_negative("ground_contact.rolling_resistance_N_m_s");
  c.slip_angle_speed_floor_m_s = r.positive("ground_contact.slip_angle_speed_floor_m_s");
  t.scene_contact.stiffness_N_m = r.non_negative("scene_contact.stiffness_N_m");
  t.scene_contact.damping_N_s_m = r.non_negative("scene_contact.damping_N_s_m");

  DriveParams& d = t.drive;
  d.drive_torque_max_N_m = r.positive("drive.drive_torque_max_N_m");
  d.brake_torque_max_N_m = r.positive("drive.brake_torque_max_N_m");
  d.torque_lag_s = r.positive("drive.torque_lag_s");
  d.brake_lag_s = r.positive("drive.brake_lag_s");
  d.brake_fade_speed_rad_s = r.positive("drive.brake_fade_speed_rad_s");

  t.steer_bandwidth_rad_s = r.positive("driven_coordinate_filters.steer_bandwidth_rad_s");
  t.lever_bandwidth_rad_s = r.positive("driven_coordinate_filters.lever_bandwidth_rad_s");
  return t;
}

Load box_load(double mass_kg, double length_m, double width_m, double height_m,
              double load_centre_m, double lateral_m) {
  Load l;
  l.mass_kg = mass_kg;
  l.cog_m = Eigen::Vector3d(load_centre_m, lateral_m, 0.5 * height_m);
  const double k = mass_kg / 12.0;
  l.inertia_kg_m2 = Eigen::Vector3d(k * (width_m * width_m + height_m * height_m),
                                    k * (length_m * length_m + height_m * height_m),
                                    k * (length_m * length_m + width_m * width_m)).asDiagonal();
  return l;
}

}  // namespace forklift
