// Units hints (ident/fit/units_check.h, docs/identification.md §5 "units_suspect"):
// a speed in rpm or deg/s, an angle in degrees, a current in mA is named with the --scale
// flag that converts it; a trace in the model's units, or one with the wrong physics but the
// right units, is not.
#include "blmd/ident/fit/units_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "blmd/ident/fit/trace_input.h"
#include "blmd/ident/optimizers/optimizer.h"
#include "blmd/io/config.h"
#include "blmd/io/csv.h"
#include "blmd/io/starting_config.h"
#include "blmd/run.h"
#include "support/test_support.h"

namespace blmd {
namespace {

using testing::SourcePath;

constexpr double kRpm = 60.0 / (2.0 * std::numbers::pi);
constexpr double kDeg = 180.0 / std::numbers::pi;

// The bundled square-wave trace of the Ganesh servo, its columns multiplied by `scales`
// (as --scale does: a recorder in other units), fitted with the config's free parameters.
struct Case {
  FitProblem problem;
  std::vector<double> fitted;
};
Case Fit(const std::string& trace, const std::map<std::string, double>& scales,
         const std::vector<std::string>& observe, std::vector<std::string> free = {"J", "B"}) {
  const Config config = LoadConfig(SourcePath("configs/ganesh-square.json"));
  TraceInputOptions options;
  options.scales = scales;
  options.required = observe;
  std::vector<FitTrace> traces;
  traces.push_back(LoadFitTrace(SourcePath(trace), options, config.experiment.initial));
  FitProblem problem(config, std::move(traces), observe, MakeFreeParameters(config, free));
  OptimizerOptions fit_options;
  fit_options.threads = 2;
  std::vector<double> fitted = FindOptimizer("ceres").Minimize(problem, fit_options).values;
  return {std::move(problem), std::move(fitted)};
}

TEST(UnitsCheck, SpeedInRpmIsNamedWithItsScaleFlag) {
  const Case c = Fit("testdata/ganesh-square.csv", {{"w", kRpm}}, {"i", "w"});
  const std::vector<UnitsHint> hints = CheckUnits(c.problem, c.fitted);
  ASSERT_EQ(hints.size(), 1u);
  EXPECT_EQ(hints[0].column, "w");
  EXPECT_EQ(hints[0].unit, "rpm");
  EXPECT_EQ(hints[0].model_unit, "rad/s");
  EXPECT_NEAR(hints[0].observed / kRpm, 1.0, 0.2);
  EXPECT_EQ(hints[0].ScaleFlag(), "--scale w=0.10471975511965977");
  EXPECT_NE(hints[0].evidence.find("the measured 'w' is "), std::string::npos) << hints[0].evidence;
}

TEST(UnitsCheck, SpeedInDegreesPerSecondAndCurrentInMilliamps) {
  const Case deg = Fit("testdata/ganesh-square.csv", {{"w", kDeg}}, {"i", "w"});
  std::vector<UnitsHint> hints = CheckUnits(deg.problem, deg.fitted);
  ASSERT_EQ(hints.size(), 1u);
  EXPECT_EQ(hints[0].unit, "deg/s");
  EXPECT_EQ(hints[0].ScaleFlag(), "--scale w=0.017453292519943295");
  const Case ma = Fit("testdata/ganesh-square.csv", {{"i", 1000.0}}, {"i", "w"});
  hints = CheckUnits(ma.problem, ma.fitted);
  ASSERT_EQ(hints.size(), 1u);
  EXPECT_EQ(hints[0].column, "i");
  EXPECT_EQ(hints[0].unit, "mA");
  EXPECT_EQ(hints[0].ScaleFlag(), "--scale i=0.001");
}

// The fit absorbs a speed in rpm into Kb (and J, B) when Kb is free: the column then agrees
// at the fitted values, but not at the config's, and Kb is the config's / 9.55.
TEST(UnitsCheck, BackEmfConstantFittedAtTheConfigsOverTheFactor) {
  const Case c = Fit("testdata/ganesh-square.csv", {{"w", kRpm}}, {"w"}, {"Kb", "J", "B"});
  ASSERT_EQ(c.fitted.size(), 3u);
  const std::vector<UnitsHint> hints = CheckUnits(c.problem, c.fitted);
  ASSERT_EQ(hints.size(), 1u);
  EXPECT_EQ(hints[0].unit, "rpm");
  EXPECT_EQ(hints[0].ScaleFlag(), "--scale w=0.10471975511965977");
}

// No hint on traces in the model's units: every bundled dc_servo trace, with and without the
// effects the config lacks (the residual then has structure, but the scale is right).
TEST(UnitsCheck, NoHintOnTracesInTheModelsUnits) {
  for (const char* trace :
       {"testdata/ganesh-square.csv", "testdata/dc-hidden-coulomb.csv",
        "testdata/dc-hidden-load.csv", "testdata/dc-hidden-drag.csv",
        "testdata/dc-hidden-cogging.csv", "testdata/dc-hidden-dead-time.csv",
        "testdata/dc-hidden-stribeck.csv", "testdata/dc-hidden-current-offset.csv",
        "testdata/dc-ambiguous-coulomb.csv"}) {
    const Case c = Fit(trace, {}, {"i", "w"});
    EXPECT_TRUE(CheckUnits(c.problem, c.fitted).empty()) << trace;
  }
  // A scale that is no unit factor (x3) is not named either.
  const Case c = Fit("testdata/ganesh-square.csv", {{"w", 3.0}}, {"i", "w"});
  EXPECT_TRUE(CheckUnits(c.problem, c.fitted).empty());
}

}  // namespace
// The starting config's typical values (blmd-sim --init-config) say nothing of the rig: a
// shaft 57.3 times lighter and less damped than the typical one runs 57.3 times faster than
// the start, the factor of deg/s, and is no units fault. The same record from a start the
// user set (J 5 % off the typical) is named, as before.
TEST(UnitsCheck, StartingConfigsTypicalValuesAreNoEvidence) {
  Config truth = ParseConfig(StartingConfigText("rigid_load"), "truth.json");
  truth.parameters.Set("J", truth.parameters.Get("J") / kDeg);
  truth.parameters.Set("B", truth.parameters.Get("B") / kDeg);
  Trace trace;
  ASSERT_TRUE(RunExperiment(truth, &trace).ok());
  testing::TempDir dir;
  const std::string path = dir.path() + "/light.csv";
  WriteTraceCsv(trace, path);
  for (const double start_factor : {1.0, 1.05}) {
    Config config = ParseConfig(StartingConfigText("rigid_load"), "start.json");
    config.parameters.Set("J", config.parameters.Get("J") * start_factor);
    TraceInputOptions options;
    options.required = {"w"};
    std::vector<FitTrace> traces;
    traces.push_back(LoadFitTrace(path, options, config.experiment.initial));
    FitProblem problem(config, std::move(traces), {"w"}, MakeFreeParameters(config, {"J", "B"}));
    OptimizerOptions fit_options;
    fit_options.threads = 2;
    const std::vector<double> fitted = FindOptimizer("ceres").Minimize(problem, fit_options).values;
    ASSERT_NEAR(fitted[0] / truth.parameters.Get("J"), 1.0, 1e-3);
    const std::vector<UnitsHint> hints = CheckUnits(problem, fitted);
    if (start_factor == 1.0) {
      EXPECT_TRUE(hints.empty()) << hints.front().evidence;
    } else {
      ASSERT_EQ(hints.size(), 1u);
      EXPECT_EQ(hints[0].unit, "deg/s");
    }
  }
}

}  // namespace blmd
