// SVG plots (src/report/svg/plot.cc): structure of the output (well-formed, one element per grid
// cell, markers where the data says), tick generation and decimation against hand-computed
// answers, and that non-finite data never leaks into the text.
#include "blmd/report/svg/plot.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <regex>
#include <string>
#include <vector>

#include "report/svg/plot_ticks.h"

namespace blmd {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::size_t Count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) {
    ++n;
  }
  return n;
}

// True when every start tag has its end tag, properly nested (comments and
// self-closing tags allowed), and nothing but whitespace follows the root.
bool TagsBalanced(const std::string& svg) {
  std::vector<std::string> open;
  std::size_t at = 0;
  bool root_closed = false;
  while ((at = svg.find('<', at)) != std::string::npos) {
    if (root_closed) return false;
    if (svg.compare(at, 4, "<!--") == 0) {
      at = svg.find("-->", at);
      if (at == std::string::npos) return false;
      continue;
    }
    const auto end = svg.find('>', at);
    if (end == std::string::npos) return false;
    const std::string tag = svg.substr(at + 1, end - at - 1);
    at = end + 1;
    if (tag.empty()) return false;
    if (tag[0] == '/') {
      if (open.empty() || open.back() != tag.substr(1)) return false;
      open.pop_back();
      if (open.empty()) root_closed = true;
      continue;
    }
    if (tag.back() == '/') continue;
    open.push_back(tag.substr(0, tag.find_first_of(" \n\t")));
  }
  return open.empty() && root_closed;
}

void ExpectWellFormed(const std::string& svg) {
  EXPECT_EQ(Count(svg, "<svg"), 1u);
  EXPECT_EQ(svg.rfind("<svg", 0), 0u) << "starts with the root element";
  std::string trimmed = svg;
  while (!trimmed.empty() && std::isspace(static_cast<unsigned char>(trimmed.back()))) {
    trimmed.pop_back();
  }
  EXPECT_TRUE(trimmed.size() >= 6 && trimmed.compare(trimmed.size() - 6, 6, "</svg>") == 0);
  EXPECT_TRUE(TagsBalanced(svg));
  EXPECT_EQ(svg.find("<script"), std::string::npos);
  EXPECT_EQ(svg.find("@import"), std::string::npos);
  EXPECT_EQ(svg.find("http://", svg.find("xmlns=") + 40), std::string::npos) << "no external refs";
}

void ExpectNoNonFiniteText(const std::string& svg) {
  for (const char* bad : {"NaN", "nan", "inf", "Inf", "INF"}) {
    EXPECT_EQ(svg.find(bad), std::string::npos) << "found '" << bad << "'";
  }
}

double Attribute(const std::string& element, const std::string& name) {
  std::smatch match;
  const std::regex pattern(name + "=\"([^\"]*)\"");
  if (!std::regex_search(element, match, pattern)) return kNaN;
  return std::stod(match[1].str());
}

// The opening tag of the first element with this class.
std::string ElementWithClass(const std::string& svg, const std::string& css_class) {
  const auto at = svg.find("class=\"" + css_class + "\"");
  if (at == std::string::npos) return "";
  const auto start = svg.rfind('<', at);
  return svg.substr(start, svg.find('>', at) - start + 1);
}

struct Rect {
  double x, y, w, h;
};
std::vector<Rect> Cells(const std::string& svg) {
  std::vector<Rect> cells;
  const std::regex pattern(
      "<rect class=\"cell\" x=\"([^\"]+)\" y=\"([^\"]+)\" width=\"([^\"]+)\" height=\"([^\"]+)\"");
  for (std::sregex_iterator it(svg.begin(), svg.end(), pattern), end; it != end; ++it) {
    cells.push_back(
        {std::stod((*it)[1]), std::stod((*it)[2]), std::stod((*it)[3]), std::stod((*it)[4])});
  }
  return cells;
}

