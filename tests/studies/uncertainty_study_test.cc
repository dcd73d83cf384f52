// Calibration of the 95 % intervals on random motors (docs/uncertainty.md): Ganesh-type DC
// servos with random R, L, Kt = Kb, J, B, driven by a +-12 V square wave of eight
// electromechanical time constants, J and B free, 1 % noise (sigma = 1 % of the column's peak)
// on i and w, white or AR(1) with coefficient 0.95. Counts how often the headline interval
// (prewhitened HAC sandwich) and the white-noise interval (Ceres's covariance) cover the
// truth, and the median half-width over the median absolute error (ideal 1.96/0.674 = 2.9).
// STUDY_SEEDS overrides the number of motors (default 100 per noise kind).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "blmd/ident/fit/problem.h"
#include "blmd/ident/optimizers/optimizer.h"
#include "blmd/io/config.h"
#include "blmd/random.h"
#include "blmd/run.h"
#include "support/random_motor.h"

namespace blmd::testing {
namespace {

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

struct Calibration {
  int runs = 0;
  int covered[2] = {0, 0};        // headline interval, J and B
  int covered_white[2] = {0, 0};  // white interval
  // Relative to the truth (random motors differ in precision by orders of magnitude, so
  // absolute widths are not comparable); per run: half-width / |error| (ideal median 2.9).
  std::vector<double> error[2], half[2], half_white[2], per_run[2], per_run_white[2];
};

Calibration Study(double rho, int seeds) {
  Calibration c;
  for (int seed = 1; seed <= seeds; ++seed) {
    Random random(static_cast<std::uint64_t>(seed) * 7919u + (rho > 0.0 ? 1u : 0u));
    Motor motor = RandomMotor(random);
    if (std::getenv("STUDY_MOTOR")) {
      Random fixed(static_cast<std::uint64_t>(std::atoi(std::getenv("STUDY_MOTOR"))) * 7919u);
      motor = RandomMotor(fixed);
    }
    const Config config = MotorConfig(motor);
    std::vector<FitTrace> traces;
    traces.push_back(ColouredNoiseTrace(config, random, rho));
    const FitProblem problem(config, std::move(traces), {"i", "w"},
                             MakeFreeParameters(config, {"J", "B"}));
    const FitResult result =
        FindOptimizer(std::getenv("STUDY_METHOD") ? std::getenv("STUDY_METHOD") : "ceres")
            .Minimize(problem, OptimizerOptions{});
    EXPECT_TRUE(result.summary.converged) << "seed " << seed << ": " << result.summary.message;
    ++c.runs;
    const double truth[2] = {motor.J, motor.B};
    for (int k = 0; k < 2; ++k) {
      const ParameterEstimate& e = result.estimates[static_cast<std::size_t>(k)];
      const double error = std::abs(e.value - truth[k]) / truth[k];
      c.error[k].push_back(error);
      if (std::getenv("STUDY_VERBOSE"))
        std::printf("seed %d %s rel %+.3e half %.3e\n", seed, k ? "B" : "J", e.value / truth[k] - 1,
                    0.5 * (e.ci95_high - e.ci95_low) / truth[k]);
      if (e.has_interval) {
        c.covered[k] += e.ci95_low <= truth[k] && truth[k] <= e.ci95_high;
        c.half[k].push_back(0.5 * (e.ci95_high - e.ci95_low) / truth[k]);
        c.per_run[k].push_back(0.5 * (e.ci95_high - e.ci95_low) / truth[k] / error);
      }
      if (e.has_white_interval) {
        c.covered_white[k] += e.ci95_white_low <= truth[k] && truth[k] <= e.ci95_white_high;
        c.half_white[k].push_back(0.5 * (e.ci95_white_high - e.ci95_white_low) / truth[k]);
        c.per_run_white[k].push_back(0.5 * (e.ci95_white_high - e.ci95_white_low) / truth[k] /
                                     error);
      }
    }
  }
  const char* names[2] = {"J", "B"};
  for (int k = 0; k < 2; ++k) {
    std::printf(
        "rho %.2f %s: coverage %d/%d (white %d/%d); median relative half-width / median "
        "relative |error| %.2f (white %.2f); median per-run half-width/|error| %.2f "
        "(white %.2f)\n",
        rho, names[k], c.covered[k], c.runs, c.covered_white[k], c.runs,
        Median(c.half[k]) / Median(c.error[k]), Median(c.half_white[k]) / Median(c.error[k]),
        Median(c.per_run[k]), Median(c.per_run_white[k]));
  }
  return c;
}

int Seeds() { return std::getenv("STUDY_SEEDS") ? std::atoi(std::getenv("STUDY_SEEDS")) : 100; }

// The bars: coverage 90-98 % and median half-width at most 6x the median error.
void ExpectCalibrated(const Calibration& c) {
  for (int k = 0; k < 2; ++k) {
    EXPECT_GE(c.covered[k], 0.90 * c.runs) << (k ? "B" : "J");
    EXPECT_LE(c.covered[k], 0.98 * c.runs) << (k ? "B" : "J");
    EXPECT_LE(Median(c.half[k]) / Median(c.error[k]), 6.0) << (k ? "B" : "J");
  }
}

TEST(IntervalCalibration, RandomMotorsWhiteNoise) { ExpectCalibrated(Study(0.0, Seeds())); }

TEST(IntervalCalibration, RandomMotorsAr1Noise095) { ExpectCalibrated(Study(0.95, Seeds())); }

}  // namespace
}  // namespace blmd::testing
