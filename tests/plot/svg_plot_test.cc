#include "forklift/plot/svg_plot.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace fp = forklift::plot;

namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();

// Checks every documented property of nice_ticks for [lo, hi] and returns the step.
// The nominal step (exactly 1, 2 or 5 x 10^n) is recovered from the whole span, since
// t[1] - t[0] cancels badly for tiny ranges far from zero.
double CheckTickProperties(double lo, double hi, const std::vector<double>& t) {
  EXPECT_GE(t.size(), 2u) << "[" << lo << ", " << hi << "]";
  if (t.size() < 2) return 0;
  const double est = (t.back() - t.front()) / static_cast<double>(t.size() - 1);
  EXPECT_GT(est, 0);
  const double p10 = std::pow(10.0, std::floor(std::log10(est) + 1e-9));
  const double mant = est / p10;
  EXPECT_TRUE(std::fabs(mant - 1) < 1e-6 || std::fabs(mant - 2) < 1e-6 ||
              std::fabs(mant - 5) < 1e-6)
      << "step " << est << " mantissa " << mant;
  const double step = std::round(mant) * p10;
  // Tolerance: a tiny fraction of the step plus the rounding of values of this magnitude.
  auto tol = [&](double v) { return 1e-6 * step + 1e-14 * std::fabs(v); };
  for (size_t i = 1; i < t.size(); ++i) {
    EXPECT_GT(t[i], t[i - 1]);
    EXPECT_NEAR(t[i] - t[i - 1], step, tol(t[i])) << "uneven spacing at " << i;
  }
  // Ticks are multiples of the step.
  for (double v : t) EXPECT_NEAR(v, std::round(v / step) * step, tol(v)) << v;
  // Covers the range, stays within one step of it.
  EXPECT_LE(t.front(), lo);
  EXPECT_GE(t.back(), hi);
  EXPECT_GE(t.front(), lo - step - tol(lo));
  EXPECT_LE(t.back(), hi + step + tol(hi));
  return step;
}

std::string ReadFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

size_t Count(const std::string& s, const std::string& needle) {
  size_t n = 0;
  for (size_t p = s.find(needle); p != std::string::npos; p = s.find(needle, p + 1)) ++n;
  return n;
}

std::string TempPath(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::path(testing::TempDir()) / "forklift_svg_plot_files";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

struct XY {
  double x, y;
};

// All points of all polylines, in order of appearance, one vector per polyline.
// (Parsed by hand: libstdc++'s recursive std::regex overflows the stack on long attributes.)
std::vector<std::vector<XY>> Polylines(const std::string& svg) {
  std::vector<std::vector<XY>> lines;
  for (size_t p = svg.find("<polyline"); p != std::string::npos; p = svg.find("<polyline", p + 1)) {
    const size_t begin = svg.find("points=\"", p) + 8;
    const size_t end = svg.find('"', begin);
    std::vector<XY> pts;
    std::istringstream in(svg.substr(begin, end - begin));
    std::string tok;
    while (in >> tok) {
      const size_t comma = tok.find(',');
      pts.push_back({std::stod(tok.substr(0, comma)), std::stod(tok.substr(comma + 1))});
    }
    lines.push_back(pts);
  }
  return lines;
}

struct Rect {
  double x, y, w, h;
};

std::vector<Rect> PlotAreas(const std::string& svg) {
  std::vector<Rect> rects;
  const std::regex re(
      "class=\"plot-area\" x=\"([-0-9.]+)\" y=\"([-0-9.]+)\" width=\"([0-9.]+)\" "
      "height=\"([0-9.]+)\"");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator();
       ++it)
    rects.push_back({std::stod((*it)[1]), std::stod((*it)[2]), std::stod((*it)[3]),
                     std::stod((*it)[4])});
  return rects;
}

std::vector<double> Linspace(double a, double b, size_t n) {
  std::vector<double> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = a + (b - a) * static_cast<double>(i) / static_cast<double>(n - 1);
  return v;
}

}  // namespace