// Grid in row-major order (first axis outermost), costs from `cost(x, y)`.
std::vector<SurfacePoint> Grid2D(const GridAxis& a, const GridAxis& b,
                                 double (*cost)(double, double)) {
  std::vector<SurfacePoint> points;
  for (int i = 0; i < a.count; ++i) {
    for (int j = 0; j < b.count; ++j) {
      SurfacePoint p;
      p.coordinates = {a.Value(i), b.Value(j)};
      p.evaluation.cost = cost(p.coordinates[0], p.coordinates[1]);
      p.evaluation.ok = std::isfinite(p.evaluation.cost);
      points.push_back(p);
    }
  }
  return points;
}

// Bowl with its bottom at J = 3, B = 10^-1.5 (inside the grid, between grid points).
double Bowl(double j, double b) {
  const double u = j - 3.2, v = std::log10(b) + 1.4;
  return 1e-3 * (0.05 + u * u + 4 * v * v);
}

GridAxis Axis(const std::string& name, double low, double high, int count, bool log) {
  GridAxis axis;
  axis.name = name;
  axis.low = low;
  axis.high = high;
  axis.count = count;
  axis.log_scale = log;
  return axis;
}

std::size_t ArgMin(const std::vector<SurfacePoint>& points) {
  std::size_t best = 0;
  for (std::size_t k = 1; k < points.size(); ++k) {
    if (points[k].evaluation.cost < points[best].evaluation.cost) best = k;
  }
  return best;
}

TEST(PlotSurfaceSvg, TwoDimensionalGridHasOneCellPerPointAndIsWellFormed) {
  const GridAxis j = Axis("J", 1, 5, 5, false), b = Axis("B", 1e-3, 1, 4, true);
  const auto points = Grid2D(j, b, Bowl);
  SurfacePlotOptions options;
  options.title = "test: cost over J, B";
  options.units = {"kg·m²", "N·m·s"};
  const std::string svg = SurfaceSvg({j, b}, points, LocalMinima({j, b}, points), options);
  ExpectWellFormed(svg);
  ExpectNoNonFiniteText(svg);
  EXPECT_EQ(Count(svg, "class=\"cell\""), 20u);
  EXPECT_EQ(Cells(svg).size(), 20u);
  EXPECT_NE(svg.find("J (kg·m²)"), std::string::npos);
  EXPECT_NE(svg.find("B (N·m·s)"), std::string::npos);
  EXPECT_NE(svg.find("cost (normalised MSE), log scale"), std::string::npos);
  EXPECT_NE(svg.find("test: cost over J, B"), std::string::npos);
  EXPECT_EQ(Count(svg, "class=\"global-min\""), 1u);
}

TEST(PlotSurfaceSvg, MinimumMarkerSitsOnTheLowestCell) {
  const GridAxis j = Axis("J", 1, 5, 5, false), b = Axis("B", 1e-3, 1, 4, true);
  const auto points = Grid2D(j, b, Bowl);
  const std::size_t best = ArgMin(points);
  const std::string svg = SurfaceSvg({j, b}, points, {}, SurfacePlotOptions{});
  const std::string marker = ElementWithClass(svg, "global-min");
  ASSERT_FALSE(marker.empty());
  EXPECT_DOUBLE_EQ(Attribute(marker, "data-x"), points[best].coordinates[0]);
  EXPECT_DOUBLE_EQ(Attribute(marker, "data-y"), points[best].coordinates[1]);
  EXPECT_DOUBLE_EQ(Attribute(marker, "data-cost"), points[best].evaluation.cost);
  EXPECT_EQ(Attribute(marker, "data-index"), static_cast<double>(best));
  // The star's top vertex is 9 px straight above the centre of the minimum's cell (cells are
  // written in grid order).
  const auto cells = Cells(svg);
  ASSERT_EQ(cells.size(), points.size());
  const Rect& cell = cells[best];
  std::smatch match;
  const std::string after = svg.substr(svg.find("class=\"global-min\""));
  ASSERT_TRUE(std::regex_search(after, match, std::regex("points=\"([-0-9.]+),([-0-9.]+)")));
  EXPECT_NEAR(std::stod(match[1]), cell.x + cell.w / 2, 0.06);
  EXPECT_NEAR(std::stod(match[2]) + 9, cell.y + cell.h / 2, 0.06);
}

