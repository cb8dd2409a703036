#include "figures.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <stdexcept>

#include "forklift/plot/svg_plot.h"
#include "forklift/units/units.h"

namespace forklift {
namespace {

// One plotted quantity: a panel of its own, or one panel per wheel in an overlay.
struct Quantity {
  std::string title, y_label;
  double min_span;            // Panel::min_span, in y_label's unit
  std::vector<int> wheels;    // empty: one value per sample, not per wheel
  std::function<double(const Sample&, int wheel)> value;
};

// The paper's wheel names (r1, r2, r3) beside ours, so panels can be matched to its figures.
std::string wheel_title(int w) {
  static const char* names[] = {"front left wheel (r1)", "front right wheel (r2)", "rear wheel (r3)"};
  return names[w];
}

const std::vector<int> kFront = {kFrontLeft, kFrontRight};
const std::vector<int> kAll = {kFrontLeft, kFrontRight, kRear};

// The spans below are the plot's resolution, not vehicle data: changes smaller than them are
// numerical noise at this figure's scale.
Quantity drive_torque() {
  return {"Drive torque (total, after the lag)", "M (N m)", 1.0, {},
          [](const Sample& s, int) { return s.drive_torque_N_m; }};
}
Quantity pitch() {
  return {"Pitch (+ nose down)", "pitch (deg)", 0.01, {},
          [](const Sample& s, int) { return s.out.q[kAvc] * kRad; }};
}
Quantity forward_speed() {
  return {"Forward speed", "v (m/s)", 0.01, {},
          [](const Sample& s, int) { return s.out.forward_speed_m_s; }};
}
Quantity rear_wheel_angle() {
  return {"Rear-wheel angle (+ turns right)", "steer (deg)", 0.1, {},
          [](const Sample& s, int) { return s.out.q[kAwr3] * kRad; }};
}
Quantity force(const char* name, const char* symbol, const std::vector<int>& wheels,
               double WheelContact::*field) {
  return {std::string(name) + " " + symbol, std::string(symbol) + " (N)", 1.0, wheels,
          [field](const Sample& s, int w) { return s.out.wheels[w].*field; }};
}
Quantity slip_angle(const std::vector<int>& wheels) {
  return {"Slip angle alpha", "alpha (deg)", 0.01, wheels,
          [](const Sample& s, int w) { return s.out.wheels[w].slip_angle_rad * kRad; }};
}

// Longitudinal slip ratio (w r - V) / max(|V|, |w r|, v0): positive when the wheel spins faster
// than it travels, -1 for a locked wheel, +1 for one spinning on the spot. Dividing by the
// larger speed keeps a start from rest (V near 0, w r not) bounded, where (w r - V) / |V|
// runs to several units. The numerator is the model's own contact slip speed -sx, the slip
// its force laws read; the wheel centre's forward speed is V = w r + sx (the contact point
// moves at V - w r), r the unloaded radius, which only scales the ratio. v0 is the speed
// floor the model uses for eq (9): at rest the ratio is 0/0 otherwise.
Quantity slip_ratio(const TruckParams& truck) {
  const double floor = std::max(truck.contact.slip_angle_speed_floor_m_s, 1e-3);
  std::array<double, kNumWheels> radius{};
  for (int w = 0; w < kNumWheels; ++w) radius[w] = truck.wheels[w].radius_m;
  return {"Slip ratio (w r - V) / max(|V|, |w r|)", "slip ratio (-)", 1e-3, kFront,
          [floor, radius](const Sample& s, int w) {
            const double sx = s.out.wheels[w].slip_x_m_s;
            const double roll = s.out.qdot[kAvr1 + w] * radius[w];
            return -sx / std::max({std::fabs(roll + sx), std::fabs(roll), floor});
          }};
}

struct GroupDef {
  FigureGroup group;
  std::vector<Quantity> (*quantities)(const TruckParams&);
};

// Figure 9 plots torque, slip ratio, Fx and pitch; 10 and 11 the vertical forces (for 4-5 the
// text also quotes the pitch and the time to stop, hence speed); 12-16 and 17-21 the slip
// angles and lateral forces (for 14-15 the text reads the Fz figures too). The steer input
// heads the turning figures so each curve can be read against it.
const std::vector<GroupDef>& group_defs() {
  static const std::vector<GroupDef> defs = {
      {{{1, 2, 3}, 9, 9, "starting manoeuvres"},
       [](const TruckParams& t) {
         return std::vector<Quantity>{drive_torque(), slip_ratio(t),
                                      force("Longitudinal force", "Fx", kFront, &WheelContact::fx_N), pitch()};
       }},
      {{{4, 5}, 10, 10, "braking manoeuvres"},
       [](const TruckParams&) {
         return std::vector<Quantity>{force("Vertical force", "Fz", kAll, &WheelContact::fz_N), pitch(),
                                      forward_speed()};
       }},
      {{{10, 11, 12}, 11, 11, "change of direction manoeuvres"},
       [](const TruckParams&) {
         return std::vector<Quantity>{rear_wheel_angle(), force("Vertical force", "Fz", kAll, &WheelContact::fz_N)};
       }},
      {{{14, 15}, 12, 16, "turning with an unbalanced load"},
       [](const TruckParams&) {
         return std::vector<Quantity>{rear_wheel_angle(), slip_angle(kAll),
                                      force("Lateral force", "Fy", kAll, &WheelContact::fy_N),
                                      force("Vertical force", "Fz", kAll, &WheelContact::fz_N)};
       }},
      {{{17, 18}, 17, 21, "zig-zag manoeuvres"},
       [](const TruckParams&) {
         return std::vector<Quantity>{rear_wheel_angle(), slip_angle(kAll),
                                      force("Lateral force", "Fy", kAll, &WheelContact::fy_N)};
       }},
  };
  return defs;
}

const GroupDef* def_of(int number) {
  for (const GroupDef& d : group_defs())
    if (std::find(d.group.manoeuvres.begin(), d.group.manoeuvres.end(), number) != d.group.manoeuvres.end())
      return &d;
  return nullptr;
}

const GroupDef& def_of(const FigureGroup& group) {
  for (const GroupDef& d : group_defs())
    if (d.group.manoeuvres == group.manoeuvres) return d;
  throw std::invalid_argument("no figure defined for these manoeuvres");
}

std::vector<double> times(const ManoeuvreResult& r) {
  std::vector<double> t;
  t.reserve(r.samples.size());
  for (const Sample& s : r.samples) t.push_back(s.t);
  return t;
}

plot::Series series(const std::string& label, const ManoeuvreResult& r, const Quantity& q, int wheel) {
  plot::Series out{label, {}, times(r)};
  out.y.reserve(r.samples.size());
  for (const Sample& s : r.samples) out.y.push_back(q.value(s, wheel));
  return out;
}

std::string figures_label(const FigureGroup& g) {
  return g.first_figure == g.last_figure ? "Figure " + std::to_string(g.first_figure)
                                         : "Figures " + std::to_string(g.first_figure) + "-" +
                                               std::to_string(g.last_figure);
}

std::string run_label(const ManoeuvreResult& r) {
  return "manoeuvre " + std::to_string(r.manoeuvre) + (r.tipped_over ? " (tipped over)" : "");
}

}  // namespace

const std::vector<FigureGroup>& figure_groups() {
  static const std::vector<FigureGroup> groups = [] {
    std::vector<FigureGroup> g;
    for (const GroupDef& d : group_defs()) g.push_back(d.group);
    return g;
  }();
  return groups;
}

const FigureGroup* figure_group_of(int number) {
  const GroupDef* d = def_of(number);
  if (!d) return nullptr;
  for (const FigureGroup& g : figure_groups())
    if (g.manoeuvres == d->group.manoeuvres) return &g;
  return nullptr;
}

std::string figure_file_name(const FigureGroup& g) {
  char fig[32];
  if (g.first_figure == g.last_figure)
    std::snprintf(fig, sizeof fig, "%02d", g.first_figure);
  else
    std::snprintf(fig, sizeof fig, "%02d-%02d", g.first_figure, g.last_figure);
  return "figure_" + std::string(fig) + "_manoeuvres_" + std::to_string(g.manoeuvres.front()) + "-" +
         std::to_string(g.manoeuvres.back()) + ".svg";
}

void write_manoeuvre_figure(const TruckParams& truck, const ManoeuvreResult& r, const std::string& description,
                            const std::string& path) {
  const GroupDef* d = def_of(r.manoeuvre);
  if (!d) throw std::invalid_argument("no figure defined for manoeuvre " + std::to_string(r.manoeuvre));
  std::vector<plot::Panel> panels;
  for (const Quantity& q : d->quantities(truck)) {
    plot::Panel p{q.title, q.y_label, {}, q.min_span};
    if (q.wheels.empty()) p.series.push_back(series(run_label(r), r, q, 0));
    for (int w : q.wheels) p.series.push_back(series(wheel_name(w), r, q, w));
    panels.push_back(std::move(p));
  }
  plot::write_svg(path,
                  "Manoeuvre " + std::to_string(r.manoeuvre) + ": " + description + " (" +
                      integrator_name(r.options.kind) + ")\n" + figures_label(d->group) + " of the paper, " +
                      d->group.name,
                  "time (s)", {}, panels, 1150);
}

void write_group_figure(const TruckParams& truck, const FigureGroup& group,
                        const std::vector<const ManoeuvreResult*>& results,
                        const std::vector<std::string>& descriptions, const std::string& path) {
  if (results.empty() || results.size() != descriptions.size())
    throw std::invalid_argument("write_group_figure: need one description per result, and at least one");
  std::vector<plot::Panel> panels;
  for (const Quantity& q : def_of(group).quantities(truck)) {
    // Per wheel, one panel each: curves of the same wheel from different runs are the ones
    // to compare, and a panel of 3 runs x 3 wheels would be unreadable.
    const std::vector<int> wheels = q.wheels.empty() ? std::vector<int>{-1} : q.wheels;
    for (int w : wheels) {
      plot::Panel p{w < 0 ? q.title : q.title + ", " + wheel_title(w), q.y_label, {}, q.min_span};
      for (const ManoeuvreResult* r : results) p.series.push_back(series(run_label(*r), *r, q, std::max(w, 0)));
      panels.push_back(std::move(p));
    }
  }
  std::string title = figures_label(group) + " of the paper: " + group.name + " (" +
                      integrator_name(results.front()->options.kind) + ")";
  for (size_t i = 0; i < results.size(); ++i)
    title += "\nmanoeuvre " + std::to_string(results[i]->manoeuvre) + ": " + descriptions[i];
  plot::write_svg(path, title, "time (s)", {}, panels, 1150, 200);
}

}  // namespace forklift