TEST(NiceTicks, UnitRange) {
  const auto t = fp::nice_ticks(0.0, 1.0);
  const std::vector<double> want{0.0, 0.2, 0.4, 0.6, 0.8, 1.0};
  ASSERT_EQ(t.size(), want.size());
  for (size_t i = 0; i < t.size(); ++i) EXPECT_NEAR(t[i], want[i], 1e-12);
  CheckTickProperties(0.0, 1.0, t);
}

TEST(NiceTicks, MixedSignRange) {
  const auto t = fp::nice_ticks(-3.7, 12.1);
  const std::vector<double> want{-5, 0, 5, 10, 15};
  ASSERT_EQ(t.size(), want.size());
  for (size_t i = 0; i < t.size(); ++i) EXPECT_NEAR(t[i], want[i], 1e-12);
  CheckTickProperties(-3.7, 12.1, t);
}

TEST(NiceTicks, LargeNegativeRange) {
  const auto t = fp::nice_ticks(-48000, -1200);
  const double step = CheckTickProperties(-48000, -1200, t);
  EXPECT_DOUBLE_EQ(step, 10000);
  EXPECT_DOUBLE_EQ(t.front(), -50000);
  EXPECT_DOUBLE_EQ(t.back(), 0);
}

TEST(NiceTicks, TinyRange) {
  const double lo = 1.0, hi = 1.0000001;
  const auto t = fp::nice_ticks(lo, hi);
  const double step = CheckTickProperties(lo, hi, t);
  EXPECT_NEAR(step, 2e-8, 1e-14);
  EXPECT_GE(t.size(), 3u);
  EXPECT_LE(t.size(), 8u);
}

TEST(NiceTicks, EqualBoundsGiveNonEmptyRange) {
  for (double v : {5.0, 0.0, -0.003, 12345.0}) {
    const auto t = fp::nice_ticks(v, v);
    CheckTickProperties(v, v, t);
    ASSERT_GE(t.size(), 2u);
    EXPECT_LT(t.front(), v) << v;
    EXPECT_GT(t.back(), v) << v;
  }
}

TEST(NiceTicks, TargetControlsDensity) {
  EXPECT_LT(fp::nice_ticks(0, 100, 3).size(), fp::nice_ticks(0, 100, 20).size());
  for (int target : {2, 5, 10, 20}) {
    const auto t = fp::nice_ticks(0, 100, target);
    CheckTickProperties(0, 100, t);
    // "about target": within a factor of ~2.5 either way (1-2-5 steps are coarse).
    EXPECT_GE(static_cast<double>(t.size()), target / 2.5) << target;
    EXPECT_LE(static_cast<double>(t.size()), target * 2.5 + 1) << target;
  }
}

TEST(NiceTicks, RandomRangesSatisfyProperties) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> exponent(-6, 6), unit(-1, 1);
  for (int i = 0; i < 500; ++i) {
    const double scale = std::pow(10.0, exponent(rng));
    double lo = unit(rng) * scale, hi = unit(rng) * scale;
    if (lo > hi) std::swap(lo, hi);
    SCOPED_TRACE(testing::Message() << "[" << lo << ", " << hi << "]");
    const auto t = fp::nice_ticks(lo, hi);
    CheckTickProperties(lo, hi, t);
    EXPECT_LE(t.size(), 12u);
  }
}

