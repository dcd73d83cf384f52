// Private: float-to-integer conversion of values that nothing bounds by construction.
#pragma once

#include <cmath>
#include <limits>
#include <type_traits>

namespace blmd::internal {

// `value` rounded toward zero and clamped to T's range; NaN gives `if_nan`. A plain
// static_cast of a double outside the target's range (or of NaN) is undefined behaviour
// ([conv.fpint]); scripts/sanitize's clang run (-fsanitize=float-cast-overflow) catches any
// that is left. Use it wherever the double comes from data (a speed, an angle span, a ratio
// of measured quantities) rather than from a validated setting.
template <typename T>
T SaturatingCast(double value, T if_nan = T{0}) {
  static_assert(std::is_integral_v<T>);
  if (std::isnan(value)) return if_nan;
  // The limits as doubles: the lowest is exact (a power of two or 0); the highest may round
  // up to a power of two that T cannot hold, so the comparison is >=.
  constexpr double kLow = static_cast<double>(std::numeric_limits<T>::lowest());
  constexpr double kHigh = static_cast<double>(std::numeric_limits<T>::max());
  if (value <= kLow) return std::numeric_limits<T>::lowest();
  if (value >= kHigh) return std::numeric_limits<T>::max();
  return static_cast<T>(value);
}

}  // namespace blmd::internal
