// --discover on a DC servo with a flexible coupling (two_mass on dc_servo; docs/effects.md):
// a record of the Ganesh servo's armature on a two-mass shaft (blmd-sim, PRBS voltage, 0.5 %
// noise on the current and the speed), fitted from a rigid dc_servo config with J and B free.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>

#include "support/test_support.h"

namespace blmd {
namespace {

using nlohmann::json;
using testing::BinPath;
using testing::TempDir;

// Discovery adds two_mass and finds the truth: J within 1 %, the anti-resonance within 2 %,
// the inertia ratio within 10 %, each 95 % interval covering it; the rigid fit's residual
// had followed the input's past.
TEST(TwoMassDcServo, DiscoveryAddsTheCouplingAndFindsIt) {
  TempDir dir;
  const std::string truth = dir.Write("truth.json", R"({
    "name": "dc two-mass", "model": "dc_servo",
    "parameters": { "R": 12.6, "L": 0.283, "Kt": 0.04, "Kb": 0.04, "J": 2.26e-5, "B": 2.261e-5 },
    "effects": { "two_mass": { "inertia_ratio": 1.0, "anti_resonance_hz": 30,
                               "shaft_damping_ratio": 0.03, "load_damping_share": 0.0 } },
    "simulation": { "dt": 1e-4 },
    "experiment": { "input": { "type": "prbs", "amplitude": 6, "clock": 0.004, "order": 10,
                               "seed": 3 },
                    "duration": 3, "sample_rate": 2000 } })");
  const std::string rigid = dir.Write("rigid.json", R"({
    "name": "dc rigid", "model": "dc_servo",
    "parameters": { "R": 12.6, "L": 0.283, "Kt": 0.04, "Kb": 0.04, "J": 1e-5, "B": 1e-5 },
    "simulation": { "dt": 1e-4 },
    "experiment": { "input": { "type": "step", "amplitude": 1 }, "duration": 1 },
    "identification": { "free": ["J", "B"], "observe": ["i", "w"] } })");
  const std::string trace = dir.File("trace.csv"), report = dir.File("report.json");
  ASSERT_EQ(testing::Run(BinPath("blmd-sim") + " --config " + truth + " --out " + trace +
                         " --noise w=0.5% --noise i=0.5% --seed 3")
                .exit_code,
            0);
  const auto fitted = testing::Run(BinPath("blmd-ident") + " --config " + rigid + " --trace " +
                                   trace + " --discover --threads 2 --quiet --report " + report);
  ASSERT_EQ(fitted.exit_code, 0) << fitted.err;
  const json r = json::parse(testing::Slurp(report));
  ASSERT_EQ(r["discovery"]["added"], json::array({"two_mass"})) << r["discovery"].dump();
  const auto& p = r["parameters"];
  auto check = [&](const char* name, double value, double tolerance) {
    const double estimate = p[name]["value"];
    EXPECT_NEAR(estimate, value, tolerance * value) << name;
    EXPECT_LE(p[name]["ci95"][0].get<double>(), value) << name;
    EXPECT_GE(p[name]["ci95"][1].get<double>(), value) << name;
  };
  check("J", 2.26e-5, 0.01);
  check("anti_resonance_hz", 30.0, 0.02);
  check("inertia_ratio", 1.0, 0.10);
}

}  // namespace
}  // namespace blmd
