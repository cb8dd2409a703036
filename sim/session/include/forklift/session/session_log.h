// The session log: the record that makes a session replayable and its marks checkable (format
// byte for byte in docs/session-log.md).
#pragma once

#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "forklift/dynamics/simulation.h"

namespace forklift {

// The dead-man response: no drive, full brake, levers still, steer held.
DriverInputs deadman_inputs(const DriverInputs& last, const TruckParams& truck);

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

// Exact text of a state (hex floats), for logs and bit-for-bit comparison.
std::string state_hex(const StateVector& x);
StateVector parse_state_hex(const std::string& text);

}  // namespace forklift
