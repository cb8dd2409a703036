#include "forklift/session/session_log.h"

#include "forklift/session/log_records.h"

#include <cinttypes>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>


namespace forklift {

namespace {

std::string hex(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%a", v);
  return buf;
}

double from_hex(const std::string& s) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end == s.c_str() || *end != '\0') throw std::runtime_error("bad number '" + s + "' in control log");
  return v;
}

std::vector<std::string> split(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

// "instructor <tick> pause|resume", "... message <text>", "... rewind <to tick>" or "... hazard
// <pedestrian id>": `rest` is the line after
// "instructor ", as written (the text keeps its own spaces).
Instruction instruction_of(const std::vector<std::string>& w, const std::string& rest) {
  const auto action = w.size() >= 3 ? parse<InstructorAction>(w[2]) : std::nullopt;
  if (!action) throw std::runtime_error("an instructor line is 'instructor <tick> pause|resume|message [text]'");
  Instruction i{*action, ""};
  if (*action == InstructorAction::kRewind) {
    if (w.size() != 4) throw std::runtime_error("a rewind is 'instructor <tick> rewind <to tick>'");
    i.to_tick = std::stoll(w[3]);
    if (i.to_tick < 0 || i.to_tick > std::stoll(w[1])) throw std::runtime_error("a rewind goes back, to a tick not before 0");
    return i;
  }
  if (*action != InstructorAction::kMessage && *action != InstructorAction::kHazard) {
    if (w.size() != 3) throw std::runtime_error("an instructor's " + w[2] + " takes no text");
    return i;
  }
  const std::string head = w[1] + " " + w[2] + " ";
  i.text = rest.rfind(head, 0) == 0 ? rest.substr(head.size()) : "";
  // The log's own bound: the worker has checked the message against data/session.json's, and the
  // pedestrian against the scene's.
  if (const auto problem = instructor_message_problem(i.text, kInstructorMessageCharsCeiling)) throw std::runtime_error(*problem);
  return i;
}

}  // namespace

std::optional<std::string> ControlLog::end_reason() const {
  if (!score_line) return std::nullopt;
  return score_line->substr(score_line->rfind(' ') + 1);
}

std::string state_hex(const StateVector& x) {
  std::string s;
  for (int i = 0; i < StateIndex::kSize; ++i) {
    if (i) s += ' ';
    s += hex(x[i]);
  }
  return s;
}

StateVector parse_state_hex(const std::string& text) {
  const std::vector<std::string> w = split(text);
  if (w.size() != StateIndex::kSize)
    throw std::runtime_error("a state needs " + std::to_string(StateIndex::kSize) + " numbers, got " + std::to_string(w.size()));
  StateVector x;
  for (int i = 0; i < StateIndex::kSize; ++i) x[i] = from_hex(w[i]);
  return x;
}

ControlLogWriter::ControlLogWriter(const std::string& path, const LogHeader& h) {
  f_ = std::fopen(path.c_str(), "w");
  if (!f_) throw std::runtime_error("cannot write control log " + path);
  std::fprintf(f_, "forklift-control-log 1\nsession %s\ncab %s\ntruck %s\ntick %s\nintegrator %s %s %d\ninit %s\n",
               h.session_id.c_str(), h.cab_id.c_str(), h.truck_file.c_str(), hex(h.tick_s).c_str(),
               integrator_name(h.integrator.kind), hex(h.integrator.rtol).c_str(), h.integrator.cvode_max_order,
               state_hex(h.initial).c_str());
  if (!h.scenario_file.empty()) std::fprintf(f_, "scenario %s\n", h.scenario_file.c_str());
  std::fprintf(f_, "mode %s\n", h.mode.c_str());
  if (h.load) {
    std::fprintf(f_, "load %s", hex(h.load->mass_kg).c_str());
    for (int i = 0; i < 3; ++i) std::fprintf(f_, " %s", hex(h.load->cog_m[i]).c_str());
    for (int i = 0; i < 9; ++i) std::fprintf(f_, " %s", hex(h.load->inertia_kg_m2(i / 3, i % 3)).c_str());
    for (int i = 0; i < 3; ++i) std::fprintf(f_, " %s", hex(h.load->size_m[i]).c_str());
    std::fprintf(f_, "\n");
  }
  std::fflush(f_);
}

