// forklift-bench-collision: what the Collision module costs per physics tick, in the shipped
// default warehouse (data/scenarios/rack_pick.json on data/scenes/warehouse.json: 52 objects,
// among them 16 racks of 16 boxes each and 14 pallets) with the shipped truck's meshes (about
// 40 boxes). Target: under 50 us per step.
//
// Rows, each a fixed truck state, so only the collision code is timed:
//   BodyPoses            baseline: the truck's body poses alone (what every step starts with)
//   PhysicsTick          baseline: one 1 ms physics tick (CVODE) of the same truck, driving
//   ContactsAt/aisle     the truck in aisle A between racks R1-R4 and R5-R8: no contact
//   ContactsAt/rack      the carriage 3 cm into rack R4's level-1 beam: one contact
//   ContactsAt/deep      the truck half a metre into rack R2, under pallet P3: the worst case
//   Step/aisle, /rack, /deep  Warehouse::step: the same plus handling and, with contacts, velocities
//   StepCarrying         Warehouse::step with pallet P13 (300 kg) on the forks: slide, set-down tests
// Read the rows as ratios to the baselines: Step/aisle / PhysicsTick is what collision adds
// to a tick. The worker steps physics at 1 kHz, so 1 ms is the whole budget.
//
//   forklift-bench-collision [--benchmark_repetitions=5 --benchmark_report_aggregates_only=true]
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "benchmark_args.h"
#include "forklift/collision/collision.h"

using namespace forklift;

namespace {

const std::string kData = FORKLIFT_DATA_DIR;

struct World {
  TruckParams truck = load_truck(kData + "/trucks/linde_e16c.json");
  Scene scene = load_scene(kData + "/scenarios/rack_pick.json", kData);
  TruckShape shape = load_truck_shape(kData + "/trucks/linde_e16c.json", kData);
  TruckDynamics dynamics{truck, Environment{scene.ground, Eigen::Vector3d(0, 0, -9.81), std::nullopt, {}}};

  // A settled truck with its front axle's middle at (x, y), heading yaw, fork top at heel_z.
  StateVector at(double x, double y, double yaw, double heel_z) const {
    const Eigen::Vector2d cog = Eigen::Vector2d(x, y) + Eigen::Rotation2Dd(yaw) * truck.chassis_cog_geometry_m.head<2>();
    double lift = 0;
    StateVector s;
    for (int i = 0; i < 3; ++i) {
      s = dynamics.rest_state(cog.x(), cog.y(), yaw, 0, 0, lift, 0);
      if (!dynamics.settle_static(s)) throw std::runtime_error("no static equilibrium");
      lift += heel_z - body_poses(truck, coordinates(s)).carriage.translation().z();
    }
    return s;
  }
};

World& world() {
  static World w;
  return w;
}

// In aisle A, heading east, between the racks.
StateVector aisle_state() { return world().at(16.0, 26.15, 0, 0.1); }
// Heading north into R4: the carriage 3 cm into its level-1 beam's face (y 27.9).
StateVector rack_state() { return world().at(21.0, 27.9 + 0.03 - 0.4, M_PI / 2, 0.1); }
// The worst case: driven on through R2 until the front axle is 0.5 m inside it, the mast, guard
// and carriage in its beams and the guard under pallet P3 on level 2.
StateVector deep_state() { return world().at(16.7, 27.9 + 0.5, M_PI / 2, 0.1); }

void BM_BodyPoses(benchmark::State& st) {
  const CoordVector q = coordinates(aisle_state());
  for (auto _ : st) benchmark::DoNotOptimize(body_poses(world().truck, q));
}
BENCHMARK(BM_BodyPoses);

void BM_PhysicsTick(benchmark::State& st) {
  Simulation sim(world().dynamics, aisle_state(), IntegratorOptions{});
  DriverInputs u;
  u.drive_torque_N_m = 300;
  sim.set_inputs(u);
  sim.advance_to(1.0);  // under way
  for (auto _ : st) sim.advance_to(sim.time() + 1e-3);
}
BENCHMARK(BM_PhysicsTick);

void BM_ContactsAt(benchmark::State& st, StateVector (*state)()) {
  Warehouse w(world().scene, world().shape, world().truck);
  const CoordVector q = coordinates(state());
  size_t contacts = 0;
  for (auto _ : st) contacts = w.contacts_at(q).size();
  st.counters["contacts"] = double(contacts);
}
BENCHMARK_CAPTURE(BM_ContactsAt, aisle, aisle_state);
BENCHMARK_CAPTURE(BM_ContactsAt, rack, rack_state);
BENCHMARK_CAPTURE(BM_ContactsAt, deep, deep_state);

void BM_Step(benchmark::State& st, StateVector (*state)()) {
  Warehouse w(world().scene, world().shape, world().truck);
  Simulation sim(world().dynamics, state(), IntegratorOptions{});
  HandlingState handling;
  size_t contacts = 0;
  for (auto _ : st) contacts = w.step(sim, handling).contacts.size();
  st.counters["contacts"] = double(contacts);
}
BENCHMARK_CAPTURE(BM_Step, aisle, aisle_state);
BENCHMARK_CAPTURE(BM_Step, rack, rack_state);
BENCHMARK_CAPTURE(BM_Step, deep, deep_state);

// Pallet P13 on the floor at (31.0, 26.0), its pockets along world y: forks in 0.9 m at pocket
// height, then lifted until the Warehouse picks it up, then 0.2 s more.
void BM_StepCarrying(benchmark::State& st) {
  Warehouse w(world().scene, world().shape, world().truck);
  Simulation sim(world().dynamics, world().at(31.0, 26.0 - 0.6 + 0.9 - 1.4, M_PI / 2, 0.092), IntegratorOptions{});
  HandlingState handling = w.initial_handling();
  const auto carried = [&] { return handling.pallet("P13")->on_forks; };
  DriverInputs u;
  u.lift_rate_m_s = 0.2;
  sim.set_inputs(u);
  for (int tick = 1; tick <= 1000 && !carried(); ++tick) {
    sim.advance_to(tick * 1e-3);
    apply(w.step(sim, handling), sim);
  }
  if (!carried()) {
    st.SkipWithError("P13 was not picked up");
    return;
  }
  sim.set_inputs(DriverInputs{});
  for (int tick = 0; tick < 200; ++tick) {
    sim.advance_to(sim.time() + 1e-3);
    apply(w.step(sim, handling), sim);
  }
  if (!carried()) {
    st.SkipWithError("P13 fell off");
    return;
  }
  for (auto _ : st) benchmark::DoNotOptimize(w.step(sim, handling));
  st.counters["total_mass_kg"] = sim.outputs().total_mass_kg;
}
BENCHMARK(BM_StepCarrying);

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"forklift-bench-collision: what the Collision module costs per physics tick in the shipped warehouse"};
  if (const auto stop = forklift::bench::parse_benchmark_command_line(app, argc, argv)) return *stop;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
