#include "forklift/plot/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "forklift/units/decimals.h"

namespace forklift::plot {
namespace {

// Layout in pixels. The right margin holds the legend so it never covers data.
constexpr double kTitleH = 40;    // figure title band (its first line)
constexpr double kSubtitleH = 16; // each further line of the title
constexpr double kBottomH = 50;   // x tick labels and x label under the last panel
constexpr double kLeft = 80;      // y tick labels and y label
constexpr double kRight = 230;    // legend
constexpr double kPanelTop = 24;  // panel title above each plot area
constexpr double kPanelGap = 12;  // space below each plot area

// Tableau 10: distinct and readable in print.
constexpr const char* kPalette[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd",
                                    "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
constexpr size_t kPaletteSize = sizeof(kPalette) / sizeof(kPalette[0]);
// Dashes as well as colours, so a curve drawn over an identical one leaves gaps the one
// below shows through. 7 is coprime with the palette's 10: (colour, dash) pairs repeat only
// after 70 series. Round caps lengthen each dash by the stroke width (1.5), hence the 0.5s.
constexpr const char* kDashes[] = {"",    "7,6",        "0.5,4.5",         "10,4,0.5,4",
                                   "3,4", "14,4,4,4", "0.5,3,0.5,3,8,3"};
constexpr size_t kDashCount = sizeof(kDashes) / sizeof(kDashes[0]);

// Fixed, limited precision keeps files small (and locale-independent digits).
std::string escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default:
        // Other control characters are illegal in XML 1.0 and would break the file.
        if (static_cast<unsigned char>(c) >= 0x20 || c == '\t' || c == '\n' || c == '\r') out += c;
    }
  }
  return out;
}

// Enough decimals to tell neighbouring ticks apart, no more.
std::string tick_label(double v, double step) {
  if (std::fabs(v) < step * 1e-6) v = 0;  // no "-0.0" or 1e-17 residue
  const int digits = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  char buf[64];
  if (digits > 9 || std::fabs(v) >= 1e7)
    std::snprintf(buf, sizeof buf, "%.6g", v);
  else
    std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

// Linear map from data to pixel coordinates.
struct Map {
  double v0, v1, p0, p1;
  double operator()(double v) const { return p0 + (v - v0) / (v1 - v0) * (p1 - p0); }
};

struct Pt {
  double x, y;
  size_t i;
};

// Appends one <polyline> per run of finite samples. Within a run, consecutive samples in the
// same pixel column collapse to that column's min and max (in sample order): a 20k-sample
// trace costs at most ~2 points per pixel, yet single-sample peaks survive.
void add_polylines(std::string& out, const std::vector<double>& x, const std::vector<double>& y,
                   const Map& mx, const Map& my) {
  std::vector<Pt> run;
  auto flush_run = [&] {
    if (run.empty()) return;
    if (run.size() == 1) run.push_back(run.front());  // zero-length line + round cap = a dot
    out += "<polyline points=\"";
    for (size_t k = 0; k < run.size(); ++k) {
      if (k) out += ' ';
      out += fixed_decimals(run[k].x, 2) + ',' + fixed_decimals(run[k].y, 2);
    }
    out += "\"/>\n";
    run.clear();
  };

  long col = 0;
  size_t n = 0;     // samples in the current column
  Pt top{}, bot{};  // highest and lowest on screen (SVG y grows downwards)
  auto flush_col = [&] {
    if (n == 0) return;
    if (top.i == bot.i) {
      run.push_back(top);
    } else {
      run.push_back(top.i < bot.i ? top : bot);
      run.push_back(top.i < bot.i ? bot : top);
    }
    n = 0;
  };

  for (size_t i = 0; i < x.size(); ++i) {
    if (!std::isfinite(x[i]) || !std::isfinite(y[i])) {  // gap: end the polyline here
      flush_col();
      flush_run();
      continue;
    }
    const Pt p{mx(x[i]), my(y[i]), i};
    const long c = static_cast<long>(std::floor(p.x));
    if (n > 0 && c != col) flush_col();
    if (n == 0) {
      col = c;
      top = bot = p;
    } else {
      if (p.y < top.y) top = p;
      if (p.y > bot.y) bot = p;
    }
    ++n;
  }
  flush_col();
  flush_run();
}

void text(std::string& out, double x, double y, const std::string& s, const char* anchor,
          int size, const char* extra = "") {
  out += "<text x=\"" + fixed_decimals(x, 2) + "\" y=\"" + fixed_decimals(y, 2) + "\" text-anchor=\"" + anchor +
         "\" font-size=\"" + std::to_string(size) + "\"" + extra + ">" + escape(s) + "</text>\n";
}

// The y range a panel shows: the data's, widened about its middle to the panel's minimum
// span so noise on a near-constant value stays a flat line (see Panel::min_span).
void widen_to_min_span(double& lo, double& hi, double min_span) {
  const double need = std::max(min_span, kMinRelativeSpan * std::max(std::fabs(lo), std::fabs(hi)));
  if (!(hi - lo < need) || !std::isfinite(need)) return;
  const double mid = 0.5 * (lo + hi);
  lo = mid - 0.5 * need;
  hi = mid + 0.5 * need;
}

}  // namespace

