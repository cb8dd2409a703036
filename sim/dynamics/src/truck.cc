// Loading and validating a truck data file; conversion to the chassis frame and SI units.
#include "forklift/dynamics/truck.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "forklift/schema/data_file.h"
#include "forklift/units/units.h"

namespace forklift {
namespace {

using nlohmann::json;

class Reader {
 public:
  Reader(const std::string& path, const json& root) : path_(path), root_(root) {}

  // The value at a dotted key path, or null where any part of it is missing.
  const json* find(const std::string& dotted) const {
    const json* j = &root_;
    size_t start = 0;
    while (true) {
      size_t dot = dotted.find('.', start);
      std::string key = dotted.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
      if (!j->is_object() || !j->contains(key)) return nullptr;
      j = &(*j)[key];
      if (dot == std::string::npos) return j;
      start = dot + 1;
    }
  }
  bool has(const std::string& dotted) const { return find(dotted) != nullptr; }
  const json& node(const std::string& dotted) const {
    const json* j = find(dotted);
    if (!j) fail(dotted, "is missing");
    return *j;
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
  // Checked against data/schema/truck.schema.json first: no number outside its range reaches
  // the model below; what follows checks what a schema cannot say.
  json root;
  try {
    root = schema::read_checked_json(path, schema::Schema::kTruck);
  } catch (const schema::DataFileError& e) {
    throw std::runtime_error(e.what());
  }
  Reader r(path, root);
  TruckParams t;
  t.name = r.node("name").is_string() ? r.node("name").get<std::string>() : path;
  t.service_mass_kg = r.positive("service_mass_kg");
  t.rated_capacity_kg = r.positive("rated_capacity_kg");
  t.rated_load_centre_m = r.positive("rated_load_centre_m");

  // The chassis' parts, where the file lists them: their mean is its CoG unless cog_m says
  // otherwise (validate then weighs the truck against the parts).
  double parts_mass = 0;
  Eigen::Vector3d parts_moment = Eigen::Vector3d::Zero();
  if (r.has("chassis.parts"))
    for (const auto& [name, part] : r.node("chassis.parts").items()) {
      if (name.empty() || name[0] == '_') continue;
      const std::string k = "chassis.parts." + name;
      const MassPart p{name, r.positive(k + ".mass_kg"), r.vec3(k + ".cog_m")};
      t.chassis_parts.push_back(p);
      parts_mass += p.mass_kg;
      parts_moment += p.mass_kg * p.cog_geometry_m;
    }
  if (!r.has("chassis.cog_m") && t.chassis_parts.empty()) r.fail("chassis", "needs cog_m or parts");
  // Everything is read in the geometry frame first, then shifted to the chassis CoG.
  const Eigen::Vector3d chassis_cog = r.has("chassis.cog_m") ? r.vec3("chassis.cog_m") : Eigen::Vector3d(parts_moment / parts_mass);
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
  t.tipped_over_rad = r.positive("tipped_over_deg") * kDeg;
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
  if (!t.chassis_parts.empty() && std::abs(parts_mass - t.chassis.mass_kg) > 0.5)
    r.fail("chassis.parts", "weigh " + std::to_string(std::lround(parts_mass)) + " kg, but the service mass less the wheels, mast and carriage leaves " +
                                std::to_string(std::lround(t.chassis.mass_kg)) + " kg for the chassis");
  t.chassis.cog_m = Eigen::Vector3d::Zero();
  t.chassis.inertia_kg_m2 = r.inertia("chassis.inertia_kg_m2");

  // Optional keys: absent, a force law keeps the paper's form (section 7-8) or has no limit.
  auto optional = [&](const std::string& key, double fallback, bool positive) {
    if (!r.has(key)) return fallback;
    return positive ? r.positive(key) : r.non_negative(key);
  };
  ContactParams& c = t.contact;
  c.stiffness_N_m = r.positive("ground_contact.vertical_stiffness_N_m");
  c.damping_N_s_m = r.non_negative("ground_contact.vertical_damping_N_s_m");
  const json* tyre_model = r.find("ground_contact.tyre_model");
  const std::string tyre = !tyre_model ? "paper" : tyre_model->is_string() ? tyre_model->get<std::string>() : "?";
  if (tyre == "paper") {
    c.tyre = TyreModel::kPaper;
    c.fx_slip_gain_s_m = r.non_negative("ground_contact.fx_slip_gain_s_m");
    c.fx_max_N = r.non_negative("ground_contact.fx_max_N");
    c.fy_mu = r.non_negative("ground_contact.fy_mu");
    c.fy_alpha0_rad = r.positive("ground_contact.fy_alpha0_deg") * kDeg;
  } else if (tyre == "bristle" || tyre == "grip_peak") {
    const bool peak = tyre == "grip_peak";
    c.tyre = peak ? TyreModel::kGripPeak : TyreModel::kBristle;
    c.mu_static = r.positive(peak ? "ground_contact.mu_peak" : "ground_contact.mu_static");
    c.mu_sliding = r.positive("ground_contact.mu_sliding");
    if (c.mu_sliding > c.mu_static)
      r.fail("ground_contact.mu_sliding", peak ? "must not exceed mu_peak" : "must not exceed mu_static");
    if (peak) {
      c.slip_peak = r.positive("ground_contact.slip_peak");
      c.slip_sliding = r.positive("ground_contact.slip_sliding");
      if (c.slip_sliding <= c.slip_peak) r.fail("ground_contact.slip_sliding", "must exceed slip_peak");
    }
    c.stribeck_speed_m_s = r.positive("ground_contact.stribeck_speed_m_s");
    c.bristle_stiffness_x_per_m = r.positive("ground_contact.bristle_stiffness_x_per_m");
    c.bristle_stiffness_y_per_m = r.positive("ground_contact.bristle_stiffness_y_per_m");
    c.bristle_damping_s_m = r.non_negative("ground_contact.bristle_damping_s_m");
    c.relaxation_length_m = r.positive("ground_contact.relaxation_length_m");
  } else {
    r.fail("ground_contact.tyre_model", "must be \"paper\", \"bristle\" or \"grip_peak\"");
  }
  c.slip_angle_speed_floor_m_s = r.positive("ground_contact.slip_angle_speed_floor_m_s");
  c.rolling_resistance_N_m_s = optional("ground_contact.rolling_resistance_N_m_s", 0, false);
  c.rolling_resistance_coefficient = optional("ground_contact.rolling_resistance_coefficient", 0, false);
  c.rolling_resistance_speed_rad_s = optional("ground_contact.rolling_resistance_speed_rad_s", 0.1, true);
  t.scene_contact.stiffness_N_m = r.non_negative("scene_contact.stiffness_N_m");
  t.scene_contact.damping_N_s_m = r.non_negative("scene_contact.damping_N_s_m");

  DriveParams& d = t.drive;
  d.drive_torque_max_N_m = r.positive("drive.drive_torque_max_N_m");
  d.brake_torque_max_N_m = r.positive("drive.brake_torque_max_N_m");
  d.torque_lag_s = r.positive("drive.torque_lag_s");
  d.brake_lag_s = r.positive("drive.brake_lag_s");
  d.brake_stick_angle_rad = optional("drive.brake_stick_angle_deg", 0, true) * kDeg;
  if (d.brake_stick_angle_rad > 0) d.brake_stick_damping_s = r.non_negative("drive.brake_stick_damping_s");
  else d.brake_fade_speed_rad_s = r.positive("drive.brake_fade_speed_rad_s");
  d.parking_brake_torque_N_m = optional("drive.parking_brake_torque_N_m", 0, false);
  d.motor_torque_max_N_m = optional("drive.motor_torque_max_N_m", INFINITY, true);
  d.motor_power_max_W = optional("drive.motor_power_max_kW", INFINITY, true) * 1e3;
  d.speed_max_m_s = optional("drive.speed_max_km_h", INFINITY, true) / 3.6;
  d.speed_governor_band_m_s = optional("drive.speed_governor_band_km_h", 1.0, true) / 3.6;
  d.drivetrain_inertia_kg_m2 = optional("drive.drivetrain_inertia_kg_m2", 0, false);

  t.steer.bandwidth_rad_s = r.positive("driven_coordinate_filters.steer_bandwidth_rad_s");
  t.steer.max_rad = r.positive("steering.max_deg") * kDeg;
  if (t.steer.max_rad > M_PI / 2) r.fail("steering.max_deg", "must not exceed 90");
  t.steer.rate_max_rad_s = optional("steering.rate_max_deg_s", INFINITY, true) * kDeg;
  t.lever_bandwidth_rad_s = r.positive("driven_coordinate_filters.lever_bandwidth_rad_s");
  t.operator_seat_m = r.has("operator_seat_m") ? r.vec3("operator_seat_m") : Eigen::Vector3d(chassis_cog);

  // Body-to-ground contact points, in the frame each body's pose gives (chassis: geometry frame).
  if (r.has("body_ground_contact")) {
    BodyGroundContact& bc = t.body_contact;
    bc.stiffness_N_m = r.positive("body_ground_contact.stiffness_N_m");
    bc.damping_N_s_m = r.non_negative("body_ground_contact.damping_N_s_m");
    bc.mu = r.non_negative("body_ground_contact.mu");
    bc.friction_speed_m_s = optional("body_ground_contact.friction_speed_m_s", 0.01, true);
    // Each named entry of `section` (an object of objects, each with a "body"): f(key, body).
    auto each_on_a_body = [&](const std::string& section, const char* what, auto&& f) {
      const json& entries = r.node(section);
      if (!entries.is_object() || entries.empty()) r.fail(section, std::string("must be an object of named ") + what);
      for (const auto& [name, v] : entries.items()) {
        const std::string key = section + "." + name;
        if (!v.is_object() || !v.contains("body") || !v["body"].is_string()) r.fail(key, "needs a \"body\"");
        const std::string body = v["body"].template get<std::string>();
        if (body != "chassis" && body != "mast" && body != "carriage")
          r.fail(key + ".body", "must be chassis, mast or carriage");
        f(name, key, body == "chassis" ? TruckBody::kChassis : body == "mast" ? TruckBody::kMast : TruckBody::kCarriage);
      }
    };
    // The chassis' points are given in the geometry frame; the dynamics hold them from its CoG.
    auto in_body_frame = [&](TruckBody body, const Eigen::Vector3d& at) -> Eigen::Vector3d {
      return body == TruckBody::kChassis ? Eigen::Vector3d(at - chassis_cog) : at;
    };
    each_on_a_body("body_ground_contact.points", "points", [&](const std::string& name, const std::string& key, TruckBody body) {
      bc.points.push_back({body, in_body_frame(body, r.vec3(key + ".at_m")), name});
    });
    // Boxes the ground steps' top edges press on between the points (optional).
    if (r.has("body_ground_contact.edge_boxes"))
      each_on_a_body("body_ground_contact.edge_boxes", "boxes", [&](const std::string& name, const std::string& key, TruckBody body) {
        BodyEdgeBox b{body, in_body_frame(body, r.vec3(key + ".min_m")), in_body_frame(body, r.vec3(key + ".max_m")), name};
        if ((b.max_m - b.min_m).minCoeff() <= 0) r.fail(key, "needs max_m above min_m on every axis");
        bc.edge_boxes.push_back(b);
      });
  }
  // The load's friction on the forks (load_on_forks.h); the fork tips are the drawing's fork
  // length, one number for the picture, the collision boxes and the load's base.
  if (r.has("load_contact")) {
    LoadContactParams& lc = t.load_contact;
    lc.friction_static = r.non_negative("load_contact.friction_static");
    lc.friction_kinetic = r.non_negative("load_contact.friction_kinetic");
    if (lc.friction_kinetic > lc.friction_static) r.fail("load_contact.friction_kinetic", "must not exceed friction_static");
    lc.fork_tip_m = r.positive("shape.fork_length_m");
  }
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
  l.size_m = Eigen::Vector3d(length_m, width_m, height_m);
  l.base_length_m = length_m;
  return l;
}

TruckParams with_chassis_mass(const TruckParams& truck, double mass_kg, const Eigen::Vector3d& at_geometry_m) {
  TruckParams t = truck;
  const Eigen::Vector3d old_cog = truck.chassis_cog_geometry_m;
  const double m0 = truck.chassis.mass_kg, m = m0 + mass_kg;
  const Eigen::Vector3d cog = (m0 * old_cog + mass_kg * at_geometry_m) / m;
  const Eigen::Vector3d shift = old_cog - cog;  // chassis-frame offsets move by this
  auto parallel = [](double mass, const Eigen::Vector3d& d) {
    return mass * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
  };
  t.chassis.mass_kg = m;
  t.chassis.inertia_kg_m2 = truck.chassis.inertia_kg_m2 + parallel(m0, old_cog - cog) + parallel(mass_kg, at_geometry_m - cog);
  t.chassis_cog_geometry_m = cog;
  t.service_mass_kg += mass_kg;
  for (WheelParams& w : t.wheels) w.centre_m += shift;
  t.mast_pivot_m += shift;
  for (BodyContactPoint& p : t.body_contact.points) if (p.body == TruckBody::kChassis) p.point_m += shift;
  return t;
}

}  // namespace forklift
