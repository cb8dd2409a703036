// What a sim worker needs beside the model: turning cab controls into driver inputs (and refusing
// bad ones), the session's scenario, and the control log that makes a session replayable.
#pragma once

#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "forklift/simulation.h"

namespace forklift {

// One cab control sample, as received (protocol's fk_Controls without the strings).
struct ControlSample {
  uint32_t seq = 0;
  double steer_rad = 0, accelerator = 0, brake = 0, lift = 0, tilt = 0, side_shift = 0;
  bool horn = false;
  bool parking_brake = false;
};

// Why a sample must not reach the integrator, or nullopt if it is fine: a non-finite value or
// one outside its documented range (protocol/idl/Forklift.idl).
std::optional<std::string> control_problem(const ControlSample& c);

// Normalised cab commands onto the truck's limits.
DriverInputs driver_inputs(const ControlSample& c, const TruckParams& truck);

// The dead-man response: no drive, full brake, levers still, steer held.
DriverInputs deadman_inputs(const DriverInputs& last, const TruckParams& truck);

// A session's starting conditions (JSON; all keys optional):
//   { "truck": "trucks/linde_e16c.json", "start": {"x_m": 0, "y_m": 0, "yaw_deg": 0},
//     "load": {"mass_kg": 500, "lateral_m": 0, "cog_height_m": 2.0} }
// Relative paths are resolved against the data directory.
struct Scenario {
  std::string truck_file;
  double x_m = 0, y_m = 0, yaw_rad = 0;
  std::optional<Load> load;
  double lift_m = 0;
};
Scenario default_scenario(const std::string& data_dir);
// Throws std::runtime_error naming the file and the problem.
Scenario load_scenario(const std::string& path, const std::string& data_dir);

// The control log: every input change with the physics tick at which it was applied, the
// initial state and load, and the final state, with doubles written exactly (hex floats), so
// that a replay re-simulates the session bit for bit. Each line is flushed as it is written.
struct LogHeader {
  std::string session_id, cab_id, truck_file;
  std::string scenario_file;  // the scene the session ran in (its pallets and contacts); empty: a bare floor
  std::string mode = "training";  // how the evaluation marks it: "training" or "exam"
  double tick_s = 1e-3;
  IntegratorOptions integrator;
  StateVector initial = StateVector::Zero();
  std::optional<Load> load;
};

class ControlLogWriter {
 public:
  ControlLogWriter(const std::string& path, const LogHeader& header);  // throws on I/O error
  ~ControlLogWriter();
  void input(int64_t tick, uint32_t seq, const DriverInputs& u);
  // A line of the session log beside the inputs (events and the score; see cab_session.h).
  void note(const std::string& line);
  void finish(int64_t ticks, const StateVector& final_state);

 private:
  FILE* f_;
};

struct ControlLog {
  LogHeader header;
  struct Entry { int64_t tick; uint32_t seq; DriverInputs inputs; };
  std::vector<Entry> entries;
  std::vector<std::string> notes;            // event ("e" evaluation, "w" worker), score and dead-man lines, in order
  std::optional<int64_t> ticks;              // absent if the worker died before finishing
  std::optional<StateVector> final_state;
};
ControlLog read_control_log(const std::string& path);  // throws std::runtime_error

// Re-simulates a logged session: applies each logged input at its tick, advancing tick by tick
// exactly as the live worker did. Runs to the logged end (or the last logged input).
StateVector replay(const ControlLog& log, int64_t* ticks_run = nullptr);

// Exact text of a state (hex floats), for logs and bit-for-bit comparison.
std::string state_hex(const StateVector& x);
StateVector parse_state_hex(const std::string& text);

// Share of the least-loaded wheel relative to an even split of the total: 1 even, 0 a wheel off.
double stability_margin(const Outputs& o);

}  // namespace forklift
