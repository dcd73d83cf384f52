// Private helper shared by the fixed-step models: the instant at which a step reads its
// zero-order-hold input.
//
// A step [t, t + dt) holds the input it reads just after its midpoint. An input change on the
// step grid (t_start + k dt, the usual case of a simulated experiment) then takes effect in
// the step that starts there, whatever the rounding of t. The read is not exactly at the
// midpoint because recorded time stamps can fall there: stamps in whole microseconds with a
// start of 796 us and dt = 100 us put about one sample in a hundred on a midpoint, and then
// the last bit of t + dt / 2 (an FMA build rounds t = t_start + k dt once, others twice)
// decided in which of two steps the new sample took effect: the same record gave the two
// builds costs 1e-3 apart.
// 2^-20 dt past the midpoint lies far from any stamp with a few significant digits, so the
// step a sample takes effect in no longer depends on the last bit.
#pragma once

namespace blmd::internal {

// The read instant as a fraction of the step: 0.5 + 2^-20 (exact in binary).
inline constexpr double kInputReadFraction = 0.5 + 0x1p-20;

// The instant, in s, at which the step that starts at t (s) with length dt (s) reads its input.
inline double InputReadTime(double t, double dt) { return t + kInputReadFraction * dt; }

}  // namespace blmd::internal