TEST(PlotSurfaceSvg, OneLocalMinimumMarkerPerIndex) {
  const GridAxis j = Axis("J", 1, 5, 5, false), b = Axis("B", 1e-3, 1, 4, true);
  const auto points = Grid2D(j, b, Bowl);
  const std::vector<std::size_t> minima = {0, 7, 13};
  const std::string svg = SurfaceSvg({j, b}, points, minima, SurfacePlotOptions{});
  EXPECT_EQ(Count(svg, "class=\"local-min\""), minima.size());
  for (std::size_t m : minima) {
    EXPECT_NE(svg.find("class=\"local-min\" data-index=\"" + std::to_string(m) + "\""),
              std::string::npos);
  }
  // From LocalMinima: the bowl has exactly one.
  const auto found = LocalMinima({j, b}, points);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(Count(SurfaceSvg({j, b}, points, found, SurfacePlotOptions{}), "class=\"local-min\""),
            1u);
}

TEST(PlotSurfaceSvg, BowlHasContours) {
  const GridAxis j = Axis("J", 1, 5, 21, false), b = Axis("B", 1e-3, 1, 21, true);
  const auto points = Grid2D(j, b, Bowl);
  const std::string svg = SurfaceSvg({j, b}, points, LocalMinima({j, b}, points), {});
  ExpectWellFormed(svg);
  EXPECT_GE(Count(svg, "class=\"contour\""), 4u);
  EXPECT_LE(Count(svg, "class=\"contour\""), 16u);
  EXPECT_EQ(Count(svg, "class=\"cell\""), 21u * 21u);
  // A constant surface has no contour lines.
  const auto flat = Grid2D(j, b, [](double, double) { return 0.5; });
  EXPECT_EQ(Count(SurfaceSvg({j, b}, flat, {}, {}), "class=\"contour\""), 0u);
}

TEST(PlotSurfaceSvg, NonFinitePointsAreHatchedAndNeverPrinted) {
  const GridAxis j = Axis("J", 1, 5, 5, false), b = Axis("B", 1e-3, 1, 4, true);
  auto points = Grid2D(j, b, Bowl);
  points[0].evaluation.cost = kInf;
  points[5].evaluation.cost = kNaN;
  points[19].evaluation.cost = kInf;
  const std::string svg = SurfaceSvg({j, b}, points, LocalMinima({j, b}, points), {});
  ExpectWellFormed(svg);
  ExpectNoNonFiniteText(svg);
  EXPECT_EQ(Count(svg, "class=\"cell\""), 20u);
  EXPECT_EQ(Count(svg, "-hatch)\""), 3u + 1u) << "three cells and the legend swatch";
  EXPECT_NE(svg.find("no finite cost"), std::string::npos);

  // Every point failed: still a well-formed plot without numbers from nowhere.
  for (auto& p : points) p.evaluation.cost = kInf;
  const std::string failed = SurfaceSvg({j, b}, points, {}, {});
  ExpectWellFormed(failed);
  ExpectNoNonFiniteText(failed);
  EXPECT_EQ(Count(failed, "class=\"global-min\""), 0u);
  EXPECT_EQ(Count(failed, "class=\"cell\""), 20u);
}

