// The session log: the record that makes a session replayable and its marks checkable (format
// byte for byte in docs/session-log.md).
#pragma once

#include <cstdint>
#include <cstdio>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "forklift/dynamics/simulation.h"
#include "forklift/session/vocabulary.h"  // kNoControlsEvent, kControlsResumedEvent

namespace forklift {

// The session log: every input change with the physics tick at which it was applied, the
// initial state and load, the dead-man switches, the events and the score the session derived,
// and the final state, with doubles written exactly (hex floats), so that a replay re-simulates
// the session bit for bit and checks its marks. Each line is flushed as it is written: a worker
// that is killed leaves everything it applied.
struct LogHeader {
  std::string session_id, cab_id, truck_file;
  std::string scenario_file;  // the scene the session ran in (its pallets and contacts); empty: a bare floor
  std::string mode = "training";  // how the evaluation marks it: "training" or "exam"
  double tick_s = 1e-3;
  IntegratorOptions integrator;
  StateVector initial = StateVector::Zero();
  std::optional<Load> load;
};

// What an instructor did to the session (the log's "instructor" line), at the tick it was done:
// pause and resume, a message with its text (one line; instructor_message_problem() holds), a
// rewind to the rewind point kept at a tick, or a hazard: a pedestrian of the scene set walking.
struct Instruction {
  InstructorAction action = InstructorAction::kPause;
  std::string text;      // a message's; a hazard's pedestrian id; empty otherwise
  int64_t to_tick = 0;   // a rewind's: the tick of the point it went back to (logged)
  double seconds = 0;    // a rewind's: how far back it was asked to go, s (the worker's; not logged)
  bool operator==(const Instruction&) const = default;
};

class ControlLogWriter {
 public:
  ControlLogWriter(const std::string& path, const LogHeader& header);  // throws on I/O error
  ~ControlLogWriter();
  ControlLogWriter(const ControlLogWriter&) = delete;
  ControlLogWriter& operator=(const ControlLogWriter&) = delete;

  void input(int64_t tick, uint32_t seq, const DriverInputs& u);     // "i": applied from this tick on
  void deadman(int64_t tick, bool on);                                // "dm": the worker's dead-man switch
  void event(int64_t tick, const std::string& kind, int worry_level); // "e": one the session derived
  void worker_event(int64_t tick, const std::string& kind);          // "w": the worker's own (not marked)
  void instruction(int64_t tick, const Instruction& what);           // "instructor": the instructor's act
  void score(const std::string& line);                                // "score": score_line() of the mark
  // "controls": the worker's tally of the cab's samples (name=count words, in this order), once,
  // before "end"; names are single words without '='.
  void control_counts(const std::vector<std::pair<std::string, long>>& counts);
  void finish(int64_t ticks, const StateVector& final_state);         // "end" and "final"

 private:
  FILE* f_;
};

struct ControlLog {
  LogHeader header;
  // `segment`: how many rewinds came before the line (ticks start again after each).
  struct Entry { int64_t tick; uint32_t seq; DriverInputs inputs; int segment = 0; };
  std::vector<Entry> entries;
  std::vector<std::pair<int64_t, bool>> deadman;          // switches, by tick
  std::vector<std::string> event_lines;                   // "e" lines, as written
  std::vector<std::pair<int64_t, std::string>> worker_events;  // "w" lines: tick, kind
  std::vector<std::pair<int64_t, Instruction>> instructions;   // "instructor" lines, in order
  std::vector<int> deadman_segments, instruction_segments;     // each "dm" and "instructor" line's segment
  std::optional<std::string> score_line;                  // "score" line, as written
  std::map<std::string, long> control_counts;             // "controls" line: the worker's tally
  std::optional<int64_t> ticks;              // absent if the worker died before finishing
  std::optional<StateVector> final_state;
  // The reason the logged session ended with (its score line's last word), if it has one.
  std::optional<std::string> end_reason() const;
};
ControlLog read_control_log(const std::string& path);  // throws std::runtime_error

// An "e" line: an event the session derived, after the tick it was found in.
std::string event_line(int64_t tick, const std::string& kind, int worry_level);

// Exact text of a state (hex floats), for logs and bit-for-bit comparison.
std::string state_hex(const StateVector& x);
StateVector parse_state_hex(const std::string& text);

}  // namespace forklift
