// Leave-one-trace-out intervals (include/blmd/ident/optimizers/trace_jackknife.h): the
// spread between traces enters the intervals. Four traces of the Ganesh servo (square wave, 1 %
// white noise on i and w), each with its own damping B drawn around a population value, as
// the runs of a real rig differ (direction, temperature). The pooled fit's HAC interval
// describes the noise only; the jackknife over traces must cover the population value.
#include "blmd/ident/optimizers/trace_jackknife.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "blmd/ident/fit/problem.h"
#include "blmd/ident/fit/trace_input.h"
#include "blmd/ident/optimizers/optimizer.h"
#include "blmd/io/config.h"
#include "blmd/random.h"
#include "blmd/run.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

FitTrace NoisyTrace(const Config& truth, Random& random) {
  Trace trace;
  EXPECT_TRUE(RunExperiment(truth, &trace).ok());
  for (const char* column : {"i", "w"}) {
    double peak = 0.0;
    for (double v : trace.Column(column)) peak = std::max(peak, std::abs(v));
    for (double& v : trace.Column(column)) v += 0.01 * peak * random.Normal();
  }
  return RecordedFitTrace(std::move(trace), truth.experiment.initial);
}

struct Outcome {
  bool covered_jackknife, covered_hac;
  std::string method;
  double half_jackknife, half_hac;  // relative half-widths of B's interval
};

// Four traces whose B is the population value times exp(spread * N(0, 1)).
Outcome Fit(std::uint64_t seed, double spread) {
  Random random(seed);
  const Config base = LoadConfig(SourcePath("configs/ganesh-square.json"));
  const double B = base.parameters.Get("B");
  std::vector<FitTrace> traces;
  for (int k = 0; k < 4; ++k) {
    Config truth = base;
    truth.parameters.Set("B", B * std::exp(spread * random.Normal()));
    traces.push_back(NoisyTrace(truth, random));
  }
  const FitProblem problem(base, std::move(traces), {"i", "w"},
                           MakeFreeParameters(base, {"J", "B"}));
  OptimizerOptions options;
  options.threads = 2;
  FitResult result = FindOptimizer("ceres").Minimize(problem, options);
  const ParameterEstimate hac = result.estimates[1];
  WidenByTraceJackknife(problem, LeaveOneTraceOut(problem, result.values, options), &result);
  const ParameterEstimate& e = result.estimates[1];
  return {e.ci95_low <= B && B <= e.ci95_high, hac.ci95_low <= B && B <= hac.ci95_high,
          e.interval_method, 0.5 * (e.ci95_high - e.ci95_low) / e.value,
          0.5 * (hac.ci95_high - hac.ci95_low) / hac.value};
}

TEST(TraceJackknife, NeedsThreeTraces) {
  const Config base = LoadConfig(SourcePath("configs/ganesh-square.json"));
  Random random(1);
  std::vector<FitTrace> traces = {NoisyTrace(base, random), NoisyTrace(base, random)};
  const FitProblem problem(base, std::move(traces), {"i", "w"},
                           MakeFreeParameters(base, {"J", "B"}));
  const TraceJackknife j = LeaveOneTraceOut(problem, {2.26e-5, 2.261e-5}, {});
  EXPECT_FALSE(j.ok);
  EXPECT_EQ(j.reason, "fewer than 3 traces");
}

// Runs that differ by 10 % in B: the HAC interval (noise only) covers the population B
// rarely; the jackknife's does in about 95 % of the seeds.
TEST(TraceJackknife, CoversThePopulationValueWhenRunsDiffer) {
  int jackknife = 0, hac = 0, widened = 0;
  const int seeds = 40;
  double half_j = 0.0, half_h = 0.0;
  for (int seed = 1; seed <= seeds; ++seed) {
    const Outcome o = Fit(static_cast<std::uint64_t>(seed) * 7919u, 0.10);
    jackknife += o.covered_jackknife;
    hac += o.covered_hac;
    widened += o.method == "leave_one_trace_out";
    half_j += o.half_jackknife / seeds;
    half_h += o.half_hac / seeds;
  }
  std::printf("B: jackknife covers %d/%d (mean half-width %.3g), HAC %d/%d (%.3g); widened %d\n",
              jackknife, seeds, half_j, hac, seeds, half_h, widened);
  EXPECT_GE(jackknife, 0.85 * seeds);
  EXPECT_LE(hac, 0.5 * seeds);
  EXPECT_EQ(widened, seeds);
}

// Runs of one motor (no spread): the interval is still honest (covers in >= 90 %) and not
// blown up: the jackknife's t quantile for 3 degrees of freedom (3.18 against 1.96) and its
// own noise make it wider than the HAC one, but by less than 4x on average.
TEST(TraceJackknife, IdenticalRunsKeepAReasonableWidth) {
  int covered = 0;
  const int seeds = 40;
  double ratio = 0.0;
  for (int seed = 1; seed <= seeds; ++seed) {
    const Outcome o = Fit(static_cast<std::uint64_t>(seed) * 104729u, 0.0);
    covered += o.covered_jackknife;
    ratio += o.half_jackknife / o.half_hac / seeds;
  }
  std::printf("B, identical runs: covers %d/%d, mean half-width / HAC's %.3g\n", covered, seeds,
              ratio);
  EXPECT_GE(covered, 0.9 * seeds);
  EXPECT_LT(ratio, 4.0);
}

}  // namespace
}  // namespace blmd::testing