TEST(WriteSvg, StructureAndOnePolylinePerSeries) {
  const auto x = Linspace(0, 10, 101);
  fp::Panel pitch{"Pitch", "pitch (deg)", {{"pitch", {}}}};
  fp::Panel fz{"Vertical wheel forces", "Fz (N)", {{"front_left", {}}, {"front_right", {}}, {"rear", {}}}};
  for (double t : x) {
    pitch.series[0].y.push_back(2 * std::sin(t));
    fz.series[0].y.push_back(8000 + 500 * std::cos(t));
    fz.series[1].y.push_back(7900 + 400 * std::cos(t));
    fz.series[2].y.push_back(5000 - 900 * std::cos(t));
  }
  const std::string path = TempPath("structure.svg");
  fp::write_svg(path, "Braking manoeuvre", "t (s)", x, {pitch, fz});
  const std::string svg = ReadFile(path);

  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_EQ(Count(svg, "<polyline"), 4u);
  EXPECT_EQ(PlotAreas(svg).size(), 2u);
  for (const char* s : {"Braking manoeuvre", "t (s)", "pitch (deg)", "Fz (N)",
                        "Vertical wheel forces", ">front_left<", ">front_right<", ">rear<"})
    EXPECT_NE(svg.find(s), std::string::npos) << s;
  EXPECT_EQ(svg.find("nan"), std::string::npos);
  EXPECT_EQ(svg.find("inf"), std::string::npos);

  // Series within a panel have distinct colours.
  std::vector<std::string> colours;
  const std::regex re("<g class=\"series\"[^>]*stroke=\"(#[0-9a-f]{6})\"");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator();
       ++it)
    colours.push_back((*it)[1]);
  ASSERT_EQ(colours.size(), 4u);
  EXPECT_NE(colours[1], colours[2]);
  EXPECT_NE(colours[1], colours[3]);
  EXPECT_NE(colours[2], colours[3]);

  // Every point lies inside its panel's plot area, and curves span the full x range.
  const auto areas = PlotAreas(svg);
  const auto lines = Polylines(svg);
  for (size_t li = 0; li < lines.size(); ++li) {
    const Rect& a = areas[li == 0 ? 0 : 1];
    for (const XY& p : lines[li]) {
      EXPECT_GE(p.x, a.x - 0.01);
      EXPECT_LE(p.x, a.x + a.w + 0.01);
      EXPECT_GE(p.y, a.y - 0.01);
      EXPECT_LE(p.y, a.y + a.h + 0.01);
    }
    EXPECT_NEAR(lines[li].front().x, a.x, 0.01);
    EXPECT_NEAR(lines[li].back().x, a.x + a.w, 0.01);
  }
}

TEST(WriteSvg, NaNSplitsPolyline) {
  const auto x = Linspace(0, 1, 50);
  std::vector<double> y(x.size(), 1.0);
  for (size_t i = 0; i < y.size(); ++i) y[i] = static_cast<double>(i % 7);
  y[25] = kNaN;
  const std::string path = TempPath("nan.svg");
  fp::write_svg(path, "gap", "t (s)", x, {{"p", "v", {{"s", y}}}});
  const std::string svg = ReadFile(path);
  const auto lines = Polylines(svg);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0].size(), 25u);  // few points: no decimation
  EXPECT_EQ(lines[1].size(), 24u);
  EXPECT_LT(lines[0].back().x, lines[1].front().x);
  EXPECT_EQ(svg.find("nan"), std::string::npos);

  // Leading/trailing non-finite values trim rather than split; infinities also break.
  y[25] = 3;
  y[0] = kNaN;
  y[49] = std::numeric_limits<double>::infinity();
  fp::write_svg(path, "gap", "t (s)", x, {{"p", "v", {{"s", y}}}});
  EXPECT_EQ(Polylines(ReadFile(path)).size(), 1u);
  y[10] = -std::numeric_limits<double>::infinity();
  y[30] = kNaN;
  fp::write_svg(path, "gap", "t (s)", x, {{"p", "v", {{"s", y}}}});
  EXPECT_EQ(Polylines(ReadFile(path)).size(), 3u);
}

