// SVG plots (docs/plots.md). Layout is computed from estimated text widths (a sans-serif
// glyph is about 0.6 em wide), so labels can be kept apart without a font engine.
#include "blmd/report/plot.h"

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

#include "blmd/io/csv.h"
#include "report/markup.h"
#include "report/plot_ticks.h"

namespace blmd {
namespace internal {
namespace {

// 10^k, exact for |k| <= 22.
double Pow10(int k) {
  double p = 1.0;
  for (int i = 0; i < std::abs(k); ++i) p *= 10.0;
  return k < 0 ? 1.0 / p : p;
}

// m * 10^k, correctly rounded for |k| <= 22 (one exact product or one division).
double Decimal(double m, int k) { return k >= 0 ? m * Pow10(k) : m / Pow10(-k); }

// The nice step as mantissa (1, 2 or 5) and decimal exponent.
void NiceStepParts(double low, double high, int target, int& mantissa, int& exponent) {
  const double span = high - low;
  mantissa = 1;
  exponent = 0;
  if (!(span > 0.0) || !std::isfinite(span)) {
    const double a = std::max(std::abs(low), std::abs(high));
    if (a > 0.0 && std::isfinite(a)) exponent = static_cast<int>(std::floor(std::log10(a)));
    return;
  }
  const double raw = span / std::max(1, target);
  exponent = static_cast<int>(std::floor(std::log10(raw)));
  const double normalised = raw / Pow10(exponent);
  if (normalised < 1.5) {
    mantissa = 1;
  } else if (normalised < 3.0) {
    mantissa = 2;
  } else if (normalised < 7.0) {
    mantissa = 5;
  } else {
    mantissa = 1;
    ++exponent;
  }
}

void StripZeros(std::string& text) {
  if (text.find('.') == std::string::npos) return;
  while (!text.empty() && text.back() == '0') text.pop_back();
  if (!text.empty() && text.back() == '.') text.pop_back();
}

std::string FixedText(double value, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", std::clamp(decimals, 0, 20), value);
  std::string text = buffer;
  StripZeros(text);
  if (text == "-0") text = "0";
  return text;
}

std::string ExponentText(double value, int significant) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*e", std::clamp(significant, 1, 17) - 1, value);
  std::string text = buffer;
  const auto e = text.find('e');
  std::string mantissa = text.substr(0, e);
  StripZeros(mantissa);
  const int exponent = std::atoi(text.c_str() + e + 1);
  return mantissa + "e" + std::to_string(exponent);
}

}  // namespace

double NiceStep(double low, double high, int target) {
  int mantissa = 1, exponent = 0;
  NiceStepParts(low, high, target, mantissa, exponent);
  return Decimal(mantissa, exponent);
}

std::vector<double> NiceLinearTicks(double low, double high, int target) {
  std::vector<double> ticks;
  if (!std::isfinite(low) || !std::isfinite(high) || high < low) return ticks;
  int mantissa = 1, exponent = 0;
  NiceStepParts(low, high, target, mantissa, exponent);
  const double step = Decimal(mantissa, exponent);
  const double first = std::ceil(low / step - 1e-9), last = std::floor(high / step + 1e-9);
  if (!(last - first < 10000.0)) return ticks;
  for (double k = first; k <= last; k += 1.0) {
    double value = Decimal(k * mantissa, exponent);
    if (std::abs(value) < step * 1e-9) value = 0.0;
    ticks.push_back(value);
  }
  return ticks;
}

std::vector<Tick> LinearAxisTicks(double low, double high, int target) {
  int mantissa = 1, exponent = 0;
  NiceStepParts(low, high, target, mantissa, exponent);
  const std::vector<double> values = NiceLinearTicks(low, high, target);
  double largest = 0.0;
  for (double v : values) largest = std::max(largest, std::abs(v));
  const bool exponent_form = largest > 0.0 && (largest < 1e-2 || largest >= 1e4);
  std::vector<Tick> ticks;
  for (double v : values) {
    std::string label;
    if (v == 0.0) {
      label = "0";
    } else if (exponent_form) {
      const int magnitude = static_cast<int>(std::floor(std::log10(std::abs(v)) + 1e-12));
      label = ExponentText(v, std::max(1, magnitude - exponent + 1));
    } else {
      label = FixedText(v, std::max(0, -exponent));
    }
    ticks.push_back({v, true, label});
  }
  return ticks;
}

std::vector<Tick> LogAxisTicks(double low, double high, int target) {
  std::vector<Tick> ticks;
  if (!(low > 0.0) || !(high > low) || !std::isfinite(high)) return ticks;
  target = std::max(2, target);
  const double lo = std::log10(low), hi = std::log10(high), span = hi - lo;
  const double tolerance = 1e-9 * std::max(1.0, span);
  auto inside = [&](double v) {
    const double t = std::log10(v);
    return t >= lo - tolerance && t <= hi + tolerance;
  };
  const int first = static_cast<int>(std::ceil(lo - tolerance));
  const int last = static_cast<int>(std::floor(hi + tolerance));
  const int decades = last - first + 1;
  if (decades >= 2) {
    const int every = std::max(1, (decades + target - 1) / target);
    const bool label_minors = every == 1 && span <= 2.5;
    for (int k = first - 1; k <= last; ++k) {
      const double decade = Decimal(1.0, k);
      if (inside(decade)) {
        const bool major = ((k % every) + every) % every == 0;
        ticks.push_back({decade, major, major ? FormatValue(decade) : std::string()});
      }
      if (every != 1) continue;
      for (double m : {2.0, 5.0}) {
        const double v = Decimal(m, k);
        if (inside(v)) ticks.push_back({v, false, label_minors ? FormatValue(v) : std::string()});
      }
    }
    std::sort(ticks.begin(), ticks.end(),
              [](const Tick& a, const Tick& b) { return a.value < b.value; });
    return ticks;
  }
  // Under two decades: the 1-2-5 values inside, or failing three of them every m x 10^k
  // (1-2-5 as majors, so their labels win when space is short).
  for (const bool all_digits : {false, true}) {
    ticks.clear();
    for (int k = static_cast<int>(std::floor(lo)) - 1; k <= static_cast<int>(std::ceil(hi)); ++k) {
      for (int m = 1; m <= 9; ++m) {
        const bool major = m == 1 || m == 2 || m == 5;
        const double v = Decimal(m, k);
        if ((major || all_digits) && inside(v)) ticks.push_back({v, major, FormatValue(v)});
      }
    }
    if (ticks.size() >= 3) return ticks;
  }
  return LinearAxisTicks(low, high, target);
}

std::string FormatValue(double value, int significant) {
  if (!std::isfinite(value)) return "-";
  if (value == 0.0) return "0";
  significant = std::clamp(significant, 1, 17);
  const double a = std::abs(value);
  // Decide on the rounded value so that 9999.7 (3 digits) prints as 1e4, not 10000.
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*e", significant - 1, a);
  const double rounded = std::strtod(buffer, nullptr);
  if (rounded < 1e-2 || rounded >= 1e4) return ExponentText(value, significant);
  const int magnitude = static_cast<int>(std::floor(std::log10(rounded) + 1e-12));
  return FixedText(value, significant - 1 - magnitude);
}

std::vector<std::size_t> DecimateMinMax(const std::vector<double>& x, const std::vector<double>& y,
                                        const std::function<double(double)>& column_of) {
  const std::size_t n = std::min(x.size(), y.size());
  std::vector<std::size_t> kept;
  double previous = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(x[i])) continue;
    if (x[i] < previous) {  // not monotonic: every sample
      kept.resize(n);
      for (std::size_t k = 0; k < n; ++k) kept[k] = k;
      return kept;
    }
    previous = x[i];
  }
  constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
  std::size_t first = kNone, last = kNone, lowest = kNone, highest = kNone, broken = kNone;
  long long column = std::numeric_limits<long long>::min();
  bool started = false;
  auto flush = [&] {
    std::size_t chosen[5] = {first, lowest, highest, last, broken};
    std::sort(chosen, chosen + 5);
    for (std::size_t k = 0; k < 5; ++k) {
      if (chosen[k] == kNone) break;
      if (k > 0 && chosen[k] == chosen[k - 1]) continue;
      kept.push_back(chosen[k]);
    }
    first = last = lowest = highest = broken = kNone;
  };
  for (std::size_t i = 0; i < n; ++i) {
    const bool finite = std::isfinite(x[i]) && std::isfinite(y[i]);
    if (std::isfinite(x[i])) {
      const double c = std::floor(column_of(x[i]));
      const long long here =
          std::isfinite(c) ? static_cast<long long>(std::clamp(c, -1e15, 1e15)) : column;
      if (!started || here != column) {
        if (started) flush();
        column = here;
        started = true;
      }
    }
    started = true;
    if (finite) {
      if (first == kNone) first = i;
      last = i;
      if (lowest == kNone || y[i] < y[lowest]) lowest = i;
      if (highest == kNone || y[i] > y[highest]) highest = i;
    } else if (broken == kNone) {
      broken = i;
    }
  }
  flush();
  return kept;
}

}  // namespace internal

