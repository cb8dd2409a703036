// forklift-bench-dynamics: integrator cost on the paper's manoeuvres 4 (sharp braking) and 17
// (zig-zag), beside the paper's Table 1, with the speed goals checked in the same run.
//
// Each row runs the 20 s manoeuvre without sampling output, `--repeat` times, and reports the
// median wall time. The accuracy column is the final position's distance from an rtol 1e-9
// CVODE run made in the same process. Below each table:
// - one evaluation of the model (its derivative), median time;
// - the worker's way: manoeuvre 4's inputs set at every 1 ms tick and Simulation::advance_to
//   landing exactly on it, each tick timed (median, p99, max);
// - MuJoCo (when libmujoco-dev is installed): a comparable 6-body three-wheel truck (chassis, three
//   wheels, mast, carriage with the load), Euler at 1 ms, driven like manoeuvre 4 for 20 s, and
//   the ratio of our real-time factor to MuJoCo's, measured in this run.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include "figure.h"
#include "forklift/dynamics/manoeuvre.h"

#ifdef FORKLIFT_HAVE_MUJOCO
#include <mujoco/mujoco.h>
#endif

using namespace forklift;

namespace {

using Clock = std::chrono::steady_clock;

struct Row {
  int manoeuvre;
  IntegratorKind kind;
  long paper_steps;
};

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(p * (v.size() - 1) + 0.5))];
}

// A laden truck under way (manoeuvre 4 at 8 s), where an evaluation does its usual work.
struct UnderWay {
  TruckDynamics dynamics;
  StateVector x;
  DriverInputs u;
};
UnderWay under_way(const TruckParams& truck) {
  const ManoeuvreSpec spec = manoeuvre(4, truck);
  TruckDynamics d(truck);
  d.attach_load(*spec.load);
  StateVector x0 = d.rest_state(0, 0, 0, 0, 0, spec.lift_m, 0);
  if (!d.settle_static(x0)) throw IntegratorError("no static equilibrium");
  Simulation sim(d, x0, IntegratorOptions{});
  sim.set_input_schedule(spec.inputs);
  sim.advance_to(8.0);
  return {d, sim.state(), spec.inputs(8.0)};
}

// Median microseconds of one derivative over `repeat` batches of 2000.
double derivative_us(const UnderWay& w, int repeat) {
  std::vector<double> per;
  StateVector dx, x = w.x;
  double sink = 0;
  for (int r = 0; r < repeat; ++r) {
    const auto t0 = Clock::now();
    for (int i = 0; i < 2000; ++i) {
      x[StateIndex::kQdot] = w.x[StateIndex::kQdot] + 1e-9 * i;  // not hoisted out of the loop
      w.dynamics.derivative(x, w.u, dx);
      sink += dx[StateIndex::kQdot];
    }
    per.push_back(seconds_since(t0) / 2000 * 1e6);
  }
  if (!std::isfinite(sink)) std::printf("(non-finite derivative)\n");
  return median(per);
}

struct TickRun {
  std::vector<double> tick_us;
  double wall_s = 0;
  Eigen::Vector3d final_pose = Eigen::Vector3d::Zero();
  IntegratorStats stats;
};

// The worker's loop: inputs held over each 1 ms tick, landing exactly on it.
TickRun run_ticks(const TruckParams& truck, const IntegratorOptions& o) {
  const ManoeuvreSpec spec = manoeuvre(4, truck);
  TruckDynamics d(truck);
  d.attach_load(*spec.load);
  StateVector x0 = d.rest_state(0, 0, 0, 0, 0, spec.lift_m, 0);
  if (!d.settle_static(x0)) throw IntegratorError("no static equilibrium");
  Simulation sim(d, x0, o);
  TickRun r;
  const long ticks = std::lround(spec.duration_s / 1e-3);
  r.tick_us.reserve(ticks);
  for (long k = 0; k < ticks; ++k) {
    const auto t0 = Clock::now();
    sim.set_inputs(spec.inputs(k * 1e-3));
    sim.advance_to((k + 1) * 1e-3);
    const double dt = seconds_since(t0);
    r.tick_us.push_back(dt * 1e6);
    r.wall_s += dt;
  }
  const StateVector& x = sim.state();
  r.final_pose = Eigen::Vector3d(x[kX], x[kY], x[kAwc]);
  r.stats = sim.stats();
  return r;
}