ControlLogWriter::~ControlLogWriter() { std::fclose(f_); }

void ControlLogWriter::input(int64_t tick, uint32_t seq, const DriverInputs& u) {
  // The horn's field only while it sounds: a log without it reads as before.
  std::fprintf(f_, "i %" PRId64 " %u %s %s %s %s %s %s %d%s\n", tick, seq, hex(u.drive_torque_N_m).c_str(),
               hex(u.brake_torque_N_m).c_str(), hex(u.steer_rad).c_str(), hex(u.tilt_rate_rad_s).c_str(),
               hex(u.lift_rate_m_s).c_str(), hex(u.shift_rate_m_s).c_str(), u.parking_brake ? 1 : 0, u.horn ? " 1" : "");
  std::fflush(f_);  // a worker that is killed leaves everything it applied
}

void ControlLogWriter::deadman(int64_t tick, bool on) {
  std::fprintf(f_, "dm %" PRId64 " %d\n", tick, on ? 1 : 0);
  std::fflush(f_);
}

std::string event_line(int64_t tick, const std::string& kind, int worry_level) {
  return "e " + std::to_string(tick) + " " + kind + " " + std::to_string(worry_level);
}

void ControlLogWriter::event(int64_t tick, const std::string& kind, int worry_level) {
  std::fprintf(f_, "%s\n", event_line(tick, kind, worry_level).c_str());
  std::fflush(f_);
}

void ControlLogWriter::worker_event(int64_t tick, const std::string& kind) {
  std::fprintf(f_, "w %" PRId64 " %s 0\n", tick, kind.c_str());
  std::fflush(f_);
}

void ControlLogWriter::instruction(int64_t tick, const Instruction& what) {
  const std::string arg = what.action == InstructorAction::kRewind ? std::to_string(what.to_tick) : what.text;
  std::fprintf(f_, "instructor %" PRId64 " %s%s%s\n", tick, name(what.action), arg.empty() ? "" : " ", arg.c_str());
  std::fflush(f_);
}

void ControlLogWriter::score(const std::string& line) {
  std::fprintf(f_, "%s\n", line.c_str());
  std::fflush(f_);
}

void ControlLogWriter::control_counts(const std::vector<std::pair<std::string, long>>& counts) {
  std::string line = "controls";
  for (const auto& [name, n] : counts) line += " " + name + "=" + std::to_string(n);
  std::fprintf(f_, "%s\n", line.c_str());
  std::fflush(f_);
}

void ControlLogWriter::finish(int64_t ticks, const StateVector& final_state) {
  std::fprintf(f_, "end %" PRId64 "\nfinal %s\n", ticks, state_hex(final_state).c_str());
  std::fflush(f_);
}

