// Shared fixtures of the collision tests: tiny scenes built in code (boxes, as the shipped
// meshes are), the shipped truck, and a driven simulation ticking the Warehouse every 1 ms.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "forklift/collision/collision.h"

namespace fx {

using namespace forklift;
using Eigen::AlignedBox3d;
using Eigen::Isometry3d;
using Eigen::Vector3d;

inline const TruckParams& truck() {
  static const TruckParams t = load_truck(std::string(FORKLIFT_DATA_DIR) + "/trucks/linde_e16c.json");
  return t;
}

// The shipped data: the default warehouse (through its rack_pick scenario) and the truck's meshes.
inline const Scene& shipped_warehouse() {
  static const Scene s = load_scene(std::string(FORKLIFT_DATA_DIR) + "/scenarios/rack_pick.json", FORKLIFT_DATA_DIR);
  return s;
}
inline const TruckShape& shipped_shape() {
  static const TruckShape s = load_truck_shape(std::string(FORKLIFT_DATA_DIR) + "/trucks/linde_e16c.json", FORKLIFT_DATA_DIR);
  return s;
}

inline AlignedBox3d box(double x0, double y0, double z0, double x1, double y1, double z1) {
  return AlignedBox3d(Vector3d(x0, y0, z0), Vector3d(x1, y1, z1));
}

// A mesh of named boxes (collision needs only a part's name, bounds and solidity).
inline std::shared_ptr<const Mesh> mesh(const std::vector<std::pair<std::string, AlignedBox3d>>& parts) {
  auto m = std::make_shared<Mesh>();
  m->source = "test";
  m->bounds.setEmpty();
  for (const auto& [name, b] : parts) {
    MeshPart p;
    p.name = name;
    p.bounds = b;
    p.solid = name.rfind("mark_", 0) != 0;
    m->parts.push_back(p);
    m->bounds.extend(b);
  }
  return m;
}

// The truck's parts as boxes, in the frames BodyPoses gives (sizes of a 1.6 t counterbalance
// truck: chassis 1.65 m long, guard roof at 2 m, mast to 2 m, forks 1 m long, 0.1 wide, 0.04 thick).
inline TruckShape truck_shape() {
  TruckShape s;
  s.chassis = mesh({{"chassis_body", box(-1.6, -0.53, 0.08, 0.05, 0.53, 1.1)},
                    {"guard_post_front_left", box(-0.1, 0.45, 1.1, -0.02, 0.53, 2.0)},
                    {"guard_post_front_right", box(-0.1, -0.53, 1.1, -0.02, -0.45, 2.0)},
                    {"guard_roof", box(-1.0, -0.53, 2.0, 0.15, 0.53, 2.06)}});
  s.mast = mesh({{"mast_left", box(-0.05, 0.27, -0.3, 0.1, 0.35, 1.65)},
                 {"mast_right", box(-0.05, -0.35, -0.3, 0.1, -0.27, 1.65)}});
  s.carriage = mesh({{"carriage_plate", box(-0.05, -0.4, 0.0, 0.0, 0.4, 1.0)},
                     {"fork_left", box(0.0, 0.13, -0.04, 1.0, 0.23, 0.0)},
                     {"fork_right", box(0.0, -0.23, -0.04, 1.0, -0.13, 0.0)}});
  return s;
}

inline Isometry3d pose(double x, double y, double z = 0, double yaw_deg = 0) {
  return Eigen::Translation3d(x, y, z) * Eigen::AngleAxisd(yaw_deg * M_PI / 180, Vector3d::UnitZ());
}

// A pallet-rack bay 2.7 m long (local x) and 1.1 m deep (y), beams along x front and back with
// their tops at `levels`, and a support per level over the whole footprint.
inline SceneObject rack(const std::string& id, const Isometry3d& where, std::vector<double> levels = {0.9, 1.8}) {
  std::vector<std::pair<std::string, AlignedBox3d>> parts;
  for (double sx : {-1.0, 1.0})
    for (double sy : {-1.0, 1.0})
      parts.push_back({"upright", box(std::min(sx * 1.35, sx * 1.27), std::min(sy * 0.55, sy * 0.47), 0,
                                      std::max(sx * 1.35, sx * 1.27), std::max(sy * 0.55, sy * 0.47), 3.2)});
  SceneObject o;
  for (size_t l = 0; l < levels.size(); ++l) {
    const double top = levels[l];
    parts.push_back({"beam_front", box(-1.27, -0.55, top - 0.1, 1.27, -0.5, top)});
    parts.push_back({"beam_back", box(-1.27, 0.5, top - 0.1, 1.27, 0.55, top)});
    o.supports.push_back({"level " + std::to_string(l + 1), int(l + 1),
                          Eigen::AlignedBox2d(Eigen::Vector2d(-1.35, -0.55), Eigen::Vector2d(1.35, 0.55)), top});
  }
  o.id = id;
  o.kind = ObjectKind::kRack;
  o.pose = where;
  o.mesh = mesh(parts);
  return o;
}

// EUR pallet 1.2 x 0.8 x 0.144 m, pockets along x, with a box load on its deck.
inline PalletSpec eur_pallet(double load_kg = 300, Vector3d load_size = Vector3d(1.0, 0.8, 0.8)) {
  PalletSpec s;
  s.pockets_y_m = {Eigen::Vector2d(-0.255, -0.0725), Eigen::Vector2d(0.0725, 0.255)};
  s.load_mass_kg = load_kg;
  s.load_size_m = load_kg > 0 ? load_size : Vector3d::Zero();
  return s;
}

// The pallet's mesh as the shipped one is built: three bottom boards across, three block rows
// along x (the gaps between them are the pockets), one deck. Without `with_mesh` the collision
// module builds its boxes from the spec.
inline SceneObject pallet(const std::string& id, const Isometry3d& where, const PalletSpec& spec, bool with_mesh = true) {
  SceneObject o;
  o.id = id;
  o.kind = ObjectKind::kPallet;
  o.pose = where;
  o.pallet = spec;
  if (with_mesh)
    o.mesh = mesh({{"bottom_back", box(-0.6, -0.4, 0, -0.455, 0.4, 0.022)},
                   {"bottom_middle", box(-0.0725, -0.4, 0, 0.0725, 0.4, 0.022)},
                   {"bottom_front", box(0.455, -0.4, 0, 0.6, 0.4, 0.022)},
                   {"blocks_right", box(-0.6, -0.4, 0.022, 0.6, -0.255, 0.122)},
                   {"blocks_centre", box(-0.6, -0.0725, 0.022, 0.6, 0.0725, 0.122)},
                   {"blocks_left", box(-0.6, 0.255, 0.022, 0.6, 0.4, 0.122)},
                   {"deck", box(-0.6, -0.4, 0.122, 0.6, 0.4, 0.144)}});
  return o;
}

// A scene of just these objects.
inline Scene scene_of(std::vector<SceneObject> objects) {
  Scene s;
  s.name = "test";
  s.objects = std::move(objects);
  return s;
}

inline SceneObject wall(const std::string& id, const AlignedBox3d& b) {
  SceneObject o;
  o.id = id;
  o.kind = ObjectKind::kWall;
  o.mesh = mesh({{"wall", b}, {"mark_stripe", box(b.min().x() - 0.01, b.min().y(), 0, b.max().x() + 0.01, b.max().y(), 0.1)}});
  return o;
}

// A settled truck whose geometry frame (the floor below the front axle's middle) stands at
// (x, y), heading yaw, with its fork top (the heel) `heel_z` above the floor.
inline StateVector settled(const TruckDynamics& d, double x, double y, double yaw, double heel_z, double tilt = 0) {
  const Eigen::Vector2d cog = Eigen::Vector2d(x, y) + Eigen::Rotation2Dd(yaw) * d.truck().chassis_cog_geometry_m.head<2>();
  double lift = 0;
  StateVector s;
  for (int i = 0; i < 3; ++i) {
    s = d.rest_state(cog.x(), cog.y(), yaw, 0, tilt, lift, 0);
    if (!d.settle_static(s)) throw std::runtime_error("no static equilibrium");
    lift += heel_z - body_poses(d.truck(), coordinates(s)).carriage.translation().z();
  }
  return s;
}

inline double forward_speed(const StateVector& x) {
  const double yaw = x[StateIndex::kQ + kAwc];
  return std::cos(yaw) * x[StateIndex::kQdot + kX] + std::sin(yaw) * x[StateIndex::kQdot + kY];
}

// Drive torque (or brake) holding a forward speed (negative: reverse).
inline DriverInputs hold_speed(double target, double v) {
  DriverInputs u;
  const double e = target - v;
  // Proportional, plus the torque the unladen truck's rolling resistance takes at the wheels.
  const TruckParams& t = truck();
  const double rolling = t.contact.rolling_resistance_coefficient * t.service_mass_kg * kGravity_m_s2 * t.wheels[kFrontLeft].radius_m;
  u.drive_torque_N_m = std::clamp(3000.0 * e + (target > 0 ? rolling : target < 0 ? -rolling : 0.0), -900.0, 900.0);
  if (std::abs(target) < 1e-9 && std::abs(v) > 0.02) { u.drive_torque_N_m = 0; u.brake_torque_N_m = 400; }
  return u;
}

// A simulation at 1 ms ticks with the Warehouse stepped after each tick, as the worker runs it.
struct Driven {
  static constexpr double kTick = 1e-3;
  TruckDynamics dynamics;
  std::unique_ptr<Simulation> sim;
  std::unique_ptr<Warehouse> warehouse;
  HandlingState handling;  // every pallet, as the warehouse steps them
  std::vector<PedestrianState> people;  // where the scene's pedestrians stand (empty: none placed)
  std::vector<std::pair<double, Contact>> contacts;  // every contact of every tick, with its time
  std::vector<HandlingEvent> events;
  std::vector<double> event_times;

