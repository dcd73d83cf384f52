// asymmetric_viscous (docs/effects.md): the viscous damping depends on the direction,
// T = dB |w| on top of B w, so B+ = B + dB turning forwards and B- = B - dB backwards.
// Oracles: the sign convention of the torque itself; the steady speed and the exponential
// approach of rigid_load under a constant torque in each direction (J dw/dt = T - B± w has
// w(t) = T/B± (1 - exp(-B± t / J)) from rest, derived by hand); a round trip through
// blmd-sim and blmd-ident --discover with the truth known.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>

#include "blmd/io/config.h"
#include "blmd/run.h"
#include "blmd/sim/effects.h"
#include "support/test_support.h"

namespace blmd {
namespace {

constexpr double kJ = 1e-3, kB = 2e-3, kdB = 0.5e-3;  // kg m^2, N m s/rad

TEST(AsymmetricViscous, RegistryEntry) {
  const EffectInfo& effect = FindEffect("asymmetric_viscous");
  ASSERT_EQ(effect.parameters.size(), 1u);
  EXPECT_EQ(effect.parameters[0].name, "dB");
  EXPECT_EQ(effect.parameters[0].unit, "N·m·s/rad");
  EXPECT_FALSE(effect.parameters[0].non_negative);  // signed: either direction may be stiffer
  const auto& models = effect.models;
  EXPECT_NE(std::find(models.begin(), models.end(), "rigid_load"), models.end());
  EXPECT_NE(std::find(models.begin(), models.end(), "blmd"), models.end());
  std::string owner;
  EXPECT_TRUE(IsEffectParameter("dB", &owner));
  EXPECT_EQ(owner, "asymmetric_viscous");
}

TEST(AsymmetricViscous, TorqueBrakesForwardsAndHelpsBackwardsForPositiveDb) {
  ParameterSet values;
  values.Set("dB", kdB);
  const ShaftEffects shaft = ShaftEffects::From(values, {"asymmetric_viscous"}, 0.0);
  EXPECT_EQ(shaft.dB, kdB);
  EXPECT_FALSE(shaft.has_friction());  // no sticking: it vanishes at rest
  // T_effects = dB |w|: with B w the total is (B + dB) w forwards, (B - dB) w backwards.
  EXPECT_DOUBLE_EQ(shaft.DragTorque(10.0), kdB * 10.0);
  EXPECT_DOUBLE_EQ(shaft.DragTorque(-10.0), kdB * 10.0);
  EXPECT_EQ(shaft.DragTorque(0.0), 0.0);
  EXPECT_DOUBLE_EQ(kB * 10.0 + shaft.DragTorque(10.0), (kB + kdB) * 10.0);
  EXPECT_DOUBLE_EQ(kB * -10.0 + shaft.DragTorque(-10.0), (kB - kdB) * -10.0);
  // Beside quadratic drag the two terms add.
  values.Set("Cd", 1e-6);
  const ShaftEffects both =
      ShaftEffects::From(values, {"asymmetric_viscous", "quadratic_drag"}, 0.0);
  EXPECT_DOUBLE_EQ(both.DragTorque(-10.0), -1e-6 * 100.0 + kdB * 10.0);
}

// rigid_load from rest under a constant torque `torque` (N m) for `duration` s.
Trace ConstantTorque(double torque, double dB, double duration) {
  const std::string text = R"({
    "model": "rigid_load",
    "parameters": { "J": )" +
                           std::to_string(kJ) + R"(, "B": )" + std::to_string(kB) + R"( },
    "effects": { "asymmetric_viscous": { "dB": )" +
                           std::to_string(dB) + R"( } },
    "simulation": { "dt": 1e-4 },
    "experiment": { "input": { "type": "step", "amplitude": )" +
                           std::to_string(torque) + R"( }, "duration": )" +
                           std::to_string(duration) +
                           R"(, "sample_rate": 1000 }
  })";
  const Config config = ParseConfig(text, "asymmetric.json");
  Trace trace;
  EXPECT_TRUE(RunExperiment(config, &trace).ok());
  return trace;
}

TEST(AsymmetricViscous, SteadySpeedIsTorqueOverTheDampingOfItsDirection) {
  for (const double dB : {kdB, -kdB}) {
    for (const double torque : {0.01, -0.01}) {
      const double damping = torque > 0.0 ? kB + dB : kB - dB;  // B+ or B-
      const double tau = kJ / damping;
      const Trace trace = ConstantTorque(torque, dB, 20.0 * tau);
      const auto& t = trace.Column("t");
      const auto& w = trace.Column("w");
      // The end: T / B± (to the exponential's e^-20 and rounding).
      EXPECT_NEAR(w.back() / (torque / damping), 1.0, 1e-8) << "dB " << dB << ", T " << torque;
      // On the way: w(t) = T/B± (1 - exp(-t/tau)); the dB term is held over each step of
      // 1e-4 s (explicit), so the transient agrees to a fraction of dt/tau.
      double worst = 0.0;
      for (std::size_t k = 0; k < t.size(); ++k) {
        const double exact = torque / damping * (1.0 - std::exp(-t[k] / tau));
        worst = std::max(worst, std::abs(w[k] - exact));
      }
      EXPECT_LT(worst, 1e-3 * std::abs(torque / damping)) << "dB " << dB << ", T " << torque;
    }
  }
}

TEST(AsymmetricViscous, ZeroDbIsTheSymmetricModelBitForBit) {
  const Trace with = ConstantTorque(0.01, 0.0, 1.0);
  const std::string text = R"({
    "model": "rigid_load",
    "parameters": { "J": )" +
                           std::to_string(kJ) + R"(, "B": )" + std::to_string(kB) + R"( },
    "simulation": { "dt": 1e-4 },
    "experiment": { "input": { "type": "step", "amplitude": 0.01 }, "duration": 1.0, "sample_rate": 1000 }
  })";
  Trace without;
  ASSERT_TRUE(RunExperiment(ParseConfig(text, "symmetric.json"), &without).ok());
  EXPECT_EQ(with.Column("w"), without.Column("w"));
  EXPECT_EQ(with.Column("theta"), without.Column("theta"));
}

