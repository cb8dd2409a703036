// The paper's manoeuvres (section 11), 20 s each, and the offline runner that measures them.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "forklift/dynamics/simulation.h"

namespace forklift {

struct ManoeuvreSpec {
  int number = 0;
  std::string description;
  std::optional<Load> load;
  double lift_m = 0;            // fork lift s held during the run
  InputSchedule inputs;
  std::vector<double> breakpoints_s;  // where the inputs jump: the integrator lands exactly there
  std::optional<double> brake_onset_s;
  double duration_s = 20;
};

// The manoeuvre numbers the paper defines: 1, 2, 3, 4, 5, 10, 11, 12, 14, 15, 17, 18.
const std::vector<int>& manoeuvre_numbers();
// Throws std::invalid_argument for a number the paper does not define.
ManoeuvreSpec manoeuvre(int number, const TruckParams& truck);

// The fork lift s that puts a load's CoG at `height_m` above flat ground (truck level).
double lift_for_load_height(const TruckParams& truck, const Load& load, double height_m);

// One recorded instant of a run.
struct Sample {
  double t = 0;
  Outputs out;
  double drive_torque_N_m = 0;  // after the lag
  double brake_torque_N_m = 0;
};

struct ManoeuvreResult {
  int manoeuvre = 0;
  IntegratorOptions options;
  double sim_time_s = 0;
  IntegratorStats stats;
  double wall_s = 0;            // time spent integrating (not sampling or writing)
  double max_pitch_deg = 0;     // largest |pitch| (+ nose down), including the static lean
  double max_roll_deg = 0;
  std::array<double, kNumWheels> min_fz_N{};
  bool rear_wheel_lifted = false;
  // Brake onset until the forward speed falls below each threshold: the paper does not say when
  // it counts the truck as stopped, so both usual readings are kept.
  struct StopTime {
    double below_m_s = 0;
    std::optional<double> s;
  };
  std::array<StopTime, 2> stop_times{{{0.05, {}}, {0.1, {}}}};
  Eigen::Vector3d final_pose = Eigen::Vector3d::Zero();  // x (m), y (m), yaw (rad)
  bool tipped_over = false;     // roll or pitch beyond 20 deg: the run stops there
  std::vector<Sample> samples;
};

// What a run keeps of each sample: every output (for a time series or a figure), or only the
// metrics (from the state and the wheels' loads: the same figures, without evaluating the model).
enum class Sampling { kSeries, kMetrics };

// Runs manoeuvre `number` from static equilibrium. Metrics are taken every `sample_dt_s` of sim
// time (interpolated by variable-step integrators, so sampling does not add steps); 0 records
// nothing but the final state. With Sampling::kMetrics, `samples` stays empty. Throws
// IntegratorError on numerical failure.
ManoeuvreResult run_manoeuvre(const TruckParams& truck, int number, const IntegratorOptions& options,
                              double sample_dt_s = 0.002, Sampling sampling = Sampling::kSeries);

// The time series as CSV (one row per sample, SI units, angles in degrees).
void write_csv(const ManoeuvreResult& result, const std::string& path, int every_nth = 1);

}  // namespace forklift