namespace {

using internal::FormatValue;
using internal::Tick;

constexpr double kGlyphWidth = 0.6;  // estimated advance of a sans-serif glyph, in em
constexpr double kTickFont = 11.0, kLabelFont = 12.5, kTitleFont = 15.0;
constexpr const char* kTextColour = "#222222";
constexpr const char* kFrameColour = "#444444";
constexpr const char* kMinimumFill = "#e8402a";     // outside viridis, visible on it and on white
constexpr const char* kCurveColour = "#0072b2";     // Okabe-Ito blue
constexpr const char* kLocalMinColour = "#d55e00";  // Okabe-Ito vermillion

// The 16-entry viridis table (matplotlib, CC0), sampled at every 17th of its 256 entries.
constexpr std::uint32_t kViridis[16] = {0x440154, 0x481a6c, 0x472f7d, 0x414487, 0x39568c, 0x31688e,
                                        0x2a788e, 0x23888e, 0x1f988b, 0x22a884, 0x35b779, 0x54c568,
                                        0x7ad151, 0xa5db36, 0xd2e21b, 0xfde725};
// Okabe-Ito colours for line plots, in order of use (yellow left out: too light on white).
constexpr const char* kPalette[] = {"#0072b2", "#d55e00", "#009e73", "#cc79a7",
                                    "#e69f00", "#56b4e9", "#000000"};

// ---- text -------------------------------------------------------------------------------

// A coordinate with at most `decimals` decimals; never "nan" or "inf".
std::string Num(double v, int decimals = 2) {
  if (!std::isfinite(v)) v = 0.0;
  v = std::clamp(v, -1e6, 1e6);
  char buffer[48];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, v);
  std::string text = buffer;
  if (text.find('.') != std::string::npos) {
    while (text.back() == '0') text.pop_back();
    if (text.back() == '.') text.pop_back();
  }
  if (text == "-0") text = "0";
  return text;
}

