#include "figures.h"

#include <cmath>
#include <functional>

#include "svg_plot.h"

namespace forklift {

void write_manoeuvre_figure(const ManoeuvreResult& r, const std::string& description, const std::string& path) {
  constexpr double kDeg = 180.0 / M_PI;
  std::vector<double> t;
  for (const Sample& s : r.samples) t.push_back(s.t);
  auto series = [&](const std::string& label, const std::function<double(const Sample&)>& f) {
    plot::Series out{label, {}};
    for (const Sample& s : r.samples) out.y.push_back(f(s));
    return out;
  };
  auto per_wheel = [&](const std::string& title, const std::string& unit,
                       const std::function<double(const WheelContact&)>& f) {
    plot::Panel p{title, unit, {}};
    for (int w = 0; w < kNumWheels; ++w)
      p.series.push_back(series(wheel_name(w), [&, w](const Sample& s) { return f(s.out.wheels[w]); }));
    return p;
  };
  std::vector<plot::Panel> panels = {
      {"Speed and torques", "m/s, kN m",
       {series("forward speed (m/s)", [](const Sample& s) { return s.out.forward_speed_m_s; }),
        series("drive torque (kN m)", [](const Sample& s) { return s.drive_torque_N_m / 1000; }),
        series("brake torque per wheel (kN m)", [](const Sample& s) { return s.brake_torque_N_m / 1000; })}},
      {"Chassis attitude and steer", "deg",
       {series("pitch (+ nose down)", [&](const Sample& s) { return s.out.q[kAvc] * kDeg; }),
        series("roll (+ right side down)", [&](const Sample& s) { return s.out.q[kAuc] * kDeg; }),
        series("rear-wheel angle / 10", [&](const Sample& s) { return s.out.q[kAwr3] * kDeg / 10; })}},
      per_wheel("Vertical wheel forces Fz", "N", [](const WheelContact& c) { return c.fz_N; }),
      per_wheel("Longitudinal forces Fx", "N", [](const WheelContact& c) { return c.fx_N; }),
      per_wheel("Lateral forces Fy", "N", [](const WheelContact& c) { return c.fy_N; }),
      per_wheel("Slip angle alpha", "deg", [&](const WheelContact& c) { return c.slip_angle_rad * kDeg; }),
  };
  plot::write_svg(path, "Manoeuvre " + std::to_string(r.manoeuvre) + ": " + description + " (" +
                            integrator_name(r.options.kind) + ")",
                  "time (s)", t, panels, 1150);
}

}  // namespace forklift