TEST(PlotSurfaceSvg, ZeroCostIsDrawnWithoutLogOfZero) {
  const GridAxis j = Axis("J", 1, 3, 3, false), b = Axis("B", 1, 3, 3, false);
  auto points =
      Grid2D(j, b, [](double x, double y) { return (x - 2) * (x - 2) + (y - 2) * (y - 2); });
  const std::string svg = SurfaceSvg({j, b}, points, LocalMinima({j, b}, points), {});
  ExpectWellFormed(svg);
  ExpectNoNonFiniteText(svg);
  EXPECT_DOUBLE_EQ(Attribute(ElementWithClass(svg, "global-min"), "data-cost"), 0.0);
}

TEST(PlotSurfaceSvg, AShardIsPlacedByCoordinates) {
  const GridAxis j = Axis("J", 1, 5, 5, false), b = Axis("B", 1e-3, 1, 4, true);
  const auto all = Grid2D(j, b, Bowl);
  const std::vector<SurfacePoint> shard(all.begin() + 8, all.begin() + 16);
  const std::string svg = SurfaceSvg({j, b}, shard, {}, {});
  ExpectWellFormed(svg);
  EXPECT_EQ(Count(svg, "class=\"cell\""), 20u);
  EXPECT_EQ(Count(svg, "-hatch)\""), 12u + 1u) << "the 12 points not in the shard are gaps";
  const std::size_t best = ArgMin(shard);
  const std::string marker = ElementWithClass(svg, "global-min");
  EXPECT_DOUBLE_EQ(Attribute(marker, "data-x"), shard[best].coordinates[0]);
  EXPECT_DOUBLE_EQ(Attribute(marker, "data-y"), shard[best].coordinates[1]);
}

TEST(PlotSurfaceSvg, OneDimensionalCurveWithMinimaAndGaps) {
  const GridAxis j = Axis("J", 1e-5, 1e-2, 31, true);
  std::vector<SurfacePoint> points;
  for (int k = 0; k < j.count; ++k) {
    SurfacePoint p;
    p.coordinates = {j.Value(k)};
    const double u = std::log10(p.coordinates[0]);
    // Two dips, at u = -4.2 (deeper) and u = -2.8.
    p.evaluation.cost = 1e-2 * (1.05 - std::exp(-std::pow((u + 4.2) / 0.3, 2)) -
                                0.6 * std::exp(-std::pow((u + 2.8) / 0.3, 2)));
    points.push_back(p);
  }
  ASSERT_EQ(LocalMinima({j}, points).size(), 2u) << "the two dips";
  points[20].evaluation.cost = kInf;
  points[21].evaluation.cost = kNaN;
  SurfacePlotOptions options;
  options.title = "1-D";
  options.units = {"kg·m²"};
  const auto minima = LocalMinima({j}, points);
  const std::string svg = SurfaceSvg({j}, points, minima, options);
  ExpectWellFormed(svg);
  ExpectNoNonFiniteText(svg);
  EXPECT_EQ(Count(svg, "class=\"curve\""), 1u);
  EXPECT_EQ(Count(svg, "class=\"local-min\""), minima.size());
  EXPECT_EQ(Count(svg, "class=\"gap\""), 2u);
  EXPECT_EQ(Count(svg, "class=\"cell\""), 0u);
  const std::size_t best = ArgMin(points);
  const std::string marker = ElementWithClass(svg, "global-min");
  EXPECT_DOUBLE_EQ(Attribute(marker, "data-x"), points[best].coordinates[0]);
  EXPECT_DOUBLE_EQ(Attribute(marker, "data-cost"), points[best].evaluation.cost);
  EXPECT_NE(svg.find("J (kg·m²)"), std::string::npos);
  EXPECT_NE(svg.find(">1e-4<"), std::string::npos) << "decade tick on the log x axis";
}

TEST(PlotSurfaceSvg, UnsupportedDimensionGivesAMessageNotACrash) {
  const GridAxis a = Axis("a", 0, 1, 2, false);
  const std::string svg = SurfaceSvg({a, a, a}, {}, {}, {});
  ExpectWellFormed(svg);
  EXPECT_NE(svg.find("3 axes"), std::string::npos);
}

