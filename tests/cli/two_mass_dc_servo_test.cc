// Fits of flexible couplings (two_mass; docs/effects.md): --discover on a DC servo's record,
// and the load side's encoder (w_load) used when a record has it.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <tuple>

#include "support/test_support.h"

namespace blmd {
namespace {

using nlohmann::json;
using testing::BinPath;
using testing::TempDir;

// The report's 95 % interval of `name` (parameters[name].ci95) covers `value`.
void ExpectCovers(const json& parameters, const char* name, double value) {
  EXPECT_LE(parameters[name]["ci95"][0].get<double>(), value) << name;
  EXPECT_GE(parameters[name]["ci95"][1].get<double>(), value) << name;
}

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
  for (const auto& [name, value, tolerance] :
       {std::tuple<const char*, double, double>{"J", 2.26e-5, 0.01},
        {"anti_resonance_hz", 30.0, 0.02},
        {"inertia_ratio", 1.0, 0.10}}) {
    EXPECT_NEAR(p[name]["value"].get<double>(), value, tolerance * value) << name;
    ExpectCovers(p, name, value);
  }
}

// A rigid_load two-mass record with a load-side encoder (blmd-sim writes w_load and
// theta_load; 0.5 % noise on w and w_load), fitted with two_mass declared and every parameter
// free from a start away from the truth: observing w and w_load, each 95 % interval is
// narrower than with w alone (the load's column sees the shaft directly) and covers the
// truth. Without two_mass, w_load is no output of the model: refused naming the valid ones.
TEST(TwoMassLoadSide, TheLoadsEncoderNarrowsEveryInterval) {
  TempDir dir;
  // A two-mass shaft (resonance 63.2 Hz) under a PRBS torque (configs/two-mass-prbs.json).
  const std::string truth = testing::SourcePath("configs/two-mass-prbs.json");
  auto config = [&](const std::string& name, const std::string& observe) {
    return dir.Write(name, R"({
    "name": "fit", "model": "rigid_load",
    "parameters": { "J": 1.5e-3, "B": 0.03, "Kt": 0.5 },
    "effects": { "two_mass": { "inertia_ratio": 1.0, "anti_resonance_hz": 35,
                               "shaft_damping_ratio": 0.05, "load_damping_share": 0.3 } },
    "simulation": { "dt": 1e-4 },
    "identification": { "free": ["J", "B", "inertia_ratio", "anti_resonance_hz",
                                 "shaft_damping_ratio", "load_damping_share"],
                        "observe": )" +
                               observe + " } }");
  };
  const std::string trace = dir.File("trace.csv");
  ASSERT_EQ(testing::Run(BinPath("blmd-sim") + " --config " + truth + " --out " + trace +
                         " --noise w=0.5% --noise w_load=0.5% --seed 7")
                .exit_code,
            0);
  auto fit = [&](const std::string& path, const std::string& report) {
    const auto run = testing::Run(BinPath("blmd-ident") + " --config " + path + " --trace " +
                                  trace + " --quiet --report " + dir.File(report));
    EXPECT_EQ(run.exit_code, 0) << run.err;
    return json::parse(testing::Slurp(dir.File(report)))["parameters"];
  };
  const json motor = fit(config("w.json", R"(["w"])"), "w.json.report");
  const json both = fit(config("wl.json", R"(["w", "w_load"])"), "wl.json.report");
  const std::pair<const char*, double> truths[] = {{"J", 2e-3},
                                                   {"B", 0.04},
                                                   {"inertia_ratio", 1.5},
                                                   {"anti_resonance_hz", 40.0},
                                                   {"shaft_damping_ratio", 0.05},
                                                   {"load_damping_share", 0.3}};
  for (const auto& [name_, value] : truths) {
    // A named copy, not the binding: clang before 16 cannot capture a structured binding.
    const char* name = name_;
    auto width = [&](const json& p) {
      return p[name]["ci95"][1].get<double>() - p[name]["ci95"][0].get<double>();
    };
    EXPECT_LT(width(both), width(motor)) << name;
    ExpectCovers(both, name, value);
  }
  const std::string rigid = dir.Write("rigid.json", R"({
    "name": "rigid", "model": "rigid_load", "parameters": { "J": 1e-3, "B": 0.02, "Kt": 0.5 },
    "identification": { "free": ["J", "B"], "observe": ["w", "w_load"] } })");
  const auto refused =
      testing::Run(BinPath("blmd-ident") + " --config " + rigid + " --trace " + trace + " --quiet");
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("'w_load' is not an output of model rigid_load (valid: w,theta); it "
                             "comes with the effect two_mass"),
            std::string::npos)
      << refused.err;
}

}  // namespace
}  // namespace blmd