// Exact round-trip value for data attributes; non-finite values never reach here.
std::string Exact(double v) { return std::isfinite(v) ? FormatNumber(v) : "0"; }

using internal::Escape;  // report/markup.h

std::size_t Utf8Length(const std::string& text) {
  std::size_t n = 0;
  for (unsigned char c : text) n += (c & 0xC0) != 0x80;
  return n;
}

double TextWidth(const std::string& text, double font) {
  return static_cast<double>(Utf8Length(text)) * kGlyphWidth * font;
}

// Cuts `text` (at a UTF-8 boundary) and appends "..." so it fits `width` px.
std::string FitText(const std::string& text, double width, double font) {
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

std::string AxisTitle(const std::string& name, const std::string& unit) {
  return unit.empty() ? name : name + " (" + unit + ")";
}

struct TextStyle {
  double size = kTickFont;
  const char* anchor = "middle";  // start | middle | end
  bool bold = false;
  double rotate = 0.0;  // degrees about (x, y)
  std::string css_class;
};

void Text(std::string& out, double x, double y, const std::string& text, const TextStyle& style) {
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

std::string Hex(std::uint32_t rgb) {
  char buffer[8];
  std::snprintf(buffer, sizeof buffer, "#%06x", static_cast<unsigned>(rgb & 0xFFFFFF));
  return buffer;
}

// Viridis at f in [0, 1], linearly interpolated between the 16 table entries.
std::string Viridis(double f) {
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
void Widen(double& low, double& high, bool log) {
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
void PlaceScales(const PlotFrame& frame, Scale& xs, Scale& ys) {
  xs.p0 = frame.left;
  xs.p1 = frame.right;
  ys.p0 = frame.bottom;
  ys.p1 = frame.top;
}

std::vector<Tick> AxisTicks(double low, double high, bool log, double length_px,
                            double px_per_tick) {
  const int target = std::max(2, static_cast<int>(length_px / px_per_tick));
  return log ? internal::LogAxisTicks(low, high, target)
             : internal::LinearAxisTicks(low, high, target);
}

double WidestLabel(const std::vector<Tick>& ticks) {
  double widest = 0.0;
  for (const auto& tick : ticks) widest = std::max(widest, TextWidth(tick.label, kTickFont));
  return widest;
}

enum class Side { kBottom, kLeft, kRight };

// Drops the labels that would overlap a kept one: majors are placed first, then minors.
void DropCrowdedLabels(std::vector<Tick>& ticks, const std::vector<double>& centre,
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
void DrawAxis(std::string& out, Side side, const Scale& scale, const std::vector<Tick>& ticks,
              double at, double grid_from = 0.0, double grid_to = 0.0) {
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

std::string Header(int width, int height) {
  const std::string w = std::to_string(width), h = std::to_string(height);
  return "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + w + "\" height=\"" + h +
         "\" viewBox=\"0 0 " + w + " " + h +
         "\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"" + w + "\" height=\"" +
         h + "\" fill=\"#ffffff\"/>\n";
}

void Title(std::string& out, int width, const std::string& title) {
  if (title.empty()) return;
  TextStyle style;
  style.size = kTitleFont;
  style.bold = true;
  style.css_class = "title";
  style.anchor = "middle";
  Text(out, width / 2.0, 24, FitText(title, width - 20.0, kTitleFont), style);
}

std::string MessageSvg(int width, int height, const std::string& title,
                       const std::string& message) {
  std::string out = Header(width, height);
  Title(out, width, title);
  TextStyle style;
  style.size = kLabelFont;
  Text(out, width / 2.0, height / 2.0, message, style);
  return out + "</svg>\n";
}

std::string HatchPattern(const std::string& id) {
  return "<pattern id=\"" + id +
         "\" width=\"6\" height=\"6\" patternUnits=\"userSpaceOnUse\" "
         "patternTransform=\"rotate(45)\"><rect width=\"6\" height=\"6\" fill=\"#d4d4d4\"/>"
         "<line x1=\"0\" y1=\"0\" x2=\"0\" y2=\"6\" stroke=\"#8a8a8a\" stroke-width=\"2\"/>"
         "</pattern>\n";
}

std::string FrameRect(double x0, double y0, double x1, double y1) {
  return "<rect class=\"plot-area\" x=\"" + Num(x0) + "\" y=\"" + Num(y0) + "\" width=\"" +
         Num(x1 - x0) + "\" height=\"" + Num(y1 - y0) + "\" fill=\"none\" stroke=\"" +
         kFrameColour + "\" stroke-width=\"1\"/>\n";
}

TextStyle AxisTitleStyle() {
  TextStyle style;
  style.size = kLabelFont;
  style.css_class = "axis-label";
  return style;
}

// The x axis title, `gap` px below the x tick labels.
void XAxisTitle(std::string& out, const PlotFrame& frame, double gap, const std::string& title) {
  Text(out, (frame.left + frame.right) / 2, frame.bottom + 5 + 3 + kTickFont + gap + kLabelFont - 2,
       title, AxisTitleStyle());
}

// The y axis title, turned, at the left edge of the image.
void YAxisTitle(std::string& out, const PlotFrame& frame, const std::string& title) {
  TextStyle style = AxisTitleStyle();
  style.rotate = -90;
  Text(out, 10 + kLabelFont - 2, (frame.top + frame.bottom) / 2, title, style);
}

// Five-pointed star of outer radius r around (x, y) as polygon points.
std::string StarPoints(double x, double y, double r) {
  std::string points;
  for (int k = 0; k < 10; ++k) {
    const double angle = -std::numbers::pi / 2 + k * std::numbers::pi / 5,
                 radius = k % 2 == 0 ? r : r * 0.45;
    if (k > 0) points += " ";
    points += Num(x + radius * std::cos(angle), 1) + "," + Num(y + radius * std::sin(angle), 1);
  }
  return points;
}

std::string StarShape(double x, double y, double r) {
  const std::string points = StarPoints(x, y, r);
  return "<polygon points=\"" + points +
         "\" fill=\"none\" stroke=\"#000000\" stroke-opacity=\"0.55\" stroke-width=\"3.5\" "
         "stroke-linejoin=\"round\"/><polygon points=\"" +
         points + "\" fill=\"" + kMinimumFill +
         "\" stroke=\"#ffffff\" stroke-width=\"1.4\" stroke-linejoin=\"round\"/>";
}

std::string RingShape(double x, double y, double r, bool on_dark) {
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
void LabelBox(std::string& out, double x, double y, const std::vector<std::string>& lines,
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

double LegendWidth(const LegendItem& item) { return 30 + TextWidth(item.text, kTickFont) + 18; }

// The legend's items in rows of at most `width` px (a wider item gets a row of its own).
std::vector<std::vector<const LegendItem*>> LegendLayout(const std::vector<LegendItem>& items,
                                                         double width) {
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

int LegendRows(const std::vector<LegendItem>& items, double width) {
  return static_cast<int>(LegendLayout(items, width).size());
}

void DrawLegend(std::string& out, const std::vector<LegendItem>& items, double centre_x, double y,
                double width) {
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

std::string HatchSwatch(const std::string& pattern_id) {
  return "<rect x=\"-9\" y=\"-6\" width=\"18\" height=\"12\" fill=\"url(#" + pattern_id +
         ")\" stroke=\"#8a8a8a\" stroke-width=\"0.6\"/>";
}

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
