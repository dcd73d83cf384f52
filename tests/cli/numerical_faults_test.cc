// Numerical faults (docs/errors.md §4): a simulation that diverges is detected and
// reported, never written as numbers. A run the user asked for (blmd-sim) exits 1 with one
// line and writes nothing; inside a sweep (blmd-surface) or an optimiser (blmd-ident) the
// point gets an infinite cost with a counted reason and the work goes on. No report holds
// NaN or Inf.
//
// The fault: quadratic drag Cd·w·|w| is applied explicitly over each step (the drag torque
// of the step start), so the step is stable only while dt·2·Cd·|w|/J stays below about 2;
// at dt = 1 ms a large Cd or a small J makes w oscillate with growing amplitude.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>

#include "support/test_support.h"

namespace blmd::testing {
namespace {

// A dc_servo (Ganesh's motor) with quadratic drag, simulated at a coarse 1 ms step.
std::string DragConfig(double Cd, double J, double dt = 1e-3) {
  char text[1024];
  std::snprintf(text, sizeof text, R"({
  "name": "drag-coarse-step",
  "model": "dc_servo",
  "parameters": { "R": 12.6, "L": 0.283, "Kt": 0.04, "Kb": 0.04, "J": %.17g, "B": 2.261e-5 },
  "effects": { "quadratic_drag": { "Cd": %.17g } },
  "simulation": { "dt": %.17g },
  "experiment": { "input": { "type": "step", "amplitude": 24.0 }, "duration": 0.5, "sample_rate": 1000 },
  "identification": { "free": ["J", "Cd"], "initial": { "J": 1e-5, "Cd": 1e-3 },
                      "bounds": { "J": [1e-6, 1e-3], "Cd": [1e-6, 1] }, "observe": ["i", "w"] }
})",
                J, Cd, dt);
  return text;
}

// "nan", "inf", "infinity" as words, any case: what a non-finite double prints as.
bool HasNonFiniteText(const std::string& text) {
  static const std::regex pattern(R"((^|[^A-Za-z_])(nan|inf|infinity)([^A-Za-z_]|$))",
                                  std::regex::icase);
  return std::regex_search(text, pattern);
}

TEST(NumericalFaults, NonFiniteTextDetectorWorks) {
  EXPECT_TRUE(HasNonFiniteText("{\"cost\": NaN}"));
  EXPECT_TRUE(HasNonFiniteText("1,2,inf\n"));
  EXPECT_TRUE(HasNonFiniteText("x = -Infinity"));
  EXPECT_FALSE(HasNonFiniteText("{\"information\": 1, \"infeasible\": \"finance\"}"));
}

TEST(NumericalFaults, BlmdSimDivergenceExitsOneWithOneLineAndWritesNothing) {
  TempDir dir;
  const std::string config = dir.Write("diverges.json", DragConfig(0.1, 2.26e-5));
  const std::string expected =
      "error: " + config +
      ": simulation diverged (non-finite or |state| > 1e+09) at t = 0.013 s; the step "
      "simulation.dt = 0.001 s may be too large for the model's fastest dynamics, or a "
      "parameter is unphysical: reduce dt or check the parameters\n";
  const std::string out = dir.File("trace.csv");
  CommandResult run =
      blmd::testing::Run(BinPath("blmd-sim") + " --config " + config + " --out " + out);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err, expected);
  EXPECT_EQ(run.out, "");
  EXPECT_FALSE(FileExists(out));
  // An earlier trace at that path is kept as it was.
  dir.Write("trace.csv", "t,u\n0,1\n");
  run = blmd::testing::Run(BinPath("blmd-sim") + " --config " + config + " --out " + out);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err, expected);
  EXPECT_EQ(Slurp(out), "t,u\n0,1\n");
  // The same motor at a 0.1 ms step is fine: the step, not the model, diverged.
  const std::string fine = dir.Write("fine.json", DragConfig(0.1, 2.26e-5, 1e-4));
  run = blmd::testing::Run(BinPath("blmd-sim") + " --quiet --config " + fine + " --out " + out);
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_FALSE(HasNonFiniteText(Slurp(out)));
}

