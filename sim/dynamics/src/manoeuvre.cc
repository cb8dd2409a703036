// Section 11's manoeuvres. The paper gives their shape but not every number; where it does
// not, the choice is written beside it.
#include "forklift/dynamics/manoeuvre.h"
#include "forklift/dynamics/stability.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <stdexcept>
#include "forklift/units/units.h"

namespace forklift {
namespace {

// A rear-wheel angle that rises from 0 to `peak` and back within `width` seconds, continuous and
// differentiable (section 11.3).
double steer_bump(double t, double start, double width, double peak) {
  if (t <= start || t >= start + width) return 0;
  return 0.5 * peak * (1 - std::cos(2 * M_PI * (t - start) / width));
}

// "While driving": 300 N m to get going, then 150 N m, which holds the truck near 2.5 m/s
// (9 km/h) against rolling resistance on a straight line.
double cruise_torque(double t) { return t < 5 ? 300.0 : 150.0; }

// The paper's test load: a 1 m cube on the forks, its CoG at the rated load centre.
Load test_load(const TruckParams& truck, double mass, double lateral) {
  return box_load(mass, 1.0, 1.0, 1.0, truck.rated_load_centre_m, lateral);
}

}  // namespace

const std::vector<int>& manoeuvre_numbers() {
  static const std::vector<int> numbers = {1, 2, 3, 4, 5, 10, 11, 12, 14, 15, 17, 18};
  return numbers;
}

double lift_for_load_height(const TruckParams& truck, const Load& load, double height_m) {
  return lift_for_fork_height(truck, height_m - load.cog_m.z());  // the load's CoG is above the forks' top
}

ManoeuvreSpec manoeuvre(int n, const TruckParams& truck) {
  ManoeuvreSpec m;
  m.number = n;
  switch (n) {
    case 1: case 2: {
      const double torque = n == 1 ? 300 : 600;
      m.description = "start from rest, constant total torque " + std::to_string(int(torque)) + " N m";
      m.inputs = [torque](double) { DriverInputs u; u.drive_torque_N_m = torque; return u; };
      break;
    }
    case 3:
      m.description = "start from rest, torque rising linearly 40 N m/s (0 to 800 N m in 20 s)";
      m.inputs = [](double t) { DriverInputs u; u.drive_torque_N_m = 40 * t; return u; };
      break;
    case 4: case 5: {
      // Progressive torque (35 N m/s) for 10 s brings the laden truck to about 1.6 m/s; then
      // the brake torque on each front wheel: 1200 N m exceeds what the tyre can pass
      // (Fx max x radius = 1026 N m), the paper's "sharp braking" that slides the wheels.
      const double brake = n == 4 ? 1200 : 500;
      m.description = "500 kg at 2 m, progressive torque for 10 s, then " + std::to_string(int(brake)) +
                      " N m braking on each front wheel";
      m.load = test_load(truck, 500, 0);
      m.lift_m = lift_for_load_height(truck, *m.load, 2.0);
      m.inputs = [brake](double t) {
        DriverInputs u;
        if (t < 10) u.drive_torque_N_m = 35 * t; else u.brake_torque_N_m = brake;
        return u;
      };
      m.breakpoints_s = {10};
      m.brake_onset_s = 10;
      break;
    }
    case 10: case 11: case 12: {
      const double peak = n == 10 ? M_PI / 8 : n == 11 ? M_PI / 4 : M_PI / 3;
      m.description = "driving, rear wheel to " + std::string(n == 10 ? "pi/8" : n == 11 ? "pi/4" : "pi/3") +
                      " and back within 5 s (t = 8-13 s)";
      m.inputs = [peak](double t) {
        DriverInputs u;
        u.drive_torque_N_m = cruise_torque(t);
        u.steer_rad = steer_bump(t, 8, 5, peak);
        return u;
      };
      m.breakpoints_s = {5};
      break;
    }
    case 14: case 15: {
      const double peak = n == 14 ? M_PI / 6 : M_PI / 3;
      m.description = "1500 kg, 0.75 m left, 2 m high; steer 0 for 15 s, then to " +
                      std::string(n == 14 ? "pi/6" : "pi/3") + " and back by 20 s";
      m.load = test_load(truck, 1500, 0.75);
      m.lift_m = lift_for_load_height(truck, *m.load, 2.0);
      m.inputs = [peak](double t) {
        DriverInputs u;
        // 1500 kg more to move: 200 N m after the start keeps about 2.2 m/s.
        u.drive_torque_N_m = t < 5 ? 300.0 : 200.0;
        u.steer_rad = steer_bump(t, 15, 5, peak);  // + turns right: towards the unfavourable side
        return u;
      };
      m.breakpoints_s = {5};
      break;
    }
    case 17: case 18: {
      const double amplitude = n == 17 ? M_PI / 4 : M_PI / 6;
      m.description = std::string("zig-zag, rear wheel sinusoidal at 0.2 Hz, amplitude ") + (n == 17 ? "pi/4" : "pi/6");
      m.inputs = [amplitude](double t) {
        DriverInputs u;
        u.drive_torque_N_m = cruise_torque(t);
        u.steer_rad = amplitude * std::sin(2 * M_PI * 0.2 * t);
        return u;
      };
      m.breakpoints_s = {5};
      break;
    }
    default:
      throw std::invalid_argument("no manoeuvre " + std::to_string(n) +
                                  " (the paper defines 1, 2, 3, 4, 5, 10, 11, 12, 14, 15, 17, 18)");
  }
  return m;
}

ManoeuvreResult run_manoeuvre(const TruckParams& truck, int number, const IntegratorOptions& options,
                              double sample_dt_s, Sampling sampling) {
  const ManoeuvreSpec spec = manoeuvre(number, truck);
  TruckDynamics dynamics(truck);
  if (spec.load) dynamics.attach_load(*spec.load);
  StateVector x0 = dynamics.rest_state(0, 0, 0, 0, 0, spec.lift_m, 0);
  if (!dynamics.settle_static(x0)) throw IntegratorError("no static equilibrium for manoeuvre " + std::to_string(number));

  Simulation sim(dynamics, x0, options);
  sim.set_input_schedule(spec.inputs);
  ManoeuvreResult r;
  r.manoeuvre = number;
  r.options = options;
  r.min_fz_N.fill(INFINITY);

  // Sample times, interpolated; the integrator never steps past the next breakpoint.
  std::vector<double> exact = spec.breakpoints_s;
  exact.push_back(spec.duration_s);
  std::sort(exact.begin(), exact.end());
  std::vector<double> stops;
  const int nsamples = sample_dt_s > 0 ? int(std::llround(spec.duration_s / sample_dt_s)) : 0;
  for (int k = 1; k <= nsamples; ++k) stops.push_back(k * sample_dt_s);
  stops.insert(stops.end(), exact.begin(), exact.end());
  std::sort(stops.begin(), stops.end());
  stops.erase(std::unique(stops.begin(), stops.end(), [](double a, double b) { return std::abs(a - b) < 1e-9; }),
              stops.end());

  // The metrics read the state and the wheels' loads alone, so that a run that writes no series
  // does not evaluate the model at every sample: its loads come from wheel_loads_N, a series'
  // from the outputs it keeps anyway (the same bits).
  double end_t = sim.time();
  StateVector end_x = sim.state();
  auto record = [&](double t, const StateVector& x) {
    end_t = t;
    end_x = x;
    const double pitch = std::abs(x[StateIndex::kQ + kAvc]) * kRad, roll = std::abs(x[StateIndex::kQ + kAuc]) * kRad;
    r.max_pitch_deg = std::max(r.max_pitch_deg, pitch);
    r.max_roll_deg = std::max(r.max_roll_deg, roll);
    std::optional<Outputs> out;
    std::array<double, kNumWheels> fz;
    if (sampling == Sampling::kSeries) {
      out = sim.outputs_at(t, x);
      for (int w = 0; w < kNumWheels; ++w) fz[w] = out->wheels[w].fz_N;
    } else {
      fz = sim.dynamics().wheel_loads_N(x);
    }
    for (int w = 0; w < kNumWheels; ++w) r.min_fz_N[w] = std::min(r.min_fz_N[w], fz[w]);
    for (ManoeuvreResult::StopTime& stop : r.stop_times)
      if (spec.brake_onset_s && !stop.s && t > *spec.brake_onset_s && std::abs(forward_speed(x)) < stop.below_m_s)
        stop.s = t - *spec.brake_onset_s;
    if (std::max(pitch, roll) > truck.tipped_over_rad * kRad) r.tipped_over = true;
    if (!out) return;
    Sample s;
    s.t = t;
    s.out = std::move(*out);
    s.drive_torque_N_m = x[StateIndex::kTorque];
    s.brake_torque_N_m = x[StateIndex::kBrake];
    r.samples.push_back(std::move(s));
  };
  if (nsamples > 0) record(0, sim.state());

  double wall = 0;
  size_t next_exact = 0;
  // A variable-step integrator's own steps are timed, and the samples between them interpolated
  // outside that time: a run's speed is the integration's, not its sampling's (10,000 samples
  // at 2 ms would add a third). The interpolant is what advance_to returns between steps, so the
  // samples are the same. A load that may slide steps at each sample, as in a session, so such
  // a run (and rk4) lands on every sample instead.
  const bool by_steps = nsamples > 0 && options.kind != IntegratorKind::kRk4 &&
                        (!spec.load || truck.load_contact.welded());
  if (by_steps) {
    size_t next_sample = 0;
    while (next_sample < stops.size() && !r.tipped_over) {
      while (next_exact + 1 < exact.size() && exact[next_exact] <= sim.time() + 1e-9) ++next_exact;
      const auto t0 = std::chrono::steady_clock::now();
      sim.step_toward(exact[next_exact], stops.front());
      wall += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const double reached = sim.time();
      for (; next_sample < stops.size() && stops[next_sample] <= reached + 1e-9 && !r.tipped_over; ++next_sample) {
        const double ts = stops[next_sample];
        record(ts, sim.state_at(std::min(ts, reached)));
      }
    }
  } else {
    for (double t : stops) {
      while (exact[next_exact] < t - 1e-9) ++next_exact;
      const auto t0 = std::chrono::steady_clock::now();
      sim.advance_to(t, exact[next_exact]);
      wall += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (nsamples > 0) {
        record(t, sim.state());
        if (r.tipped_over) break;
      }
    }
    end_t = sim.time();
    end_x = sim.state();
  }
  r.wall_s = wall;
  r.sim_time_s = end_t;
  r.stats = sim.stats();
  r.final_pose = Eigen::Vector3d(end_x[kX], end_x[kY], end_x[kAwc]);
  for (int w = 0; w < kNumWheels; ++w) if (nsamples == 0) r.min_fz_N[w] = NAN;
  r.rear_wheel_lifted = nsamples > 0 && r.min_fz_N[kRear] <= 0;
  return r;
}

void write_csv(const ManoeuvreResult& r, const std::string& path, int every_nth) {
  std::ofstream f(path);
  if (!f) throw std::runtime_error("cannot write " + path);
  f << "t_s,x_m,y_m,z_m,yaw_deg,roll_deg,pitch_deg,speed_m_s,steer_deg,tilt_deg,lift_m,shift_m,"
       "drive_torque_N_m,brake_torque_N_m";
  for (int w = 0; w < kNumWheels; ++w) {
    const std::string n = wheel_name(w);
    for (const char* col : {"fz_N", "fx_N", "fy_N", "slip_x_m_s", "slip_y_m_s", "slip_angle_deg", "wheel_torque_N_m", "spin_rad_s"})
      f << ',' << n << '_' << col;
  }
  f << ",lambda_steer_N_m,lambda_tilt_N_m,lambda_lift_N,lambda_shift_N\n";
  f.precision(6);
  for (size_t i = 0; i < r.samples.size(); i += std::max(1, every_nth)) {
    const Sample& s = r.samples[i];
    const Outputs& o = s.out;
    f << s.t << ',' << o.q[kX] << ',' << o.q[kY] << ',' << o.q[kZ] << ',' << o.q[kAwc] * kRad << ','
      << o.q[kAuc] * kRad << ',' << o.q[kAvc] * kRad << ',' << o.forward_speed_m_s << ',' << o.q[kAwr3] * kRad
      << ',' << o.q[kBeta] * kRad << ',' << o.q[kS] << ',' << o.q[kR] << ',' << s.drive_torque_N_m << ','
      << s.brake_torque_N_m;
    for (int w = 0; w < kNumWheels; ++w) {
      const WheelContact& c = o.wheels[w];
      f << ',' << c.fz_N << ',' << c.fx_N << ',' << c.fy_N << ',' << c.slip_x_m_s << ',' << c.slip_y_m_s << ','
        << c.slip_angle_rad * kRad << ',' << c.drive_torque_N_m + c.brake_torque_N_m << ',' << o.qdot[kAvr1 + w];
    }
    for (int d = 0; d < kNumDriven; ++d) f << ',' << o.driven_force[d];
    f << '\n';
  }
  if (!f) throw std::runtime_error("error writing " + path);
}

}  // namespace forklift
