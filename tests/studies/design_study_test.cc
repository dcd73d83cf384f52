// Calibration of blmd-design's predictions (docs/design.md §4): on the Ganesh DC servo
// (configs/ganesh-square.json, J and B free, i and w observed), the predicted 95 % half-widths
// of J and B against the spread of the estimates over 50 simulated noisy experiments (white
// Gaussian noise sigma_i = 0.014 A, sigma_w = 2.5 rad/s, 1 % of the square wave's peaks as
// in testdata/ganesh-square.csv; each fitted with the ceres method from the config's start J = B =
// 1e-5), for the default square wave (+-12 V, 1 s period, 2 s) and for the design searched within
// the same duration and |u| <= 12 V. The spread is 1.96 x the sample standard deviation of the 50
// estimates. STUDY_RUNS overrides the number of runs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "blmd/ident/experiment_design/experiment_design.h"
#include "blmd/ident/fit/trace_input.h"
#include "blmd/ident/optimizers/optimizer.h"
#include "blmd/io/config.h"
#include "blmd/random.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

constexpr double kSigmaI = 0.014;  // A
constexpr double kSigmaW = 2.5;    // rad/s

int Runs() { return std::getenv("STUDY_RUNS") ? std::atoi(std::getenv("STUDY_RUNS")) : 50; }

struct Spread {
  double ci95_halfwidth[2] = {0.0, 0.0};  // 1.96 x sample std of J and B
  double q95_error[2] = {0.0, 0.0};       // 95 % quantile of |estimate - truth| (printed only)
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
    std::vector<double> error;
    const double truth = problem.config.parameters.Get(k ? "B" : "J");
    for (double v : estimates[k]) error.push_back(std::abs(v - truth));
    std::sort(error.begin(), error.end());
    spread.q95_error[k] = error[static_cast<std::size_t>(std::ceil(0.95 * runs)) - 1];
    spread.ci95_halfwidth[k] = 1.959963984540054 * std::sqrt(sum2 / (runs - 1));
  }
  return spread;
}

DesignProblem GaneshProblem() {
  DesignProblem problem = MakeDesignProblem(LoadConfig(SourcePath("configs/ganesh-square.json")));
  problem.sigma = {kSigmaI, kSigmaW};
  return problem;
}

// 2 s at |u| <= 12 V (the config's own run), with more limits when given.
ExperimentDesignOptions Options(const std::map<std::string, double>& output_limits = {}) {
  ExperimentDesignOptions options;
  options.duration = 2.0;
  options.sample_rate = 2000.0;
  options.input_limit = 12.0;
  options.output_limits = output_limits;
  return options;
}

void Report(const char* what, const PrecisionPrediction& predicted, const Spread& spread,
            int runs) {
  const char* names[2] = {"J", "B"};
  for (int k = 0; k < 2; ++k) {
    std::printf(
        "%s %s: predicted half-width %.4g, measured 1.96*std %.4g over %d runs (ratio "
        "%.3f; 95 %% quantile of |error| %.4g), mean %.5g; Cramer-Rao %.4g\n",
        what, names[k], predicted.ci95_halfwidth[static_cast<std::size_t>(k)],
        spread.ci95_halfwidth[k], runs,
        predicted.ci95_halfwidth[static_cast<std::size_t>(k)] / spread.ci95_halfwidth[k],
        spread.q95_error[k], spread.mean[k],
        predicted.cramer_rao_ci95_halfwidth[static_cast<std::size_t>(k)]);
  }
}

struct Comparison {
  double predicted_narrowing_j = 0.0;  // default's predicted J half-width / the design's
  double measured_narrowing_j = 0.0;   // the same from the 50-run spreads
};

