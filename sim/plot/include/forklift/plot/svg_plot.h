#pragma once
#include <string>
#include <vector>

namespace forklift::plot {

// One curve: y values sampled at the figure's shared x values, or at its own `x` when that
// is not empty (curves overlaid from runs with different sample times or lengths).
struct Series {
  std::string label;
  std::vector<double> y;
  std::vector<double> x{};  // empty: the figure's shared x
};

// One panel of a stacked figure: its own y axis, one or more curves.
struct Panel {
  std::string title;    // e.g. "Vertical wheel forces"
  std::string y_label;  // with unit, e.g. "Fz (N)"
  std::vector<Series> series;
  // Smallest y span shown, in the panel's unit: numerical noise on a constant (a slip of
  // 1e-12) must not fill the panel's height. Spans below kMinRelativeSpan x |largest value|
  // are widened too, whatever this is.
  double min_span = 0;
};

// A panel's y range spans at least this fraction of its largest |value| (15 N on 15 kN).
inline constexpr double kMinRelativeSpan = 1e-3;

// Writes a standalone SVG: a figure title (lines after a '\n' are drawn smaller, as a
// subtitle), then the panels stacked vertically, all sharing one x axis (e.g. time in s)
// that covers `x` and every series' own x. Each panel gets "nice" tick values (1, 2, 5 x
// 10^n steps) on both axes, grid lines, and a legend naming its series. Series i of a panel
// gets colour i and dash pattern i of two cycles of coprime lengths, so curves that coincide
// stay distinguishable and no two series of a panel share both. Non-finite values break the
// polyline (gap) rather than being drawn. A panel whose values are all equal, or vary by
// less than its minimum span, is centred in a range of that span (see Panel::min_span).
// Text is XML-escaped. Throws std::invalid_argument if a series' size differs from its x
// (its own, or the shared x), or a series uses the shared x and it is empty, or no x
// values are given at all; std::runtime_error if the file cannot be written.
void write_svg(const std::string& path, const std::string& title,
               const std::string& x_label, const std::vector<double>& x,
               const std::vector<Panel>& panels, int width = 900, int panel_height = 220);

// The SVG stroke-dasharray write_svg gives series `index` of a panel ("" = solid), and the
// length of the cycle it repeats with (exposed for testing and for matching legends).
std::string dash_pattern(size_t index);
size_t dash_pattern_count();

// The tick values write_svg uses for the range [lo, hi] with about `target` ticks
// (exposed for testing): ascending, evenly spaced by 1, 2 or 5 x 10^n, covering the
// data range, all within [lo - step, hi + step].
std::vector<double> nice_ticks(double lo, double hi, int target = 5);

}  // namespace forklift::plot
