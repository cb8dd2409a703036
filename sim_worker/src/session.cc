#include "forklift/session.h"

#include <cinttypes>
#include <cmath>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "forklift/manoeuvre.h"

namespace forklift {

std::optional<std::string> control_problem(const ControlSample& c) {
  struct Field { const char* name; double value, lo, hi; };
  const Field fields[] = {{"steer_rad", c.steer_rad, -1.5, 1.5},  {"accelerator", c.accelerator, -1, 1},
                          {"brake", c.brake, 0, 1},               {"lift", c.lift, -1, 1},
                          {"tilt", c.tilt, -1, 1},                {"side_shift", c.side_shift, -1, 1}};
  for (const Field& f : fields) {
    if (!std::isfinite(f.value)) return std::string(f.name) + " is not finite";
    if (f.value < f.lo || f.value > f.hi) {
      std::ostringstream s;
      s << f.name << " = " << f.value << " is outside [" << f.lo << ", " << f.hi << "]";
      return s.str();
    }
  }
  return std::nullopt;
}

DriverInputs driver_inputs(const ControlSample& c, const TruckParams& t) {
  DriverInputs u;
  u.drive_torque_N_m = c.accelerator * t.drive.drive_torque_max_N_m;
  u.brake_torque_N_m = c.brake * t.drive.brake_torque_max_N_m;
  u.steer_rad = c.steer_rad;
  u.lift_rate_m_s = c.lift * t.limits.lift_rate_max_m_s;
  u.tilt_rate_rad_s = c.tilt * t.limits.tilt_rate_max_rad_s;
  u.shift_rate_m_s = c.side_shift * t.limits.side_shift_rate_max_m_s;
  u.parking_brake = c.parking_brake;
  return u;
}

DriverInputs deadman_inputs(const DriverInputs& last, const TruckParams& t) {
  DriverInputs u;
  u.steer_rad = last.steer_rad;
  u.brake_torque_N_m = t.drive.brake_torque_max_N_m;
  return u;
}

Scenario default_scenario(const std::string& data_dir) {
  Scenario s;
  s.truck_file = data_dir + "/trucks/linde_e16c.json";
  return s;
}

Scenario load_scenario(const std::string& path, const std::string& data_dir) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open scenario");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path + ": not valid JSON: " + e.what());
  }
  Scenario s = default_scenario(data_dir);
  try {
    if (j.contains("truck")) {
      const std::string t = j.at("truck").get<std::string>();
      s.truck_file = (!t.empty() && t[0] == '/') ? t : data_dir + "/" + t;
    }
    if (j.contains("start")) {
      const auto& st = j.at("start");
      s.x_m = st.value("x_m", 0.0);
      s.y_m = st.value("y_m", 0.0);
      s.yaw_rad = st.value("yaw_deg", 0.0) * M_PI / 180;
    }
    const TruckParams truck = load_truck(s.truck_file);
    if (j.contains("load") && !j.at("load").is_null()) {
      const auto& l = j.at("load");
      const double mass = l.at("mass_kg").get<double>();
      if (!(mass > 0 && mass < 20000)) throw std::runtime_error("load.mass_kg must be in (0, 20000)");
      s.load = box_load(mass, 1.0, 1.0, 1.0, truck.rated_load_centre_m, l.value("lateral_m", 0.0));
      s.lift_m = std::clamp(lift_for_load_height(truck, *s.load, l.value("cog_height_m", 0.6)), 0.0, truck.limits.lift_max_m);
    }
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path + ": " + e.what());
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  if (!std::isfinite(s.x_m) || !std::isfinite(s.y_m) || !std::isfinite(s.yaw_rad))
    throw std::runtime_error(path + ": start pose is not finite");
  return s;
}

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

}  // namespace

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
  std::fprintf(f_, "i %" PRId64 " %u %s %s %s %s %s %s %d\n", tick, seq, hex(u.drive_torque_N_m).c_str(),
               hex(u.brake_torque_N_m).c_str(), hex(u.steer_rad).c_str(), hex(u.tilt_rate_rad_s).c_str(),
               hex(u.lift_rate_m_s).c_str(), hex(u.shift_rate_m_s).c_str(), u.parking_brake ? 1 : 0);
  std::fflush(f_);  // a worker that is killed leaves everything it applied
}

