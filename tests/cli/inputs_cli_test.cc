// The prbs and chirp inputs end to end (docs/config.md, experiment.input): blmd-sim runs the
// example configs, writes the input it used, and blmd-ident recovers the Ganesh servo's J and
// B from the noise-free traces within 1 %.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "blmd/io/config.h"
#include "blmd/io/csv.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

constexpr double kJ = 2.26e-5, kB = 2.261e-5;  // configs/ganesh-*.json

class InputFamilies : public ::testing::TestWithParam<const char*> {};

TEST_P(InputFamilies, SimulatedTraceCarriesTheInputAndIdentifiesJAndB) {
  const std::string config = SourcePath(std::string("configs/ganesh-") + GetParam() + ".json");
  TempDir dir;
  const std::string trace = dir.File("trace.csv");
  CommandResult run =
      blmd::testing::Run(BinPath("blmd-sim") + " --config " + config + " --out " + trace);
  ASSERT_EQ(run.exit_code, 0) << run.err;

  // The written u column is the configured signal at the sample times.
  const Config loaded = LoadConfig(config);
  const Trace t = ReadTraceCsv(trace);
  const auto& time = t.Column("t");
  const auto& u = t.Column("u");
  ASSERT_EQ(time.size(), loaded.experiment.SampleTimes().size());
  int wrong = 0;
  for (std::size_t k = 0; k < u.size(); ++k) {
    wrong += std::abs(u[k] - loaded.experiment.input.At(time[k])) > 1e-12;
  }
  EXPECT_EQ(wrong, 0);

  const std::string report = dir.File("report.json");
  run = blmd::testing::Run(BinPath("blmd-ident") + " --config " + config + " --trace " + trace +
                           " --quiet --report " + report);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json json = nlohmann::json::parse(Slurp(report));
  const double J = json["parameters"]["J"]["value"].get<double>();
  const double B = json["parameters"]["B"]["value"].get<double>();
  std::printf("%s: J error %.3g %%, B error %.3g %%\n", GetParam(), 100.0 * (J / kJ - 1.0),
              100.0 * (B / kB - 1.0));
  EXPECT_NEAR(J, kJ, 0.01 * kJ);
  EXPECT_NEAR(B, kB, 0.01 * kB);
}

INSTANTIATE_TEST_SUITE_P(GaneshServo, InputFamilies, ::testing::Values("prbs", "chirp"));

}  // namespace
}  // namespace blmd::testing
