// SVG plots' axis ticks, number labels and min/max decimation (docs/plots.md).
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
#include "blmd/report/svg/plot.h"
#include "report/markup.h"
#include "report/svg/plot_ticks.h"

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

}  // namespace blmd