TEST(WriteSvg, EscapesText) {
  const auto x = Linspace(0, 1, 5);
  const std::string path = TempPath("escape.svg");
  fp::write_svg(path, "a<b & c>d", "t \"s\"", x,
                {{"<panel>", "F & M", {{"x<y", {1, 2, 3, 4, 5}}}}});
  const std::string svg = ReadFile(path);
  EXPECT_NE(svg.find("a&lt;b &amp; c&gt;d"), std::string::npos);
  EXPECT_EQ(svg.find("a<b"), std::string::npos);
  EXPECT_NE(svg.find("&lt;panel&gt;"), std::string::npos);
  EXPECT_NE(svg.find("F &amp; M"), std::string::npos);
  EXPECT_NE(svg.find("x&lt;y"), std::string::npos);
  EXPECT_NE(svg.find("t &quot;s&quot;"), std::string::npos);
  // Every '&' starts an entity.
  for (size_t p = svg.find('&'); p != std::string::npos; p = svg.find('&', p + 1))
    EXPECT_TRUE(svg.compare(p, 4, "&lt;") == 0 || svg.compare(p, 4, "&gt;") == 0 ||
                svg.compare(p, 5, "&amp;") == 0 || svg.compare(p, 6, "&quot;") == 0 ||
                svg.compare(p, 6, "&apos;") == 0)
        << svg.substr(p, 8);
}

TEST(WriteSvg, InvalidInputThrows) {
  const std::string path = TempPath("invalid.svg");
  std::filesystem::remove(path);
  const std::vector<double> x{0, 1, 2};
  EXPECT_THROW(fp::write_svg(path, "t", "x", x, {{"p", "y", {{"s", {1, 2}}}}}),
               std::invalid_argument);
  EXPECT_THROW(fp::write_svg(path, "t", "x", x, {{"p", "y", {{"ok", {1, 2, 3}}, {"s", {1, 2, 3, 4}}}}}),
               std::invalid_argument);
  EXPECT_THROW(fp::write_svg(path, "t", "x", {}, {{"p", "y", {{"s", {}}}}}), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(path)) << "validation must precede writing";
}

TEST(WriteSvg, UnwritablePathThrows) {
  const std::vector<double> x{0, 1, 2};
  EXPECT_THROW(fp::write_svg("/nonexistent_dir/x.svg", "t", "x", x, {{"p", "y", {{"s", {1, 2, 3}}}}}),
               std::runtime_error);
}

TEST(WriteSvg, DecimationKeepsSingleSampleSpike) {
  const size_t n = 20000;
  const auto x = Linspace(0, 20, n);
  std::vector<double> y(n, 0.0);
  y[12345] = 10.0;  // ticks 0..10: the spike must reach the top of the plot area
  const std::string path = TempPath("spike.svg");
  fp::write_svg(path, "spike", "t (s)", x, {{"p", "v", {{"s", y}}}});
  const std::string svg = ReadFile(path);
  const auto areas = PlotAreas(svg);
  const auto lines = Polylines(svg);
  ASSERT_EQ(areas.size(), 1u);
  ASSERT_EQ(lines.size(), 1u);
  const auto& pts = lines[0];

  // At most ~2 points per horizontal pixel.
  EXPECT_LE(static_cast<double>(pts.size()), 2 * areas[0].w + 4);
  EXPECT_GT(pts.size(), 10u);

  double min_y = 1e9, max_y = -1e9, spike_x = 0;
  for (const XY& p : pts) {
    if (p.y < min_y) min_y = p.y, spike_x = p.x;
    max_y = std::max(max_y, p.y);
  }
  EXPECT_NEAR(min_y, areas[0].y, 2.0);               // spike at the top
  EXPECT_NEAR(max_y, areas[0].y + areas[0].h, 2.0);  // baseline at the bottom
  EXPECT_NEAR(spike_x, areas[0].x + areas[0].w * 12345.0 / (n - 1), 1.0);

  // x stays monotonic after decimation (order preserved).
  for (size_t i = 1; i < pts.size(); ++i) EXPECT_GE(pts[i].x, pts[i - 1].x);

  // A negative spike survives too.
  y[12345] = 0;
  y[777] = -10.0;
  fp::write_svg(path, "spike", "t (s)", x, {{"p", "v", {{"s", y}}}});
  const std::string svg2 = ReadFile(path);
  const auto areas2 = PlotAreas(svg2);
  const auto lines2 = Polylines(svg2);
  ASSERT_EQ(lines2.size(), 1u);
  double max_y2 = -1e9;
  for (const XY& p : lines2[0]) max_y2 = std::max(max_y2, p.y);
  EXPECT_NEAR(max_y2, areas2[0].y + areas2[0].h, 2.0);
}

