// The step of a quantised column (QuantisationStep, include/blmd/ident/optimizers/noise_model.h):
// an encoder's or a converter's lattice is found, and a column printed with a fixed number of
// decimals is not mistaken for one whose step is the rounding of its text.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "blmd/ident/optimizers/noise_model.h"

namespace blmd {
namespace {

TEST(QuantisationStep, FindsAnEncodersCount) {
  // 10 000 counts per revolution, a shaft turning back and forth over three turns.
  const double q = 2.0 * 3.141592653589793 / 10000.0;
  std::vector<double> theta;
  for (int k = 0; k < 2000; ++k) {
    const double angle = 3.0 * std::sin(0.01 * k) * 6.283185307179586;
    theta.push_back(q * std::round(angle / q));
  }
  EXPECT_NEAR(QuantisationStep(theta), q, 1e-9 * q);  // gaps of ~19 rad values: ~1e-14 of rounding
}

TEST(QuantisationStep, ATorquePrintedToSixDecimalsHasNoStepOfItsRounding) {
  // A smooth torque written with "%.6f" and read back: its values differ by multiples of
  // 1e-6 as printed, and by a few 1e-17 where two texts parse to neighbouring doubles. That
  // last difference is no physical step (it was reported as a quantum of 3.47e-18).
  std::vector<double> u;
  for (int k = 0; k < 5000; ++k) {
    char text[64];
    std::snprintf(text, sizeof text, "%.6f", 0.3 * std::sin(0.002 * k) + 0.1 * std::sin(0.05 * k));
    u.push_back(std::strtod(text, nullptr));
  }
  // Two values one ulp apart, as two printers' rounding gives.
  u.push_back(0.1);
  u.push_back(std::nextafter(0.1, 1.0));
  const double q = QuantisationStep(u);
  EXPECT_TRUE(q == 0.0 || q >= 0.99e-6) << "step " << q;
}

}  // namespace
}  // namespace blmd