TEST(PlotSurfaceSvg, SameInputSameBytes) {
  const GridAxis j = Axis("J", 1, 5, 5, false), b = Axis("B", 1e-3, 1, 4, true);
  const auto points = Grid2D(j, b, Bowl);
  EXPECT_EQ(SurfaceSvg({j, b}, points, {3}, {}), SurfaceSvg({j, b}, points, {3}, {}));
}

// ---- ticks ------------------------------------------------------------------------------

std::vector<std::string> Labels(const std::vector<internal::Tick>& ticks, bool major_only) {
  std::vector<std::string> labels;
  for (const auto& t : ticks) {
    if (!major_only || t.major) labels.push_back(t.label);
  }
  return labels;
}

TEST(PlotTicks, NiceLinearTicksUseOneTwoFiveSteps) {
  using internal::NiceLinearTicks;
  EXPECT_EQ(NiceLinearTicks(0, 1, 5), (std::vector<double>{0, 0.2, 0.4, 0.6, 0.8, 1.0}));
  EXPECT_EQ(NiceLinearTicks(0, 10, 5), (std::vector<double>{0, 2, 4, 6, 8, 10}));
  EXPECT_EQ(NiceLinearTicks(-1, 1, 4), (std::vector<double>{-1, -0.5, 0, 0.5, 1}));
  EXPECT_EQ(NiceLinearTicks(-3.7, 12.2, 6), (std::vector<double>{-2, 0, 2, 4, 6, 8, 10, 12}));
  // Exact decimals: 3 * 2e-4 is the double nearest 6e-4.
  EXPECT_EQ(NiceLinearTicks(1e-4, 1e-3, 5), (std::vector<double>{2e-4, 4e-4, 6e-4, 8e-4, 1e-3}));
  EXPECT_EQ(NiceLinearTicks(0.13, 0.47, 3), (std::vector<double>{0.2, 0.3, 0.4}));
  EXPECT_DOUBLE_EQ(internal::NiceStep(0, 30, 5), 5.0);
  EXPECT_DOUBLE_EQ(internal::NiceStep(0, 37, 5), 10.0);
  EXPECT_DOUBLE_EQ(internal::NiceStep(0, 0.9, 5), 0.2);
}

TEST(PlotTicks, LinearLabelsAreCompactAndConsistent) {
  EXPECT_EQ(Labels(internal::LinearAxisTicks(0, 1, 5), false),
            (std::vector<std::string>{"0", "0.2", "0.4", "0.6", "0.8", "1"}));
  EXPECT_EQ(Labels(internal::LinearAxisTicks(0, 0.004, 4), false),
            (std::vector<std::string>{"0", "1e-3", "2e-3", "3e-3", "4e-3"}));
  EXPECT_EQ(Labels(internal::LinearAxisTicks(0, 50000, 5), false),
            (std::vector<std::string>{"0", "1e4", "2e4", "3e4", "4e4", "5e4"}));
  EXPECT_EQ(Labels(internal::LinearAxisTicks(1.0012, 1.0018, 3), false),
            (std::vector<std::string>{"1.0012", "1.0014", "1.0016", "1.0018"}));
  EXPECT_EQ(Labels(internal::LinearAxisTicks(0.0012, 0.0015, 3), false),
            (std::vector<std::string>{"1.2e-3", "1.3e-3", "1.4e-3", "1.5e-3"}));
}