// The config's square wave (its amplitude lowered, as blmd-design does, to keep within the
// limits) and the design (D-optimal, or A-optimal with a target), each predicted and measured over
// `runs` experiments; the predictions of J and B within 25 % of the measured spread.
Comparison CompareWithDefault(const ExperimentDesignOptions& options) {
  const DesignProblem problem = GaneshProblem();
  const int runs = Runs();
  DesignCandidate square;
  square.family = "config";
  square.input = problem.config.experiment.input;
  square = EvaluateCandidate(problem, options, square);
  EXPECT_TRUE(square.feasible) << square.rejected;
  const ExperimentDesignResult design = SearchDesign(problem, options);
  EXPECT_TRUE(design.ok) << design.reason;
  if (!square.feasible || !design.ok) return {};
  std::printf("default: square, amplitude %.4g V, period %.4g s\n", square.input.amplitude,
              square.input.period);
  std::printf(
      "design: %s, amplitude %.4g V (period %.4g s, dwell %.4g s, levels %d, clock %.4g "
      "s, f %.4g-%.4g Hz), best of %ld\n",
      design.best.family.c_str(), design.best.input.amplitude, design.best.input.period,
      design.best.dwell, design.best.levels, design.best.input.clock, design.best.input.f0,
      design.best.input.f1, design.evaluated);
  const Spread square_spread = MeasureSpread(problem, square.input, runs);
  Report("default", square.prediction, square_spread, runs);
  const Spread design_spread = MeasureSpread(problem, design.best.input, runs);
  Report("design", design.best.prediction, design_spread, runs);
  EXPECT_EQ(square_spread.converged, runs);
  EXPECT_EQ(design_spread.converged, runs);
  for (int k = 0; k < 2; ++k) {
    const auto j = static_cast<std::size_t>(k);
    EXPECT_NEAR(square.prediction.ci95_halfwidth[j] / square_spread.ci95_halfwidth[k], 1.0, 0.25)
        << (k ? "B" : "J") << " default";
    EXPECT_NEAR(design.best.prediction.ci95_halfwidth[j] / design_spread.ci95_halfwidth[k], 1.0,
                0.25)
        << (k ? "B" : "J") << " design";
  }
  Comparison out;
  out.predicted_narrowing_j =
      square.prediction.ci95_halfwidth[0] / design.best.prediction.ci95_halfwidth[0];
  out.measured_narrowing_j = square_spread.ci95_halfwidth[0] / design_spread.ci95_halfwidth[0];
  std::printf("J narrowed %.3fx predicted, %.3fx measured\n", out.predicted_narrowing_j,
              out.measured_narrowing_j);
  return out;
}

// The config's own run: 2 s at |u| <= 12 V, the A-optimal design for J. The config's 1 s square
// wave is close to the best any family reaches here (docs/design.md §4): the design narrows J
// by about 1.1x, and the prediction's narrowing agrees with the measured one.
TEST(DesignStudy, ConfigRunPredictionsMatchTheSpread) {
  ExperimentDesignOptions options = Options();
  options.target = {"J"};
  const Comparison c = CompareWithDefault(options);
  EXPECT_GE(c.predicted_narrowing_j, 1.0);
  EXPECT_NEAR(c.measured_narrowing_j / c.predicted_narrowing_j, 1.0, 0.25);
}

// A limited travel, |theta| <= 20 rad (about three turns) in the same 2 s at |u| <= 12 V: the
// square wave must lower its amplitude to 2.3 V to stay within it; the design narrows J at
// least twice, by the measured spread.
TEST(DesignStudy, LimitedTravelDesignNarrowsJTwice) {
  const Comparison c = CompareWithDefault(Options({{"theta", 20.0}}));
  EXPECT_GE(c.predicted_narrowing_j, 2.0);
  EXPECT_GE(c.measured_narrowing_j, 2.0);
}