  Driven(const Scene& scene, const TruckShape& shape, const StateVector& x0)
      : dynamics(truck(), Environment{scene.ground, Vector3d(0, 0, -kGravity_m_s2), std::nullopt, {}}) {
    sim = std::make_unique<Simulation>(dynamics, x0, IntegratorOptions{});
    warehouse = std::make_unique<Warehouse>(scene, shape, truck());
    handling = warehouse->initial_handling();
  }

  const StateVector& x() const { return sim->state(); }
  double v() const { return forward_speed(x()); }
  double t() const { return sim->time(); }
  BodyPoses poses() const { return body_poses(truck(), coordinates(x())); }
  double lift() const { return coordinates(x())[kS]; }
  double mass() const { return sim->outputs().total_mass_kg; }

  // Ticks until `done` holds (checked after each tick) or `max_s` has passed; true if done.
  bool run(double max_s, const std::function<DriverInputs()>& control, const std::function<bool()>& done = {}) {
    const double end = t() + max_s;
    while (t() < end - 1e-9) {
      sim->set_inputs(control());
      sim->advance_to(t() + kTick);
      const StepReport& r = warehouse->step(*sim, handling, people);
      apply(r, *sim);
      for (const Contact& c : r.contacts) contacts.emplace_back(t(), c);
      for (const HandlingEvent& e : r.handling) {
        events.push_back(e);
        event_times.push_back(t());
      }
      if (done && done()) return true;
    }
    return false;
  }

  int count(HandlingEvent::Kind k) const {
    return int(std::count_if(events.begin(), events.end(), [k](const HandlingEvent& e) { return e.kind == k; }));
  }
};

}  // namespace fx
