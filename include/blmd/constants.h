// The constants every layer shares, defined once: π and its multiples, and the unit factors
// between the units a recorder may use and the model's SI units (rad, rad/s).
#pragma once

#include <numbers>

namespace blmd {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kTwoPi = 2.0 * std::numbers::pi;
inline constexpr double kRadiansPerDegree = std::numbers::pi / 180.0;
inline constexpr double kDegreesPerRadian = 180.0 / std::numbers::pi;
// 1 rad/s is 60 / (2π) rev/min.
inline constexpr double kRpmPerRadPerSecond = 60.0 / (2.0 * std::numbers::pi);

}  // namespace blmd