TEST(WriteSvg, ConstantPanelGetsSensibleRange) {
  const auto x = Linspace(0, 5, 100);
  const std::string path = TempPath("constant.svg");
  fp::write_svg(path, "flat", "t (s)", x,
                {{"zero", "a", {{"s", std::vector<double>(x.size(), 0.0)}}},
                 {"const", "b", {{"s", std::vector<double>(x.size(), 3.0)}}},
                 {"empty", "c", {}}});
  const std::string svg = ReadFile(path);
  EXPECT_EQ(svg.find("nan"), std::string::npos);
  EXPECT_EQ(svg.find("inf"), std::string::npos);
  const auto areas = PlotAreas(svg);
  const auto lines = Polylines(svg);
  ASSERT_EQ(areas.size(), 3u);
  ASSERT_EQ(lines.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    // A flat line strictly inside the frame (not on an edge, not NaN).
    for (const XY& p : lines[i]) {
      EXPECT_GT(p.y, areas[i].y + 1);
      EXPECT_LT(p.y, areas[i].y + areas[i].h - 1);
      EXPECT_DOUBLE_EQ(p.y, lines[i][0].y);
    }
  }
}

namespace {

// The attribute `name` of every <g class="series"> element, in order ("" where absent).
std::vector<std::string> SeriesAttr(const std::string& svg, const std::string& name) {
  std::vector<std::string> values;
  for (size_t p = svg.find("<g class=\"series\""); p != std::string::npos;
       p = svg.find("<g class=\"series\"", p + 1)) {
    const std::string tag = svg.substr(p, svg.find('>', p) - p);
    const size_t a = tag.find(" " + name + "=\"");
    values.push_back(a == std::string::npos ? "" : tag.substr(a + name.size() + 3, tag.find('"', a + name.size() + 3) - (a + name.size() + 3)));
  }
  return values;
}

// Smallest and largest y pixel over the given polylines.
std::pair<double, double> PixelRangeY(const std::vector<std::vector<XY>>& lines) {
  double lo = 1e9, hi = -1e9;
  for (const auto& l : lines)
    for (const XY& p : l) lo = std::min(lo, p.y), hi = std::max(hi, p.y);
  return {lo, hi};
}

}  // namespace

