// Discovery on traces with one undeclared effect (testdata/README.md, scripts/make-testdata):
// the real blmd-ident --discover on real files. Each case knows the hidden effect and its
// value, and the true J and B.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "support/test_support.h"

namespace blmd::testing {
namespace {

struct HiddenEffectCase {
  std::string name;    // test name
  std::string config;  // configs/...
  std::string trace;   // testdata/...
  std::string observe;
  std::string effect;                   // the hidden effect ("" for controls)
  std::map<std::string, double> truth;  // its parameters
  double J = 0.0, B = 0.0;              // the true inertia and damping
  std::string known_failure;            // non-empty: skipped, with the reason
};

void PrintTo(const HiddenEffectCase& c, std::ostream* out) { *out << c.name; }

nlohmann::json Discover(const HiddenEffectCase& c) {
  const CommandResult run =
      blmd::testing::Run(BinPath("blmd-ident") + " --config " + SourcePath(c.config) + " --trace " +
                         SourcePath(c.trace) + " --observe " + c.observe + " --discover --json");
  EXPECT_EQ(run.exit_code, 0) << run.err;
  return nlohmann::json::parse(run.out);
}

class HiddenEffect : public ::testing::TestWithParam<HiddenEffectCase> {};

TEST_P(HiddenEffect, IsFoundFittedAndExplainsTheResidual) {
  const HiddenEffectCase& c = GetParam();
  if (!c.known_failure.empty())
    GTEST_SKIP() << "KNOWN FAILURE, not solved yet: " << c.known_failure;
  const nlohmann::json report = Discover(c);
  const auto& d = report["discovery"];
  ASSERT_EQ(d["added"], nlohmann::json::array({c.effect})) << d["conclusion"];
  const auto& step = d["steps"][0];
  for (const auto& [name, value] : c.truth) {
    const double fitted = step["parameters"][name].get<double>();
    std::cout << c.name << ": " << name << " = " << fitted << " (truth " << value << ", "
              << 100.0 * (fitted / value - 1.0) << " %)\n";
    EXPECT_NEAR(fitted, value, 0.10 * std::abs(value)) << name;
  }
  const double before = d["error_before"]["nrmse"].get<double>();
  const double after = d["error_after"]["nrmse"].get<double>();
  std::cout << c.name << ": NRMSE " << before << " -> " << after << "\n";
  EXPECT_LE(after, 0.5 * before);
  // The headline is the final model (schema 2); the first fit is under discovery.before.
  const double J_before = d["before"]["parameters"]["J"]["value"].get<double>();
  const double B_before = d["before"]["parameters"]["B"]["value"].get<double>();
  const double J_after = d["parameters_after"]["J"].get<double>();
  const double B_after = d["parameters_after"]["B"].get<double>();
  EXPECT_EQ(report["parameters"]["J"]["value"].get<double>(), J_after);
  EXPECT_EQ(report["parameters"]["B"]["value"].get<double>(), B_after);
  EXPECT_EQ(report["fit"]["nrmse"], d["error_after"]["nrmse"]);
  std::cout << c.name << ": J " << 100 * (J_before / c.J - 1) << " % -> "
            << 100 * (J_after / c.J - 1) << " %, B " << 100 * (B_before / c.B - 1) << " % -> "
            << 100 * (B_after / c.B - 1) << " %\n";
  EXPECT_NEAR(J_after, c.J, 0.02 * c.J);
  EXPECT_NEAR(B_after, c.B, 0.02 * c.B);
  // Before, the model without the effect absorbs it into J and B, and discovery does not
  // leave them worse. (Weighted by each column's noise, the first fit is no longer visibly
  // biased on every case: a current offset of 0.04 A moved J by -0.08 % and B by +0.5 %, where
  // the variance weighting had moved B by more than 2 %.)
  EXPECT_LE(std::abs(J_after / c.J - 1) + std::abs(B_after / c.B - 1),
            std::abs(J_before / c.J - 1) + std::abs(B_before / c.B - 1) + 0.002);
}

const double kJ = 2.26e-5, kB = 2.261e-5;  // Ganesh no-load motor
const double kJb = 11.9e-4, kBb = 5e-4;    // blmd-d31x
INSTANTIATE_TEST_SUITE_P(Testdata, HiddenEffect,
                         ::testing::Values(HiddenEffectCase{"DcCoulomb",
                                                            "configs/ganesh-square.json",
                                                            "testdata/dc-hidden-coulomb.csv",
                                                            "i,w",
                                                            "coulomb_friction",
                                                            {{"Tc", 0.012}},
                                                            kJ,
                                                            kB,
                                                            ""},
                                           HiddenEffectCase{"DcLoad",
                                                            "configs/ganesh-square.json",
                                                            "testdata/dc-hidden-load.csv",
                                                            "i,w",
                                                            "load_torque",
                                                            {{"TL", 0.0015}},
                                                            kJ,
                                                            kB,
                                                            ""},
                                           HiddenEffectCase{"DcDrag",
                                                            "configs/ganesh-staircase.json",
                                                            "testdata/dc-hidden-drag.csv",
                                                            "i,w",
                                                            "quadratic_drag",
                                                            {{"Cd", 3e-7}},
                                                            kJ,
                                                            kB,
                                                            ""},
                                           HiddenEffectCase{"DcDeadTime",
                                                            "configs/ganesh-square.json",
                                                            "testdata/dc-hidden-dead-time.csv",
                                                            "i,w",
                                                            "dead_time",
                                                            {{"Vdt", 0.6}},
                                                            kJ,
                                                            kB,
                                                            ""},
                                           HiddenEffectCase{"DcCurrentOffset",
                                                            "configs/ganesh-square.json",
                                                            "testdata/dc-hidden-current-offset.csv",
                                                            "i,w",
                                                            "current_offset",
                                                            {{"i0", 0.04}},
                                                            kJ,
                                                            kB,
                                                            ""},
                                           HiddenEffectCase{"DcStribeck",
                                                            "configs/ganesh-square.json",
                                                            "testdata/dc-hidden-stribeck.csv",
                                                            "i,w",
                                                            "stribeck",
                                                            {{"Ts", 0.02}, {"ws", 50.0}},
                                                            kJ,
                                                            kB,
                                                            ""},
                                           HiddenEffectCase{"DcCogging",
                                                            "configs/ganesh-square.json",
                                                            "testdata/dc-hidden-cogging.csv",
                                                            "i,w",
                                                            "cogging",
                                                            {{"Tcog", 0.025}, {"periods", 6.0}},
                                                            kJ,
                                                            kB,
                                                            ""},
                                           HiddenEffectCase{"BlmdLoad",
                                                            "configs/blmd-d31x-square.json",
                                                            "testdata/blmd-hidden-load.csv",
                                                            "w",
                                                            "load_torque",
                                                            {{"TL", 0.15}},
                                                            kJb,
                                                            kBb,
                                                            ""},
                                           HiddenEffectCase{"BlmdCogging",
                                                            "configs/blmd-d31x-square.json",
                                                            "testdata/blmd-hidden-cogging.csv",
                                                            "w",
                                                            "cogging",
                                                            {{"Tcog", 0.15}, {"periods", 12.0}},
                                                            kJb,
                                                            kBb,
                                                            ""}),
                         [](const ::testing::TestParamInfo<HiddenEffectCase>& info) {
                           return info.param.name;
                         });

TEST(Discovery, ControlsWithoutAHiddenEffectAddNothing) {
  for (const auto& [config, trace, observe] :
       std::vector<std::tuple<std::string, std::string, std::string>>{
           {"configs/ganesh-square.json", "testdata/ganesh-square.csv", "i,w"},
           {"configs/blmd-d31x-square.json", "testdata/blmd-square.csv", "w"}}) {
    HiddenEffectCase c{"control", config, trace, observe, "", {}, 0, 0, ""};
    const nlohmann::json report = Discover(c);
    EXPECT_EQ(report["discovery"]["added"], nlohmann::json::array()) << trace;
    EXPECT_EQ(report["discovery"]["conclusion"].get<std::string>().rfind("nothing missing", 0), 0u)
        << report["discovery"]["conclusion"];
  }
}

TEST(Discovery, CoulombAndLoadAreAmbiguousWhenTheShaftNeverStops) {
  HiddenEffectCase c{"ambiguous",
                     "configs/ganesh-running.json",
                     "testdata/dc-ambiguous-coulomb.csv",
                     "i,w",
                     "",
                     {},
                     0,
                     0,
                     ""};
  const nlohmann::json report = Discover(c);
  const auto& d = report["discovery"];
  // The best of the two by BIC is added (the model with neither fits clearly worse than each,
  // NRMSE 0.074 against 0.043: it must not head the report), the other reported beside it.
  ASSERT_EQ(d["added"].size(), 1u);
  const std::string added = d["added"][0];
  EXPECT_TRUE(added == "coulomb_friction" || added == "load_torque") << added;
  ASSERT_EQ(d["ambiguous"].size(), 1u);
  EXPECT_EQ(d["ambiguous"][0]["effects"],
            nlohmann::json::array({"coulomb_friction", "load_torque"}));
  EXPECT_EQ(d["conclusion"].get<std::string>().rfind(
                "added " + added + " (the best of models that fit as well", 0),
            0u)
      << d["conclusion"];
  // Each competing model is reported with its J and B and error, and the headline's
  // intervals cover them, and the truth (J 2.26e-5, B 2.261e-5), which the first fit's B,
  // +52 %, missed.
  const auto& models = d["ambiguous"][0]["models"];
  ASSERT_EQ(models.size(), 2u);
  for (const auto& m : models) {
    for (const char* name : {"J", "B"}) {
      const double v = m["parameters"][name].get<double>();
      const auto& ci = report["parameters"][name]["ci95"];
      EXPECT_LE(ci[0].get<double>(), v) << m["effect"] << " " << name;
      EXPECT_GE(ci[1].get<double>(), v) << m["effect"] << " " << name;
    }
    EXPECT_NEAR(m["nrmse"].get<double>(), report["fit"]["nrmse"].get<double>(), 0.001);
  }
  for (const auto& [name, truth] : {std::pair{"J", 2.26e-5}, std::pair{"B", 2.261e-5}}) {
    const auto& ci = report["parameters"][name]["ci95"];
    EXPECT_LE(ci[0].get<double>(), truth) << name;
    EXPECT_GE(ci[1].get<double>(), truth) << name;
  }
  EXPECT_GT(report["discovery"]["before"]["parameters"]["B"]["value"].get<double>(),
            1.4 * 2.261e-5);
  std::string message;
  for (const auto& w : report["warnings"])
    if (w["code"] == "discovery_ambiguous") message = w["message"];
  EXPECT_NE(message.find("it added " + added + ", the best by BIC"), std::string::npos) << message;
  EXPECT_NE(message.find("agree across them"), std::string::npos) << message;
}

}  // namespace
}  // namespace blmd::testing
