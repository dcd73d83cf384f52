// The cost surface as SVG (docs/plots.md): a heat map with contours for two axes, a cost curve
// for one.
#include "blmd/report/svg/plot.h"
#include "report/svg/svg_parts.h"

namespace blmd {

using namespace svg_detail;  // NOLINT(google-build-using-namespace): the plots' own parts

namespace {

// ---- surfaces --------------------------------------------------------------------------

// The surface on its grid: costs per grid index (row-major), the point behind each index.
struct SurfaceGrid {
  std::vector<double> cost;              // NaN where no point
  std::vector<std::size_t> point_of;     // index into points, or npos
  std::vector<std::size_t> grid_of;      // grid index of points[k], or npos
  std::vector<double> log_cost;          // log10(cost) where finite (0 clamped), NaN otherwise
  double log_low = 0.0, log_high = 1.0;  // range of log_cost
  bool any_finite = false, any_missing = false;
  std::size_t best = std::numeric_limits<std::size_t>::max();  // grid index of the minimum
};

constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();

double AxisT(const GridAxis& axis, double v) { return axis.log_scale ? std::log10(v) : v; }

SurfaceGrid BuildGrid(const std::vector<GridAxis>& axes, const std::vector<SurfacePoint>& points) {
  SurfaceGrid grid;
  std::size_t total = 1;
  for (const auto& axis : axes) total *= static_cast<std::size_t>(axis.count);
  grid.cost.assign(total, std::numeric_limits<double>::quiet_NaN());
  grid.point_of.assign(total, kNone);
  grid.grid_of.assign(points.size(), kNone);
  for (std::size_t k = 0; k < points.size(); ++k) {
    std::size_t index = k;
    if (points.size() != total) {  // a shard: place by coordinates
      if (points[k].coordinates.size() != axes.size()) continue;
      index = 0;
      for (std::size_t a = 0; a < axes.size(); ++a) {
        const GridAxis& axis = axes[a];
        const double v = points[k].coordinates[a];
        double f = 0.0;
        if (axis.count > 1 && std::isfinite(v) && (!axis.log_scale || v > 0)) {
          f = (AxisT(axis, v) - AxisT(axis, axis.low)) /
              (AxisT(axis, axis.high) - AxisT(axis, axis.low)) * (axis.count - 1);
        }
        const long position = std::clamp(std::lround(std::isfinite(f) ? f : 0.0), 0L,
                                         static_cast<long>(axis.count - 1));
        index = index * static_cast<std::size_t>(axis.count) + static_cast<std::size_t>(position);
      }
    }
    grid.grid_of[k] = index;
    grid.point_of[index] = k;
    grid.cost[index] = points[k].evaluation.cost;
  }
  double smallest_positive = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < total; ++i) {
    const double c = grid.cost[i];
    if (!std::isfinite(c)) {
      grid.any_missing = true;
      continue;
    }
    grid.any_finite = true;
    if (c > 0) smallest_positive = std::min(smallest_positive, c);
    if (grid.best == kNone || c < grid.cost[grid.best]) grid.best = i;
  }
  // Costs are >= 0; zero (an exact fit) is drawn at the smallest positive cost.
  const double floor = std::isfinite(smallest_positive) ? smallest_positive : 1.0;
  grid.log_cost.assign(total, std::numeric_limits<double>::quiet_NaN());
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (std::size_t i = 0; i < total; ++i) {
    if (!std::isfinite(grid.cost[i])) continue;
    grid.log_cost[i] = std::log10(std::max(grid.cost[i], floor));
    lo = std::min(lo, grid.log_cost[i]);
    hi = std::max(hi, grid.log_cost[i]);
  }
  if (grid.any_finite) {
    grid.log_low = lo;
    grid.log_high = hi;
    if (!(hi - lo > 1e-12)) {
      grid.log_low -= 0.5;
      grid.log_high += 0.5;
    }
  }
  return grid;
}

// Cell boundaries of an axis in transformed coordinates: half-way between grid values,
// half a spacing beyond the ends (half a decade or 10 % around a single value).
std::vector<double> CellEdges(const GridAxis& axis) {
  std::vector<double> centre(static_cast<std::size_t>(axis.count));
  for (int k = 0; k < axis.count; ++k)
    centre[static_cast<std::size_t>(k)] = AxisT(axis, axis.Value(k));
  std::vector<double> edges(centre.size() + 1);
  if (centre.size() == 1) {
    double low = axis.Value(0), high = low;
    Widen(low, high, axis.log_scale);
    edges[0] = AxisT(axis, low);
    edges[1] = AxisT(axis, high);
    return edges;
  }
  for (std::size_t k = 1; k < centre.size(); ++k) edges[k] = (centre[k - 1] + centre[k]) / 2;
  edges.front() = centre[0] - (centre[1] - centre[0]) / 2;
  edges.back() = centre.back() + (centre.back() - centre[centre.size() - 2]) / 2;
  return edges;
}

double Untransform(const GridAxis& axis, double t) {
  return axis.log_scale ? std::pow(10.0, t) : t;
}

std::string Unit(const SurfacePlotOptions& options, std::size_t axis) {
  return axis < options.units.size() ? options.units[axis] : std::string();
}

std::string CoordinateText(const GridAxis& axis, const std::string& unit, double value) {
  return axis.name + " = " + FormatValue(value, 4) + (unit.empty() ? "" : " " + unit);
}

// Marching squares on one level: polylines in pixel coordinates. Nodes at (cx[i], cy[j]),
// values v[i * ny + j]; squares with a non-finite corner are skipped. Saddles are resolved by
// the mean of the four corners.
std::vector<std::vector<std::pair<double, double>>> ContourLines(const std::vector<double>& v,
                                                                 const std::vector<double>& cx,
                                                                 const std::vector<double>& cy,
                                                                 double level) {
  const std::size_t nx = cx.size(), ny = cy.size();
  auto at = [&](std::size_t i, std::size_t j) { return v[i * ny + j]; };
  // Edge keys: horizontal edge (i,j)-(i+1,j) is 2*(i*ny+j), vertical (i,j)-(i,j+1) is +1.
  auto h_key = [&](std::size_t i, std::size_t j) { return 2 * (i * ny + j); };
  auto v_key = [&](std::size_t i, std::size_t j) { return 2 * (i * ny + j) + 1; };
  auto point_on = [&](std::size_t key) {
    const std::size_t node = key / 2, i = node / ny, j = node % ny;
    const bool vertical = key % 2 == 1;
    const std::size_t i2 = vertical ? i : i + 1, j2 = vertical ? j + 1 : j;
    const double a = at(i, j), b = at(i2, j2);
    const double t = b != a ? std::clamp((level - a) / (b - a), 0.0, 1.0) : 0.5;
    return std::make_pair(cx[i] + t * (cx[i2] - cx[i]), cy[j] + t * (cy[j2] - cy[j]));
  };
  std::vector<std::pair<std::size_t, std::size_t>> segments;
  for (std::size_t i = 0; i + 1 < nx; ++i) {
    for (std::size_t j = 0; j + 1 < ny; ++j) {
      const double c[4] = {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)};
      if (!std::isfinite(c[0]) || !std::isfinite(c[1]) || !std::isfinite(c[2]) ||
          !std::isfinite(c[3])) {
        continue;
      }
      const bool above[4] = {c[0] > level, c[1] > level, c[2] > level, c[3] > level};
      // Edges in order: bottom (c0-c1), right (c1-c2), top (c3-c2), left (c0-c3).
      const std::size_t edge[4] = {h_key(i, j), v_key(i + 1, j), h_key(i, j + 1), v_key(i, j)};
      const bool crossed[4] = {above[0] != above[1], above[1] != above[2], above[3] != above[2],
                               above[0] != above[3]};
      std::size_t found[4], count = 0;
      for (std::size_t e = 0; e < 4; ++e) {
        if (crossed[e]) found[count++] = e;
      }
      if (count == 2) {
        segments.emplace_back(edge[found[0]], edge[found[1]]);
      } else if (count == 4) {
        const bool centre_above = (c[0] + c[1] + c[2] + c[3]) / 4 > level;
        if (centre_above == above[0]) {  // c0 and c2 joined: cut off c1 and c3
          segments.emplace_back(edge[0], edge[1]);
          segments.emplace_back(edge[2], edge[3]);
        } else {  // cut off c0 and c2
          segments.emplace_back(edge[3], edge[0]);
          segments.emplace_back(edge[1], edge[2]);
        }
      }
    }
  }
  // Join segments sharing an edge point into polylines.
  std::unordered_map<std::size_t, std::vector<std::size_t>> by_edge;
  for (std::size_t s = 0; s < segments.size(); ++s) {
    by_edge[segments[s].first].push_back(s);
    by_edge[segments[s].second].push_back(s);
  }
  std::vector<bool> used(segments.size(), false);
  auto next_from = [&](std::size_t key) -> std::size_t {
    for (std::size_t s : by_edge[key]) {
      if (!used[s]) return s;
    }
    return kNone;
  };
  std::vector<std::vector<std::pair<double, double>>> lines;
  for (std::size_t s = 0; s < segments.size(); ++s) {
    if (used[s]) continue;
    used[s] = true;
    std::vector<std::size_t> keys = {segments[s].first, segments[s].second};
    for (int direction = 0; direction < 2; ++direction) {
      while (true) {
        const std::size_t end = keys.back();
        const std::size_t t = next_from(end);
        if (t == kNone) break;
        used[t] = true;
        keys.push_back(segments[t].first == end ? segments[t].second : segments[t].first);
      }
      std::reverse(keys.begin(), keys.end());
    }
    std::vector<std::pair<double, double>> line;
    line.reserve(keys.size());
    for (std::size_t key : keys) line.push_back(point_on(key));
    lines.push_back(std::move(line));
  }
  return lines;
}