std::string dash_pattern(size_t index) { return kDashes[index % kDashCount]; }
size_t dash_pattern_count() { return kDashCount; }

std::vector<double> nice_ticks(double lo, double hi, int target) {
  if (!std::isfinite(lo)) lo = std::isfinite(hi) ? hi : 0.0;
  if (!std::isfinite(hi)) hi = lo;
  if (lo > hi) std::swap(lo, hi);
  target = std::max(target, 1);

  // A (near-)zero-width range would give no usable step: size the step from the value's
  // magnitude instead, and bracket the value strictly so the axis still has extent.
  const bool flat = hi - lo <= 1e-12 * std::max(std::fabs(lo), std::fabs(hi));
  const double span = flat ? (lo == 0 ? 2.0 : 0.2 * std::fabs(lo)) : hi - lo;
  const std::vector<double> fallback{lo, hi > lo ? hi : lo + 1};

  const double raw = span / target;
  if (!std::isfinite(raw) || raw <= 0) return fallback;
  int e = static_cast<int>(std::floor(std::log10(raw)));
  const double norm = raw / std::pow(10.0, e);
  int m = norm < 1.5 ? 1 : norm < 3 ? 2 : norm < 7 ? 5 : 10;
  if (m == 10) m = 1, ++e;

  // Ticks are k * m * 10^e. For e < 0, dividing by the exact integer 10^-e yields the double
  // nearest the decimal value (0.6, not 0.6000000000000001 as 3 * 0.2 would).
  const double p = std::pow(10.0, std::abs(e));
  if (!std::isfinite(p) || p == 0) return fallback;
  auto tick = [&](double k) { return e >= 0 ? k * m * p : k * m / p; };
  const double step = tick(1);

  // floor/ceil of lo/step may be off by one through rounding; fix up with exact comparisons.
  double k0 = std::floor(lo / step), k1 = std::ceil(hi / step);
  if (flat) {  // strict bracket: lo - step < first < lo, hi < last < hi + step
    while (tick(k0) >= lo) --k0;
    while (tick(k0 + 1) < lo) ++k0;
    while (tick(k1) <= hi) ++k1;
    while (tick(k1 - 1) > hi) --k1;
  } else {  // lo - step < first <= lo, hi <= last < hi + step
    while (tick(k0) > lo) --k0;
    while (tick(k0 + 1) <= lo) ++k0;
    while (tick(k1) < hi) ++k1;
    while (tick(k1 - 1) >= hi) --k1;
  }
  if (k1 - k0 > 10000) return fallback;  // cannot happen for sane input; guards memory

  std::vector<double> ticks;
  for (double k = k0; k <= k1; ++k) ticks.push_back(tick(k));
  return ticks;
}