TEST(WriteSvg, NearConstantDataGetsMinimumSpan) {
  // A wheel's Fz wobbling by 1e-6 N around 15 kN, and a slip ratio of numerical noise: both
  // must draw as flat lines mid-panel, not as noise stretched to the panel's full height.
  const auto x = Linspace(0, 20, 2001);
  std::vector<double> fz, slip, genuine;
  for (size_t i = 0; i < x.size(); ++i) {
    fz.push_back(15000 + 1e-6 * std::sin(7 * x[i]));
    slip.push_back(1e-12 * std::cos(3 * x[i]));
    genuine.push_back(15000 + 50 * std::sin(x[i]));  // 100 N of 15 kN: above the relative span
  }
  const std::string path = TempPath("min_span.svg");
  fp::write_svg(path, "noise", "t (s)", x,
                {{"Fz", "Fz (N)", {{"rear", fz}}, 1.0},
                 {"slip", "slip ratio (-)", {{"front_left", slip}}, 1e-3},
                 {"no absolute floor", "Fz (N)", {{"rear", fz}}},
                 {"genuine variation", "Fz (N)", {{"rear", genuine}}, 1.0}});
  const std::string svg = ReadFile(path);
  const auto areas = PlotAreas(svg);
  const auto lines = Polylines(svg);
  ASSERT_EQ(areas.size(), 4u);
  ASSERT_EQ(lines.size(), 4u);
  for (size_t i = 0; i < 3; ++i) {
    SCOPED_TRACE(i);
    const auto [lo, hi] = PixelRangeY({lines[i]});
    EXPECT_LT(hi - lo, 0.5) << "noise drawn at a visible height";
    // Widened about the data's middle: the line sits well inside the frame.
    EXPECT_GT(lo, areas[i].y + 0.25 * areas[i].h);
    EXPECT_LT(hi, areas[i].y + 0.75 * areas[i].h);
  }
  // Real variation still fills most of the panel.
  const auto [lo, hi] = PixelRangeY({lines[3]});
  EXPECT_GT(hi - lo, 0.5 * areas[3].h);

  // The tick labels of the Fz panel span at least kMinRelativeSpan x 15 kN (15 N), whatever
  // its absolute floor says; those of the slip panel at least its floor.
  std::vector<double> labels;
  const std::regex re("text-anchor=\"end\" font-size=\"11\">([-0-9.e+]+)<");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator(); ++it)
    labels.push_back(std::stod((*it)[1]));
  ASSERT_GE(labels.size(), 4u);
  double fz_lo = 1e18, fz_hi = -1e18, slip_lo = 1e18, slip_hi = -1e18;
  for (double v : labels) {
    if (v > 1000) fz_lo = std::min(fz_lo, v), fz_hi = std::max(fz_hi, v);
    else if (std::fabs(v) < 1) slip_lo = std::min(slip_lo, v), slip_hi = std::max(slip_hi, v);
  }
  EXPECT_GE(fz_hi - fz_lo, fp::kMinRelativeSpan * 15000 * 0.999);
  EXPECT_GE(slip_hi - slip_lo, 1e-3 * 0.999);
  EXPECT_LE(slip_hi - slip_lo, 1e-2);  // sensible: about the floor, not a unit range
}

TEST(WriteSvg, SeriesDifferInColourAndDash) {
  // Two identical curves (a left and a right wheel on a straight run) must both show.
  const auto x = Linspace(0, 10, 200);
  std::vector<fp::Series> series;
  for (int i = 0; i < 12; ++i) {
    fp::Series s{"s" + std::to_string(i), {}};
    for (double t : x) s.y.push_back(std::sin(t) + (i < 2 ? 0 : 0.1 * i));
    series.push_back(s);
  }
  const std::string path = TempPath("dashes.svg");
  fp::write_svg(path, "dashes", "t (s)", x, {{"p", "v", series}});
  const std::string svg = ReadFile(path);
  const auto colours = SeriesAttr(svg, "stroke");
  const auto dashes = SeriesAttr(svg, "stroke-dasharray");
  ASSERT_EQ(colours.size(), 12u);
  ASSERT_EQ(dashes.size(), 12u);
  EXPECT_EQ(dashes[0], "") << "the first series is solid";
  for (size_t i = 0; i < 12; ++i)
    for (size_t j = i + 1; j < 12; ++j) {
      // Within a palette cycle both differ; beyond it at least the pair differs.
      if (j < std::min<size_t>(fp::dash_pattern_count(), 10)) {
        EXPECT_NE(colours[i], colours[j]) << i << " " << j;
        EXPECT_NE(dashes[i], dashes[j]) << i << " " << j;
      }
      EXPECT_FALSE(colours[i] == colours[j] && dashes[i] == dashes[j]) << i << " " << j;
    }
  for (size_t i = 0; i < fp::dash_pattern_count(); ++i)
    for (size_t j = i + 1; j < fp::dash_pattern_count(); ++j) EXPECT_NE(fp::dash_pattern(i), fp::dash_pattern(j));
  EXPECT_GE(fp::dash_pattern_count(), 4u);

  // Each series has a legend entry drawn in its own colour and dash.
  for (size_t i = 0; i < 12; ++i) {
    EXPECT_NE(svg.find(">s" + std::to_string(i) + "<"), std::string::npos) << i;
    const std::string dash = dashes[i].empty() ? "" : " stroke-dasharray=\"" + dashes[i] + "\"";
    EXPECT_NE(svg.find("stroke=\"" + colours[i] + "\" stroke-width=\"1.5\" stroke-linecap=\"round\"" + dash + "/>"),
              std::string::npos)
        << "legend of series " << i;
  }
  EXPECT_EQ(Count(svg, "<line class=\"legend\""), 12u);
}