std::string SurfacePrefix(const std::vector<GridAxis>& axes,
                          const std::vector<SurfacePoint>& points,
                          const SurfacePlotOptions& options) {
  if (!options.id_prefix.empty()) return options.id_prefix;
  Fingerprint fingerprint;
  fingerprint.Add(options.title);
  for (const auto& axis : axes) fingerprint.Add(axis.Spec());
  for (const auto& point : points) fingerprint.Add(point.evaluation.cost);
  return fingerprint.Id();
}

// Whether some local minimum is not hidden under the grid-minimum star (for the legend).
bool AnyLocalMinimumBesidesBest(const std::vector<std::size_t>& minima, const SurfaceGrid& grid) {
  for (std::size_t m : minima) {
    if (m < grid.grid_of.size() && grid.grid_of[m] != kNone && grid.grid_of[m] != grid.best) {
      return true;
    }
  }
  return false;
}

// The legend entries of the minima: the grid minimum's star and, when one shows beside it, the
// local minima's ring (drawn for a dark background on the heat map).
void AddMinimaLegend(std::vector<LegendItem>& legend, const std::vector<std::size_t>& minima,
                     const SurfaceGrid& grid, bool on_dark) {
  if (grid.best != kNone) legend.push_back({StarShape(0, 0, 7), "grid minimum"});
  if (AnyLocalMinimumBesidesBest(minima, grid)) {
    legend.push_back({RingShape(0, 0, 5, on_dark), "local minima"});
  }
}