void write_svg(const std::string& path, const std::string& title, const std::string& x_label,
               const std::vector<double>& x, const std::vector<Panel>& panels, int width,
               int panel_height) {
  // Validate everything before touching the file system.
  auto xs_of = [&](const Series& s) -> const std::vector<double>& { return s.x.empty() ? x : s.x; };
  bool any_x = !x.empty();
  for (const Panel& panel : panels)
    for (const Series& s : panel.series) {
      if (s.x.empty() && x.empty())
        throw std::invalid_argument("write_svg: series '" + s.label + "' in panel '" + panel.title +
                                    "' has no x values of its own and the shared x is empty");
      if (s.y.size() != xs_of(s).size())
        throw std::invalid_argument("write_svg: series '" + s.label + "' in panel '" +
                                    panel.title + "' has " + std::to_string(s.y.size()) +
                                    " values but its x has " + std::to_string(xs_of(s).size()));
      any_x = any_x || !s.x.empty();
    }
  if (!any_x) throw std::invalid_argument("write_svg: x is empty");

  std::vector<std::string> title_lines;
  for (size_t b = 0;;) {
    const size_t e = title.find('\n', b);
    title_lines.push_back(title.substr(b, e == std::string::npos ? e : e - b));
    if (e == std::string::npos) break;
    b = e + 1;
  }
  const double title_h = kTitleH + kSubtitleH * static_cast<double>(title_lines.size() - 1);

  const double W = std::max(width, 400), PH = std::max(panel_height, 100);
  const double H = title_h + PH * static_cast<double>(panels.size()) + kBottomH;
  const double plot_l = kLeft, plot_r = W - kRight, plot_w = plot_r - plot_l;

  // The shared x axis hugs the data: no empty margins on a time axis.
  double xlo = std::numeric_limits<double>::infinity(), xhi = -xlo;
  auto cover_x = [&](const std::vector<double>& v) {
    for (double t : v)
      if (std::isfinite(t)) xlo = std::min(xlo, t), xhi = std::max(xhi, t);
  };
  cover_x(x);
  for (const Panel& panel : panels)
    for (const Series& s : panel.series) cover_x(s.x);
  if (xlo > xhi) xlo = 0, xhi = 1;  // no finite x at all: nothing will be drawn anyway
  std::vector<double> xt = nice_ticks(xlo, xhi, std::max(2, static_cast<int>(plot_w / 100)));
  if (!(xhi > xlo)) {
    xlo = xt.front(), xhi = xt.back();
  } else {  // stretch to a tick just outside the data (t ending at 9.9995 -> 10) so ends get labels
    const double slack = 0.02 * (xhi - xlo);
    if (xt.front() < xlo && xlo - xt.front() <= slack) xlo = xt.front();
    if (xt.back() > xhi && xt.back() - xhi <= slack) xhi = xt.back();
  }
  const double xstep = xt.size() > 1 ? xt[1] - xt[0] : 1.0;
  std::erase_if(xt, [&](double t) { return t < xlo - 1e-9 * xstep || t > xhi + 1e-9 * xstep; });
  const Map mx{xlo, xhi, plot_l, plot_r};

  std::string out;
  out += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + fixed_decimals(W, 0) + "\" height=\"" +
         fixed_decimals(H, 0) + "\" viewBox=\"0 0 " + fixed_decimals(W, 0) + ' ' + fixed_decimals(H, 0) +
         "\" font-family=\"Helvetica, Arial, sans-serif\">\n";
  out += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  text(out, 10, 26, title_lines[0], "start", 15, " font-weight=\"bold\"");  // long titles stay on the page
  for (size_t li = 1; li < title_lines.size(); ++li)
    text(out, 10, 26 + kSubtitleH * static_cast<double>(li), title_lines[li], "start", 12);

  for (size_t pi = 0; pi < panels.size(); ++pi) {
    const Panel& panel = panels[pi];
    const double top = title_h + PH * static_cast<double>(pi) + kPanelTop;
    const double bottom = title_h + PH * static_cast<double>(pi + 1) - kPanelGap;

    double ylo = std::numeric_limits<double>::infinity(), yhi = -ylo;
    for (const Series& s : panel.series) {
      const std::vector<double>& sx = xs_of(s);
      for (size_t i = 0; i < sx.size(); ++i)
        if (std::isfinite(s.y[i]) && std::isfinite(sx[i]))
          ylo = std::min(ylo, s.y[i]), yhi = std::max(yhi, s.y[i]);
    }
    if (ylo > yhi) ylo = 0, yhi = 1;  // empty panel: still draw a labelled frame
    widen_to_min_span(ylo, yhi, panel.min_span);
    const std::vector<double> yt =
        nice_ticks(ylo, yhi, std::max(2, static_cast<int>((bottom - top) / 35)));
    const double ystep = yt.size() > 1 ? yt[1] - yt[0] : 1.0;
    const Map my{yt.front(), yt.back(), bottom, top};

    out += "<g class=\"panel\">\n";
    text(out, plot_l, top - 8, panel.title, "start", 13, " font-weight=\"bold\"");
    // Grid first so curves draw over it.
    out += "<g stroke=\"#e0e0e0\" stroke-width=\"1\">\n";
    for (double t : yt)
      out += "<line x1=\"" + fixed_decimals(plot_l, 2) + "\" y1=\"" + fixed_decimals(my(t), 2) + "\" x2=\"" + fixed_decimals(plot_r, 2) +
             "\" y2=\"" + fixed_decimals(my(t), 2) + "\"/>\n";
    for (double t : xt)
      out += "<line x1=\"" + fixed_decimals(mx(t), 2) + "\" y1=\"" + fixed_decimals(top, 2) + "\" x2=\"" + fixed_decimals(mx(t), 2) +
             "\" y2=\"" + fixed_decimals(bottom, 2) + "\"/>\n";
    out += "</g>\n";
    out += "<rect class=\"plot-area\" x=\"" + fixed_decimals(plot_l, 2) + "\" y=\"" + fixed_decimals(top, 2) + "\" width=\"" +
           fixed_decimals(plot_w, 2) + "\" height=\"" + fixed_decimals(bottom - top, 2) +
           "\" fill=\"none\" stroke=\"#444\" stroke-width=\"1\"/>\n";
    for (double t : yt) text(out, plot_l - 6, my(t) + 4, tick_label(t, ystep), "end", 11);
    out += "<text transform=\"translate(16," + fixed_decimals((top + bottom) / 2, 2) +
           ") rotate(-90)\" text-anchor=\"middle\" font-size=\"12\">" + escape(panel.y_label) +
           "</text>\n";
    if (pi + 1 == panels.size())  // shared axis: label x only under the last panel
      for (double t : xt) text(out, mx(t), bottom + 16, tick_label(t, xstep), "middle", 11);

    for (size_t si = 0; si < panel.series.size(); ++si) {
      const Series& s = panel.series[si];
      const std::string colour = kPalette[si % kPaletteSize];
      const std::string pattern = dash_pattern(si);
      const std::string dash = pattern.empty() ? "" : " stroke-dasharray=\"" + pattern + "\"";
      out += "<g class=\"series\" fill=\"none\" stroke=\"" + colour + "\" stroke-width=\"1.5\"" +
             dash + " stroke-linejoin=\"round\" stroke-linecap=\"round\">\n<title>" +
             escape(s.label) + "</title>\n";
      add_polylines(out, xs_of(s), s.y, mx, my);
      out += "</g>\n";
      // Legend entry in the right margin, long enough to show a whole dash cycle.
      const double ly = top + 10 + 16 * static_cast<double>(si);
      out += "<line class=\"legend\" x1=\"" + fixed_decimals(plot_r + 10, 2) + "\" y1=\"" + fixed_decimals(ly, 2) +
             "\" x2=\"" + fixed_decimals(plot_r + 44, 2) + "\" y2=\"" + fixed_decimals(ly, 2) + "\" stroke=\"" + colour +
             "\" stroke-width=\"1.5\" stroke-linecap=\"round\"" + dash + "/>\n";
      text(out, plot_r + 50, ly + 4, s.label, "start", 12);
    }
    out += "</g>\n";
  }
  if (!panels.empty()) text(out, (plot_l + plot_r) / 2, H - 12, x_label, "middle", 12);
  out += "</svg>\n";

  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  if (!f) throw std::runtime_error("write_svg: cannot open '" + path + "' for writing");
  f.write(out.data(), static_cast<std::streamsize>(out.size()));
  f.close();
  if (!f) throw std::runtime_error("write_svg: failed writing '" + path + "'");
}

}  // namespace forklift::plot
