// Line plots as SVG (docs/plots.md): series, bands and legends on linear or log axes.
#include "blmd/report/svg/plot.h"
#include "report/svg/svg_parts.h"

namespace blmd {

using namespace svg_detail;  // NOLINT(google-build-using-namespace): the plots' own parts

// ---- line plots ------------------------------------------------------------------------

namespace {

// The samples [*begin, *end) of a series worth drawing on the x range [low, high]: all of
// them, or for a series whose finite x never decreases, those inside the range and one
// neighbour on each side (so the line leaves the frame where the data does).
void SamplesInRange(const std::vector<double>& x, std::size_t n, double low, double high,
                    std::size_t* begin, std::size_t* end) {
  *begin = 0;
  *end = n;
  double previous = -std::numeric_limits<double>::infinity();
  std::size_t first_inside = n, last_inside = n;
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(x[i])) continue;
    if (x[i] < previous) return;  // not monotonic: everything
    previous = x[i];
    if (x[i] >= low && x[i] <= high) {
      if (first_inside == n) first_inside = i;
      last_inside = i;
    }
  }
  if (first_inside == n) return;  // nothing inside: let the clip path decide
  *begin = first_inside > 0 ? first_inside - 1 : 0;
  *end = std::min(n, last_inside + 2);
}

bool FiniteBand(const Band& band, bool log) {
  return std::isfinite(band.low) && std::isfinite(band.high) && band.low <= band.high &&
         (!log || band.low > 0);
}

// A value that can be drawn on a linear axis, or on a log axis.
bool Usable(double v, bool log) { return std::isfinite(v) && (!log || v > 0); }

// The data ranges of a line plot, in data units.
struct PlotRanges {
  double x_lo = std::numeric_limits<double>::infinity(), x_hi = -x_lo, y_lo = x_lo, y_hi = -x_lo;
  bool has_data = false;
};

// The ranges of the series' usable samples and of the bands; `fingerprint` takes in what the
// plot is drawn from.
PlotRanges DataRanges(const LinePlotOptions& options, const std::vector<Series>& series,
                      Fingerprint& fingerprint) {
  PlotRanges r;
  fingerprint.Add(options.title);
  for (const auto& s : series) {
    fingerprint.Add(s.label);
    const std::size_t n = std::min(s.x.size(), s.y.size());
    fingerprint.Add(static_cast<double>(n));
    for (std::size_t i = 0; i < n; ++i) {
      if (!Usable(s.x[i], options.x_log) || !Usable(s.y[i], options.y_log)) continue;
      r.x_lo = std::min(r.x_lo, s.x[i]);
      r.x_hi = std::max(r.x_hi, s.x[i]);
      r.y_lo = std::min(r.y_lo, s.y[i]);
      r.y_hi = std::max(r.y_hi, s.y[i]);
      fingerprint.Add(s.y[i]);
    }
  }
  r.has_data = r.x_lo <= r.x_hi;
  for (const auto& band : options.bands) {
    if (!r.has_data || !FiniteBand(band, band.vertical ? options.x_log : options.y_log)) continue;
    double& lo = band.vertical ? r.x_lo : r.y_lo;
    double& hi = band.vertical ? r.x_hi : r.y_hi;
    lo = std::min(lo, band.low);
    hi = std::max(hi, band.high);
    fingerprint.Add(band.low);
    fingerprint.Add(band.high);
  }
  return r;
}

// The ranges drawn: the data's (a default without data), widened when empty, 5 % headroom on
// y, then any fixed limits of the options.
void SetDrawnRanges(const LinePlotOptions& options, PlotRanges& r) {
  if (!r.has_data) {
    r.x_lo = options.x_log ? 1.0 : 0.0;
    r.x_hi = options.x_log ? 10.0 : 1.0;
    r.y_lo = r.x_lo;
    r.y_hi = r.x_hi;
  }
  Widen(r.x_lo, r.x_hi, options.x_log);
  Widen(r.y_lo, r.y_hi, options.y_log);
  {  // 5 % headroom on y, in the axis' own scale
    const double a = options.y_log ? std::log10(r.y_lo) : r.y_lo,
                 b = options.y_log ? std::log10(r.y_hi) : r.y_hi;
    const double pad = 0.05 * (b - a);
    r.y_lo = options.y_log ? std::pow(10.0, a - pad) : a - pad;
    r.y_hi = options.y_log ? std::pow(10.0, b + pad) : b + pad;
  }
  auto fixed = [](double low, double high, bool log) {
    return std::isfinite(low) && std::isfinite(high) && low < high && (!log || low > 0);
  };
  const double ox_lo = std::isfinite(options.x_min) ? options.x_min : r.x_lo;
  const double ox_hi = std::isfinite(options.x_max) ? options.x_max : r.x_hi;
  if (fixed(ox_lo, ox_hi, options.x_log)) {
    r.x_lo = ox_lo;
    r.x_hi = ox_hi;
  }
  const double oy_lo = std::isfinite(options.y_min) ? options.y_min : r.y_lo;
  const double oy_hi = std::isfinite(options.y_max) ? options.y_max : r.y_hi;
  if (fixed(oy_lo, oy_hi, options.y_log)) {
    r.y_lo = oy_lo;
    r.y_hi = oy_hi;
  }
}

