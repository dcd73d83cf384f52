// The noise model behind discovery's evidence (evidence.h): Yule-Walker AR fits with the
// order chosen by BIC, on series whose model is known.
#include "blmd/ident/residual/evidence.h"

#include <gtest/gtest.h>

#include <vector>

#include "blmd/random.h"

namespace blmd {
namespace {

// x_t = a_1 x_{t-1} + ... + a_p x_{t-p} + N(0, 1), after 500 samples of burn-in.
std::vector<double> Autoregressive(const std::vector<double>& a, std::size_t n,
                                   std::uint64_t seed) {
  Random random(seed);
  std::vector<double> x(n + 500, 0.0);
  for (std::size_t t = 0; t < x.size(); ++t) {
    x[t] = random.Normal();
    for (std::size_t j = 0; j < a.size() && j < t; ++j) x[t] += a[j] * x[t - 1 - j];
  }
  return std::vector<double>(x.begin() + 500, x.end());
}

TEST(Autoregression, WhiteNoiseNeedsNoFilter) {
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    EXPECT_TRUE(FitAutoregression(Autoregressive({}, 20000, seed), 8).empty()) << seed;
  }
}

TEST(Autoregression, RecoversFirstAndSecondOrderModels) {
  const std::vector<double> one = FitAutoregression(Autoregressive({0.95}, 20000, 3), 8);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_NEAR(one[0], 0.95, 0.01);
  const std::vector<double> two = FitAutoregression(Autoregressive({0.5, 0.3}, 20000, 4), 8);
  ASSERT_EQ(two.size(), 2u);
  EXPECT_NEAR(two[0], 0.5, 0.03);
  EXPECT_NEAR(two[1], 0.3, 0.03);
}

TEST(Autoregression, ShortOrConstantSeriesAreWhite) {
  EXPECT_TRUE(FitAutoregression({1.0, 2.0, 3.0}, 8).empty());
  EXPECT_TRUE(FitAutoregression(std::vector<double>(100, 4.0), 8).empty());
}

}  // namespace
}  // namespace blmd