TEST(PlotTicks, LogTicksAreDecadesWithTwoAndFiveSubTicks) {
  const auto wide = internal::LogAxisTicks(1e-4, 1e-1, 6);
  EXPECT_EQ(Labels(wide, true), (std::vector<std::string>{"1e-4", "1e-3", "0.01", "0.1"}));
  EXPECT_EQ(wide.size(), 4u + 6u) << "2x and 5x sub-ticks in each of the 3 decades";
  for (const auto& t : wide) {
    if (!t.major) {
      EXPECT_EQ(t.label, "") << t.value << ": 3 decades leave no room for minors";
    }
  }
  // Two decades: the sub-ticks are labelled too.
  EXPECT_EQ(Labels(internal::LogAxisTicks(1e-3, 1e-1, 6), false),
            (std::vector<std::string>{"1e-3", "2e-3", "5e-3", "0.01", "0.02", "0.05", "0.1"}));
  // Many decades: every second decade labelled.
  EXPECT_EQ(Labels(internal::LogAxisTicks(1e-10, 1, 6), true),
            (std::vector<std::string>{"1e-10", "1e-8", "1e-6", "1e-4", "0.01", "1"}));
  // Under two decades: 1-2-5 values when three fit, else 1..9 x 10^k, else linear ticks.
  EXPECT_EQ(Labels(internal::LogAxisTicks(3e-4, 5e-3, 6), false),
            (std::vector<std::string>{"5e-4", "1e-3", "2e-3", "5e-3"}));
  EXPECT_EQ(Labels(internal::LogAxisTicks(2e-4, 8e-4, 6), false),
            (std::vector<std::string>{"2e-4", "3e-4", "4e-4", "5e-4", "6e-4", "7e-4", "8e-4"}));
  EXPECT_EQ(Labels(internal::LogAxisTicks(5.5e-4, 2.6e-3, 6), false),
            (std::vector<std::string>{"6e-4", "7e-4", "8e-4", "9e-4", "1e-3", "2e-3"}));
  EXPECT_EQ(Labels(internal::LogAxisTicks(5.5e-4, 2.6e-3, 6), true),
            (std::vector<std::string>{"1e-3", "2e-3"}));
  EXPECT_EQ(Labels(internal::LogAxisTicks(1.1, 1.5, 4), false),
            (std::vector<std::string>{"1.1", "1.2", "1.3", "1.4", "1.5"}))
      << "linear ticks inside a factor of 1.4";
}

TEST(PlotTicks, FormatValueIsCompact) {
  using internal::FormatValue;
  EXPECT_EQ(FormatValue(0.0012), "1.2e-3");
  EXPECT_EQ(FormatValue(0.5), "0.5");
  EXPECT_EQ(FormatValue(-0.25), "-0.25");
  EXPECT_EQ(FormatValue(1e-4), "1e-4");
  EXPECT_EQ(FormatValue(25000), "2.5e4");
  EXPECT_EQ(FormatValue(100), "100");
  EXPECT_EQ(FormatValue(0.0), "0");
  EXPECT_EQ(FormatValue(9999.7), "1e4");
  EXPECT_EQ(FormatValue(1.23456e-7, 4), "1.235e-7");
  EXPECT_EQ(FormatValue(kNaN), "-");
  EXPECT_EQ(FormatValue(kInf), "-");
}

// ---- line plots and decimation ----------------------------------------------------------

