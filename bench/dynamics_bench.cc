// forklift-bench-dynamics: integrator cost on the paper's manoeuvres 4 (sharp braking) and 17
// (zig-zag), beside the paper's Table 1, with the targets checked in the same run.
//
// Each row runs the 20 s manoeuvre without sampling output, `--repeat` times, and reports the
// median wall time. The accuracy column is the final position's distance from an rtol 1e-10
// CVODE run made in the same process.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "forklift/dynamics/manoeuvre.h"

using namespace forklift;

namespace {

struct Row {
  int manoeuvre;
  IntegratorKind kind;
  long paper_steps;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"forklift-bench-dynamics: integrators on manoeuvres 4 and 17 (paper Table 1)"};
  int repeat = 5;
  // Both shipped trucks by default: the paper's (its Table 1) and the training truck.
  std::vector<std::string> truck_files = {std::string(FORKLIFT_DATA_DIR) + "/trucks/simucel_paper.json",
                                          std::string(FORKLIFT_DATA_DIR) + "/trucks/linde_e16c.json"};
  app.add_option("--repeat", repeat, "runs per row; the median wall time is reported")->check(CLI::Range(1, 1000));
  app.add_option("--truck", truck_files, "truck data files (one table each)")->check(CLI::ExistingFile);
  CLI11_PARSE(app, argc, argv);
  bool ok = true;
  for (const std::string& truck_file : truck_files) {
  const TruckParams truck = load_truck(truck_file);
  std::printf("%s%s\n", truck_file == truck_files.front() ? "" : "\n", truck.name.c_str());

  // The paper's Table 1 (steps for 20 s): ode45 287004 / 15289, ode23s 245 / 261, rk4 20000 / 20000.
  const std::vector<Row> rows = {
      {4, IntegratorKind::kCvodeBdf, 245}, {4, IntegratorKind::kDopri5, 287004}, {4, IntegratorKind::kRk4, 20000},
      {17, IntegratorKind::kCvodeBdf, 261}, {17, IntegratorKind::kDopri5, 15289}, {17, IntegratorKind::kRk4, 20000},
  };
  IntegratorOptions reference;
  reference.rtol = 1e-10;
  const Eigen::Vector3d ref4 = run_manoeuvre(truck, 4, reference, 0).final_pose;
  const Eigen::Vector3d ref17 = run_manoeuvre(truck, 17, reference, 0).final_pose;

  std::printf("%-4s %-7s %-22s %8s %9s %10s %10s %12s %11s\n", "man", "integr", "paper (method: steps)", "steps",
              "rhs", "wall_ms", "x_realtime", "us_per_rhs", "err_cm");
  for (const Row& row : rows) {
    IntegratorOptions o;
    o.kind = row.kind;
    std::vector<double> walls;
    ManoeuvreResult r;
    for (int i = 0; i < repeat; ++i) {
      r = run_manoeuvre(truck, row.manoeuvre, o, 0);
      walls.push_back(r.wall_s);
    }
    std::nth_element(walls.begin(), walls.begin() + walls.size() / 2, walls.end());
    const double wall = walls[walls.size() / 2];
    const Eigen::Vector3d& ref = row.manoeuvre == 4 ? ref4 : ref17;
    const double err_cm = (r.final_pose.head<2>() - ref.head<2>()).norm() * 100;
    const char* paper_method = row.kind == IntegratorKind::kCvodeBdf ? "ode23s" : row.kind == IntegratorKind::kDopri5 ? "ode45" : "rk4";
    char paper[32];
    std::snprintf(paper, sizeof paper, "%s: %ld", paper_method, row.paper_steps);
    std::printf("%-4d %-7s %-22s %8ld %9ld %10.2f %10.0f %12.2f %11.3f\n", row.manoeuvre, integrator_name(row.kind), paper,
                r.stats.steps, r.stats.rhs_evals, wall * 1e3, 20.0 / wall, wall * 1e6 / r.stats.rhs_evals, err_cm);
    if (row.kind == IntegratorKind::kCvodeBdf) {
      ok &= r.stats.steps <= 500;
      if (row.manoeuvre == 4) ok &= (20.0 / wall >= 1000) && err_cm <= 1.0;
    }
  }
  }
  std::printf("\ntargets (CVODE BDF, every truck): <= 500 steps on manoeuvres 4 and 17; manoeuvre 4 >= 1000x real time "
              "and within 1 cm of the rtol 1e-10 run: %s\n",
              ok ? "met" : "NOT MET");
  return ok ? 0 : 1;
}