// A 2-D sweep whose corner of large Cd and small J diverges: exit 0, every failed point
// counted with its reason, the rest computed; no NaN anywhere. Oracle for which points
// fail: blmd-sim run on each point's own config (same step input, same sample times).
TEST(NumericalFaults, SurfaceCountsDivergedPointsAndGoesOn) {
  TempDir dir;
  const std::string config = dir.Write("drag.json", DragConfig(1e-4, 2.26e-5));
  const std::string trace = dir.File("trace.csv");
  ASSERT_EQ(
      blmd::testing::Run(BinPath("blmd-sim") + " --quiet --config " + config + " --out " + trace)
          .exit_code,
      0);
  const std::string out = dir.File("surface.csv");
  const std::string grid = " --grid Cd=log:1e-4:1:5 --grid J=log:1e-6:1e-4:3";
  const CommandResult run =
      blmd::testing::Run(BinPath("blmd-surface") + " --config " + config + " --trace " + trace +
                         grid + " --out " + out + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.err, "");
  EXPECT_FALSE(HasNonFiniteText(run.out)) << run.out;
  const auto report = nlohmann::json::parse(run.out);
  int expected_failures = 0;
  std::size_t k = 0;
  for (double Cd : {1e-4, 1e-3, 1e-2, 1e-1, 1.0}) {
    for (double J : {1e-6, 1e-5, 1e-4}) {
      const auto& point = report["points"][k++];
      EXPECT_NEAR(point["Cd"].get<double>() / Cd, 1.0, 1e-12);
      EXPECT_NEAR(point["J"].get<double>() / J, 1.0, 1e-12);
      const std::string single = dir.Write("point.json", DragConfig(Cd, J));
      const int sim_exit = blmd::testing::Run(BinPath("blmd-sim") + " --quiet --config " + single +
                                              " --out " + dir.File("point.csv"))
                               .exit_code;
      ASSERT_TRUE(sim_exit == 0 || sim_exit == 1);
      SCOPED_TRACE("Cd = " + std::to_string(Cd) + ", J = " + std::to_string(J));
      if (sim_exit == 1) {
        ++expected_failures;
        EXPECT_TRUE(point["cost"].is_null());
      } else {
        EXPECT_TRUE(point["cost"].is_number());
        EXPECT_TRUE(std::isfinite(point["cost"].get<double>()));
      }
    }
  }
  EXPECT_GT(expected_failures, 0);   // part of the grid diverges ...
  EXPECT_LT(expected_failures, 15);  // ... and part does not
  EXPECT_EQ(report["failed_points"], expected_failures);
  EXPECT_EQ(
      report["failure_reasons"],
      nlohmann::json({{"simulation diverged (non-finite or |state| > 1e+09)", expected_failures}}));
  EXPECT_NEAR(report["minimum"]["Cd"].get<double>(), 1e-4, 1e-16);
  EXPECT_NEAR(report["minimum"]["J"].get<double>(), 1e-5, 1e-17);
  // The CSV: a failed point is `inf` cost with empty mse fields (docs/cli.md), never NaN.
  const std::string csv = Slurp(out);
  EXPECT_EQ(csv.find("nan"), std::string::npos);
  int inf_rows = 0;
  for (std::size_t at = csv.find(",,,inf\n"); at != std::string::npos;
       at = csv.find(",,,inf\n", at + 1))
    ++inf_rows;
  EXPECT_EQ(inf_rows, expected_failures);
  // The summary counts them with their reason.
  const CommandResult summary = blmd::testing::Run(BinPath("blmd-surface") + " --config " + config +
                                                   " --trace " + trace + grid + " --out " + out);
  ASSERT_EQ(summary.exit_code, 0);
  EXPECT_NE(summary.out.find("failed points: " + std::to_string(expected_failures) +
                             " (cost inf); " + std::to_string(expected_failures) +
                             " x simulation diverged (non-finite or |state| > 1e+09)"),
            std::string::npos)
      << summary.out;
}

// FSD samples the whole box, whose large-Cd part diverges: the evaluations fail, are
// counted with their reason, and the report holds no NaN or Inf (null where a number is
// undefined).
TEST(NumericalFaults, IdentCountsFailedEvaluationsAndTheReportHasNoNonFiniteNumber) {
  TempDir dir;
  const std::string config = dir.Write("drag.json", DragConfig(1e-4, 2.26e-5));
  const std::string trace = dir.File("trace.csv");
  ASSERT_EQ(
      blmd::testing::Run(BinPath("blmd-sim") + " --quiet --config " + config + " --out " + trace)
          .exit_code,
      0);
  const std::string report_path = dir.File("report.json");
  const CommandResult run =
      blmd::testing::Run(BinPath("blmd-ident") + " --config " + config + " --trace " + trace +
                         " --method fsd --report " + report_path);
  ASSERT_TRUE(run.exit_code == 0 || run.exit_code == 1)
      << run.err;  // converged or not: not the point
  EXPECT_FALSE(HasNonFiniteText(run.out)) << run.out;
  const std::string text = Slurp(report_path);
  EXPECT_FALSE(HasNonFiniteText(text));
  const auto report = nlohmann::json::parse(text);
  const long failed = report["fit"]["failed_evaluations"].get<long>();
  EXPECT_GT(failed, 0);
  EXPECT_LT(failed, report["fit"]["evaluations"].get<long>());
  const auto& reasons = report["method_summary"]["failure_reasons"];
  ASSERT_TRUE(reasons.contains("simulation diverged (non-finite or |state| > 1e+09)")) << reasons;
  long counted = 0;
  for (const auto& [reason, n] : reasons.items()) counted += n.get<long>();
  EXPECT_EQ(counted, failed);
  EXPECT_NE(run.out.find("(" + std::to_string(failed) + " failed)"), std::string::npos) << run.out;
}

}  // namespace
}  // namespace blmd::testing
