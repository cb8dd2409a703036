// forklift-worker: one cab's real-time simulation. Its loop reads like the pipeline:
// take the cab's controls, step the dynamics in 1 ms physics ticks against the wall clock,
// publish the truck's state; everything applied is logged so that --replay reproduces it.
#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>
#include <thread>

#include "forklift/protocol.h"
#include "forklift/session.h"

using namespace forklift;
using Clock = std::chrono::steady_clock;

namespace {

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

constexpr double kTick = 1e-3;  // physics tick: controls are applied on tick boundaries

void log_line(const std::string& cab, const std::string& text) {
  std::cerr << "forklift-worker[" << cab << "]: " << text << std::endl;
}

nlohmann::json pose_json(const StateVector& x) {
  return {{"x", x[kX]}, {"y", x[kY]}, {"yaw", x[kAwc] * 180 / M_PI}};
}

int replay_main(const std::string& path) {
  const ControlLog log = read_control_log(path);
  int64_t ticks = 0;
  const StateVector x = replay(log, &ticks);
  nlohmann::json out = {{"session", log.header.session_id}, {"cab", log.header.cab_id}, {"ticks", ticks},
                        {"sim_time_s", ticks * log.header.tick_s}, {"final_pose", pose_json(x)},
                        {"state_hex", state_hex(x)}};
  if (log.final_state) out["matches_log"] = (*log.final_state == x);  // bit for bit
  std::cout << out.dump(2) << std::endl;
  return log.final_state && *log.final_state != x ? 4 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"forklift-worker: the real-time simulation of one cab's truck"};
  std::string cab, session, scenario_file, log_file, dds_config, replay_file;
  double rate = 60, deadman_s = 0.5, duration = 0, start_timeout = 0;
  std::optional<int> domain;
  app.add_option("--cab", cab, "the cab this worker drives (its controls only)");
  app.add_option("--session", session, "session id, stamped on every status and event");
  app.add_option("--scenario", scenario_file, "scenario JSON (truck, start pose, load)")->check(CLI::ExistingFile);
  app.add_option("--rate", rate, "TruckState rate, Hz")->check(CLI::Range(1.0, 1000.0));
  app.add_option("--log", log_file, "control log to write (default: <session>.ctl in the current directory)");
  app.add_option("--deadman-timeout", deadman_s, "silence after which the truck is stopped, s")->check(CLI::Range(0.05, 60.0));
  app.add_option("--duration", duration, "end the session after this much sim time, s (0: run until signalled)")->check(CLI::Range(0.0, 1e6));
  app.add_option("--start-timeout", start_timeout, "fail if no cab speaks within this many seconds (0: wait)")->check(CLI::Range(0.0, 1e6));
  app.add_option("--dds-domain", domain, "DDS domain id (default FORKLIFT_DDS_DOMAIN or 0)")->check(CLI::Range(0, 232));
  app.add_option("--dds-config", dds_config, "Cyclone DDS configuration file (default: loopback)")->check(CLI::ExistingFile);
  app.add_option("--replay", replay_file, "re-simulate a control log with no cab and print its final state")->check(CLI::ExistingFile);
  CLI11_PARSE(app, argc, argv);

  try {
    if (!replay_file.empty()) return replay_main(replay_file);
    if (cab.empty() || session.empty()) throw CLI::RequiredError("--cab and --session (or --replay)");
  } catch (const CLI::Error& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::cerr << "forklift-worker: " << e.what() << '\n';
    return 2;
  }

  std::signal(SIGTERM, on_signal);
  std::signal(SIGINT, on_signal);

  // Set-up failures are reported as a failed session when DDS is up, and always on stderr.
  std::unique_ptr<dds::Participant> participant;
  std::unique_ptr<dds::Writer<fk_SessionStatus>> status_writer;
  auto publish_status = [&](const char* state, double t, const std::string& reason) {
    if (!status_writer) return;
    fk_SessionStatus s{};
    dds::set_string(s.session_id, session);
    dds::set_string(s.cab_id, cab);
    dds::set_string(s.state, state);
    s.sim_time_s = t;
    dds::set_string(s.reason, reason);
    status_writer->write(s);
  };