// Round trip: a square-wave torque both ways with 1 % speed noise and a hidden dB; discovery
// must add asymmetric_viscous (not Coulomb friction or a load torque, which differ by
// direction too but not in proportion to the speed) with dB, J and B within 5 %.
TEST(AsymmetricViscous, DiscoveryFindsItOnARoundTrip) {
  testing::TempDir dir;
  const std::string config = dir.Write("square.json", R"({
    "model": "rigid_load",
    "parameters": { "J": 1e-3, "B": 2e-3 },
    "simulation": { "dt": 1e-4 },
    "experiment": { "input": { "type": "square", "amplitude": 0.01, "period": 4.0 },
                    "duration": 8.0, "sample_rate": 500 },
    "identification": { "free": ["J", "B"], "initial": { "J": 5e-4, "B": 1e-3 },
                        "observe": ["w"], "method": "ceres" }
  })");
  const std::string trace = dir.File("trace.csv");
  const testing::CommandResult sim =
      testing::Run(testing::BinPath("blmd-sim") + " --config " + config + " --out " + trace +
                   " --effect asymmetric_viscous:dB=0.0005 --noise w=0.05 --seed 3 --quiet");
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const testing::CommandResult ident =
      testing::Run(testing::BinPath("blmd-ident") + " --config " + config + " --trace " + trace +
                   " --discover --json --threads 1");
  ASSERT_EQ(ident.exit_code, 0) << ident.err;
  const nlohmann::json report = nlohmann::json::parse(ident.out);
  const auto& d = report["discovery"];
  ASSERT_EQ(d["added"], nlohmann::json::array({"asymmetric_viscous"})) << d["conclusion"];
  const auto& after = d["parameters_after"];
  EXPECT_NEAR(after["dB"].get<double>(), kdB, 0.05 * kdB);
  EXPECT_NEAR(after["J"].get<double>(), kJ, 0.05 * kJ);
  EXPECT_NEAR(after["B"].get<double>(), kB, 0.05 * kB);
  EXPECT_LT(d["error_after"]["nrmse"].get<double>(),
            0.5 * d["error_before"]["nrmse"].get<double>());
}

}  // namespace
}  // namespace blmd