TEST(WriteSvg, SeriesWithTheirOwnSampleTimes) {
  // Two runs overlaid: one sampled every 2 ms for 20 s, one every 5 ms that stopped at 12 s.
  const auto t_full = Linspace(0, 20, 10001), t_short = Linspace(0, 12, 2401);
  fp::Series full{"full run", {}, t_full}, stopped{"stopped early", {}, t_short};
  for (double t : t_full) full.y.push_back(t);
  for (double t : t_short) stopped.y.push_back(20 - t);
  const std::string path = TempPath("own_x.svg");
  fp::write_svg(path, "overlay", "t (s)", {}, {{"p", "v", {full, stopped}}});
  const std::string svg = ReadFile(path);
  const auto areas = PlotAreas(svg);
  const auto lines = Polylines(svg);
  ASSERT_EQ(areas.size(), 1u);
  ASSERT_EQ(lines.size(), 2u);
  const Rect& a = areas[0];
  // The x axis covers the union, 0-20 s; the short run ends at 12 s, 60% across.
  EXPECT_NEAR(lines[0].front().x, a.x, 0.01);
  EXPECT_NEAR(lines[0].back().x, a.x + a.w, 0.01);
  EXPECT_NEAR(lines[1].front().x, a.x, 0.01);
  EXPECT_NEAR(lines[1].back().x, a.x + 0.6 * a.w, 0.01);
  // Both on the same y scale: at t = 0 one is at 0 (bottom), the other at 20 (top).
  EXPECT_NEAR(lines[0].front().y, a.y + a.h, 0.01);
  EXPECT_NEAR(lines[1].front().y, a.y, 0.01);
  // Decimation works per series on its own x.
  EXPECT_LE(static_cast<double>(lines[0].size()), 2 * a.w + 4);

  // Own x beside a shared x: the axis covers both.
  const std::vector<double> shared = Linspace(0, 5, 11);
  fp::write_svg(path, "mixed", "t (s)", shared,
                {{"p", "v", {{"shared", std::vector<double>(11, 1.0)}, {"own", {1, 2}, {2, 30}}}}});
  const auto lines2 = Polylines(ReadFile(path));
  ASSERT_EQ(lines2.size(), 2u);
  EXPECT_LT(lines2[0].back().x, lines2[1].back().x);

  // A series' y must match its own x; a series without one needs the shared x.
  EXPECT_THROW(fp::write_svg(path, "t", "x", {}, {{"p", "v", {{"s", {1, 2, 3}, {0, 1}}}}}), std::invalid_argument);
  EXPECT_THROW(fp::write_svg(path, "t", "x", {}, {{"p", "v", {{"own", {1, 2}, {0, 1}}, {"shared", {1, 2}}}}}),
               std::invalid_argument);
  EXPECT_THROW(fp::write_svg(path, "t", "x", {}, {{"p", "v", {}}}), std::invalid_argument);
}

TEST(WriteSvg, SubtitleLinesPushPanelsDown) {
  const std::vector<double> x{0, 1, 2};
  const std::string one = TempPath("title1.svg"), three = TempPath("title3.svg");
  fp::write_svg(one, "Figure", "t", x, {{"p", "v", {{"s", {1, 2, 3}}}}});
  fp::write_svg(three, "Figure\nmanoeuvre 1: a & b\nmanoeuvre 2", "t", x, {{"p", "v", {{"s", {1, 2, 3}}}}});
  const std::string svg = ReadFile(three);
  EXPECT_NE(svg.find(">manoeuvre 1: a &amp; b</text>"), std::string::npos);
  EXPECT_NE(svg.find(">manoeuvre 2</text>"), std::string::npos);
  EXPECT_EQ(svg.find("Figure\n"), std::string::npos);
  EXPECT_GT(PlotAreas(svg)[0].y, PlotAreas(ReadFile(one))[0].y + 20);
}