void AddMissingCostLegend(std::vector<LegendItem>& legend, const SurfaceGrid& grid,
                          const std::string& hatch_id) {
  if (grid.any_missing)
    legend.push_back({HatchSwatch(hatch_id), "no finite cost (simulation failed)"});
}

// A surface plot's frame and ticks. Top: below the title; bottom: above the x tick labels, the
// x axis title and the legend rows; left: right of the y axis title and tick labels.
struct SurfaceLayout {
  PlotFrame frame;
  std::vector<Tick> x_ticks, y_ticks, c_ticks;  // c_ticks: the colour bar's (2-D only)
};

double SurfaceTop(const SurfacePlotOptions& options) { return options.title.empty() ? 18 : 42; }

double SurfaceBottom(int H, int legend_rows) {
  return H - (5 + 3 + kTickFont + 10 + kLabelFont + 10 + 16.0 * legend_rows + 4);
}

double SurfaceLeft(const std::vector<Tick>& y_ticks) {
  return 10 + kLabelFont + 8 + WidestLabel(y_ticks) + 8;
}

// ---- 2-D: heat map ---------------------------------------------------------------------

constexpr double kColourBarGap = 18, kColourBarWidth = 14;  // px right of the frame; px wide

// Contour levels: nice values of log10(cost) strictly inside the range; `step` their spacing
// (0 when there are none to draw).
std::vector<double> ContourLevels(const SurfaceGrid& grid, int contour_levels, std::size_t nx,
                                  std::size_t ny, double* step) {
  std::vector<double> levels;
  *step = 0.0;
  if (contour_levels > 0 && grid.any_finite && nx > 1 && ny > 1) {
    *step = internal::NiceStep(grid.log_low, grid.log_high, contour_levels);
    for (double level : internal::NiceLinearTicks(grid.log_low, grid.log_high, contour_levels)) {
      const double margin = 1e-9 * (grid.log_high - grid.log_low);
      if (level > grid.log_low + margin && level < grid.log_high - margin) levels.push_back(level);
    }
  }
  return levels;
}

std::vector<LegendItem> HeatMapLegend(const std::vector<std::size_t>& minima,
                                      const SurfaceGrid& grid, const std::vector<double>& levels,
                                      double level_step, const std::string& hatch_id) {
  std::vector<LegendItem> legend;
  AddMinimaLegend(legend, minima, grid, true);
  if (!levels.empty()) {
    legend.push_back(
        {"<line x1=\"-11\" y1=\"0\" x2=\"11\" y2=\"0\" stroke=\"#333333\" "
         "stroke-width=\"1.2\"/>",
         "contours every " + FormatValue(level_step) + " in log10(cost)"});
  }
  AddMissingCostLegend(legend, grid, hatch_id);
  return legend;
}

