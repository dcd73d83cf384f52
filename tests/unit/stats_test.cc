// The residual statistics of ident/residual/stats.h: the regularised upper incomplete gamma
// (Boost.Math) against closed forms, its limits, and the Ljung-Box p-value built on it.
#include "blmd/ident/residual/stats.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <iostream>
#include <vector>

#include "blmd/random.h"

namespace blmd {
namespace {

TEST(GammaQ, EqualsClosedForms) {
  for (double x : {1e-6, 0.01, 0.5, 1.0, 3.7, 10.0, 50.0, 300.0}) {
    // Q(1, x) = exp(-x); Q(1/2, x) = erfc(sqrt(x)); Q(2, x) = (1 + x) exp(-x).
    EXPECT_NEAR(GammaQ(1.0, x) / std::exp(-x), 1.0, 1e-13) << x;
    EXPECT_NEAR(GammaQ(0.5, x) / std::erfc(std::sqrt(x)), 1.0, 1e-12) << x;
    EXPECT_NEAR(GammaQ(2.0, x) / ((1.0 + x) * std::exp(-x)), 1.0, 1e-13) << x;
  }
  // The chi-square survival with 2 degrees of freedom is exp(-x/2); with 1, erfc(sqrt(x/2)).
  EXPECT_NEAR(ChiSquareSurvival(5.991464547107979, 2.0), 0.05, 1e-15);
  EXPECT_NEAR(ChiSquareSurvival(3.841458820694124, 1.0), 0.05, 1e-14);
  // 20 lags (Ljung-Box's default): the 95 % point of chi-square(20) is 31.410432844230918.
  EXPECT_NEAR(ChiSquareSurvival(31.410432844230918, 20.0), 0.05, 1e-14);
}

TEST(GammaQ, LimitsAndOutsideTheDomain) {
  EXPECT_EQ(GammaQ(3.0, 0.0), 1.0);
  EXPECT_EQ(GammaQ(3.0, -2.0), 1.0);
  EXPECT_EQ(GammaQ(3.0, INFINITY), 0.0);
  EXPECT_EQ(GammaQ(3.0, 1e6), 0.0);  // underflows to 0, never below
  EXPECT_TRUE(std::isnan(GammaQ(0.0, 1.0)));
  EXPECT_TRUE(std::isnan(GammaQ(-1.0, 1.0)));
  EXPECT_TRUE(std::isnan(GammaQ(2.0, NAN)));
}

// The test's size on white noise: p < 0.05 on about 5 % of 400 Gaussian series (the binomial
// 99.9 % range is 8..36 of 400), and a random walk is never white.
TEST(LjungBox, FalseAlarmRateOnWhiteNoiseAndPowerOnARandomWalk) {
  int false_alarms = 0;
  for (std::uint64_t seed = 1; seed <= 400; ++seed) {
    Random random(seed);
    std::vector<double> white, walk;
    double sum = 0.0;
    for (int k = 0; k < 1000; ++k) {
      white.push_back(random.Normal());
      sum += white.back();
      walk.push_back(sum);
    }
    const LjungBox w = LjungBoxTest(white, 20);
    ASSERT_EQ(w.lags, 20);
    EXPECT_EQ(w.p_value, ChiSquareSurvival(w.q, 20.0));
    if (w.p_value < 0.05) ++false_alarms;
    EXPECT_LT(LjungBoxTest(walk, 20).p_value, 1e-12) << seed;
  }
  std::cout << "Ljung-Box false alarms at 5 %: " << false_alarms << " of 400\n";
  EXPECT_GE(false_alarms, 8);
  EXPECT_LE(false_alarms, 36);
}

}  // namespace
}  // namespace blmd