void ControlLogWriter::note(const std::string& line) {
  std::fprintf(f_, "%s\n", line.c_str());
  std::fflush(f_);
}

void ControlLogWriter::finish(int64_t ticks, const StateVector& final_state) {
  std::fprintf(f_, "end %" PRId64 "\nfinal %s\n", ticks, state_hex(final_state).c_str());
  std::fflush(f_);
}

ControlLog read_control_log(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open control log " + path);
  ControlLog log;
  std::string line;
  int n = 0;
  bool has_init = false;
  while (std::getline(in, line)) {
    ++n;
    const std::vector<std::string> w = split(line);
    if (w.empty()) continue;
    try {
      const std::string& k = w[0];
      const std::string rest = line.size() > k.size() ? line.substr(k.size() + 1) : "";
      if (n == 1) {
        if (k != "forklift-control-log" || w.size() < 2 || w[1] != "1") throw std::runtime_error("not a control log");
      } else if (k == "session") log.header.session_id = rest;
      else if (k == "cab") log.header.cab_id = rest;
      else if (k == "truck") log.header.truck_file = rest;
      else if (k == "scenario") log.header.scenario_file = rest;
      else if (k == "mode") log.header.mode = rest;
      else if (k == "e" || k == "w" || k == "score" || k == "dm") log.notes.push_back(line);
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
        if (w.size() != 9 && w.size() != 10) throw std::runtime_error("an input line needs 8 or 9 fields");
        ControlLog::Entry e;
        e.tick = std::stoll(w[1]);
        e.seq = static_cast<uint32_t>(std::stoul(w[2]));
        e.inputs = {from_hex(w[3]), from_hex(w[4]), from_hex(w[5]), from_hex(w[6]), from_hex(w[7]), from_hex(w[8])};
        if (w.size() == 10) {
          if (w[9] != "0" && w[9] != "1") throw std::runtime_error("the parking brake is 0 or 1");
          e.inputs.parking_brake = w[9] == "1";
        }
        if (!log.entries.empty() && e.tick < log.entries.back().tick) throw std::runtime_error("ticks go backwards");
        log.entries.push_back(e);
      } else if (k == "end") log.ticks = std::stoll(w.at(1));
      else if (k == "final") log.final_state = parse_state_hex(rest);
      else throw std::runtime_error("unknown record '" + k + "'");
    } catch (const std::exception& e) {
      throw std::runtime_error(path + ":" + std::to_string(n) + ": " + e.what());
    }
  }
  if (n == 0 || !has_init) throw std::runtime_error(path + ": no header");
  return log;
}

StateVector replay(const ControlLog& log, int64_t* ticks_run) {
  TruckDynamics dyn(load_truck(log.header.truck_file));
  if (log.header.load) dyn.attach_load(*log.header.load);
  Simulation sim(dyn, log.header.initial, log.header.integrator);
  const int64_t end = log.ticks ? *log.ticks : (log.entries.empty() ? 0 : log.entries.back().tick + 1);
  size_t next = 0;
  const double dt = log.header.tick_s;
  for (int64_t tick = 0; tick < end; ++tick) {
    while (next < log.entries.size() && log.entries[next].tick == tick) sim.set_inputs(log.entries[next++].inputs);
    sim.advance_to((tick + 1) * dt);
  }
  if (ticks_run) *ticks_run = end;
  return sim.state();
}

double stability_margin(const Outputs& o) {
  double total = 0, least = INFINITY;
  for (const WheelContact& c : o.wheels) { total += c.fz_N; least = std::min(least, c.fz_N); }
  return total > 0 ? std::clamp(least / (total / kNumWheels), 0.0, 1.0) : 0.0;
}

}  // namespace forklift