  try {
    participant = std::make_unique<dds::Participant>(dds::DomainSettings::resolve(domain, dds_config));
    status_writer = std::make_unique<dds::Writer<fk_SessionStatus>>(*participant);
    dds::Reader<fk_Controls> controls(*participant, dds::cab_partition(cab));
    dds::Writer<fk_TruckState> state_writer(*participant, dds::cab_partition(cab));
    dds::Writer<fk_Event> event_writer(*participant);
    dds::WaitSet waitset(*participant);
    waitset.attach_reader(controls.handle());

    const Scenario scenario = scenario_file.empty() ? default_scenario(FORKLIFT_DATA_DIR) : load_scenario(scenario_file, FORKLIFT_DATA_DIR);
    const TruckParams truck = load_truck(scenario.truck_file);
    TruckDynamics dyn(truck);
    if (scenario.load) dyn.attach_load(*scenario.load);
    StateVector x0 = dyn.rest_state(scenario.x_m, scenario.y_m, scenario.yaw_rad, 0, 0, scenario.lift_m, 0);
    if (!dyn.settle_static(x0)) throw std::runtime_error("the truck does not stand in the scenario's start");
    LogHeader header;
    header.session_id = session;
    header.cab_id = cab;
    header.truck_file = scenario.truck_file;
    header.tick_s = kTick;
    header.initial = x0;
    header.load = scenario.load;
    ControlLogWriter log(log_file.empty() ? session + ".ctl" : log_file, header);
    Simulation sim(dyn, x0, header.integrator);

    uint32_t event_seq = 0;
    auto publish_event = [&](const char* kind, int worry, const std::string& details) {
      fk_Event e{};
      dds::set_string(e.session_id, session);
      e.seq = ++event_seq;
      e.sim_time_s = sim.time();
      dds::set_string(e.kind, kind);
      e.worry_level = static_cast<uint8_t>(worry);
      e.x_m = sim.state()[kX];
      e.y_m = sim.state()[kY];
      dds::set_string(e.details, details);
      event_writer.write(e);
    };

    // Controls: refuse what must not reach the integrator, keep the newest good sample.
    long rejected_non_finite = 0, rejected_range = 0, rejected_cab = 0;
    std::optional<ControlSample> pending;
    Clock::time_point last_valid{};
    bool have_cab = false;
    auto take_controls = [&] {
      controls.take_each([&](const fk_Controls& c) {
        ControlSample s{c.seq, c.steer_rad, c.accelerator, c.brake, c.lift, c.tilt, c.side_shift, c.horn};
        if (cab != c.cab_id) {
          ++rejected_cab;
          log_line(cab, "rejected control " + std::to_string(c.seq) + " from cab '" + std::string(c.cab_id) + "'");
          return;
        }
        if (const auto problem = control_problem(s)) {
          ++(problem->find("finite") != std::string::npos ? rejected_non_finite : rejected_range);
          log_line(cab, "rejected control " + std::to_string(c.seq) + ": " + *problem);
          return;
        }
        pending = s;
        last_valid = Clock::now();
        have_cab = true;
      });
    };

    // Waiting: the session's clock starts with the cab's first good sample.
    publish_status("waiting", 0, "");
    const Clock::time_point created = Clock::now();
    while (!g_stop && !have_cab) {
      waitset.wait(0.05);
      take_controls();
      if (start_timeout > 0 && std::chrono::duration<double>(Clock::now() - created).count() > start_timeout) {
        publish_status("failed", 0, "no controls from cab " + cab + " within the start timeout");
        log_line(cab, "no controls within " + std::to_string(start_timeout) + " s; giving up");
        dds_sleepfor(DDS_MSECS(200));  // let the reliable status reach late readers
        return 5;
      }
    }
    publish_status("running", 0, "");
    log_line(cab, "session " + session + " running");

    DriverInputs applied{};
    uint32_t applied_seq = 0;
    bool deadman = false;
    long deadman_count = 0;
    int64_t tick = 0;
    double next_state_t = 0;
    const Clock::time_point start = Clock::now();
    auto publish_state = [&] {
      const Outputs o = sim.outputs();
      fk_TruckState s{};
      dds::set_string(s.cab_id, cab);
      dds::set_string(s.session_id, session);
      s.sim_time_s = sim.time();
      s.x_m = o.q[kX]; s.y_m = o.q[kY]; s.z_m = o.q[kZ];
      s.yaw_rad = o.q[kAwc]; s.roll_rad = o.q[kAuc]; s.pitch_rad = o.q[kAvc];
      s.speed_m_s = o.forward_speed_m_s;
      s.steer_rad = o.q[kAwr3]; s.tilt_rad = o.q[kBeta]; s.lift_m = o.q[kS]; s.side_shift_m = o.q[kR];
      s.fz_front_left_N = o.wheels[kFrontLeft].fz_N;
      s.fz_front_right_N = o.wheels[kFrontRight].fz_N;
      s.fz_rear_N = o.wheels[kRear].fz_N;
      s.load_attached = sim.dynamics().load().has_value();
      s.load_mass_kg = s.load_attached ? sim.dynamics().load()->mass_kg : 0.0;
      s.stability_margin = stability_margin(o);
      s.applied_control_sequence = applied_seq;
      s.deadman = deadman;
      state_writer.write(s);
    };

    // Real-time health: how far the simulation fell behind the wall clock, and how many states
    // went out more than one state period after they were due.
    double max_lag_s = 0, max_lag_at_s = 0;
    long late_states = 0;
    bool echo = false;  // a newly applied control owes the cab a state
    std::string end_reason = "signal";
    while (!g_stop) {
      take_controls();
      const double wall = std::chrono::duration<double>(Clock::now() - start).count();
      // Dead man: a silent cab gets throttle off and full brake, once, with an event.
      const double silence = std::chrono::duration<double>(Clock::now() - last_valid).count();
      if (!deadman && silence > deadman_s) {
        deadman = true;
        ++deadman_count;
        pending.reset();
        publish_event("deadman", 0, "no controls for " + std::to_string(silence) + " s: throttle off, brake on");
        log_line(cab, "cab silent for " + std::to_string(silence) + " s: dead-man stop");
        applied = deadman_inputs(applied, truck);
        sim.set_inputs(applied);
        log.input(tick, applied_seq, applied);
      } else if (deadman && pending) {
        deadman = false;
        publish_event("controls_resumed", 0, "controls from the cab again");
        log_line(cab, "controls resumed");
      }
      if (pending) {  // applied at the start of the next physics tick
        applied = driver_inputs(*pending, truck);
        applied_seq = pending->seq;
        pending.reset();
        sim.set_inputs(applied);
        log.input(tick, applied_seq, applied);
        echo = true;
      }
      // Physics catches up with the wall clock, one tick at a time; how far behind it was first.
      if (wall - sim.time() > max_lag_s) { max_lag_s = wall - sim.time(); max_lag_at_s = sim.time(); }
      const int64_t due = static_cast<int64_t>(std::floor(wall / kTick)) + 1;
      bool stepped = false;
      while (tick < due) {
        sim.advance_to((tick + 1) * kTick);
        ++tick;
        stepped = true;
        if (sim.time() + 1e-12 >= next_state_t) {
          const double late = std::chrono::duration<double>(Clock::now() - start).count() - next_state_t;
          if (late > 1.0 / rate && ++late_states <= 5)
            log_line(cab, "state for t = " + std::to_string(next_state_t) + " s went out " + std::to_string(late * 1e3) + " ms late");
          publish_state();
          next_state_t += 1.0 / rate;
          echo = false;
        }
        if (duration > 0 && sim.time() >= duration - 1e-12) break;
      }
      if (echo && stepped) publish_state();  // the cab sees its command's effect without waiting for the 60 Hz slot
      if (duration > 0 && sim.time() >= duration - 1e-12) { end_reason = "duration"; break; }
      const double until_next = tick * kTick - std::chrono::duration<double>(Clock::now() - start).count();
      if (until_next > 0) waitset.wait(until_next);
    }

    log.finish(tick, sim.state());
    publish_state();
    publish_status("ended", sim.time(), end_reason);
    log_line(cab, "session " + session + " ended (" + end_reason + ") at t = " + std::to_string(sim.time()) + " s");
    nlohmann::json out = {
        {"session", session}, {"cab", cab}, {"sim_time_s", sim.time()}, {"ticks", tick},
        {"final_pose", pose_json(sim.state())}, {"state_hex", state_hex(sim.state())},
        {"rejected_controls", {{"non_finite", rejected_non_finite}, {"out_of_range", rejected_range}, {"wrong_cab", rejected_cab}}},
        {"deadman_stops", deadman_count}, {"integrator_steps", sim.stats().steps},
        {"max_lag_ms", max_lag_s * 1e3}, {"max_lag_at_s", max_lag_at_s}, {"late_states", late_states}};
    std::cout << out.dump(2) << std::endl;
    dds_sleepfor(DDS_MSECS(200));  // let the final reliable status reach its readers
    return 0;
  } catch (const std::exception& e) {
    log_line(cab, std::string("failed: ") + e.what());
    publish_status("failed", 0, e.what());
    dds_sleepfor(DDS_MSECS(200));
    return 3;
  }
}