// Each series' colour: its own, or the next of the palette.
std::vector<std::string> SeriesColours(const std::vector<Series>& series) {
  std::vector<std::string> colours;
  colours.reserve(series.size());
  std::size_t next_colour = 0;
  for (const auto& s : series) {
    colours.push_back(s.colour.empty() ? kPalette[next_colour++ % std::size(kPalette)] : s.colour);
  }
  return colours;
}

// A series' legend symbol: its line, its marker, or both.
std::string SeriesSymbol(const Series& s, const std::string& colour) {
  std::string symbol;
  if (s.line_width > 0) {
    symbol = "<line x1=\"-11\" y1=\"0\" x2=\"11\" y2=\"0\" stroke=\"" + Escape(colour) +
             "\" stroke-width=\"" + Num(std::max(1.5, s.line_width)) + "\"" +
             (s.dash.empty() ? "" : " stroke-dasharray=\"" + Escape(s.dash) + "\"") + "/>";
  }
  if (s.marker_radius > 0 || s.line_width <= 0) {
    symbol += "<circle r=\"" + Num(std::max(2.5, s.marker_radius)) + "\" " +
              (s.hollow_markers
                   ? "fill=\"#ffffff\" stroke=\"" + Escape(colour) + "\" stroke-width=\"1.5\""
                   : "fill=\"" + Escape(colour) + "\"") +
              "/>";
  }
  return symbol;
}

// A band's legend symbol: a line for a reference value, a swatch for a range.
std::string BandSymbol(const Band& band) {
  const std::string colour = Escape(band.colour);
  if (band.low == band.high) {
    return "<line x1=\"-11\" y1=\"0\" x2=\"11\" y2=\"0\" stroke=\"" + colour +
           "\" stroke-width=\"1.5\"" +
           (band.dash.empty() ? "" : " stroke-dasharray=\"" + Escape(band.dash) + "\"") + "/>";
  }
  return "<rect x=\"-10\" y=\"-6\" width=\"20\" height=\"12\" fill=\"" + colour +
         "\" fill-opacity=\"" + Num(std::clamp(band.opacity, 0.05, 1.0), 3) + "\" stroke=\"" +
         colour + "\" stroke-width=\"0.6\"/>";
}

// The labelled series, then the labelled bands.
std::vector<LegendItem> LinePlotLegend(const LinePlotOptions& options,
                                       const std::vector<Series>& series,
                                       const std::vector<std::string>& colours) {
  std::vector<LegendItem> legend;
  for (std::size_t k = 0; k < series.size(); ++k) {
    if (series[k].label.empty()) continue;
    legend.push_back({SeriesSymbol(series[k], colours[k]), series[k].label});
  }
  for (const auto& band : options.bands) {
    if (band.label.empty()) continue;
    legend.push_back({BandSymbol(band), band.label});
  }
  return legend;
}

// Where the legend's first row is drawn: under the title, above the frame.
double LinePlotLegendTop(const LinePlotOptions& options) { return options.title.empty() ? 14 : 40; }

struct LinePlotLayout {
  PlotFrame frame;
  std::vector<Tick> x_ticks, y_ticks;
  bool x_label = false, y_label = false;  // whether the axis has a title
};

// Top: under the title and the legend rows; bottom: above the x tick labels and title; left:
// right of the y title and tick labels.
LinePlotLayout MakeLinePlotLayout(const LinePlotOptions& options, const PlotRanges& r,
                                  int legend_rows, int W, int H) {
  LinePlotLayout layout;
  PlotFrame& frame = layout.frame;
  frame.top = LinePlotLegendTop(options) + 16.0 * legend_rows + (legend_rows ? 6 : 0);
  layout.x_label = !options.x_label.empty() || !options.x_unit.empty();
  frame.bottom = H - (5 + 3 + kTickFont + 8 + (layout.x_label ? kLabelFont + 10 : 0));
  layout.x_ticks = AxisTicks(r.x_lo, r.x_hi, options.x_log, W * 0.75, 85);
  layout.y_ticks = AxisTicks(r.y_lo, r.y_hi, options.y_log, frame.bottom - frame.top, 42);
  layout.y_label = !options.y_label.empty() || !options.y_unit.empty();
  frame.left = 10 + (layout.y_label ? kLabelFont + 8 : 0) + WidestLabel(layout.y_ticks) + 8;
  frame.right = W - 20.0;
  return layout;
}