// The frame leaves room on the right for the colour bar, its tick labels and its title.
SurfaceLayout HeatMapLayout(const SurfacePlotOptions& options, const Scale& xs, const Scale& ys,
                            const Scale& cs, int legend_rows, int W, int H) {
  SurfaceLayout layout;
  PlotFrame& frame = layout.frame;
  frame.top = SurfaceTop(options);
  frame.bottom = SurfaceBottom(H, legend_rows);
  layout.x_ticks = AxisTicks(xs.low, xs.high, xs.log, W * 0.6, 85);
  layout.y_ticks = AxisTicks(ys.low, ys.high, ys.log, frame.bottom - frame.top, 42);
  layout.c_ticks = AxisTicks(cs.low, cs.high, true, frame.bottom - frame.top, 42);
  frame.left = SurfaceLeft(layout.y_ticks);
  frame.right = W - (kColourBarGap + kColourBarWidth + 8 + WidestLabel(layout.c_ticks) + 10 +
                     kLabelFont + 10);
  return layout;
}

// The hatch pattern of cells without a cost and the colour bar's viridis gradient.
std::string HeatMapDefs(const std::string& hatch_id, const std::string& bar_id) {
  std::string out = "<defs>\n" + HatchPattern(hatch_id);
  out += "<linearGradient id=\"" + bar_id + "\" x1=\"0\" y1=\"1\" x2=\"0\" y2=\"0\">";
  for (int k = 0; k < 16; ++k) {
    out += "<stop offset=\"" + Num(k / 15.0, 4) + "\" stop-color=\"" + Hex(kViridis[k]) + "\"/>";
  }
  out += "</linearGradient>\n</defs>\n";
  return out;
}

// One rectangle per grid point, coloured by log10(cost), with a tooltip on grids of at most
// 2500 points.
void DrawHeatMapCells(std::string& out, const std::vector<GridAxis>& axes,
                      const SurfacePlotOptions& options, const SurfaceGrid& grid, const Scale& xs,
                      const Scale& ys, const std::string& hatch_id) {
  const GridAxis &ax = axes[0], &ay = axes[1];
  const std::size_t nx = static_cast<std::size_t>(ax.count),
                    ny = static_cast<std::size_t>(ay.count);
  const std::vector<double> edges_x = CellEdges(ax), edges_y = CellEdges(ay);
  const bool tooltips = nx * ny <= 2500;
  std::vector<double> px(nx + 1), py(ny + 1);
  for (std::size_t i = 0; i <= nx; ++i) px[i] = xs.FromT(edges_x[i]);
  for (std::size_t j = 0; j <= ny; ++j) py[j] = ys.FromT(edges_y[j]);
  const double span = grid.log_high - grid.log_low;
  out += "<g class=\"heatmap\" shape-rendering=\"crispEdges\">\n";
  for (std::size_t i = 0; i < nx; ++i) {
    for (std::size_t j = 0; j < ny; ++j) {
      const std::size_t k = i * ny + j;
      const double l = grid.log_cost[k];
      const std::string fill =
          std::isfinite(l) ? Viridis((l - grid.log_low) / span) : "url(#" + hatch_id + ")";
      out += "<rect class=\"cell\" x=\"" + Num(px[i]) + "\" y=\"" + Num(py[j + 1]) + "\" width=\"" +
             Num(px[i + 1] - px[i]) + "\" height=\"" + Num(py[j] - py[j + 1]) + "\" fill=\"" +
             fill + "\"";
      if (tooltips) {
        out +=
            "><title>" +
            Escape(CoordinateText(ax, Unit(options, 0), ax.Value(static_cast<int>(i))) + ", " +
                   CoordinateText(ay, Unit(options, 1), ay.Value(static_cast<int>(j))) + ": cost " +
                   (std::isfinite(grid.cost[k]) ? FormatValue(grid.cost[k], 4) : "none")) +
            "</title></rect>\n";
      } else {
        out += "/>\n";
      }
    }
  }
  out += "</g>\n";
}

