#pragma once
#include <string>
#include <vector>

namespace forklift::plot {

// One curve: y values sampled at the figure's shared x values.
struct Series {
  std::string label;
  std::vector<double> y;
};

// One panel of a stacked figure: its own y axis, one or more curves.
struct Panel {
  std::string title;    // e.g. "Vertical wheel forces"
  std::string y_label;  // with unit, e.g. "Fz (N)"
  std::vector<Series> series;
};

// Writes a standalone SVG: a figure title, then the panels stacked vertically,
// all sharing the x axis `x` (e.g. time in s). Each panel gets "nice" tick values
// (1, 2, 5 x 10^n steps) on both axes, grid lines, a legend naming its series, and
// distinct colours per series. Non-finite y values break the polyline (gap) rather
// than being drawn. A panel whose values are all equal still gets a sensible range.
// Text is XML-escaped. Throws std::invalid_argument if a series' size differs from
// x.size() or x is empty; std::runtime_error if the file cannot be written.
void write_svg(const std::string& path, const std::string& title,
               const std::string& x_label, const std::vector<double>& x,
               const std::vector<Panel>& panels, int width = 900, int panel_height = 220);

// The tick values write_svg uses for the range [lo, hi] with about `target` ticks
// (exposed for testing): ascending, evenly spaced by 1, 2 or 5 x 10^n, covering the
// data range, all within [lo - step, hi + step].
std::vector<double> nice_ticks(double lo, double hi, int target = 5);

}  // namespace forklift::plot
