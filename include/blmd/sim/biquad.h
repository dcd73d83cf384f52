// One second-order section of a digital filter, y = (b0 + b1 z^-1 + b2 z^-2) /
// (1 + a1 z^-1 + a2 z^-2) x: its coefficients, its response and a runner in the transposed
// direct form II. Used by the drive's notch (notch_filter.h) and the identification's
// low-pass filters (ident/fit/equation_error.h).
#pragma once

#include <complex>

namespace blmd {

struct Biquad {
  double b0 = 1.0, b1 = 0.0, b2 = 0.0, a1 = 0.0, a2 = 0.0;
  // The section's response at z.
  std::complex<double> At(std::complex<double> z) const {
    const std::complex<double> zi = 1.0 / z;
    return (b0 + zi * (b1 + zi * b2)) / (1.0 + zi * (a1 + zi * a2));
  }
};

// A Biquad run sample by sample, transposed direct form II: y = b0 x + s1,
// s1 <- b1 x − a1 y + s2, s2 <- b2 x − a2 y (from rest).
class BiquadRunner {
 public:
  BiquadRunner() = default;
  explicit BiquadRunner(const Biquad& section) : c_(section) {}
  // The output for input x without advancing the section.
  double Peek(double x) const { return c_.b0 * x + s1_; }
  // The output for input x, the section advanced one sample.
  double Step(double x) {
    const double y = c_.b0 * x + s1_;
    s1_ = c_.b1 * x - c_.a1 * y + s2_;
    s2_ = c_.b2 * x - c_.a2 * y;
    return y;
  }

 private:
  Biquad c_;
  double s1_ = 0.0, s2_ = 0.0;
};

}  // namespace blmd
