// SVG plots shared by blmd-surface --svg and the HTML report (docs/plots.md).
// Self-contained SVG text: no script, no external font or stylesheet, generic font family
// (sans-serif). Output is deterministic: the same input gives the same bytes. Numbers in the
// SVG are always finite; non-finite data is drawn as gaps, never printed.
//
// Elements carry class names so that tests and readers can find them:
//   cell        one heat-map cell per grid point (2-D)
//   contour     one path per contour level (2-D), data-level = log10(cost) of the level
//   curve       the cost curve (1-D) or one path per line-plot series
//   gap         a hatched band over a non-finite point (1-D)
//   global-min  the grid minimum: data-index, data-x [, data-y], data-cost (exact round-trip)
//   local-min   one marker per entry of `minima`: data-index
//   plot-area   the rectangle of the data area: x, y, width, height in px
#pragma once

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "blmd/ident/fit/surface.h"

namespace blmd {

struct SurfacePlotOptions {
  std::string title;               // e.g. "blmd-d31x: cost over J, B (observe i)"
  std::vector<std::string> units;  // one per axis, e.g. "kg·m²"; missing or empty: no unit
  std::string value_label = "cost (normalised MSE)";
  int width = 720, height = 540;  // px
  int contour_levels = 8;         // about this many contour lines (2-D); 0: none
  // Prefix of the ids inside the SVG (hatch pattern, gradient, clip path). Empty: derived
  // from the content, so several plots can share one HTML page without clashing ids.
  std::string id_prefix;
};

// 2-D: heat map of log10(cost) with contour lines, axis ticks and labels with units, a
// colour bar, the grid minimum marked and local minima marked. 1-D: the cost curve on a
// log axis with its local minima and the global minimum labelled.
// Non-finite points are drawn as gaps (hatched cells in 2-D).
// `points` is the full grid in row-major order (first axis outermost, as ComputeSurface
// and LocalMinima use it); a partial set (one shard) is placed by its coordinates and the
// missing points are drawn as gaps. `minima` indexes `points` (as from LocalMinima).
// Axes: the first grid axis is horizontal, the second vertical; a log_scale axis is drawn
// on a log scale. Colour map: viridis.
std::string SurfaceSvg(const std::vector<GridAxis>& axes, const std::vector<SurfacePoint>& points,
                       const std::vector<std::size_t>& minima, const SurfacePlotOptions& options);

// One line of a LinePlotSvg.
struct Series {
  std::string label;            // legend text; empty: not listed in the legend
  std::vector<double> x, y;     // same length; a non-finite value breaks the line (a gap)
  std::string colour;           // any SVG colour, e.g. "#0072b2"; empty: next palette colour
  std::string dash;             // SVG stroke-dasharray, e.g. "6 3"; empty: solid
  double line_width = 1.5;      // px; 0: no line (markers only)
  double marker_radius = 0.0;   // px; > 0: a dot at every drawn sample
  bool hollow_markers = false;  // markers as rings (white inside): tells series apart in grey
};

// A shaded band or a reference line across a LinePlotSvg, drawn under the series (e.g. the
// 95 % band of an autocorrelation, a confidence interval, the estimate). Its limits count in
// the axis range taken from the data, so it is always in view.
struct Band {
  std::string label;             // legend text; empty: not listed in the legend
  bool vertical = false;         // false: y in [low, high] across the plot; true: x in [low, high]
  double low = 0.0, high = 0.0;  // data units; low == high: a line; non-finite: not drawn
  std::string colour = "#999999";
  double opacity = 0.25;  // fill opacity of a band (a line is opaque); a band is at least 1 px
  std::string dash;       // stroke-dasharray of a line, e.g. "5 3"; empty: solid
};

struct LinePlotOptions {
  std::string title;
  std::string x_label, x_unit;  // the axis reads "x_label (x_unit)"
  std::string y_label, y_unit;
  bool x_log = false, y_log = false;  // on a log axis, values <= 0 are gaps
  // Axis ranges in data units; NaN: from the data (y padded by 5 % of its range).
  double x_min = std::numeric_limits<double>::quiet_NaN();
  double x_max = std::numeric_limits<double>::quiet_NaN();
  double y_min = std::numeric_limits<double>::quiet_NaN();
  double y_max = std::numeric_limits<double>::quiet_NaN();
  int width = 720, height = 400;  // px
  std::string id_prefix;          // as SurfacePlotOptions::id_prefix
  std::vector<Band> bands;        // shaded bands and reference lines, listed after the series
};

// Lines over shared axes with "nice" ticks (1-2-5 steps; decades on log axes), axis labels
// with units and a legend above the plot. Colours default to the Okabe-Ito palette (safe for
// colour-blind readers). Long series are decimated per pixel column: of the samples falling
// in one column only the first, last, lowest and highest are drawn (and the first
// non-finite one, so gaps stay visible). Spikes therefore survive and the SVG size is
// bounded by the plot width, not by the series length (1e6 samples give ~60 kB).
// Decimation applies only to series whose finite x values are non-decreasing. Samples of a
// monotonic series outside a given x range are not drawn (but for one on each side, so the
// line leaves the frame where the data does): a detail of a long trace stays small.
std::string LinePlotSvg(const LinePlotOptions& options, const std::vector<Series>& series);

}  // namespace blmd
