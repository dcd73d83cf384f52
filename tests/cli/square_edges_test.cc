// Square-wave edges land on the right sample (docs/config.md): sample k of
// a trace at rate fs is +A exactly when floor(k / (fs·P/2)) is even, in blmd-sim's written u
// column and in the simulator's own input. Before the fix, fmod rounding put some edges one
// sample late in the written column (periods 0.1, 0.15, 0.2, 0.4 s), so a noise-free trace
// could not be fitted by its own model (NRMSE 0.041) and discovery "found" a load torque.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "blmd/io/csv.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

struct Case {
  double period;       // s
  double sample_rate;  // Hz
};

std::string SquareConfig(const TempDir& dir, const Case& c) {
  nlohmann::json config = nlohmann::json::parse(Slurp(SourcePath("configs/ganesh-square.json")));
  config["experiment"]["input"]["period"] = c.period;
  config["experiment"]["duration"] = 2.0 * c.period;
  config["experiment"]["sample_rate"] = c.sample_rate;
  // Started at the truth: the fit must stay there (a noise-free trace of the same model).
  config["identification"]["initial"] = {{"J", 2.26e-5}, {"B", 2.261e-5}};
  return dir.Write("square.json", config.dump(2));
}

class SquareEdges : public ::testing::TestWithParam<Case> {};

TEST_P(SquareEdges, WrittenInputFollowsTheSampleRuleAndTheTraceFitsItsOwnModel) {
  const Case c = GetParam();
  TempDir dir;
  const std::string config = SquareConfig(dir, c);
  const std::string trace = dir.File("trace.csv");
  CommandResult run = blmd::testing::Run(BinPath("blmd-sim") + " --config " + config + " --out " +
                                         trace + " --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.err;

  const Trace t = ReadTraceCsv(trace);
  const std::vector<double>& u = t.Column("u");
  const long samples_per_half = std::lround(c.sample_rate * c.period / 2.0);
  int wrong = 0;
  for (std::size_t k = 0; k < u.size(); ++k) {
    const double expected = (static_cast<long>(k) / samples_per_half) % 2 == 0 ? 12.0 : -12.0;
    wrong += u[k] != expected;
  }
  EXPECT_EQ(wrong, 0) << "samples of u on the wrong side of an edge";

  const std::string report = dir.File("report.json");
  run = blmd::testing::Run(BinPath("blmd-ident") + " --config " + config + " --trace " + trace +
                           " --discover --quiet --report " + report);
  EXPECT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json json = nlohmann::json::parse(Slurp(report));
  EXPECT_LT(json["discovery"]["error_before"]["nrmse"].get<double>(), 1e-6);
  EXPECT_TRUE(json["discovery"]["added"].empty()) << json["discovery"]["added"].dump();
}

INSTANTIATE_TEST_SUITE_P(PeriodsAndRates, SquareEdges,
                         ::testing::Values(Case{0.1, 2000}, Case{0.15, 2000}, Case{0.2, 2000},
                                           Case{0.4, 2000}, Case{1.0, 2000}, Case{0.1, 10000},
                                           Case{0.15, 10000}, Case{0.2, 10000}, Case{0.4, 10000},
                                           Case{1.0, 10000}),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           return "P" + std::to_string(std::lround(info.param.period * 1000)) +
                                  "ms_" +
                                  std::to_string(std::lround(info.param.sample_rate / 1000)) +
                                  "kHz";
                         });

}  // namespace
}  // namespace blmd::testing