ControlLog read_control_log(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open control log " + path);
  std::ostringstream text;
  text << in.rdbuf();
  ControlLog log;
  bool has_init = false;
  int segment = 0;  // rewinds so far
  const std::vector<LogRecord> records = scan_log_records(text.str());
  const size_t n = records.size();
  for (size_t index = 0; index < records.size(); ++index) {
    const std::vector<std::string>& w = records[index].words;
    try {
      const std::string& k = w[0];
      const std::string& rest = records[index].rest;
      if (index == 0) {
        if (k != "forklift-control-log" || w.size() < 2 || w[1] != "1") throw std::runtime_error("not a control log");
      } else if (k == "session") log.header.session_id = rest;
      else if (k == "cab") log.header.cab_id = rest;
      else if (k == "truck") log.header.truck_file = rest;
      else if (k == "scenario") log.header.scenario_file = rest;
      else if (k == "mode") log.header.mode = rest;
      else if (k == "e") log.event_lines.push_back(k + " " + rest);  // as written: one space between words
      else if (k == "score") log.score_line = k + " " + rest;
      else if (k == "w") log.worker_events.emplace_back(std::stoll(w.at(1)), w.at(2));
      else if (k == "instructor") {
        log.instructions.emplace_back(std::stoll(w.at(1)), instruction_of(w, rest));
        log.instruction_segments.push_back(segment);
        if (log.instructions.back().second.action == InstructorAction::kRewind) ++segment;  // ticks start again from its point
      }
      else if (k == "controls") {
        for (size_t i = 1; i < w.size(); ++i) {
          const size_t eq = w[i].find('=');
          const char* digits = eq == std::string::npos ? "" : w[i].c_str() + eq + 1;
          char* end = nullptr;
          const long n = std::strtol(digits, &end, 10);
          if (eq == 0 || end == digits || *end != '\0' || n < 0)
            throw std::runtime_error("a controls line is 'controls <name>=<count> ...', not '" + w[i] + "'");
          log.control_counts[w[i].substr(0, eq)] = n;
        }
      }
      else if (k == "dm") {
        if (w.size() != 3 || (w[2] != "0" && w[2] != "1")) throw std::runtime_error("a dead-man line is 'dm <tick> 0|1'");
        log.deadman.emplace_back(std::stoll(w[1]), w[2] == "1");
        log.deadman_segments.push_back(segment);
      }
      else if (k == "tick") log.header.tick_s = from_hex(w.at(1));
      else if (k == "integrator") {
        log.header.integrator.kind = parse_integrator(w.at(1));
        log.header.integrator.rtol = from_hex(w.at(2));
        log.header.integrator.cvode_max_order = std::stoi(w.at(3));
      } else if (k == "init") { log.header.initial = parse_state_hex(rest); has_init = true; }
      else if (k == "load") {
        if (w.size() != 14 && w.size() != 17) throw std::runtime_error("load needs 13 or 16 numbers");
        Load l;
        l.mass_kg = from_hex(w[1]);
        for (int i = 0; i < 3; ++i) l.cog_m[i] = from_hex(w[2 + i]);
        for (int i = 0; i < 9; ++i) l.inertia_kg_m2(i / 3, i % 3) = from_hex(w[5 + i]);
        if (w.size() == 17) for (int i = 0; i < 3; ++i) l.size_m[i] = from_hex(w[14 + i]);
        log.header.load = l;
      } else if (k == "i") {
        if (w.size() < 9 || w.size() > 11) throw std::runtime_error("an input line needs 8, 9 or 10 fields");
        ControlLog::Entry e;
        e.tick = std::stoll(w[1]);
        e.seq = static_cast<uint32_t>(std::stoul(w[2]));
        e.inputs = {from_hex(w[3]), from_hex(w[4]), from_hex(w[5]), from_hex(w[6]), from_hex(w[7]), from_hex(w[8])};
        if (w.size() == 10) {
          if (w[9] != "0" && w[9] != "1") throw std::runtime_error("the parking brake is 0 or 1");
          e.inputs.parking_brake = w[9] == "1";
        }
        if (w.size() == 11) {
          if (w[10] != "0" && w[10] != "1") throw std::runtime_error("the horn is 0 or 1");
          e.inputs.horn = w[10] == "1";
        }
        e.segment = segment;
        if (!log.entries.empty() && e.segment == log.entries.back().segment && e.tick < log.entries.back().tick)
          throw std::runtime_error("ticks go backwards (other than after a rewind)");
        log.entries.push_back(e);
      } else if (k == "end") log.ticks = std::stoll(w.at(1));
      else if (k == "final") log.final_state = parse_state_hex(rest);
      else throw std::runtime_error("unknown record '" + k + "'");
    } catch (const std::exception& e) {
      throw std::runtime_error(path + ":" + std::to_string(records[index].line) + ": " + e.what());
    }
  }
  if (n == 0 || !has_init) throw std::runtime_error(path + ": no header");
  return log;
}

}  // namespace forklift