// A band across the frame (vertical: an x range) or, when it is a single value, a line.
void DrawBand(std::string& out, const Band& band, const LinePlotOptions& options, const Scale& xs,
              const Scale& ys, const PlotFrame& frame) {
  const bool log = band.vertical ? options.x_log : options.y_log;
  if (!FiniteBand(band, log)) return;
  const double left = frame.left, right = frame.right, top = frame.top, bottom = frame.bottom;
  const Scale& scale = band.vertical ? xs : ys;
  const double a = std::clamp(scale(band.low), -1e5, 1e5),
               b = std::clamp(scale(band.high), -1e5, 1e5);
  const std::string colour = Escape(band.colour);
  if (band.low == band.high) {
    out += "<line class=\"reference-line\" " +
           (band.vertical ? "x1=\"" + Num(a) + "\" y1=\"" + Num(top) + "\" x2=\"" + Num(a) +
                                "\" y2=\"" + Num(bottom) + "\""
                          : "x1=\"" + Num(left) + "\" y1=\"" + Num(a) + "\" x2=\"" + Num(right) +
                                "\" y2=\"" + Num(a) + "\"") +
           " stroke=\"" + colour + "\" stroke-width=\"1.5\"" +
           (band.dash.empty() ? "" : " stroke-dasharray=\"" + Escape(band.dash) + "\"") + "/>\n";
    return;
  }
  double lo = std::min(a, b), extent = std::abs(b - a);
  if (extent < 1.0) {  // at least one pixel, centred
    lo -= (1.0 - extent) / 2;
    extent = 1.0;
  }
  out += "<rect class=\"band\" " +
         (band.vertical ? "x=\"" + Num(lo) + "\" y=\"" + Num(top) + "\" width=\"" + Num(extent) +
                              "\" height=\"" + Num(bottom - top) + "\""
                        : "x=\"" + Num(left) + "\" y=\"" + Num(lo) + "\" width=\"" +
                              Num(right - left) + "\" height=\"" + Num(extent) + "\"") +
         " fill=\"" + colour + "\" fill-opacity=\"" + Num(std::clamp(band.opacity, 0.05, 1.0), 3) +
         "\"/>\n";
}

// The indices of the samples of `s` to draw: those in the x range, thinned to the extremes of
// each pixel column when there are more than 4 per column.
std::vector<std::size_t> SamplesToDraw(const Series& s, const LinePlotOptions& options,
                                       const Scale& xs, const PlotRanges& r,
                                       const PlotFrame& frame) {
  const double columns = frame.right - frame.left, left = frame.left;
  const std::size_t n = std::min(s.x.size(), s.y.size());
  std::size_t begin = 0, end = n;
  SamplesInRange(s.x, n, r.x_lo, r.x_hi, &begin, &end);
  std::vector<std::size_t> kept;
  if (static_cast<double>(end - begin) > 4 * columns) {
    const std::vector<double> x(s.x.begin() + static_cast<std::ptrdiff_t>(begin),
                                s.x.begin() + static_cast<std::ptrdiff_t>(end));
    const std::vector<double> y(s.y.begin() + static_cast<std::ptrdiff_t>(begin),
                                s.y.begin() + static_cast<std::ptrdiff_t>(end));
    kept = internal::DecimateMinMax(x, y, [&](double v) {
      return options.x_log && !(v > 0) ? std::numeric_limits<double>::quiet_NaN() : xs(v) - left;
    });
    for (std::size_t& i : kept) i += begin;
  } else {
    kept.resize(end - begin);
    for (std::size_t i = begin; i < end; ++i) kept[i - begin] = i;
  }
  return kept;
}

