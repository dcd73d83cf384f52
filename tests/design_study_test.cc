// Calibration of blmd-design's predictions (docs/design.md §4): on the Ganesh DC servo
// (configs/ganesh-square.json, J and B free, i and w observed), the predicted 95 % half-widths
// of J and B against the spread of the estimates over 50 simulated noisy experiments (white
// Gaussian noise sigma_i = 0.014 A, sigma_w = 2.5 rad/s, 1 % of the square wave's peaks as
// in testdata/ganesh-square.csv; each fitted with the ceres method from the config's start J = B = 1e-5), for the
// default square wave (+-12 V, 1 s period, 2 s) and for the design searched within the same
// duration and |u| <= 12 V. The spread is 1.96 x the sample standard deviation of the 50
// estimates. STUDY_RUNS overrides the number of runs.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "blmd/ident/design.h"
#include "blmd/ident/optimizer.h"
#include "blmd/ident/trace_input.h"
#include "blmd/io/config.h"
#include "blmd/random.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

constexpr double kSigmaI = 0.014;  // A
constexpr double kSigmaW = 2.5;   // rad/s

int Runs() { return std::getenv("STUDY_RUNS") ? std::atoi(std::getenv("STUDY_RUNS")) : 50; }

struct Spread {
  double ci95_halfwidth[2] = {0.0, 0.0};  // 1.96 x sample std of J and B
  double mean[2] = {0.0, 0.0};
  int converged = 0;
};

// `runs` noisy experiments with `input`, each fitted with ceres.
Spread MeasureSpread(const DesignProblem& problem, const InputSignal& input, int runs) {
  const std::vector<double> times = [&] {
    Experiment e;
    e.duration = 2.0;
    e.sample_rate = problem.config.experiment.sample_rate;
    return e.SampleTimes();
  }();
  Trace clean;
  EXPECT_TRUE(SimulateSampledInput(problem, input, times, &clean).ok());
  const Config& config = problem.config;
  std::vector<double> estimates[2];
  Spread spread;
  for (int run = 0; run < runs; ++run) {
    Random random(1000u + static_cast<std::uint64_t>(run));
    Trace noisy = clean;
    for (double& v : noisy.Column("i")) v += kSigmaI * random.Normal();
    for (double& v : noisy.Column("w")) v += kSigmaW * random.Normal();
    std::vector<FitTrace> traces;
    traces.push_back(RecordedFitTrace(std::move(noisy), config.experiment.initial));
    const FitProblem fit(config, std::move(traces), {"i", "w"},
                         MakeFreeParameters(config, {"J", "B"}));
    OptimizerOptions options;
    options.threads = 2;
    const FitResult result = FindOptimizer("ceres").Minimize(fit, options);
    spread.converged += result.summary.converged;
    for (int k = 0; k < 2; ++k) estimates[k].push_back(result.values[static_cast<std::size_t>(k)]);
  }
  for (int k = 0; k < 2; ++k) {
    double sum = 0.0, sum2 = 0.0;
    for (double v : estimates[k]) sum += v;
    const double mean = sum / runs;
    for (double v : estimates[k]) sum2 += (v - mean) * (v - mean);
    spread.mean[k] = mean;
    spread.ci95_halfwidth[k] = 1.959963984540054 * std::sqrt(sum2 / (runs - 1));
  }
  return spread;
}

DesignProblem GaneshProblem() {
  DesignProblem problem = MakeDesignProblem(LoadConfig(SourcePath("configs/ganesh-square.json")));
  problem.sigma = {kSigmaI, kSigmaW};
  return problem;
}

DesignOptions Options() {
  DesignOptions options;
  options.duration = 2.0;
  options.sample_rate = 2000.0;
  options.input_limit = 12.0;
  return options;
}

void Report(const char* what, const PrecisionPrediction& predicted, const Spread& spread,
            int runs) {
  const char* names[2] = {"J", "B"};
  for (int k = 0; k < 2; ++k) {
    std::printf("%s %s: predicted half-width %.4g, measured 1.96*std %.4g over %d runs (ratio "
                "%.3f), mean %.5g; Cramer-Rao %.4g\n",
                what, names[k], predicted.ci95_halfwidth[static_cast<std::size_t>(k)],
                spread.ci95_halfwidth[k], runs,
                predicted.ci95_halfwidth[static_cast<std::size_t>(k)] / spread.ci95_halfwidth[k],
                spread.mean[k], predicted.cramer_rao_ci95_halfwidth[static_cast<std::size_t>(k)]);
  }
}

TEST(DesignStudy, PredictionsMatchTheSpreadAndTheDesignNarrowsJ) {
  const DesignProblem problem = GaneshProblem();
  const int runs = Runs();
  // The default: the config's own square wave.
  DesignCandidate square;
  square.family = "square";
  square.input = problem.config.experiment.input;
  square = EvaluateCandidate(problem, Options(), square);
  ASSERT_TRUE(square.feasible) << square.rejected;
  const Spread square_spread = MeasureSpread(problem, square.input, runs);
  Report("square", square.prediction, square_spread, runs);

  const DesignResult design = SearchDesign(problem, Options());
  ASSERT_TRUE(design.ok) << design.reason;
  std::printf("design: %s, %ld candidates, criterion %.4g (square %.4g)\n",
              design.best.family.c_str(), design.evaluated, design.best.criterion,
              square.criterion);
  const Spread design_spread = MeasureSpread(problem, design.best.input, runs);
  Report("design", design.best.prediction, design_spread, runs);

  EXPECT_EQ(square_spread.converged, runs);
  EXPECT_EQ(design_spread.converged, runs);
  for (int k = 0; k < 2; ++k) {
    const auto j = static_cast<std::size_t>(k);
    EXPECT_NEAR(square.prediction.ci95_halfwidth[j] / square_spread.ci95_halfwidth[k], 1.0, 0.25)
        << (k ? "B" : "J") << " square";
    EXPECT_NEAR(design.best.prediction.ci95_halfwidth[j] / design_spread.ci95_halfwidth[k], 1.0,
                0.25)
        << (k ? "B" : "J") << " design";
  }
  // The designed experiment narrows J at least twice, by the measured spread.
  EXPECT_GE(square_spread.ci95_halfwidth[0] / design_spread.ci95_halfwidth[0], 2.0);
}

}  // namespace
}  // namespace blmd::testing
