// Private to the SVG plots (src/report/svg/): the pieces the surface and line plots share —
// text placement, colours, ids, scales and axes, the document, legends. Layout is computed from
// estimated text widths (a sans-serif glyph is about 0.6 em wide), so labels can be kept apart
// without a font engine.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <limits>
#include <numbers>
#include <unordered_map>
#include <utility>

#include "blmd/format.h"
#include "blmd/io/csv.h"
#include "blmd/report/svg/plot.h"
#include "report/markup.h"
#include "report/svg/plot_ticks.h"

namespace blmd::svg_detail {

using internal::FormatValue;
using internal::Tick;

inline constexpr double kGlyphWidth = 0.6;  // estimated advance of a sans-serif glyph, in em
inline constexpr double kTickFont = 11.0, kLabelFont = 12.5, kTitleFont = 15.0;
inline constexpr const char* kTextColour = "#222222";
inline constexpr const char* kFrameColour = "#444444";
inline constexpr const char* kMinimumFill =
    "#e8402a";  // outside viridis, visible on it and on white
inline constexpr const char* kCurveColour = "#0072b2";     // Okabe-Ito blue
inline constexpr const char* kLocalMinColour = "#d55e00";  // Okabe-Ito vermillion

// The 16-entry viridis table (matplotlib, CC0), sampled at every 17th of its 256 entries.
inline constexpr std::uint32_t kViridis[16] = {
    0x440154, 0x481a6c, 0x472f7d, 0x414487, 0x39568c, 0x31688e, 0x2a788e, 0x23888e,
    0x1f988b, 0x22a884, 0x35b779, 0x54c568, 0x7ad151, 0xa5db36, 0xd2e21b, 0xfde725};
// Okabe-Ito colours for line plots, in order of use (yellow left out: too light on white).
inline constexpr const char* kPalette[] = {"#0072b2", "#d55e00", "#009e73", "#cc79a7",
                                           "#e69f00", "#56b4e9", "#000000"};

// ---- text -------------------------------------------------------------------------------

// A coordinate with at most `decimals` decimals; never "nan" or "inf".
inline std::string Num(double v, int decimals = 2) { return FormatFixedTrimmed(v, decimals); }

// Exact round-trip value for data attributes; non-finite values never reach here.
inline std::string Exact(double v) { return std::isfinite(v) ? FormatNumber(v) : "0"; }

using internal::Escape;  // report/markup.h

inline std::size_t Utf8Length(const std::string& text) {
  std::size_t n = 0;
  for (unsigned char c : text) n += (c & 0xC0) != 0x80;
  return n;
}

inline double TextWidth(const std::string& text, double font) {
  return static_cast<double>(Utf8Length(text)) * kGlyphWidth * font;
}

// Cuts `text` (at a UTF-8 boundary) and appends "..." so it fits `width` px.
inline std::string FitText(const std::string& text, double width, double font) {
  if (TextWidth(text, font) <= width) return text;
  const std::size_t keep =
      static_cast<std::size_t>(std::max(0.0, width / (kGlyphWidth * font) - 3));
  std::string out;
  std::size_t chars = 0;
  for (const char byte : text) {
    const auto c = static_cast<unsigned char>(byte);
    if ((c & 0xC0) != 0x80 && chars++ == keep) break;
    out += byte;
  }
  return out + "...";
}

inline std::string AxisTitle(const std::string& name, const std::string& unit) {
  return unit.empty() ? name : name + " (" + unit + ")";
}

struct TextStyle {
  double size = kTickFont;
  const char* anchor = "middle";  // start | middle | end
  bool bold = false;
  double rotate = 0.0;  // degrees about (x, y)
  std::string css_class;
};

inline void Text(std::string& out, double x, double y, const std::string& text,
                 const TextStyle& style) {
  out += "<text";
  if (!style.css_class.empty()) out += " class=\"" + style.css_class + "\"";
  out += " x=\"" + Num(x) + "\" y=\"" + Num(y) + "\"";
  if (std::strcmp(style.anchor, "start") != 0)
    out += " text-anchor=\"" + std::string(style.anchor) + "\"";
  if (style.size != kTickFont) out += " font-size=\"" + Num(style.size) + "\"";
  if (style.bold) out += " font-weight=\"bold\"";
  if (style.rotate != 0.0) {
    out += " transform=\"rotate(" + Num(style.rotate) + " " + Num(x) + " " + Num(y) + ")\"";
  }
  out += ">" + Escape(text) + "</text>\n";
}

// ---- colour ----------------------------------------------------------------------------

inline std::string Hex(std::uint32_t rgb) {
  char buffer[8];
  std::snprintf(buffer, sizeof buffer, "#%06x", static_cast<unsigned>(rgb & 0xFFFFFF));
  return buffer;
}

// Viridis at f in [0, 1], linearly interpolated between the 16 table entries.
inline std::string Viridis(double f) {
  if (!std::isfinite(f)) f = 0.0;
  const double position = std::clamp(f, 0.0, 1.0) * 15.0;
  const int i = std::min(14, static_cast<int>(position));
  const double t = position - i;
  std::uint32_t rgb = 0;
  for (int shift = 16; shift >= 0; shift -= 8) {
    const double a = (kViridis[i] >> shift) & 0xFF, b = (kViridis[i + 1] >> shift) & 0xFF;
    rgb |= static_cast<std::uint32_t>(std::lround(a + t * (b - a))) << shift;
  }
  return Hex(rgb);
}

// ---- ids -------------------------------------------------------------------------------

// FNV-1a over the inputs: a deterministic id prefix that differs between plots.
class Fingerprint {
 public:
  void Add(const std::string& text) { Bytes(text.data(), text.size()); }
  void Add(double v) { Bytes(&v, sizeof v); }
  std::string Id() const {
    char buffer[20];
    std::snprintf(buffer, sizeof buffer, "p%08x", static_cast<unsigned>(hash_ ^ (hash_ >> 32)));
    return buffer;
  }