// The contour lines through the grid points' centres (cx, cy in pixels).
void DrawContours(std::string& out, const SurfaceGrid& grid, const std::vector<double>& levels,
                  const std::vector<double>& cx, const std::vector<double>& cy) {
  if (levels.empty()) return;
  const double span = grid.log_high - grid.log_low;
  out += "<g class=\"contours\" fill=\"none\" stroke-width=\"1\" stroke-linejoin=\"round\">\n";
  for (double level : levels) {
    const auto lines = ContourLines(grid.log_cost, cx, cy, level);
    if (lines.empty()) continue;
    // Light lines over the dark (low) part of viridis, dark lines over the light part.
    const bool light = (level - grid.log_low) / span < 0.6;
    std::string d;
    for (const auto& line : lines) {
      for (std::size_t p = 0; p < line.size(); ++p) {
        d += (p == 0 ? (d.empty() ? "M" : " M") : " ") + Num(line[p].first, 1) + "," +
             Num(line[p].second, 1);
      }
    }
    out += "<path class=\"contour\" data-level=\"" + Exact(level) + "\" stroke=\"" +
           (light ? "#ffffff\" stroke-opacity=\"0.7" : "#1a1a1a\" stroke-opacity=\"0.55") +
           "\" d=\"" + d + "\"><title>cost " + Escape(FormatValue(std::pow(10.0, level))) +
           "</title></path>\n";
  }
  out += "</g>\n";
}

// The colour bar right of the frame, with its ticks (log scale), the contour levels marked and
// its title.
void DrawColourBar(std::string& out, const SurfacePlotOptions& options, const SurfaceGrid& grid,
                   const std::vector<double>& levels, const SurfaceLayout& layout,
                   const std::string& bar_id) {
  const PlotFrame& frame = layout.frame;
  const double top = frame.top, bottom = frame.bottom;
  const double bar_x = frame.right + kColourBarGap, bar_width = kColourBarWidth;
  const double span = grid.log_high - grid.log_low;
  Scale cs{std::pow(10.0, grid.log_low), std::pow(10.0, grid.log_high), true};
  cs.p0 = bottom;
  cs.p1 = top;
  out += "<g class=\"colour-bar\">\n<rect x=\"" + Num(bar_x) + "\" y=\"" + Num(top) +
         "\" width=\"" + Num(bar_width) + "\" height=\"" + Num(bottom - top) + "\" fill=\"url(#" +
         bar_id + ")\" stroke=\"" + kFrameColour + "\" stroke-width=\"1\"/>\n";
  for (double level : levels) {
    const double y = cs.FromT(level);
    const bool light = (level - grid.log_low) / span < 0.6;
    out += "<line x1=\"" + Num(bar_x) + "\" y1=\"" + Num(y) + "\" x2=\"" + Num(bar_x + bar_width) +
           "\" y2=\"" + Num(y) + "\" stroke=\"" + (light ? "#ffffff" : "#1a1a1a") +
           "\" stroke-opacity=\"0.8\"/>\n";
  }
  DrawAxis(out, Side::kRight, cs, layout.c_ticks, bar_x + bar_width);
  TextStyle style = AxisTitleStyle();
  style.rotate = -90;
  Text(out, bar_x + bar_width + 8 + WidestLabel(layout.c_ticks) + 10 + kLabelFont - 2,
       (top + bottom) / 2, options.value_label + ", log scale", style);
  out += "</g>\n";
}

// Local minima, then the global minimum with its label on top (cx, cy: the pixels of the grid
// values).
void DrawHeatMapMinima(std::string& out, const std::vector<GridAxis>& axes,
                       const std::vector<SurfacePoint>& points,
                       const std::vector<std::size_t>& minima, const SurfacePlotOptions& options,
                       const SurfaceGrid& grid, const std::vector<double>& cx,
                       const std::vector<double>& cy, const PlotFrame& frame) {
  const GridAxis &ax = axes[0], &ay = axes[1];
  const std::size_t ny = static_cast<std::size_t>(ay.count);
  std::vector<std::pair<double, double>> marker_positions;
  out += "<g class=\"minima\">\n";
  for (std::size_t m : minima) {
    if (m >= grid.grid_of.size() || grid.grid_of[m] == kNone) continue;
    const std::size_t g = grid.grid_of[m];
    marker_positions.emplace_back(cx[g / ny], cy[g % ny]);
    out += "<g class=\"local-min\" data-index=\"" + std::to_string(m) + "\">" +
           RingShape(cx[g / ny], cy[g % ny], 6, true) + "</g>\n";
  }
  if (grid.best != kNone) {
    const std::size_t i = grid.best / ny, j = grid.best % ny, p = grid.point_of[grid.best];
    const double vx = points[p].coordinates.size() == 2 ? points[p].coordinates[0]
                                                        : ax.Value(static_cast<int>(i));
    const double vy = points[p].coordinates.size() == 2 ? points[p].coordinates[1]
                                                        : ay.Value(static_cast<int>(j));
    out += "<g class=\"global-min\" data-index=\"" + std::to_string(p) + "\" data-x=\"" +
           Exact(vx) + "\" data-y=\"" + Exact(vy) + "\" data-cost=\"" +
           Exact(grid.cost[grid.best]) + "\">" + StarShape(cx[i], cy[j], 9) + "</g>\n";
    std::vector<std::string> lines = {"grid minimum: cost " + FormatValue(grid.cost[grid.best], 4)};
    const std::string a = CoordinateText(ax, Unit(options, 0), vx);
    const std::string b = CoordinateText(ay, Unit(options, 1), vy);
    if (TextWidth(a + ", " + b, kTickFont) < 0.5 * (frame.right - frame.left)) {
      lines.push_back(a + ", " + b);
    } else {
      lines.push_back(a);
      lines.push_back(b);
    }
    LabelBox(out, cx[i], cy[j], lines, frame.left, frame.top, frame.right, frame.bottom,
             marker_positions);
  }
  out += "</g>\n";
}

