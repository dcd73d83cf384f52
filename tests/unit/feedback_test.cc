// The feedback test (TestFeedback, include/blmd/ident/residual/diagnostics.h,
// docs/identification.md §9): a residual that later inputs follow marks a closed-loop record;
// an input designed beforehand does not follow the residual, however coloured either is.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "blmd/ident/residual/diagnostics.h"
#include "blmd/random.h"

namespace blmd {
namespace {

// AR(1) noise of coefficient `a`, unit innovation.
std::vector<double> Coloured(Random& random, std::size_t n, double a) {
  std::vector<double> x(n, 0.0);
  for (std::size_t k = 1; k < n; ++k) x[k] = a * x[k - 1] + random.Normal();
  return x;
}

TEST(FeedbackTest, AnInputDesignedBeforehandDoesNotFollowTheResidual) {
  // 20 records: a random binary sequence held for 10 samples (a PRBS-like experiment) and a
  // residual of strongly coloured noise plus a lagged response to the input (a model
  // error): neither makes the later input follow the residual. Family level 1e-3: none
  // flagged.
  int flagged = 0;
  for (int seed = 1; seed <= 20; ++seed) {
    Random random(static_cast<std::uint64_t>(seed));
    const std::size_t n = 4000;
    std::vector<double> u(n), e = Coloured(random, n, 0.95);
    double level = 1.0;
    for (std::size_t k = 0; k < n; ++k) {
      if (k % 10 == 0) level = random.Normal() > 0.0 ? 1.0 : -1.0;
      u[k] = level + 0.1 * random.Normal();
    }
    for (std::size_t k = 5; k < n; ++k) e[k] += 0.5 * u[k - 5];
    const ColumnDiagnostics d = TestFeedback(e, u, 20);
    ASSERT_EQ(d.future_ccf.size(), 20u);
    flagged += d.feedback_p < 1e-3;
  }
  EXPECT_EQ(flagged, 0);
}

TEST(FeedbackTest, ALoopThatReactsToTheMeasuredNoiseIsFound) {
  // u computed from the measured output: u[k] = K (r[k] - y_meas[k - 1]), y_meas = y + e, a
  // smooth reference as a motion profile;
  // the residual e (white here) is what the output error leaves, and later u follows it.
  int found = 0;
  for (int seed = 1; seed <= 20; ++seed) {
    Random random(static_cast<std::uint64_t>(seed) + 100);
    const std::size_t n = 4000;
    std::vector<double> u(n, 0.0), e(n), y(n, 0.0);
    for (std::size_t k = 0; k < n; ++k) e[k] = 0.1 * random.Normal();
    for (std::size_t k = 1; k < n; ++k) {
      const double r = std::sin(2.0 * 3.141592653589793 * static_cast<double>(k) / 500.0);
      u[k] = 2.0 * (r - (y[k - 1] + e[k - 1]));
      y[k] = 0.9 * y[k - 1] + 0.05 * u[k];
    }
    const ColumnDiagnostics d = TestFeedback(e, u, 20);
    found += d.feedback_p < 1e-3;
    if (d.feedback_p < 1e-3) {
      EXPECT_EQ(d.feedback_peak_lead, 1);  // u[k] reacts to y_meas[k - 1]
    }
  }
  EXPECT_EQ(found, 20);
}

TEST(FeedbackTest, AnInputOfAFewStepsIsNotJudged) {
  // Three steps whiten to three spikes: a slow residual (a model far off) correlates with the
  // samples around each alike, and the chi-squared law does not hold. Not judged.
  Random random(7);
  const std::size_t n = 1000;
  std::vector<double> u(n), e(n);
  for (std::size_t k = 0; k < n; ++k) {
    u[k] = k < 100 ? 0.0 : (k < 500 ? 4.0 : (k < 900 ? 6.0 : 0.0));
    e[k] = 0.01 * static_cast<double>(k) + 0.01 * random.Normal();
  }
  const ColumnDiagnostics d = TestFeedback(e, u, 20);
  EXPECT_LT(1000.0 / d.feedback_input_kurtosis, kFeedbackMinEvents);
  EXPECT_TRUE(d.future_ccf.empty());
  EXPECT_EQ(d.feedback_p, 1.0);
}

TEST(FeedbackTest, TooShortARecordIsNotJudged) {
  const ColumnDiagnostics d =
      TestFeedback(std::vector<double>(30, 1.0), std::vector<double>(30, 2.0), 20);
  EXPECT_TRUE(d.future_ccf.empty());
  EXPECT_EQ(d.feedback_p, 1.0);
}

}  // namespace
}  // namespace blmd