 private:
  void Bytes(const void* data, std::size_t size) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) hash_ = (hash_ ^ p[i]) * 1099511628211ULL;
  }
  std::uint64_t hash_ = 14695981039346656037ULL;
};

// ---- scales and axes -------------------------------------------------------------------

// Maps data values to pixels, linearly or in log10.
struct Scale {
  double low = 0.0, high = 1.0;  // data units; on a log scale 0 < low
  bool log = false;
  double p0 = 0.0, p1 = 1.0;  // pixels of low and high

  double T(double v) const { return log ? std::log10(v) : v; }
  // Pixel of a transformed coordinate (log10 of the value on a log scale).
  double FromT(double t) const {
    const double t0 = T(low), t1 = T(high);
    return p0 + (t - t0) / (t1 - t0) * (p1 - p0);
  }
  double operator()(double v) const { return FromT(T(v)); }
};

// Widens an empty range so that a scale can be drawn.
inline void Widen(double& low, double& high, bool log) {
  if (high > low) return;
  if (log) {
    low /= std::sqrt(10.0);
    high *= std::sqrt(10.0);
  } else {
    const double half = low == 0.0 ? 0.5 : std::abs(low) * 0.1;
    low -= half;
    high += half;
  }
}

// Where the plot rectangle lies in the image, in pixels (y grows downwards).
struct PlotFrame {
  double left = 0.0, top = 0.0, right = 0.0, bottom = 0.0;
};

// Maps the scales' data ranges onto the frame: x from left to right, y from bottom to top.
inline void PlaceScales(const PlotFrame& frame, Scale& xs, Scale& ys) {
  xs.p0 = frame.left;
  xs.p1 = frame.right;
  ys.p0 = frame.bottom;
  ys.p1 = frame.top;
}

inline std::vector<Tick> AxisTicks(double low, double high, bool log, double length_px,
                                   double px_per_tick) {
  const int target = std::max(2, static_cast<int>(length_px / px_per_tick));
  return log ? internal::LogAxisTicks(low, high, target)
             : internal::LinearAxisTicks(low, high, target);
}

inline double WidestLabel(const std::vector<Tick>& ticks) {
  double widest = 0.0;
  for (const auto& tick : ticks) widest = std::max(widest, TextWidth(tick.label, kTickFont));
  return widest;
}

enum class Side { kBottom, kLeft, kRight };