std::string Surface2D(const std::vector<GridAxis>& axes, const std::vector<SurfacePoint>& points,
                      const std::vector<std::size_t>& minima, const SurfacePlotOptions& options,
                      const SurfaceGrid& grid, int W, int H) {
  const GridAxis &ax = axes[0], &ay = axes[1];
  const std::size_t nx = static_cast<std::size_t>(ax.count),
                    ny = static_cast<std::size_t>(ay.count);
  const std::string prefix = SurfacePrefix(axes, points, options);
  const std::string hatch_id = prefix + "-hatch", bar_id = prefix + "-bar";
  const std::vector<double> edges_x = CellEdges(ax), edges_y = CellEdges(ay);

  Scale xs{Untransform(ax, edges_x.front()), Untransform(ax, edges_x.back()), ax.log_scale};
  Scale ys{Untransform(ay, edges_y.front()), Untransform(ay, edges_y.back()), ay.log_scale};
  const Scale cs{std::pow(10.0, grid.log_low), std::pow(10.0, grid.log_high), true};

  double level_step = 0.0;
  const std::vector<double> levels =
      ContourLevels(grid, options.contour_levels, nx, ny, &level_step);
  // Legend entries decide the bottom margin.
  const std::vector<LegendItem> legend = HeatMapLegend(minima, grid, levels, level_step, hatch_id);
  const int legend_rows = LegendRows(legend, W - 20.0);
  const SurfaceLayout layout = HeatMapLayout(options, xs, ys, cs, legend_rows, W, H);
  const PlotFrame& frame = layout.frame;
  PlaceScales(frame, xs, ys);

  std::string out = Header(W, H);
  out += HeatMapDefs(hatch_id, bar_id);
  Title(out, W, options.title);
  DrawHeatMapCells(out, axes, options, grid, xs, ys, hatch_id);
  std::vector<double> cx(nx), cy(ny);
  for (std::size_t i = 0; i < nx; ++i) cx[i] = xs(ax.Value(static_cast<int>(i)));
  for (std::size_t j = 0; j < ny; ++j) cy[j] = ys(ay.Value(static_cast<int>(j)));
  DrawContours(out, grid, levels, cx, cy);

  out += FrameRect(frame.left, frame.top, frame.right, frame.bottom);
  DrawAxis(out, Side::kBottom, xs, layout.x_ticks, frame.bottom);
  DrawAxis(out, Side::kLeft, ys, layout.y_ticks, frame.left);
  XAxisTitle(out, frame, 10, AxisTitle(ax.name, Unit(options, 0)));
  YAxisTitle(out, frame, AxisTitle(ay.name, Unit(options, 1)));
  DrawColourBar(out, options, grid, levels, layout, bar_id);
  DrawHeatMapMinima(out, axes, points, minima, options, grid, cx, cy, frame);
  DrawLegend(out, legend, W / 2.0, H - 16.0 * legend_rows + 6, W - 20.0);
  return out + "</svg>\n";
}

// ---- 1-D: cost curve -------------------------------------------------------------------

std::vector<LegendItem> CostCurveLegend(const SurfacePlotOptions& options,
                                        const std::vector<std::size_t>& minima,
                                        const SurfaceGrid& grid, const std::string& hatch_id) {
  std::vector<LegendItem> legend;
  legend.push_back({"<line x1=\"-11\" y1=\"0\" x2=\"11\" y2=\"0\" stroke=\"" +
                        std::string(kCurveColour) + "\" stroke-width=\"1.8\"/>",
                    options.value_label});
  AddMinimaLegend(legend, minima, grid, false);
  AddMissingCostLegend(legend, grid, hatch_id);
  return legend;
}