TEST(PlotDecimation, KeepsTheSpikeOfAMillionSamples) {
  const std::size_t n = 1'000'000, spike = 654'321;
  std::vector<double> x(n), y(n);
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = static_cast<double>(i);
    y[i] = 0.1 * std::sin(static_cast<double>(i) * 1e-3);
  }
  y[spike] = 10.0;
  const auto kept =
      internal::DecimateMinMax(x, y, [](double v) { return v / static_cast<double>(n) * 600; });
  EXPECT_LE(kept.size(), 5u * 601u);
  EXPECT_GE(kept.size(), 2u * 600u);
  EXPECT_NE(std::find(kept.begin(), kept.end(), spike), kept.end());
  EXPECT_TRUE(std::is_sorted(kept.begin(), kept.end()));

  LinePlotOptions options;
  options.title = "one spike in a million";
  options.x_label = "t";
  options.x_unit = "s";
  options.y_label = "i";
  options.y_unit = "A";
  options.y_min = -1.0;
  options.y_max = 10.0;
  Series series;
  series.label = "current";
  series.x = x;
  series.y = y;
  const std::string svg = LinePlotSvg(options, {series});
  ExpectWellFormed(svg);
  EXPECT_LT(svg.size(), 2'000'000u);
  EXPECT_LT(svg.size(), 200'000u) << "bounded by the plot width";
  // The highest drawn point is the spike, at the top edge of the plot area (y = 10).
  const std::string area = ElementWithClass(svg, "plot-area");
  const double top = Attribute(area, "y");
  const auto start = svg.find("d=\"", svg.find("class=\"curve\"")) + 3;
  const std::string d = svg.substr(start, svg.find('"', start) - start);
  double highest = kInf;
  const std::regex pair("([-0-9.]+),([-0-9.]+)");
  for (std::sregex_iterator it(d.begin(), d.end(), pair), end; it != end; ++it) {
    highest = std::min(highest, std::stod((*it)[2]));
  }
  EXPECT_NEAR(highest, top, 0.06);
}

TEST(PlotDecimation, NonFiniteSamplesBreakTheLineAndUnsortedXIsKept) {
  std::vector<double> x = {0, 1, 2, 3, 4, 5}, y = {1, 2, kNaN, 4, 5, 6};
  // Everything in one column: first, min, max, last and the first break.
  EXPECT_EQ(internal::DecimateMinMax(x, y, [](double) { return 0.0; }),
            (std::vector<std::size_t>{0, 2, 5}));
  std::vector<double> unsorted = {0, 2, 1, 3};
  EXPECT_EQ(internal::DecimateMinMax(unsorted, {1, 2, 3, 4}, [](double) { return 0.0; }).size(),
            4u);
}

TEST(PlotLineSvg, SeriesLegendAxesAndNoNonFiniteText) {
  LinePlotOptions options;
  options.title = "measured and simulated";
  options.x_label = "time";
  options.x_unit = "s";
  options.y_label = "speed";
  options.y_unit = "rad/s";
  Series measured, simulated;
  measured.label = "measured";
  simulated.label = "simulated";
  simulated.dash = "6 3";
  for (int k = 0; k < 200; ++k) {
    measured.x.push_back(k * 1e-3);
    simulated.x.push_back(k * 1e-3);
    measured.y.push_back(std::sin(k * 0.05));
    simulated.y.push_back(std::sin(k * 0.05 + 0.1));
  }
  measured.y[50] = kNaN;
  simulated.y[60] = kInf;
  const std::string svg = LinePlotSvg(options, {measured, simulated});
  ExpectWellFormed(svg);
  ExpectNoNonFiniteText(svg);
  EXPECT_EQ(Count(svg, "class=\"curve\""), 2u);
  EXPECT_NE(svg.find(">measured<"), std::string::npos);
  EXPECT_NE(svg.find(">simulated<"), std::string::npos);
  EXPECT_NE(svg.find("time (s)"), std::string::npos);
  EXPECT_NE(svg.find("speed (rad/s)"), std::string::npos);
  EXPECT_NE(svg.find("stroke-dasharray=\"6 3\""), std::string::npos);
  EXPECT_EQ(Count(svg, " M"), 2u) << "each series broken once by its non-finite sample";

  // No data at all, and log axes with non-positive values: still well-formed.
  EXPECT_TRUE(TagsBalanced(LinePlotSvg({}, {})));
  LinePlotOptions log_options;
  log_options.x_log = log_options.y_log = true;
  Series s;
  s.x = {-1, 0, 1, 10, 100};
  s.y = {1, 1, 0, 1e-3, 1e-6};
  const std::string log_svg = LinePlotSvg(log_options, {s});
  ExpectWellFormed(log_svg);
  ExpectNoNonFiniteText(log_svg);
}

}  // namespace
}  // namespace blmd