// Drops the labels that would overlap a kept one: majors are placed first, then minors.
inline void DropCrowdedLabels(std::vector<Tick>& ticks, const std::vector<double>& centre,
                              const std::vector<double>& half_extent, double gap) {
  std::vector<std::pair<double, double>> taken;
  for (int pass = 0; pass < 2; ++pass) {
    for (std::size_t i = 0; i < ticks.size(); ++i) {
      if (ticks[i].label.empty() || ticks[i].major != (pass == 0)) continue;
      const double a = centre[i] - half_extent[i], b = centre[i] + half_extent[i];
      bool free = true;
      for (const auto& [c, d] : taken) free = free && (b + gap <= c || a >= d + gap);
      if (free) {
        taken.emplace_back(a, b);
      } else {
        ticks[i].label.clear();
      }
    }
  }
}

// Tick marks and labels along one side of the plot rectangle at pixel `at` (y for the
// bottom side, x for the others). Grid lines from `grid_from` to `grid_to` when they differ.
inline void DrawAxis(std::string& out, Side side, const Scale& scale,
                     const std::vector<Tick>& ticks, double at, double grid_from = 0.0,
                     double grid_to = 0.0) {
  const double lo = std::min(scale.p0, scale.p1) - 0.5, hi = std::max(scale.p0, scale.p1) + 0.5;
  std::vector<Tick> visible;
  std::vector<double> centre, half;
  for (const auto& tick : ticks) {
    const double p = scale(tick.value);
    if (!(p >= lo && p <= hi)) continue;
    visible.push_back(tick);
    centre.push_back(p);
    half.push_back(side == Side::kBottom ? TextWidth(tick.label, kTickFont) / 2 : kTickFont * 0.55);
  }
  DropCrowdedLabels(visible, centre, half, side == Side::kBottom ? 8.0 : 3.0);
  if (grid_from != grid_to) {
    out += "<g class=\"grid\" stroke-width=\"1\">\n";
    for (std::size_t i = 0; i < visible.size(); ++i) {
      const std::string colour = visible[i].major ? "#e3e3e3" : "#f0f0f0";
      const std::string p = Num(centre[i]);
      if (side == Side::kBottom) {
        out += "<line x1=\"" + p + "\" y1=\"" + Num(grid_from) + "\" x2=\"" + p + "\" y2=\"" +
               Num(grid_to) + "\" stroke=\"" + colour + "\"/>\n";
      } else {
        out += "<line x1=\"" + Num(grid_from) + "\" y1=\"" + p + "\" x2=\"" + Num(grid_to) +
               "\" y2=\"" + p + "\" stroke=\"" + colour + "\"/>\n";
      }
    }
    out += "</g>\n";
  }
  out += "<g class=\"ticks\" stroke=\"" + std::string(kFrameColour) + "\" stroke-width=\"1\">\n";
  for (std::size_t i = 0; i < visible.size(); ++i) {
    const double length = visible[i].major ? 5.0 : 3.0;
    const std::string p = Num(centre[i]);
    if (side == Side::kBottom) {
      out += "<line x1=\"" + p + "\" y1=\"" + Num(at) + "\" x2=\"" + p + "\" y2=\"" +
             Num(at + length) + "\"/>\n";
    } else {
      const double sign = side == Side::kLeft ? -1.0 : 1.0;
      out += "<line x1=\"" + Num(at) + "\" y1=\"" + p + "\" x2=\"" + Num(at + sign * length) +
             "\" y2=\"" + p + "\"/>\n";
    }
  }
  out += "</g>\n<g class=\"tick-labels\" fill=\"" + std::string(kTextColour) + "\">\n";
  for (std::size_t i = 0; i < visible.size(); ++i) {
    if (visible[i].label.empty()) continue;
    TextStyle style;
    if (side == Side::kBottom) {
      Text(out, centre[i], at + 5 + kTickFont + 2, visible[i].label, style);
    } else if (side == Side::kLeft) {
      style.anchor = "end";
      Text(out, at - 8, centre[i] + kTickFont * 0.35, visible[i].label, style);
    } else {
      style.anchor = "start";
      Text(out, at + 8, centre[i] + kTickFont * 0.35, visible[i].label, style);
    }
  }
  out += "</g>\n";
}

// ---- document --------------------------------------------------------------------------

inline std::string Header(int width, int height) {
  const std::string w = std::to_string(width), h = std::to_string(height);
  return "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + w + "\" height=\"" + h +
         "\" viewBox=\"0 0 " + w + " " + h +
         "\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"" + w + "\" height=\"" +
         h + "\" fill=\"#ffffff\"/>\n";
}