SurfaceLayout CostCurveLayout(const SurfacePlotOptions& options, const Scale& xs, const Scale& ys,
                              int legend_rows, int W, int H) {
  SurfaceLayout layout;
  PlotFrame& frame = layout.frame;
  frame.top = SurfaceTop(options);
  frame.bottom = SurfaceBottom(H, legend_rows);
  layout.x_ticks = AxisTicks(xs.low, xs.high, xs.log, W * 0.7, 85);
  layout.y_ticks = AxisTicks(ys.low, ys.high, true, frame.bottom - frame.top, 40);
  frame.left = SurfaceLeft(layout.y_ticks);
  frame.right = W - 24.0;
  return layout;
}

// Gaps: hatched bands over the cells of non-finite points.
void DrawCostGaps(std::string& out, const SurfaceGrid& grid, const std::vector<double>& edges,
                  const Scale& xs, const PlotFrame& frame, const std::string& hatch_id) {
  out += "<g class=\"gaps\" fill=\"url(#" + hatch_id + ")\" fill-opacity=\"0.6\">\n";
  for (std::size_t i = 0; i + 1 < edges.size(); ++i) {
    if (std::isfinite(grid.log_cost[i])) continue;
    const double a = std::max(frame.left, xs.FromT(edges[i])),
                 b = std::min(frame.right, xs.FromT(edges[i + 1]));
    out += "<rect class=\"gap\" x=\"" + Num(a) + "\" y=\"" + Num(frame.top) + "\" width=\"" +
           Num(std::max(0.5, b - a)) + "\" height=\"" + Num(frame.bottom - frame.top) + "\"/>\n";
  }
  out += "</g>\n";
}

// The curve through the finite points (cx, cy in pixels), broken at the others, and dots.
void DrawCostCurve(std::string& out, const SurfaceGrid& grid, const std::vector<double>& cx,
                   const std::vector<double>& cy) {
  const std::size_t n = cx.size();
  std::string d;
  bool pen_down = false;
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(grid.log_cost[i])) {
      pen_down = false;
      continue;
    }
    d += (pen_down ? " " : (d.empty() ? "M" : " M")) + Num(cx[i], 1) + "," + Num(cy[i], 1);
    pen_down = true;
  }
  if (!d.empty()) {
    out += "<path class=\"curve\" d=\"" + d + "\" fill=\"none\" stroke=\"" + kCurveColour +
           "\" stroke-width=\"1.8\" stroke-linejoin=\"round\"/>\n";
  }
  // Single isolated points are invisible as a path: dots for every sample on short grids, and
  // always for points with no finite neighbour.
  out += "<g class=\"samples\" fill=\"" + std::string(kCurveColour) + "\">\n";
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(grid.log_cost[i])) continue;
    const bool isolated = (i == 0 || !std::isfinite(grid.log_cost[i - 1])) &&
                          (i + 1 == n || !std::isfinite(grid.log_cost[i + 1]));
    if (n <= 80 || isolated) {
      out += "<circle cx=\"" + Num(cx[i]) + "\" cy=\"" + Num(cy[i]) + "\" r=\"2.2\"/>\n";
    }
  }
  out += "</g>\n";
}

// Local minima, then the global minimum with its label.
void DrawCostCurveMinima(std::string& out, const GridAxis& ax,
                         const std::vector<SurfacePoint>& points,
                         const std::vector<std::size_t>& minima, const SurfacePlotOptions& options,
                         const SurfaceGrid& grid, const std::vector<double>& cx,
                         const std::vector<double>& cy, const PlotFrame& frame) {
  std::vector<std::pair<double, double>> marker_positions;
  out += "<g class=\"minima\">\n";
  for (std::size_t m : minima) {
    if (m >= grid.grid_of.size() || grid.grid_of[m] == kNone) continue;
    const std::size_t g = grid.grid_of[m];
    if (!std::isfinite(grid.log_cost[g])) continue;
    marker_positions.emplace_back(cx[g], cy[g]);
    out += "<g class=\"local-min\" data-index=\"" + std::to_string(m) + "\">" +
           RingShape(cx[g], cy[g], 6.5, false) + "</g>\n";
  }
  if (grid.best != kNone) {
    const std::size_t i = grid.best, p = grid.point_of[i];
    const double vx = points[p].coordinates.size() == 1 ? points[p].coordinates[0]
                                                        : ax.Value(static_cast<int>(i));
    out += "<g class=\"global-min\" data-index=\"" + std::to_string(p) + "\" data-x=\"" +
           Exact(vx) + "\" data-cost=\"" + Exact(grid.cost[i]) + "\">" +
           StarShape(cx[i], cy[i], 9) + "</g>\n";
    LabelBox(out, cx[i], cy[i],
             {"grid minimum: cost " + FormatValue(grid.cost[i], 4),
              CoordinateText(ax, Unit(options, 0), vx)},
             frame.left, frame.top, frame.right, frame.bottom, marker_positions);
  }
  out += "</g>\n";
}