#ifdef FORKLIFT_HAVE_MUJOCO
// A truck of the same make-up as ours: chassis on a free joint, two driven front wheels, a rear
// wheel that steers and spins, a mast that tilts, a carriage that lifts with 500 kg on it (one body).
// Friction 0.3, so that the 1200 N m braking slides the front wheels without tipping the truck
// onto its forks, as in manoeuvre 4; the forks start at their height.
const char* const kMujocoTruck = R"(
<mujoco model="three-wheel truck">
  <compiler autolimits="true"/>
  <default><geom friction="0.3 0.005 0.0001"/></default>
  <option timestep="0.001" integrator="Euler"/>
  <worldbody>
    <geom type="plane" size="500 500 0.1"/>
    <body name="chassis" pos="0 0 0.5">
      <freejoint/>
      <geom type="box" size="0.85 0.5 0.3" pos="-0.8 0 0.05" mass="2400"/>
      <body name="front_left" pos="0 0.45 -0.27">
        <joint name="spin_left" type="hinge" axis="0 1 0"/>
        <geom type="cylinder" size="0.23 0.09" euler="90 0 0" mass="60"/>
      </body>
      <body name="front_right" pos="0 -0.45 -0.27">
        <joint name="spin_right" type="hinge" axis="0 1 0"/>
        <geom type="cylinder" size="0.23 0.09" euler="90 0 0" mass="60"/>
      </body>
      <body name="rear" pos="-1.25 0 -0.31">
        <joint name="steer" type="hinge" axis="0 0 1" range="-1.5 1.5" damping="50"/>
        <joint name="spin_rear" type="hinge" axis="0 1 0"/>
        <geom type="cylinder" size="0.19 0.06" euler="90 0 0" mass="40"/>
      </body>
      <body name="mast" pos="0.3 0 -0.1">
        <joint name="tilt" type="hinge" axis="0 1 0" range="-0.1 0.1" damping="5000"/>
        <geom type="box" size="0.08 0.4 1.1" pos="0 0 1.05" mass="350"/>
        <body name="carriage" pos="0.15 0 0.1">
          <joint name="lift" type="slide" axis="0 0 1" range="0 3" damping="5000"/>
          <geom type="box" size="0.5 0.5 0.5" pos="0.5 0 0.55" mass="650"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="spin_left"/>
    <motor joint="spin_right"/>
    <position joint="steer" kp="20000"/>
    <position joint="tilt" kp="200000"/>
    <position joint="lift" kp="200000"/>
  </actuator>
</mujoco>
)";

// MuJoCo's real-time factor over 20 s of manoeuvre 4's inputs (median of `repeat`); 0 on failure.
// `travel_m`: how far the chassis went, to show the run was a drive and not a blow-up.
double mujoco_realtime(int repeat, double& travel_m) {
  char error[1000] = "";
  mjVFS vfs;
  mj_defaultVFS(&vfs);
  if (mj_makeEmptyFileVFS(&vfs, "truck.xml", int(std::strlen(kMujocoTruck))) != 0) return 0;
  std::memcpy(vfs.filedata[vfs.nfile - 1], kMujocoTruck, std::strlen(kMujocoTruck));
  mjModel* m = mj_loadXML("truck.xml", &vfs, error, sizeof error);
  mj_deleteVFS(&vfs);
  if (!m) {
    std::printf("MuJoCo: %s\n", error);
    return 0;
  }
  const int spin_left = m->jnt_dofadr[mj_name2id(m, mjOBJ_JOINT, "spin_left")];
  const int spin_right = m->jnt_dofadr[mj_name2id(m, mjOBJ_JOINT, "spin_right")];
  std::vector<double> walls;
  for (int r = 0; r < repeat; ++r) {
    mjData* d = mj_makeData(m);
    d->qpos[m->jnt_qposadr[mj_name2id(m, mjOBJ_JOINT, "lift")]] = 0.8;  // the load at about 2 m
    d->ctrl[4] = 0.8;
    mj_forward(m, d);
    const auto t0 = Clock::now();
    for (int k = 0; k < 20000; ++k) {
      const double t = k * 1e-3;
      for (int w = 0; w < 2; ++w) {
        const double spin = d->qvel[w == 0 ? spin_left : spin_right];
        d->ctrl[w] = t < 10 ? 0.5 * 35 * t : -1200 * std::tanh(spin / 0.1);
      }
      mj_step(m, d);
    }
    walls.push_back(seconds_since(t0));
    travel_m = std::hypot(d->qpos[0], d->qpos[1]);
    mj_deleteData(d);
  }
  mj_deleteModel(m);
  return 20.0 / median(walls);
}
#endif