inline void Title(std::string& out, int width, const std::string& title) {
  if (title.empty()) return;
  TextStyle style;
  style.size = kTitleFont;
  style.bold = true;
  style.css_class = "title";
  style.anchor = "middle";
  Text(out, width / 2.0, 24, FitText(title, width - 20.0, kTitleFont), style);
}

inline std::string MessageSvg(int width, int height, const std::string& title,
                              const std::string& message) {
  std::string out = Header(width, height);
  Title(out, width, title);
  TextStyle style;
  style.size = kLabelFont;
  Text(out, width / 2.0, height / 2.0, message, style);
  return out + "</svg>\n";
}

inline std::string HatchPattern(const std::string& id) {
  return "<pattern id=\"" + id +
         "\" width=\"6\" height=\"6\" patternUnits=\"userSpaceOnUse\" "
         "patternTransform=\"rotate(45)\"><rect width=\"6\" height=\"6\" fill=\"#d4d4d4\"/>"
         "<line x1=\"0\" y1=\"0\" x2=\"0\" y2=\"6\" stroke=\"#8a8a8a\" stroke-width=\"2\"/>"
         "</pattern>\n";
}

inline std::string FrameRect(double x0, double y0, double x1, double y1) {
  return "<rect class=\"plot-area\" x=\"" + Num(x0) + "\" y=\"" + Num(y0) + "\" width=\"" +
         Num(x1 - x0) + "\" height=\"" + Num(y1 - y0) + "\" fill=\"none\" stroke=\"" +
         kFrameColour + "\" stroke-width=\"1\"/>\n";
}

inline TextStyle AxisTitleStyle() {
  TextStyle style;
  style.size = kLabelFont;
  style.css_class = "axis-label";
  return style;
}

// The x axis title, `gap` px below the x tick labels.
inline void XAxisTitle(std::string& out, const PlotFrame& frame, double gap,
                       const std::string& title) {
  Text(out, (frame.left + frame.right) / 2, frame.bottom + 5 + 3 + kTickFont + gap + kLabelFont - 2,
       title, AxisTitleStyle());
}

// The y axis title, turned, at the left edge of the image.
inline void YAxisTitle(std::string& out, const PlotFrame& frame, const std::string& title) {
  TextStyle style = AxisTitleStyle();
  style.rotate = -90;
  Text(out, 10 + kLabelFont - 2, (frame.top + frame.bottom) / 2, title, style);
}

// Five-pointed star of outer radius r around (x, y) as polygon points.
inline std::string StarPoints(double x, double y, double r) {
  std::string points;
  for (int k = 0; k < 10; ++k) {
    const double angle = -std::numbers::pi / 2 + k * std::numbers::pi / 5,
                 radius = k % 2 == 0 ? r : r * 0.45;
    if (k > 0) points += " ";
    points += Num(x + radius * std::cos(angle), 1) + "," + Num(y + radius * std::sin(angle), 1);
  }
  return points;
}

inline std::string StarShape(double x, double y, double r) {
  const std::string points = StarPoints(x, y, r);
  return "<polygon points=\"" + points +
         "\" fill=\"none\" stroke=\"#000000\" stroke-opacity=\"0.55\" stroke-width=\"3.5\" "
         "stroke-linejoin=\"round\"/><polygon points=\"" +
         points + "\" fill=\"" + kMinimumFill +
         "\" stroke=\"#ffffff\" stroke-width=\"1.4\" stroke-linejoin=\"round\"/>";
}

inline std::string RingShape(double x, double y, double r, bool on_dark) {
  const std::string c = "cx=\"" + Num(x) + "\" cy=\"" + Num(y) + "\" r=\"" + Num(r) + "\"";
  if (on_dark) {
    return "<circle " + c +
           " fill=\"none\" stroke=\"#000000\" stroke-opacity=\"0.5\" "
           "stroke-width=\"3.2\"/><circle " +
           c +
           " fill=\"none\" stroke=\"#ffffff\" "
           "stroke-width=\"1.5\"/>";
  }
  return "<circle " + c + " fill=\"none\" stroke=\"" + std::string(kLocalMinColour) +
         "\" stroke-width=\"1.8\"/>";
}