// Series k: its line through the samples to draw (broken at unusable ones) and its markers.
void DrawSeries(std::string& out, const Series& s, std::size_t k, const std::string& colour_text,
                const LinePlotOptions& options, const Scale& xs, const Scale& ys,
                const PlotRanges& r, const PlotFrame& frame) {
  const std::size_t n = std::min(s.x.size(), s.y.size());
  std::string d;
  bool pen_down = false;
  std::vector<std::pair<double, double>> dots;
  for (std::size_t i : SamplesToDraw(s, options, xs, r, frame)) {
    if (i >= n || !Usable(s.x[i], options.x_log) || !Usable(s.y[i], options.y_log)) {
      pen_down = false;
      continue;
    }
    const double x = std::clamp(xs(s.x[i]), -1e5, 1e5), y = std::clamp(ys(s.y[i]), -1e5, 1e5);
    d += (pen_down ? " " : (d.empty() ? "M" : " M")) + Num(x, 1) + "," + Num(y, 1);
    pen_down = true;
    if (s.marker_radius > 0 || s.line_width <= 0) dots.emplace_back(x, y);
  }
  const std::string colour = Escape(colour_text);
  out += "<g class=\"series\" data-series=\"" + std::to_string(k) + "\">\n";
  if (!d.empty() && s.line_width > 0) {
    out += "<path class=\"curve\" d=\"" + d + "\" fill=\"none\" stroke=\"" + colour +
           "\" stroke-width=\"" + Num(s.line_width) + "\" stroke-linejoin=\"round\"" +
           (s.dash.empty() ? "" : " stroke-dasharray=\"" + Escape(s.dash) + "\"") + "/>\n";
  }
  const double radius = s.marker_radius > 0 ? s.marker_radius : 2.0;
  const std::string paint = s.hollow_markers
                                ? "fill=\"#ffffff\" stroke=\"" + colour + "\" stroke-width=\"1.5\""
                                : "fill=\"" + colour + "\"";
  for (const auto& [x, y] : dots) {
    out += "<circle cx=\"" + Num(x, 1) + "\" cy=\"" + Num(y, 1) + "\" r=\"" + Num(radius) + "\" " +
           paint + "/>\n";
  }
  out += "</g>\n";
}

}  // namespace

std::string LinePlotSvg(const LinePlotOptions& options, const std::vector<Series>& series) {
  const int W = std::max(240, options.width), H = std::max(160, options.height);
  Fingerprint fingerprint;
  PlotRanges r = DataRanges(options, series, fingerprint);
  SetDrawnRanges(options, r);
  const std::string prefix = options.id_prefix.empty() ? fingerprint.Id() : options.id_prefix;

  // Legend above the plot.
  const std::vector<std::string> colours = SeriesColours(series);
  const std::vector<LegendItem> legend = LinePlotLegend(options, series, colours);
  const int legend_rows = LegendRows(legend, W - 20.0);
  const LinePlotLayout layout = MakeLinePlotLayout(options, r, legend_rows, W, H);
  const PlotFrame& frame = layout.frame;
  Scale xs{r.x_lo, r.x_hi, options.x_log};
  Scale ys{r.y_lo, r.y_hi, options.y_log};
  PlaceScales(frame, xs, ys);

  std::string out = Header(W, H);
  out += "<defs><clipPath id=\"" + prefix + "-clip\"><rect x=\"" + Num(frame.left) + "\" y=\"" +
         Num(frame.top) + "\" width=\"" + Num(frame.right - frame.left) + "\" height=\"" +
         Num(frame.bottom - frame.top) + "\"/></clipPath></defs>\n";
  Title(out, W, options.title);
  DrawLegend(out, legend, W / 2.0, LinePlotLegendTop(options) + 12, W - 20.0);
  DrawAxis(out, Side::kBottom, xs, layout.x_ticks, frame.bottom, frame.top, frame.bottom);
  DrawAxis(out, Side::kLeft, ys, layout.y_ticks, frame.left, frame.left, frame.right);

  out += "<g clip-path=\"url(#" + prefix + "-clip)\">\n";
  for (const auto& band : options.bands) DrawBand(out, band, options, xs, ys, frame);
  for (std::size_t k = 0; k < series.size(); ++k) {
    DrawSeries(out, series[k], k, colours[k], options, xs, ys, r, frame);
  }
  out += "</g>\n";
  out += FrameRect(frame.left, frame.top, frame.right, frame.bottom);
  if (!r.has_data) {
    TextStyle style;
    style.size = kLabelFont;
    Text(out, (frame.left + frame.right) / 2, (frame.top + frame.bottom) / 2, "no data", style);
  }
  if (layout.x_label) XAxisTitle(out, frame, 8, AxisTitle(options.x_label, options.x_unit));
  if (layout.y_label) YAxisTitle(out, frame, AxisTitle(options.y_label, options.y_unit));
  return out + "</svg>\n";
}

}  // namespace blmd
