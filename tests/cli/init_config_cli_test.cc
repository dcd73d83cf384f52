// blmd-sim --init-config MODEL (docs/cli.md §1.1) as a user runs it: for every model of the
// registry, the printed config passes the config schema, blmd-sim runs it (1 % noise on the
// observed columns), and blmd-ident fits J and B to that run from a start 40 % below J and
// 60 % above B and recovers both within 1 % (the oracle: the config's own values, which made
// the trace). A misspelt model is exit 2
// with one line naming the valid ones.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "blmd/sim/model.h"
#include "support/test_support.h"

namespace blmd {
namespace {

using testing::BinPath;
using testing::CommandResult;
using testing::FileExists;
using testing::Slurp;
using testing::SourcePath;
using testing::TempDir;

std::string Number(double value) {
  std::ostringstream text;
  text.precision(17);
  text << value;
  return text.str();
}

// Debian's interpreter has python3-jsonschema (tests/CMakeLists.txt, schema tests).
std::string Python() { return FileExists("/usr/bin/python3") ? "/usr/bin/python3" : "python3"; }

TEST(InitConfigCli, EveryModelRunsAndItsJAndBAreRecovered) {
  for (const Model* model : ModelRegistry()) {
    const std::string name(model->name());
    SCOPED_TRACE(name);
    TempDir dir;
    const CommandResult init = testing::Run(BinPath("blmd-sim") + " --init-config " + name);
    ASSERT_EQ(init.exit_code, 0) << init.err;
    EXPECT_EQ(init.err, "");
    const std::string config_path = dir.Write(name + ".json", init.out);

    const CommandResult schema = testing::Run(Python() + " " + SourcePath("scripts/validate-json") +
                                              " config " + config_path);
    EXPECT_EQ(schema.exit_code, 0) << schema.err;

    // A run with 1 % noise on every observed column.
    const nlohmann::json config = nlohmann::json::parse(init.out);
    std::string noise;
    for (const auto& column : config["identification"]["observe"])
      noise += " --noise " + column.get<std::string>() + "=1%";
    const std::string trace_path = dir.File(name + ".csv");
    const CommandResult sim = testing::Run(BinPath("blmd-sim") + " --config " + config_path +
                                           " --out " + trace_path + noise + " --seed 1 --quiet");
    ASSERT_EQ(sim.exit_code, 0) << sim.err;
    EXPECT_EQ(sim.err, "");

    const double J = config["parameters"]["J"].get<double>();
    const double B = config["parameters"]["B"].get<double>();
    const std::string report_path = dir.File(name + "-report.json");
    const CommandResult fit =
        testing::Run(BinPath("blmd-ident") + " --config " + config_path + " --trace " + trace_path +
                     " --initial J=" + Number(0.6 * J) + " --initial B=" + Number(1.6 * B) +
                     " --report " + report_path + " --quiet");
    ASSERT_EQ(fit.exit_code, 0) << fit.err;
    const nlohmann::json report = nlohmann::json::parse(Slurp(report_path));
    const double J_fit = report["parameters"]["J"]["value"].get<double>();
    const double B_fit = report["parameters"]["B"]["value"].get<double>();
    EXPECT_NEAR(J_fit / J, 1.0, 0.01) << "J = " << J_fit << ", true " << J;
    EXPECT_NEAR(B_fit / B, 1.0, 0.01) << "B = " << B_fit << ", true " << B;
    std::printf("[ %-10s ] J %.6g (true %.6g, %+.3f %%), B %.6g (true %.6g, %+.3f %%)\n",
                name.c_str(), J_fit, J, 100.0 * (J_fit / J - 1.0), B_fit, B,
                100.0 * (B_fit / B - 1.0));
  }
}

TEST(InitConfigCli, UnknownModelIsExitTwoListingTheValidOnes) {
  const CommandResult result = testing::Run(BinPath("blmd-sim") + " --init-config dc_motor");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_EQ(result.out, "");
  EXPECT_EQ(result.err,
            "error: --init-config: unknown model 'dc_motor' (valid: blmd, dc_servo, rigid_load)\n");
}

TEST(InitConfigCli, TakesNoOtherFlag) {
  TempDir dir;
  const std::string out = dir.File("trace.csv");
  const CommandResult result =
      testing::Run(BinPath("blmd-sim") + " --init-config dc_servo --out " + out);
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_EQ(result.out, "");
  EXPECT_EQ(result.err,
            "error: --init-config prints a config and takes no other flag (got --out)\n");
  EXPECT_FALSE(FileExists(out));
  // Without --init-config, --config and --out stay required, with CLI11's message.
  const CommandResult bare = testing::Run(BinPath("blmd-sim") + " --quiet");
  EXPECT_EQ(bare.exit_code, 2);
  EXPECT_EQ(bare.err, "error: --config is required (see " + BinPath("blmd-sim") + " --help)\n");
}

TEST(InitConfigCli, BlmdIdentPrintsTheSameStartingConfig) {
  // A new user starts from blmd-ident, the command that reads the config: it prints the
  // same config as blmd-sim, alone on its command line, and still needs --config and
  // --trace without it.
  for (const char* model : {"rigid_load", "dc_servo", "blmd"}) {
    SCOPED_TRACE(model);
    const CommandResult sim = testing::Run(BinPath("blmd-sim") + " --init-config " + model);
    const CommandResult ident = testing::Run(BinPath("blmd-ident") + " --init-config " + model);
    ASSERT_EQ(ident.exit_code, 0) << ident.err;
    EXPECT_EQ(ident.out, sim.out);
    EXPECT_EQ(ident.err, "");
  }
  const CommandResult other =
      testing::Run(BinPath("blmd-ident") + " --init-config rigid_load --discover");
  EXPECT_EQ(other.exit_code, 2);
  EXPECT_EQ(other.out, "");
  EXPECT_EQ(other.err,
            "error: --init-config prints a config and takes no other flag (got --discover)\n");
  const CommandResult unknown = testing::Run(BinPath("blmd-ident") + " --init-config dc_motor");
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_EQ(unknown.err,
            "error: --init-config: unknown model 'dc_motor' (valid: blmd, dc_servo, rigid_load)\n");
  const CommandResult bare = testing::Run(BinPath("blmd-ident") + " --quiet");
  EXPECT_EQ(bare.exit_code, 2);
}

}  // namespace
}  // namespace blmd
