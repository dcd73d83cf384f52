// blmd-ident as a user and a CI script see it: the real binary, real files, exit codes.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "support/test_support.h"

namespace blmd::testing {
namespace {

std::string Ident(const std::string& arguments) {
  return BinPath("blmd-ident") + " --config " + SourcePath("configs/ganesh-noload.json") +
         " --trace " + SourcePath("testdata/ganesh-noload-step.csv") + " " + arguments;
}

TEST(BlmdIdentCli, ReportHasTheStableKeysOfTheInterface) {
  TempDir dir;
  const std::string report_path = dir.File("report.json");
  const CommandResult run = blmd::testing::Run(Ident("--report " + report_path));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto report = nlohmann::json::parse(Slurp(report_path));
  EXPECT_EQ(report["tool"], "blmd-ident");
  EXPECT_TRUE(report["version"].is_string());
  EXPECT_EQ(report["model"], "dc_servo");
  EXPECT_EQ(report["method"], "ceres");
  EXPECT_EQ(report["trace"]["samples"], 10001);  // 1 s at 10 kHz
  const CommandResult sha =
      blmd::testing::Run("sha256sum " + SourcePath("testdata/ganesh-noload-step.csv"));
  EXPECT_EQ(report["trace"]["sha256"].get<std::string>(), sha.out.substr(0, 64));
  for (const char* name : {"J", "B"}) {
    const auto& p = report["parameters"][name];
    EXPECT_TRUE(p["value"].is_number()) << name;
    EXPECT_TRUE(p["initial"].is_number()) << name;
    EXPECT_TRUE(p["std"].is_number()) << name;
    ASSERT_TRUE(p["ci95"].is_array()) << name;
    EXPECT_LT(p["ci95"][0].get<double>(), p["value"].get<double>());
    EXPECT_GT(p["ci95"][1].get<double>(), p["value"].get<double>());
  }
  EXPECT_NEAR(report["parameters"]["J"]["value"].get<double>(), 2.26e-5, 0.01 * 2.26e-5);
  EXPECT_NEAR(report["parameters"]["B"]["value"].get<double>(), 2.261e-5, 0.01 * 2.261e-5);
  const auto& fit = report["fit"];
  EXPECT_EQ(fit["observe"], nlohmann::json::array({"i", "w"}));
  for (const char* key : {"mse", "nrmse", "fit_percent", "wall_time_s"}) {
    EXPECT_TRUE(fit[key].is_number()) << key;
  }
  EXPECT_TRUE(fit["rmse"]["i"].is_number());
  EXPECT_TRUE(fit["rmse"]["w"].is_number());
  EXPECT_GT(fit["evaluations"].get<long>(), 0);
  EXPECT_GT(fit["iterations"].get<long>(), 0);
  EXPECT_EQ(fit["converged"], true);
  EXPECT_NEAR(fit["nrmse"].get<double>() * fit["nrmse"].get<double>(), fit["mse"].get<double>(),
              1e-12);
  EXPECT_TRUE(report["residual"]["whiteness_p"].is_number());
  EXPECT_EQ(report.dump().find("NaN"), std::string::npos);
}

TEST(BlmdIdentCli, JsonPrintsTheReportOnStdout) {
  const CommandResult run = blmd::testing::Run(Ident("--json --method powell"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto report = nlohmann::json::parse(run.out);
  EXPECT_EQ(report["method"], "powell");
  EXPECT_EQ(report["method_summary"]["algorithm"], "LN_BOBYQA");
}

TEST(BlmdIdentCli, GateAboveNrmseExitsThreeAndStillWritesTheReport) {
  TempDir dir;
  const CommandResult run =
      blmd::testing::Run(Ident("--fail-above-nrmse 0.001 --quiet --report " + dir.File("r.json")));
  EXPECT_EQ(run.exit_code, 3);
  EXPECT_TRUE(FileExists(dir.File("r.json")));
  EXPECT_NE(run.err.find("above --fail-above-nrmse"), std::string::npos) << run.err;
  EXPECT_EQ(blmd::testing::Run(Ident("--fail-above-nrmse 0.5 --quiet")).exit_code, 0);
}

// With --discover the final model is the one after discovery: the gate reads its NRMSE
// (0.0157 on this trace; the first fit's is 0.051).
TEST(BlmdIdentCli, GateReadsTheNrmseAfterDiscovery) {
  const std::string command = BinPath("blmd-ident") + " --config " +
                              SourcePath("configs/ganesh-square.json") + " --trace " +
                              SourcePath("testdata/dc-hidden-coulomb.csv") + " --discover --quiet";
  EXPECT_EQ(blmd::testing::Run(command + " --fail-above-nrmse 0.03").exit_code, 0);
  EXPECT_EQ(blmd::testing::Run(command + " --fail-above-nrmse 0.01").exit_code, 3);
}

TEST(BlmdIdentCli, AFitThatDoesNotConvergeExitsOne) {
  const CommandResult run =
      blmd::testing::Run(Ident("--method powell --max-evaluations 3 --quiet"));
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("did not converge"), std::string::npos) << run.err;
}

struct BadCase {
  std::string arguments;
  std::string message;  // a part of the one-line error
};

TEST(BlmdIdentCli, BadFlagsAndFilesExitTwoWithOneLineAndNoReport) {
  TempDir dir;
  const std::string bad_trace = dir.Write("bad.csv", "t,u,i\n0,1,0\n0.1,1,x\n");
  const std::vector<BadCase> cases = {
      {"--bogus", "--bogus"},
      {"--method simplex", "unknown method 'simplex' (valid: ceres, classic, fsd, powell)"},
      {"--observe i,q", "--observe: 'q' is not an output of model dc_servo (valid: i,w,theta)"},
      {"--free J,Q", "free parameter 'Q' is not a parameter of"},
      {"--option algorithm=simplex --method powell",
       "powell option algorithm='simplex' (valid: bobyqa, praxis)"},
      {"--option speed=3", "unknown option 'speed' for method ceres"},
      {"--initial J=abc", "--initial J: 'abc' is not a finite number"},
      {"--initial J=1", "initial value 1 of 'J' is outside its bounds [1e-07, 0.01]"},
      {"--trace " + dir.File("missing.csv"), "missing.csv: cannot read"},
      {"--trace " + bad_trace, "bad.csv:3:3: column 'i' is not a number (\"x\")"},
      {"--column w=speed", "--column w=speed: no column 'speed'"},
  };
  for (const auto& c : cases) {
    const std::string report = dir.File("report.json");
    const CommandResult run = blmd::testing::Run(Ident(c.arguments + " --report " + report));
    EXPECT_EQ(run.exit_code, 2) << c.arguments << ": " << run.err;
    EXPECT_NE(run.err.find(c.message), std::string::npos) << c.arguments << ": " << run.err;
    EXPECT_EQ(run.err.rfind("error: ", 0), 0u) << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
    EXPECT_FALSE(FileExists(report)) << c.arguments;
  }
}

TEST(BlmdIdentCli, ClassicOnTheBundledCoastDownIsWithinTwoPercent) {
  const CommandResult run = blmd::testing::Run(
      BinPath("blmd-ident") + " --config " + SourcePath("configs/ganesh-coastdown.json") +
      " --trace " + SourcePath("testdata/ganesh-coastdown.csv") + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto report = nlohmann::json::parse(run.out);
  EXPECT_EQ(report["method"], "classic");
  EXPECT_NEAR(report["parameters"]["J"]["value"].get<double>(), 2.26e-5, 0.02 * 2.26e-5);
  EXPECT_NEAR(report["parameters"]["B"]["value"].get<double>(), 2.261e-5, 0.02 * 2.261e-5);
}

TEST(BlmdIdentCli, HelpAndVersionExitZero) {
  EXPECT_EQ(blmd::testing::Run(BinPath("blmd-ident") + " --help").exit_code, 0);
  const CommandResult version = blmd::testing::Run(BinPath("blmd-ident") + " --version");
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_EQ(version.out.rfind("blmd-ident ", 0), 0u) << version.out;
}

}  // namespace
}  // namespace blmd::testing