std::string Surface1D(const std::vector<GridAxis>& axes, const std::vector<SurfacePoint>& points,
                      const std::vector<std::size_t>& minima, const SurfacePlotOptions& options,
                      const SurfaceGrid& grid, int W, int H) {
  const GridAxis& ax = axes[0];
  const std::size_t n = static_cast<std::size_t>(ax.count);
  const std::string prefix = SurfacePrefix(axes, points, options);
  const std::string hatch_id = prefix + "-hatch";
  const std::vector<double> edges = CellEdges(ax);

  // x: the grid range and 2 % more on each side (so end markers are whole).
  double x_lo = AxisT(ax, ax.Value(0)), x_hi = AxisT(ax, ax.Value(ax.count - 1));
  if (n == 1) {
    x_lo = edges.front();
    x_hi = edges.back();
  }
  const double x_pad = 0.02 * (x_hi - x_lo);
  Scale xs{Untransform(ax, x_lo - x_pad), Untransform(ax, x_hi + x_pad), ax.log_scale};
  const double y_pad = 0.06 * (grid.log_high - grid.log_low);
  Scale ys{std::pow(10.0, grid.log_low - y_pad), std::pow(10.0, grid.log_high + y_pad), true};

  const std::vector<LegendItem> legend = CostCurveLegend(options, minima, grid, hatch_id);
  const int legend_rows = LegendRows(legend, W - 20.0);
  const SurfaceLayout layout = CostCurveLayout(options, xs, ys, legend_rows, W, H);
  const PlotFrame& frame = layout.frame;
  PlaceScales(frame, xs, ys);

  std::string out = Header(W, H);
  out += "<defs>\n" + HatchPattern(hatch_id) + "</defs>\n";
  Title(out, W, options.title);
  DrawAxis(out, Side::kBottom, xs, layout.x_ticks, frame.bottom, frame.top, frame.bottom);
  DrawAxis(out, Side::kLeft, ys, layout.y_ticks, frame.left, frame.left, frame.right);

  std::vector<double> cx(n), cy(n);
  for (std::size_t i = 0; i < n; ++i) {
    cx[i] = xs(ax.Value(static_cast<int>(i)));
    cy[i] = std::isfinite(grid.log_cost[i]) ? ys.FromT(grid.log_cost[i]) : 0.0;
  }
  DrawCostGaps(out, grid, edges, xs, frame, hatch_id);
  DrawCostCurve(out, grid, cx, cy);
  out += FrameRect(frame.left, frame.top, frame.right, frame.bottom);
  XAxisTitle(out, frame, 10, AxisTitle(ax.name, Unit(options, 0)));
  YAxisTitle(out, frame, options.value_label + ", log scale");
  DrawCostCurveMinima(out, ax, points, minima, options, grid, cx, cy, frame);
  DrawLegend(out, legend, W / 2.0, H - 16.0 * legend_rows + 6, W - 20.0);
  return out + "</svg>\n";
}

}  // namespace

std::string SurfaceSvg(const std::vector<GridAxis>& axes, const std::vector<SurfacePoint>& points,
                       const std::vector<std::size_t>& minima, const SurfacePlotOptions& options) {
  const int W = std::max(240, options.width), H = std::max(180, options.height);
  if (axes.empty() || axes.size() > 2) {
    return MessageSvg(W, H, options.title,
                      "cannot draw a surface over " + std::to_string(axes.size()) + " axes");
  }
  std::size_t total = 1;
  for (const auto& axis : axes) {
    const bool valid = axis.count >= 1 && std::isfinite(axis.low) && std::isfinite(axis.high) &&
                       axis.low <= axis.high && (!axis.log_scale || axis.low > 0.0);
    if (!valid) return MessageSvg(W, H, options.title, "invalid grid axis " + axis.name);
    total *= static_cast<std::size_t>(axis.count);
  }
  if (total > 4'000'000) return MessageSvg(W, H, options.title, "grid too large to draw");
  const SurfaceGrid grid = BuildGrid(axes, points);
  return axes.size() == 1 ? Surface1D(axes, points, minima, options, grid, W, H)
                          : Surface2D(axes, points, minima, options, grid, W, H);
}

}  // namespace blmd
