// The screening grid (src/ident/discovery/screening.h, docs/discovery.md §3c): discovery screens
// its candidates on a coarser fixed step where that simulates the model as the config's step
// does, and nowhere else.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "blmd/ident/discovery/discovery.h"
#include "blmd/ident/fit/trace_input.h"
#include "blmd/ident/optimizers/optimizer.h"
#include "blmd/ident/residual/adequacy.h"
#include "blmd/ident/residual/diagnostics.h"
#include "blmd/io/config.h"
#include "ident/discovery/effect_search.h"
#include "ident/discovery/screening.h"
#include "support/test_support.h"

namespace blmd {
namespace {

// testdata/dc-hidden-coulomb.csv: the Ganesh servo of configs/ganesh-square.json (dt 1e-5 s,
// 2 kHz samples: 50 steps per sample) with a Coulomb friction of 0.012 N·m the config does
// not declare, noise of sigma 0.0114 A on i and 1.70 rad/s on w (its header), weighted by that
// noise as blmd-ident weighs it. `clean`: the same record simulated without noise.
FitProblem HiddenCoulomb(bool clean = false) {
  const Config config = LoadConfig(testing::SourcePath("configs/ganesh-square.json"));
  TraceInputOptions options;
  options.required = {"i", "w"};
  FitTrace trace = LoadFitTrace(testing::SourcePath("testdata/dc-hidden-coulomb.csv"), options,
                                config.experiment.initial);
  if (clean) {
    ParameterSet friction;
    friction.Set("Tc", 0.012);
    trace = RecordedFitTrace(testing::SimulateWithEffect(config, "coulomb_friction", friction),
                             config.experiment.initial);
  } else {
    trace.noise_variance = {{"i", 0.01140309139194024 * 0.01140309139194024},
                            {"w", 1.6971699355573617 * 1.6971699355573617}};
  }
  std::vector<FitTrace> traces;
  traces.push_back(std::move(trace));
  return FitProblem(config, std::move(traces), {"i", "w"}, MakeFreeParameters(config, {"J", "B"}));
}

// The J, B fit of `problem` and the screening grid it allows.
struct FittedGrid {
  FitResult fit;
  internal::ScreeningGrid grid;
};
FittedGrid FitAndGrid(const FitProblem& problem) {
  FittedGrid out;
  out.fit = FindOptimizer("ceres").Minimize(problem, OptimizerOptions{});
  EXPECT_TRUE(out.fit.evaluation.ok);
  out.grid = internal::ChooseScreeningGrid(problem, out.fit.values, NoiseFloorNrmse(problem));
  return out;
}

TEST(ScreeningGrid, NoisyServoIsScreenedTenStepsAtATimeAndTheFrictionFoundOnIt) {
  const FitProblem problem = HiddenCoulomb();
  const auto [fit, grid] = FitAndGrid(problem);
  // 50 steps per sample, at least 4 steps per sample: the divisors 10, 5 and 2 are tried, and
  // the model without friction (linear) simulates alike on each.
  ASSERT_EQ(grid.levels(), 3);
  EXPECT_EQ(grid.Factor(0), 10);
  EXPECT_EQ(grid.Factor(1), 5);
  EXPECT_EQ(grid.Factor(2), 2);
  EXPECT_DOUBLE_EQ(grid.Step(0, 1e-5), 1e-4);
  EXPECT_EQ(grid.Factor(-1), 1);
  // The Coulomb candidate at a typical size simulates on the coarsest level as well.
  const ResidualAnalysis analysis = AnalyseResidual(problem, fit.values);
  const internal::CandidatePlan plan =
      internal::PlanCandidate("coulomb_friction", grid.Problem(0, problem), analysis, fit.values);
  EXPECT_EQ(grid.LevelFor(problem, fit.values, plan, nullptr), 0);
  // Screened on it, the friction lowers BIC as on the config's step, and the refit's start is
  // the one the config's step gives, each within 10 %.
  const double bic = Bic(problem, fit.evaluation, problem.num_free());
  const internal::CandidateRun run = internal::ScreenCandidate(grid.Problem(0, problem), fit.values,
                                                               plan, grid.Bic(0, bic), nullptr);
  const internal::CandidatePlan fine_plan =
      internal::PlanCandidate("coulomb_friction", problem, analysis, fit.values);
  const internal::CandidateRun fine =
      internal::ScreenCandidate(problem, fit.values, fine_plan, bic, nullptr);
  std::cout << "screening BIC " << run.screen_bic << " (config's step: " << fine.screen_bic
            << "), Tc " << run.screen_values[2] << " (" << fine.screen_values[2] << ")\n";
  // (measured: -14724 against -14116, Tc 0.00971 against 0.01033 N·m)
  EXPECT_LT(run.screen_bic, -1000.0);
  EXPECT_NEAR(run.screen_bic / fine.screen_bic, 1.0, 0.1);
  ASSERT_EQ(run.screen_values.size(), 3u);
  EXPECT_NEAR(run.screen_values[2] / fine.screen_values[2], 1.0, 0.1);
  // On one step per sample (factor 50, the step the grid refuses) the friction is found too
  // (measured: BIC -12943). Its cost was a staircase there, on which the local searches
  // stalled (BIC > 0), while a shaft that stopped inside a step broke away backwards only at
  // the next: the reversal's instant, and the cost, jumped by a step whenever the stop
  // crossed a step boundary (ShaftEffects::StopInStep).
  const FitProblem coarse = problem.WithStep(50 * 1e-5);
  const Evaluation at = coarse.Evaluate(fit.values);
  const internal::CandidatePlan coarse_plan =
      internal::PlanCandidate("coulomb_friction", coarse, analysis, fit.values);
  const internal::CandidateRun stalled = internal::ScreenCandidate(
      coarse, fit.values, coarse_plan, Bic(coarse, at, coarse.num_free()), nullptr);
  EXPECT_LT(stalled.screen_bic, -1000.0);
}

// Sampled unevenly (the time stamps moved by ±0.123 ms in turn: the shortest interval 0.254 ms,
// 25.4 steps), the factors are the largest that leaves 4 steps, 6, and its halving, 3.
TEST(ScreeningGrid, UnevenSamplingTriesTheLargestFactorAndItsHalvings) {
  const FitProblem even = HiddenCoulomb();
  std::vector<FitTrace> traces = even.traces();
  std::vector<double>& t = traces[0].trace.Column("t");
  for (std::size_t k = 1; k + 1 < t.size(); ++k) t[k] += (k % 2 == 0 ? 1.23e-4 : -1.23e-4);
  traces[0].input.times = t;
  const FitProblem uneven(even.config(), traces, even.observe(), even.free());
  const internal::ScreeningGrid grid = FitAndGrid(uneven).grid;
  ASSERT_EQ(grid.levels(), 2);
  EXPECT_EQ(grid.Factor(0), 6);
  EXPECT_EQ(grid.Factor(1), 3);
}

TEST(ScreeningGrid, NoiseFreeDataAndTheEventsMethodKeepTheConfigsStep) {
  const FitProblem clean = HiddenCoulomb(/*clean=*/true);
  const FitResult fit = FindOptimizer("ceres").Minimize(clean, OptimizerOptions{});
  // Noise-free, the reference is the model's cost; a linear model misses the friction by far
  // more than any step's error, so the reference is the noise's: zero, nothing to hide in.
  EXPECT_EQ(internal::ChooseScreeningGrid(clean, fit.values, 0.0).levels(), 0);
  // A fixed step is what the grid coarsens: the events method has none.
  Config events = clean.config();
  events.simulation.method = SimulationMethod::kEvents;
  const FitProblem on_events(events, clean.traces(), clean.observe(), clean.free());
  EXPECT_EQ(internal::ChooseScreeningGrid(on_events, fit.values, 0.01).levels(), 0);
}

}  // namespace
}  // namespace blmd
