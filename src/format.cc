#include "blmd/format.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace blmd {

std::string FormatRoundTrip(double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

std::string FormatExact17(double value) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.17g", value);
  return buffer;
}

std::string FormatSignificant(double value, int digits) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*g", digits, value);
  return text;
}

std::string FormatSignificantOrWord(double value, int digits) {
  if (!std::isfinite(value))
    return std::isinf(value) ? (value > 0 ? "infinite" : "-infinite") : "n/a";
  return FormatSignificant(value, digits);
}

std::string FormatReadable(double value, int digits) {
  if (!std::isfinite(value)) return "n/a";
  char buffer[64];
  const double a = std::abs(value);
  const bool exponent_form = a != 0.0 && (a < 1e-3 || a >= 1e6);
  std::snprintf(buffer, sizeof buffer, exponent_form ? "%.*e" : "%.*g",
                exponent_form ? digits - 1 : digits, value);
  std::string text = buffer;
  const auto e = text.find('e');
  if (e == std::string::npos) return text;
  std::string mantissa = text.substr(0, e);  // compact: no trailing zeros, no exponent padding
  if (mantissa.find('.') != std::string::npos) {
    while (mantissa.back() == '0') mantissa.pop_back();
    if (mantissa.back() == '.') mantissa.pop_back();
  }
  return mantissa + "e" + std::to_string(std::atoi(text.c_str() + e + 1));
}

std::string FormatFixedTrimmed(double value, int decimals) {
  if (!std::isfinite(value)) value = 0.0;
  value = std::clamp(value, -1e6, 1e6);
  char buffer[48];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
  std::string text = buffer;
  if (text.find('.') != std::string::npos) {
    while (text.back() == '0') text.pop_back();
    if (text.back() == '.') text.pop_back();
  }
  if (text == "-0") text = "0";
  return text;
}

std::string DisplayNumber(double value) {
  std::string shortest = FormatRoundTrip(value);
  char buffer[400];
  const auto result =
      std::to_chars(buffer, buffer + sizeof buffer, value, std::chars_format::fixed);
  if (result.ec != std::errc()) return shortest;
  std::string fixed(buffer, result.ptr);
  return fixed.size() <= shortest.size() + 2 ? fixed : shortest;
}

}  // namespace blmd