using bench::figure;
using bench::fmt;

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"forklift-bench-dynamics: integrators on manoeuvres 4 and 17 (paper Table 1), the worker's 1 ms "
               "tick, and MuJoCo on a comparable truck"};
  app.set_version_flag("--version", FORKLIFT_VERSION);
  app.option_defaults()->always_capture_default();  // --help shows each option's default
  int repeat = 5;
  // Both shipped trucks by default: the paper's (its Table 1) and the training truck.
  std::vector<std::string> truck_files = {std::string(FORKLIFT_DATA_DIR) + "/trucks/simucel_paper.json",
                                          std::string(FORKLIFT_DATA_DIR) + "/trucks/linde_e16c.json"};
  app.add_option("--repeat", repeat, "runs per row; the median wall time is reported")->check(CLI::Range(1, 1000));
  app.add_option("--truck", truck_files, "truck data files (one table each)")->check(CLI::ExistingFile);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help and --version: 0; bad usage: 2, as every program
  }

#ifdef FORKLIFT_HAVE_MUJOCO
  double mujoco_travel_m = 0;
  const double mujoco_x = mujoco_realtime(repeat, mujoco_travel_m);
#else
  const double mujoco_x = 0;
#endif

  constexpr double kGoalRealtime = 10'000, kGoalVsMujoco = 100;
  bool ok = true;
  double first_m4_x = 0;
  for (const std::string& truck_file : truck_files) {
    const TruckParams truck = load_truck(truck_file);
    std::printf("%s%s\n", truck_file == truck_files.front() ? "" : "\n", truck.name.c_str());

    // The paper's Table 1 (steps for 20 s): ode45 287004 / 15289, ode23s 245 / 261, rk4 20000 / 20000.
    const std::vector<Row> rows = {
        {4, IntegratorKind::kCvodeBdf, 245}, {4, IntegratorKind::kDopri5, 287004}, {4, IntegratorKind::kRk4, 20000},
        {17, IntegratorKind::kCvodeBdf, 261}, {17, IntegratorKind::kDopri5, 15289}, {17, IntegratorKind::kRk4, 20000},
    };
    IntegratorOptions reference;
    reference.rtol = 1e-9;
    const Eigen::Vector3d ref4 = run_manoeuvre(truck, 4, reference, 0).final_pose;
    const Eigen::Vector3d ref17 = run_manoeuvre(truck, 17, reference, 0).final_pose;

    std::printf("%-4s %-7s %-22s %8s %9s %10s %10s %12s %11s\n", "man", "integr", "paper (method: steps)", "steps",
                "rhs", "wall_ms", "x_realtime", "us_per_step", "err_cm");
    for (const Row& row : rows) {
      IntegratorOptions o;
      o.kind = row.kind;
      std::vector<double> walls;
      ManoeuvreResult r;
      for (int i = 0; i < repeat; ++i) {
        r = run_manoeuvre(truck, row.manoeuvre, o, 0);
        walls.push_back(r.wall_s);
      }
      const double wall = median(walls);
      const Eigen::Vector3d& ref = row.manoeuvre == 4 ? ref4 : ref17;
      const double err_cm = (r.final_pose.head<2>() - ref.head<2>()).norm() * 100;
      const char* paper_method = row.kind == IntegratorKind::kCvodeBdf ? "ode23s"
                                 : row.kind == IntegratorKind::kDopri5 ? "ode45"
                                                                       : "rk4";
      char paper[32];
      std::snprintf(paper, sizeof paper, "%s: %ld", paper_method, row.paper_steps);
      std::printf("%-4d %-7s %-22s %8ld %9ld %10.2f %10.0f %12.2f %11.3f\n", row.manoeuvre, integrator_name(row.kind),
                  paper, r.stats.steps, r.stats.rhs_evals, wall * 1e3, 20.0 / wall, wall * 1e6 / r.stats.steps, err_cm);
      if (row.kind == IntegratorKind::kCvodeBdf) {
        ok &= r.stats.steps <= 500;
        if (row.manoeuvre == 4) {
          ok &= (20.0 / wall >= kGoalRealtime) && err_cm <= 1.0;
          if (first_m4_x == 0) {
            first_m4_x = 20.0 / wall;
            figure("dynamics, manoeuvre 4 (" + truck.name + "), CVODE: times real time", ">= 10,000x",
                   fmt("%.0fx", first_m4_x), first_m4_x >= kGoalRealtime);
            figure("dynamics, manoeuvre 4: steps; distance from an rtol 1e-9 run", "<= 500; <= 1 cm",
                   fmt("%ld; %.2f cm", r.stats.steps, err_cm), r.stats.steps <= 500 && err_cm <= 1.0);
          }
          if (mujoco_x > 0) ok &= 20.0 / wall >= kGoalVsMujoco * mujoco_x;
        }
      }
    }

    std::printf("one evaluation of the model (manoeuvre 4 under way): %.2f us\n", derivative_us(under_way(truck), repeat * 20));
    std::vector<double> tick_us;
    TickRun ticks;
    for (int i = 0; i < repeat; ++i) {
      ticks = run_ticks(truck, IntegratorOptions{});
      tick_us.insert(tick_us.end(), ticks.tick_us.begin(), ticks.tick_us.end());
    }
    if (truck_file == truck_files.front())
      figure("dynamics alone in the worker's 1 ms tick (manoeuvre 4): median; p99", "(the whole tick below)",
             fmt("%.1f us; %.1f us", median(tick_us), percentile(tick_us, 0.99)), percentile(tick_us, 0.99) < 150);
    std::printf("worker's 1 ms tick, manoeuvre 4 (cvode, inputs set each tick): median %.1f us, p99 %.1f us, max %.0f us; "
                "%ld steps, %ld rhs, %.0fx real time, err %.3f cm\n",
                median(tick_us), percentile(tick_us, 0.99), *std::max_element(tick_us.begin(), tick_us.end()),
                ticks.stats.steps, ticks.stats.rhs_evals, 20.0 / ticks.wall_s,
                (ticks.final_pose.head<2>() - ref4.head<2>()).norm() * 100);
  }

  std::printf("\n");