// A label box of some lines next to a marker at (x, y), inside [x0, x1] x [y0, y1] when
// possible, avoiding the `avoid` points (other markers) where it can.
inline void LabelBox(std::string& out, double x, double y, const std::vector<std::string>& lines,
                     double x0, double y0, double x1, double y1,
                     const std::vector<std::pair<double, double>>& avoid) {
  const double line_height = kTickFont + 3, pad = 5;
  double w = 0;
  for (const auto& line : lines) w = std::max(w, TextWidth(line, kTickFont));
  w += 2 * pad;
  const double h = static_cast<double>(lines.size()) * line_height + 2 * pad - 3;
  const double gap = 11;
  const std::pair<double, double> corners[4] = {{x + gap, y - gap - h},
                                                {x + gap, y + gap},
                                                {x - gap - w, y - gap - h},
                                                {x - gap - w, y + gap}};
  double best_score = std::numeric_limits<double>::infinity(), bx = 0, by = 0;
  for (const auto& [cx, cy] : corners) {
    const double overflow = std::max(0.0, x0 - cx) + std::max(0.0, cx + w - x1) +
                            std::max(0.0, y0 - cy) + std::max(0.0, cy + h - y1);
    double covered = 0;
    for (const auto& [ax, ay] : avoid) {
      covered += ax > cx - 6 && ax < cx + w + 6 && ay > cy - 6 && ay < cy + h + 6;
    }
    const double score = overflow * 1000 + covered;
    if (score < best_score) {
      best_score = score;
      bx = cx;
      by = cy;
    }
  }
  bx = std::clamp(bx, x0 + 1, std::max(x0 + 1, x1 - w - 1));
  by = std::clamp(by, y0 + 1, std::max(y0 + 1, y1 - h - 1));
  out += "<g class=\"min-label\"><rect x=\"" + Num(bx) + "\" y=\"" + Num(by) + "\" width=\"" +
         Num(w) + "\" height=\"" + Num(h) +
         "\" rx=\"3\" fill=\"#ffffff\" fill-opacity=\"0.9\" stroke=\"#444444\" "
         "stroke-width=\"0.6\"/>\n";
  for (std::size_t i = 0; i < lines.size(); ++i) {
    TextStyle style;
    style.anchor = "start";
    style.bold = i == 0;
    Text(out, bx + pad, by + pad + kTickFont - 1 + static_cast<double>(i) * line_height, lines[i],
         style);
  }
  out += "</g>\n";
}

// A row of legend entries (symbol + text) centred at the bottom; wraps into more rows.
struct LegendItem {
  std::string symbol;  // SVG drawn around (0, 0), about 24 px wide
  std::string text;
};

inline double LegendWidth(const LegendItem& item) {
  return 30 + TextWidth(item.text, kTickFont) + 18;
}

// The legend's items in rows of at most `width` px (a wider item gets a row of its own).
inline std::vector<std::vector<const LegendItem*>> LegendLayout(
    const std::vector<LegendItem>& items, double width) {
  std::vector<std::vector<const LegendItem*>> rows;
  double used = 0;
  for (const auto& item : items) {
    const double w = LegendWidth(item);
    if (rows.empty() || (used > 0 && used + w > width)) {
      rows.emplace_back();
      used = 0;
    }
    rows.back().push_back(&item);
    used += w;
  }
  return rows;
}

inline int LegendRows(const std::vector<LegendItem>& items, double width) {
  return static_cast<int>(LegendLayout(items, width).size());
}

inline void DrawLegend(std::string& out, const std::vector<LegendItem>& items, double centre_x,
                       double y, double width) {
  if (items.empty()) return;
  const std::vector<std::vector<const LegendItem*>> rows = LegendLayout(items, width);
  out += "<g class=\"legend\" fill=\"" + std::string(kTextColour) + "\">\n";
  for (const auto& row : rows) {
    double total = -18;
    for (const auto* item : row) total += LegendWidth(*item);
    double x = centre_x - total / 2;
    for (const auto* item : row) {
      out += "<g transform=\"translate(" + Num(x + 12) + " " + Num(y - 4) + ")\">" + item->symbol +
             "</g>\n";
      TextStyle style;
      style.anchor = "start";
      Text(out, x + 30, y, item->text, style);
      x += LegendWidth(*item);
    }
    y += 16;
  }
  out += "</g>\n";
}

inline std::string HatchSwatch(const std::string& pattern_id) {
  return "<rect x=\"-9\" y=\"-6\" width=\"18\" height=\"12\" fill=\"url(#" + pattern_id +
         ")\" stroke=\"#8a8a8a\" stroke-width=\"0.6\"/>";
}

}  // namespace blmd::svg_detail
