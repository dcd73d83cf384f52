// A record cut in two (src/ident/residual/record_parts.h, docs/effects.md two_mass "Limits"):
// the second part starts from the model's own simulated state at the cut, a two-mass shaft's
// load included, so that the true model predicts the second part as it fits the whole.
#include "ident/residual/record_parts.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "blmd/ident/fit/problem.h"
#include "blmd/ident/fit/trace_input.h"
#include "blmd/io/config.h"
#include "blmd/run.h"

namespace blmd {
namespace {

// A lightly damped shaft (J/B = 10 s) on a 40 Hz coupling, driven by a PRBS torque: at the
// cut the load turns apart from the motor and the shaft is twisted.
Config TwoMassConfig() {
  return ParseConfig(R"({
    "name": "two-mass", "model": "rigid_load",
    "parameters": { "J": 2e-3, "B": 2e-4, "Kt": 0.5 },
    "effects": { "two_mass": { "inertia_ratio": 1.5, "anti_resonance_hz": 40,
                               "shaft_damping_ratio": 0.05, "load_damping_share": 0.3 } },
    "simulation": { "dt": 1e-4 },
    "experiment": { "input": { "type": "prbs", "amplitude": 1.0, "clock": 0.0025, "order": 10,
                               "seed": 3 },
                    "duration": 1.0, "sample_rate": 2000 },
    "identification": { "free": ["J", "B"], "observe": ["w"] } })",
                     "two-mass.json");
}

TEST(RecordParts, TheSecondHalfStartsTheLoadWhereTheSimulationHadIt) {
  const Config config = TwoMassConfig();
  Trace simulated;
  ASSERT_TRUE(RunExperiment(config, &simulated).ok());
  std::vector<FitTrace> traces;
  traces.push_back(RecordedFitTrace(simulated, config.experiment.initial));
  const FitProblem problem(config, traces, {"w"}, MakeFreeParameters(config, {"J", "B"}));
  const std::vector<double> truth = {2e-3, 2e-4};
  const internal::RecordParts parts = internal::SplitRecord(problem, truth);
  ASSERT_TRUE(parts.ok) << parts.reason;
  // The true model predicts the second half as the record has it (noise-free: to rounding),
  // because the second half starts from the simulated state at the cut, the load's included.
  const FitProblem second(config, parts.second, {"w"}, MakeFreeParameters(config, {"J", "B"}));
  const Evaluation score = second.Evaluate(truth);
  ASSERT_TRUE(score.ok) << score.reason;
  EXPECT_LT(std::sqrt(score.nrmse2), 1e-6);
  // That state: the load's speed and the twist where the simulation had them.
  const std::size_t split = simulated.rows() / 2;
  const InitialState& start = parts.second.front().initial;
  ASSERT_TRUE(start.w_load.has_value());
  EXPECT_DOUBLE_EQ(*start.w_load, simulated.Column("w_load")[split]);
  EXPECT_DOUBLE_EQ(start.twist,
                   simulated.Column("theta")[split] - simulated.Column("theta_load")[split]);
  EXPECT_GT(std::abs(*start.w_load - start.w), 1e-3);  // the load apart from the motor there
}

// A record whose motion lies in its second half (a step at the middle, the shaft at rest
// before it: a student lab's bump test) cannot be cut in two: its first half's angle is
// constant, and a fit of it is no fit. The parts say so with the reason; before, the part's
// FitProblem threw, and the command that asked for a cross-validation failed with exit 2.
TEST(RecordParts, AHalfAtRestIsNoPartAndSaysWhy) {
  Config config = ParseConfig(R"({
    "name": "late-step", "model": "rigid_load",
    "parameters": { "J": 2e-3, "B": 2e-3, "Kt": 1.0 },
    "simulation": { "dt": 1e-3 },
    "experiment": { "input": { "type": "step", "amplitude": 1.0, "t0": 0.6 },
                    "duration": 1.0, "sample_rate": 500 },
    "identification": { "free": ["J", "B"], "observe": ["theta"] } })",
                              "late-step.json");
  Trace simulated;
  ASSERT_TRUE(RunExperiment(config, &simulated).ok());
  std::vector<FitTrace> traces;
  traces.push_back(RecordedFitTrace(simulated, config.experiment.initial));
  const FitProblem problem(config, traces, {"theta"}, MakeFreeParameters(config, {"J", "B"}));
  const internal::RecordParts parts = internal::SplitRecord(problem, {2e-3, 2e-3});
  EXPECT_FALSE(parts.ok);
  EXPECT_EQ(parts.reason,
            "a part of the record cannot be fitted alone (generated (first half): observed column "
            "'theta' is constant: it cannot inform the fit (observe another column with "
            "--observe))");
}

}  // namespace
}  // namespace blmd
