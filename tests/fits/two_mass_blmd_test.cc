// A flexible coupling behind the BLMD drive (two_mass on blmd; docs/model-blmd.md §10a): a
// record of the D31x-class drive on a two-mass shaft under a PRBS torque demand, fitted from
// a rigid config as a new user would: the plain fit warns that the residual follows the
// input's past, --discover adds two_mass and finds the shaft, and blmd-tune names the
// crossover its resonance allows.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <tuple>

#include "support/test_support.h"

namespace blmd::testing {
namespace {

using nlohmann::json;

constexpr const char* kDrive = R"("Ud": 310, "Rs": 1.0, "Ls": 0.004, "Ke": 0.3, "p": 3,
    "Kc": 1.1, "Kf": 0.5, "Kp": 8, "Ki": 16000, "Vtri": 10, "Tpwm": 2e-4, "delta": 2e-5)";

// The report's 95 % interval of `name` covers `value`.
void ExpectCovers(const json& parameters, const char* name, double value) {
  EXPECT_LE(parameters[name]["ci95"][0].get<double>(), value) << name;
  EXPECT_GE(parameters[name]["ci95"][1].get<double>(), value) << name;
}

TEST(TwoMassBlmd, DiscoveryAddsTheCouplingAndTuneRespectsIt) {
  TempDir dir;
  // J 1.19e-3 kg·m² in total, load/motor 1.5, fa 40 Hz (fr 63.2 Hz), zeta 0.05; the PRBS
  // clock a whole number of samples, so that the recorded u replays the demand exactly.
  const std::string truth = dir.Write("truth.json", std::string(R"({
    "name": "blmd two-mass", "model": "blmd",
    "parameters": { )") + kDrive + R"(, "J": 1.19e-3, "B": 5e-4 },
    "effects": { "two_mass": { "inertia_ratio": 1.5, "anti_resonance_hz": 40,
                               "shaft_damping_ratio": 0.05, "load_damping_share": 0.3 } },
    "simulation": { "dt": 2e-6, "regula_falsi": true },
    "experiment": { "input": { "type": "prbs", "amplitude": 1.0, "clock": 0.002, "order": 8,
                               "seed": 3 },
                    "duration": 0.6, "sample_rate": 5000 } })");
  const std::string rigid = dir.Write("rigid.json", std::string(R"({
    "name": "blmd rigid", "model": "blmd",
    "parameters": { )") + kDrive + R"(, "J": 2e-3, "B": 1e-3 },
    "simulation": { "dt": 2e-6, "regula_falsi": true },
    "experiment": { "input": { "type": "step", "amplitude": 1 }, "duration": 0.1 },
    "identification": { "free": ["J", "B"], "observe": ["w"] } })");
  const std::string trace = dir.File("trace.csv"), plain = dir.File("plain.json"),
                    report = dir.File("report.json");
  ASSERT_EQ(blmd::testing::Run(BinPath("blmd-sim") + " --config " + truth + " --out " + trace +
                               " --noise w=0.5% --seed 3 --quiet")
                .exit_code,
            0);

  ASSERT_EQ(blmd::testing::Run(BinPath("blmd-ident") + " --config " + rigid + " --trace " + trace +
                               " --threads 2 --quiet --report " + plain)
                .exit_code,
            0);
  const json p0 = json::parse(Slurp(plain));
  ASSERT_FALSE(p0["warnings"].empty());
  EXPECT_EQ(p0["warnings"][0]["code"], "model_inadequate");
  EXPECT_NE(p0["warnings"][0]["message"].get<std::string>().find("u (past"), std::string::npos);

  const auto fitted =
      blmd::testing::Run(BinPath("blmd-ident") + " --config " + rigid + " --trace " + trace +
                         " --discover --threads 2 --quiet --report " + report);
  ASSERT_EQ(fitted.exit_code, 0) << fitted.err;
  const json r = json::parse(Slurp(report));
  ASSERT_EQ(r["discovery"]["added"], json::array({"two_mass"})) << r["discovery"].dump();
  EXPECT_TRUE(r["warnings"].empty()) << r["warnings"].dump();
  const auto& p = r["parameters"];
  for (const auto& [name, value, tolerance] :
       {std::tuple<const char*, double, double>{"J", 1.19e-3, 0.01},
        {"anti_resonance_hz", 40.0, 0.02},
        {"inertia_ratio", 1.5, 0.10},
        {"shaft_damping_ratio", 0.05, 0.10}}) {
    EXPECT_NEAR(p[name]["value"].get<double>(), value, tolerance * value) << name;
    ExpectCovers(p, name, value);
  }
  EXPECT_NEAR(r["derived"]["resonance_hz"]["value"].get<double>(), 40.0 * std::sqrt(2.5), 0.5);

  // A 40 Hz speed loop sampled at 5 kHz is refused by the resonance, naming the crossover it
  // allows (below 40 Hz); the named crossover is then tuned (exit 0).
  const auto refused = blmd::testing::Run(
      BinPath("blmd-tune") + " --config " + rigid + " --from-report " + report +
      " --loop speed --crossover 40 --phase-margin 60 --sample-rate 5000 --notch off");
  EXPECT_EQ(refused.exit_code, 1) << refused.err;
  const std::string marker = "on the two-mass shaft is ";
  const auto at = refused.err.find(marker);
  ASSERT_NE(at, std::string::npos) << refused.err;
  const double allowed = std::stod(refused.err.substr(at + marker.size()));
  EXPECT_GT(allowed, 10.0);
  EXPECT_LT(allowed, 40.0);
  const auto tuned =
      blmd::testing::Run(BinPath("blmd-tune") + " --config " + rigid + " --from-report " + report +
                         " --loop speed --crossover " + std::to_string(0.95 * allowed) +
                         " --phase-margin 60 --sample-rate 5000 --notch off --quiet");
  EXPECT_EQ(tuned.exit_code, 0) << tuned.err;
}

}  // namespace
}  // namespace blmd::testing