#ifdef FORKLIFT_HAVE_MUJOCO
  if (mujoco_x > 0)
    std::printf("MuJoCo %s, 6-body three-wheel truck, Euler 1 ms, 20 s of manoeuvre 4's inputs (%.1f m driven): "
                "%.0fx real time; ours (CVODE, manoeuvre 4, first truck) / MuJoCo's = %.0fx (goal >= %.0fx)\n",
                mj_versionString(), mujoco_travel_m, mujoco_x, first_m4_x / mujoco_x, kGoalVsMujoco);
  if (mujoco_x > 0)
    figure(std::string("dynamics against MuJoCo ") + mj_versionString() + " (6 bodies, Euler 1 ms): ratio of real-time factors",
           ">= 100x", fmt("%.0fx (MuJoCo %.0fx real time)", first_m4_x / mujoco_x, mujoco_x), first_m4_x >= kGoalVsMujoco * mujoco_x);
  else
    std::printf("MuJoCo failed to load the truck; comparison skipped\n");
#else
  std::printf("MuJoCo not installed; comparison skipped\n");
#endif
  std::printf("targets (CVODE BDF, every truck): <= 500 steps on manoeuvres 4 and 17; manoeuvre 4 >= %.0fx real time, "
              "within 1 cm of the rtol 1e-9 run and >= %.0fx MuJoCo's real-time factor: %s\n",
              kGoalRealtime, kGoalVsMujoco, ok ? "met" : "NOT MET");
  return ok ? 0 : 1;
}
