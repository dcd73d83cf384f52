// The stability check of discovery's decisions (docs/discovery.md §3d): a candidate whose
// score moves under a change of the data is never added and is reported; under a change far
// below the noise a real effect's decision holds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "blmd/ident/discovery/discovery.h"
#include "blmd/ident/fit/problem.h"
#include "blmd/ident/fit/trace_input.h"
#include "blmd/ident/optimizers/optimizer.h"
#include "blmd/io/config.h"
#include "blmd/random.h"
#include "support/test_support.h"

namespace blmd {
namespace {

using testing::SourcePath;

// The Ganesh servo's square wave with a Coulomb friction of 2 mN·m the fit config lacks, and
// white noise of 1 % of each column's peak on i and w.
struct Case {
  Config fit_config;
  FitProblem problem;
  FitResult fit;
};

Case HiddenCoulomb() {
  const Config fit_config = LoadConfig(SourcePath("configs/ganesh-square.json"));
  ParameterSet tc;
  tc.Set("Tc", 0.002);
  Trace trace = testing::SimulateWithEffect(fit_config, "coulomb_friction", tc);
  Random random(7);
  for (const char* column : {"i", "w"}) {
    double peak = 0.0;
    for (double v : trace.Column(column)) peak = std::max(peak, std::abs(v));
    for (double& v : trace.Column(column)) v += 0.01 * peak * random.Normal();
  }
  std::vector<FitTrace> traces = {
      RecordedFitTrace(std::move(trace), fit_config.experiment.initial)};
  FitProblem problem(fit_config, std::move(traces), {"i", "w"},
                     MakeFreeParameters(fit_config, {"J", "B"}));
  OptimizerOptions options;
  options.threads = 2;
  FitResult fit = FindOptimizer("ceres").Minimize(problem, options);
  return {fit_config, std::move(problem), std::move(fit)};
}

DiscoveryOptions Options(double perturbation) {
  DiscoveryOptions options;
  options.refit.threads = 2;
  options.candidates = {"coulomb_friction", "load_torque"};
  options.max_effects = 1;
  options.stability_perturbation = perturbation;
  return options;
}

TEST(DiscoveryStability, ARealEffectHoldsUnderAChangeFarBelowTheNoise) {
  const Case c = HiddenCoulomb();
  const DiscoveryResult result = Discover(c.problem, c.fit, Options(1e-9));
  ASSERT_EQ(result.added, std::vector<std::string>{"coulomb_friction"});
  EXPECT_TRUE(result.unstable.empty());
  const CandidateOutcome& added = result.steps.at(0).candidates.at(0);
  ASSERT_EQ(added.effect, "coulomb_friction");
  EXPECT_TRUE(added.stability_checked);
  EXPECT_TRUE(added.stable);
  ASSERT_EQ(added.stability_perturbed.size(), 2u);
  EXPECT_LT(added.stability_delta_bic, -100.0);
  for (double moved : added.stability_perturbed)  // smooth: the score moves by far less than 1
    EXPECT_LT(std::abs(moved - added.stability_delta_bic), 0.01);
}

TEST(DiscoveryStability, ACandidateWhoseScoreMovesWithTheDataIsNeverAdded) {
  // A "perturbation" of 30 % of every value is a different record: the check must see the
  // score move, refuse the effect and say so.
  const Case c = HiddenCoulomb();
  const DiscoveryResult result = Discover(c.problem, c.fit, Options(0.3));
  EXPECT_TRUE(std::find(result.added.begin(), result.added.end(), "coulomb_friction") ==
              result.added.end());
  ASSERT_FALSE(result.unstable.empty());
  const auto unstable =
      std::find_if(result.unstable.begin(), result.unstable.end(),
                   [](const CandidateOutcome& o) { return o.effect == "coulomb_friction"; });
  ASSERT_NE(unstable, result.unstable.end());
  EXPECT_FALSE(unstable->stable);
  EXPECT_EQ(unstable->reason.rfind("unstable: a change of the data of 0.3 of their values", 0), 0u)
      << unstable->reason;
  EXPECT_NE(result.conclusion.find("undecided: coulomb_friction"), std::string::npos)
      << result.conclusion;
}

TEST(DiscoveryStability, OffWhenNoChecksAreAsked) {
  const Case c = HiddenCoulomb();
  DiscoveryOptions options = Options(0.3);
  options.stability_checks = 0;
  const DiscoveryResult result = Discover(c.problem, c.fit, options);
  EXPECT_EQ(result.added, std::vector<std::string>{"coulomb_friction"});
  EXPECT_TRUE(result.unstable.empty());
  EXPECT_FALSE(result.steps.at(0).candidates.at(0).stability_checked);
}

}  // namespace
}  // namespace blmd