// With friction (docs/design.md §7): the Ganesh servo with a Coulomb friction of 10 % of its
// stall torque (Tc = 0.004 N m against Kt 12 V / R = 0.038 N m), J, B and Tc free, 2 s at
// |u| <= 12 V. `input`'s predicted half-widths of all three against the spread of 50 noisy
// experiments fitted from the truth with Ceres; the ratios (predicted / measured).
std::vector<double> FrictionRatios(const DesignProblem& problem, const InputSignal& input,
                                   const PrecisionPrediction& predicted) {
  const Config& config = problem.config;
  Experiment e;
  e.duration = 2.0;
  e.sample_rate = config.experiment.sample_rate;
  Trace clean;
  EXPECT_TRUE(SimulateSampledInput(problem, input, e.SampleTimes(), &clean).ok());
  const int runs = Runs();
  std::vector<double> estimates[3];
  int converged = 0;
  for (int run = 0; run < runs; ++run) {
    Random random(5000u + static_cast<std::uint64_t>(run));
    Trace noisy = clean;
    for (double& v : noisy.Column("i")) v += kSigmaI * random.Normal();
    for (double& v : noisy.Column("w")) v += kSigmaW * random.Normal();
    std::vector<FitTrace> traces;
    traces.push_back(RecordedFitTrace(std::move(noisy), config.experiment.initial));
    // Weighted by the columns' noise, as blmd-ident weighs them (docs/identification.md §1a)
    // and as the prediction assumes: the variance weighting is a less efficient estimator,
    // whose spread the inverse Fisher information does not predict.
    traces.back().noise_variance = {{"i", kSigmaI * kSigmaI}, {"w", kSigmaW * kSigmaW}};
    const FitProblem fit(config, std::move(traces), {"i", "w"},
                         MakeFreeParameters(config, {"J", "B", "Tc"}));
    OptimizerOptions options;
    options.threads = 2;
    const FitResult result = FindOptimizer("ceres").Minimize(fit, options);
    converged += result.summary.converged;
    for (std::size_t k = 0; k < 3; ++k) estimates[k].push_back(result.values[k]);
  }
  std::vector<double> ratios;
  for (std::size_t k = 0; k < 3; ++k) {
    double sum = 0.0, sum2 = 0.0;
    for (double v : estimates[k]) sum += v;
    const double mean = sum / runs;
    for (double v : estimates[k]) sum2 += (v - mean) * (v - mean);
    const double measured = 1.959963984540054 * std::sqrt(sum2 / (runs - 1));
    std::printf(
        "  %s: predicted half-width %.4g, measured 1.96*std %.4g over %d runs (ratio "
        "%.3f), mean %.5g, truth %.5g (%d converged)\n",
        predicted.names[k].c_str(), predicted.ci95_halfwidth[k], measured, runs,
        predicted.ci95_halfwidth[k] / measured, mean, config.parameters.Get(predicted.names[k]),
        converged);
    ratios.push_back(predicted.ci95_halfwidth[k] / measured);
  }
  return ratios;
}

// The config's square wave (+-12 V, 1 s period): every prediction within 25 % of the measured
// spread of the noise-weighted fits (measured 2026-12-01: 0.995, 0.878, 0.883). The D-optimal
// search picks a PRBS there, whose B and Tc predictions are about 30 % optimistic (0.94, 0.68,
// 0.70; docs/design.md §7: the fixed-step simulation's friction reversals make the
// finite-difference sensitivities depend on the step), printed, not asserted.
TEST(DesignStudy, PredictionsWithCoulombFrictionMatchTheSpread) {
  Config config = LoadConfig(SourcePath("configs/ganesh-square.json"));
  ParameterSet friction;
  friction.Set("Tc", 0.004);
  config.AddEffect("coulomb_friction", friction);
  config.identification.free = {"J", "B", "Tc"};
  config.identification.bounds["Tc"] = {1e-5, 0.05};
  DesignProblem problem = MakeDesignProblem(config);
  problem.sigma = {kSigmaI, kSigmaW};
  DesignCandidate square;
  square.family = "config";
  square.input = config.experiment.input;
  square = EvaluateCandidate(problem, Options(), square);
  ASSERT_TRUE(square.feasible) << square.rejected;
  ASSERT_EQ(square.prediction.names, (std::vector<std::string>{"J", "B", "Tc"}));
  std::printf("the config's square wave, amplitude %.4g V:\n", square.input.amplitude);
  const std::vector<double> ratios = FrictionRatios(problem, square.input, square.prediction);
  for (std::size_t k = 0; k < 3; ++k)
    EXPECT_NEAR(ratios[k], 1.0, 0.25) << square.prediction.names[k];
  if (std::getenv("STUDY_DESIGN_WITH_FRICTION")) {
    const ExperimentDesignResult design = SearchDesign(problem, Options());
    ASSERT_TRUE(design.ok) << design.reason;
    std::printf("the design: %s, amplitude %.4g V, best of %ld:\n", design.best.family.c_str(),
                design.best.input.amplitude, design.evaluated);
    FrictionRatios(problem, design.best.input, design.best.prediction);
  }
}

}  // namespace
}  // namespace blmd::testing
