// The report's warnings about the final model (docs/report.md "Warnings"): each
// code from the figures that call for it, and --fail-on-warning as a CI gate.
#include <gtest/gtest.h>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "blmd/io/csv.h"
#include "blmd/report/report.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

// A report whose every figure is fine: no warning.
IdentReport CleanReport() {
  IdentReport report;
  ModelReport& model = report.final_model;
  model.summary.converged = true;
  model.summary.termination = "CONVERGENCE";
  model.fit.errors.ok = true;
  model.fit.errors.nrmse = 0.05;
  ResidualAnalysis residual;
  residual.ok = true;
  residual.white = true;
  residual.whiteness_p = 0.4;
  model.residual.analysis = residual;
  ParameterReport J;
  J.estimate.name = "J";
  J.estimate.value = 2e-5;
  J.estimate.has_interval = true;
  J.estimate.ci95_low = 1.9e-5;
  J.estimate.ci95_high = 2.1e-5;
  J.has_bounds = true;
  J.lower = 1e-7;
  J.upper = 1e-3;
  model.parameters["J"] = J;
  ParameterReport Kb;  // a classic estimate: no interval, no warning for it
  Kb.estimate.name = "Kb";
  Kb.estimate.value = 0.05;
  Kb.free = false;
  model.parameters["Kb"] = Kb;
  return report;
}

std::vector<std::string> Codes(IdentReport report) {
  AddWarnings(&report);
  std::vector<std::string> codes;
  for (const auto& w : report.warnings) codes.push_back(w.code);
  return codes;
}

ErrorFigures Nrmse(double nrmse) {
  ErrorFigures errors;
  errors.ok = true;
  errors.nrmse = nrmse;
  return errors;
}

TEST(Warnings, NoneWhenEveryFigureIsFine) { EXPECT_TRUE(Codes(CleanReport()).empty()); }

TEST(Warnings, EachCodeFromItsFigure) {
  using Codes_ = std::vector<std::string>;
  IdentReport r = CleanReport();
  r.final_model.summary.converged = false;
  EXPECT_EQ(Codes(r), Codes_{"not_converged"});
  r = CleanReport();
  r.final_model.fit.errors.nrmse = 1.0;
  EXPECT_EQ(Codes(r), Codes_{"nrmse_at_least_one"});
  r = CleanReport();
  r.final_model.validation = ValidationReport{};
  r.final_model.validation->errors = Nrmse(1.3);
  EXPECT_EQ(Codes(r), Codes_{"nrmse_at_least_one"});
  // A coloured residual alone is no verdict on the model (a note, not a warning).
  r = CleanReport();
  r.final_model.residual.analysis->white = false;
  r.final_model.residual.analysis->whiteness_p = 1e-9;
  EXPECT_EQ(Codes(r), Codes_{});
  // Structure the adequacy check flags is: run --discover.
  r = CleanReport();
  r.adequacy = AdequacyReport{};
  r.adequacy->ok = true;
  StructureTest sign;
  sign.state = "sign(w)";
  sign.column = "w";
  sign.share = 0.4;
  sign.p_value = 1e-30;
  sign.significant = sign.flagged = true;
  r.adequacy->flagged.push_back(sign);
  EXPECT_EQ(Codes(r), Codes_{"model_inadequate"});
  {
    IdentReport inadequate = r;
    AddWarnings(&inadequate);
    EXPECT_NE(inadequate.warnings[0].message.find("run --discover"), std::string::npos);
    EXPECT_EQ(inadequate.warnings[0].message.find("both directions"), std::string::npos);
    // Motion one way only: J and a constant torque are confounded.
    inadequate = r;
    inadequate.final_model.residual.analysis->w_changes_sign = false;
    inadequate.final_model.residual.analysis->w_max = 100.0;
    AddWarnings(&inadequate);
    EXPECT_NE(inadequate.warnings[0].message.find("record motion in both directions"),
              std::string::npos);
  }
  // Not a fit: NRMSE >= 1 with a parameter at its bound.
  r = CleanReport();
  r.final_model.fit.errors.nrmse = 8.9;
  r.final_model.parameters["J"].at_bound = true;
  EXPECT_EQ(Codes(r), (Codes_{"nrmse_at_least_one", "not_a_fit", "parameter_at_bound"}));
  r = CleanReport();
  r.final_model.parameters["J"].at_bound = true;
  EXPECT_EQ(Codes(r), Codes_{"parameter_at_bound"});
  r = CleanReport();
  r.final_model.parameters["J"].estimate.ci95_low = -1e-5;  // +-150 %
  r.final_model.parameters["J"].estimate.ci95_high = 5e-5;
  EXPECT_EQ(Codes(r), Codes_{"parameter_poorly_determined"});
  r = CleanReport();
  r.final_model.parameters["J"].estimate.has_interval = false;
  r.final_model.summary.interval_unavailable = "the Jacobian is rank deficient";
  IdentReport with = r;
  AddWarnings(&with);
  ASSERT_EQ(with.warnings.size(), 1u);
  EXPECT_EQ(with.warnings[0].code, "interval_unavailable");
  EXPECT_EQ(with.warnings[0].message, "no interval for J: the Jacobian is rank deficient");
  r = CleanReport();
  r.discovery = DiscoveryReport{};
  r.discovery->ambiguous.push_back(
      {{"coulomb_friction", "load_torque"}, "they explain the residual equally well", {}});
  r.discovery->has_validation = true;
  r.discovery->validation_before = Nrmse(0.1);
  r.discovery->validation_after = Nrmse(0.12);
  EXPECT_EQ(Codes(r), (Codes_{"discovery_ambiguous", "validation_worse_after_discovery"}));
}

// Widening for ambiguity: the headline's interval becomes the hull of the competing
// models' values, the interval before is kept, and the method says so.
TEST(Warnings, AmbiguityWidensTheIntervalToTheCompetingModels) {
  IdentReport r = CleanReport();
  r.discovery = DiscoveryReport{};
  r.discovery->ambiguous.push_back({{"coulomb_friction", "load_torque"},
                                    "close",
                                    {{"coulomb_friction", 0.1, -20.0, {{"J", 2.3e-5}}},
                                     {"load_torque", 0.1, -19.0, {{"J", 2e-5}}}}});
  r.final_model.parameters["J"].estimate.interval_method = "hac_prewhitened";
  WidenForAmbiguity(&r);
  const ParameterReport& J = r.final_model.parameters["J"];
  EXPECT_TRUE(J.widened_by_ambiguity);
  EXPECT_EQ(J.estimate.ci95_low, 1.9e-5);
  EXPECT_EQ(J.estimate.ci95_high, 2.3e-5);
  EXPECT_EQ(J.ci95_before_ambiguity_high, 2.1e-5);
  EXPECT_EQ(J.estimate.interval_method, "hac_prewhitened+ambiguity");
  const nlohmann::json json = r;
  EXPECT_EQ(json["parameters"]["J"]["ci95_before_ambiguity"], nlohmann::json({1.9e-5, 2.1e-5}));
  EXPECT_EQ(json["parameters"]["J"]["ci95"], nlohmann::json({1.9e-5, 2.3e-5}));
}

// The summary's line for an equation-error discovery compares the first fit (as a
// simulation) with the final model. Before the typed report it printed the final model's
// figure on both sides ("0.04958 -> 0.04958" on EMPS), as the headline had become the final
// model while the summary still read the headline for "before".
TEST(Warnings, SummaryComparesTheFirstFitWithTheFinalModelAsSimulations) {
  IdentReport r = CleanReport();
  r.final_model.fit.equation_error = true;
  r.final_model.fit.simulated = SimulatedFit{"w", Nrmse(0.0496)};
  r.discovery = DiscoveryReport{};
  r.discovery->before = r.final_model;
  r.discovery->before.fit.simulated = SimulatedFit{"w", Nrmse(0.1973)};
  r.discovery->equation_error = true;
  r.discovery->simulated_after = SimulatedFit{"w", Nrmse(0.0496)};
  r.discovery->error_before = Nrmse(0.181);
  r.discovery->error_after = Nrmse(0.0434);
  const std::string summary = HumanSummary(r);
  EXPECT_NE(summary.find("  simulated w NRMSE before -> after: 0.1973 -> 0.0496\n"),
            std::string::npos)
      << summary;
}

// The gate: the bundled Coulomb trace fitted without its friction leaves a residual that is
// not white; with --discover the final model's residual is white and nothing is warned.
TEST(Warnings, FailOnWarningIsExitThreeAfterWritingTheReport) {
  TempDir dir;
  const std::string base = BinPath("blmd-ident") + " --config " +
                           SourcePath("configs/ganesh-square.json") + " --trace " +
                           SourcePath("testdata/dc-hidden-coulomb.csv") + " --quiet --threads 2";
  CommandResult run =
      blmd::testing::Run(base + " --report " + dir.File("r.json") + " --fail-on-warning");
  EXPECT_EQ(run.exit_code, 3);
  EXPECT_EQ(run.err, "error: 1 warning (model_inadequate) and --fail-on-warning\n");
  const nlohmann::json report = nlohmann::json::parse(Slurp(dir.File("r.json")));
  EXPECT_EQ(report["schema_version"], 2);
  ASSERT_EQ(report["warnings"].size(), 1u);
  EXPECT_EQ(report["warnings"][0]["code"], "model_inadequate");
  run = blmd::testing::Run(
      base + " --discover --candidates coulomb_friction,load_torque --fail-on-warning");
  EXPECT_EQ(run.exit_code, 0) << run.err;
}

// Units hints (docs/identification.md §5a): the bundled square-wave trace with its speed
// written in rpm is named with the flag that converts it, exit 3 with --fail-on-warning; with
// that flag the fit equals the one on the trace in rad/s (to 1e-6) and nothing is warned.
TEST(Warnings, UnitsSuspectNamesTheScaleFlagThatFixesTheTrace) {
  TempDir dir;
  Trace trace = ReadTraceCsv(SourcePath("testdata/ganesh-square.csv"));
  for (double& w : trace.Column("w")) w *= 60.0 / (2.0 * 3.14159265358979323846);
  WriteTraceCsv(trace, dir.File("rpm.csv"));
  const std::string base = BinPath("blmd-ident") + " --config " +
                           SourcePath("configs/ganesh-square.json") + " --threads 2 --quiet";
  CommandResult run = blmd::testing::Run(base + " --trace " + dir.File("rpm.csv") + " --report " +
                                         dir.File("rpm.json") + " --fail-on-warning");
  EXPECT_EQ(run.exit_code, 3);
  EXPECT_EQ(run.err, "error: 2 warnings (model_inadequate, units_suspect) and --fail-on-warning\n");
  const nlohmann::json rpm = nlohmann::json::parse(Slurp(dir.File("rpm.json")));
  const std::string message = rpm["warnings"][1]["message"];
  EXPECT_EQ(rpm["warnings"][1]["code"], "units_suspect");
  const std::string tail =
      ": is 'w' in rpm? The model works in rad/s; if so, convert it with --scale "
      "w=0.10471975511965977";
  ASSERT_GE(message.size(), tail.size());
  EXPECT_EQ(message.substr(message.size() - tail.size()), tail) << message;

  run = blmd::testing::Run(base + " --trace " + dir.File("rpm.csv") +
                           " --scale w=0.10471975511965977 --report " + dir.File("fixed.json") +
                           " --fail-on-warning");
  EXPECT_EQ(run.exit_code, 0) << run.err;
  run = blmd::testing::Run(base + " --trace " + SourcePath("testdata/ganesh-square.csv") +
                           " --report " + dir.File("rad.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json fixed = nlohmann::json::parse(Slurp(dir.File("fixed.json")));
  const nlohmann::json rad = nlohmann::json::parse(Slurp(dir.File("rad.json")));
  EXPECT_TRUE(fixed["warnings"].empty()) << fixed["warnings"].dump();
  for (const char* name : {"J", "B"}) {
    const double a = fixed["parameters"][name]["value"], b = rad["parameters"][name]["value"];
    EXPECT_NEAR(a / b, 1.0, 1e-6) << name;
  }
}

// With load_torque and quadratic_drag both in the model the intervals of J and B once
// collapsed by about four orders of magnitude (J +-1.2e-11 on HSM150). On a square-wave
// trace of the Ganesh servo with both effects (1 % noise), J, B, TL and Cd free: J's
// interval is a believable +-0.3 %. B trades against Cd (both oppose the speed): weighted by
// the columns' variance the fit put B on its lower bound with an interval of 250 decades
// (warned as poorly determined); weighted by their noise (the default since 0.3) all four are
// determined, B within 15 % of the truth and no warning.
TEST(Warnings, LoadTorqueAndDragTogetherKeepHonestIntervals) {
  TempDir dir;
  nlohmann::json config = nlohmann::json::parse(Slurp(SourcePath("configs/ganesh-square.json")));
  config["effects"] = {{"load_torque", {{"TL", 0.0015}}}, {"quadratic_drag", {{"Cd", 3e-7}}}};
  config["identification"]["free"] = {"J", "B", "TL", "Cd"};
  const std::string path = dir.Write("lq.json", config.dump());
  CommandResult run =
      blmd::testing::Run(BinPath("blmd-sim") + " --config " + path +
                         " --noise i=1% --noise w=1% --seed 3 --quiet --out " + dir.File("lq.csv"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  run = blmd::testing::Run(BinPath("blmd-ident") + " --config " + path + " --trace " +
                           dir.File("lq.csv") + " --threads 2 --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json report = nlohmann::json::parse(run.out);
  const auto& J = report["parameters"]["J"];
  const double half = 0.5 * (J["ci95"][1].get<double>() - J["ci95"][0].get<double>());
  const double relative = half / J["value"].get<double>();
  EXPECT_GT(relative, 1e-3);  // measured 3.2e-3 (the collapse gave ~5e-7)
  EXPECT_LT(relative, 0.02);
  EXPECT_NEAR(J["value"].get<double>(), 2.26e-5, 0.01 * 2.26e-5);  // +0.7 %
  for (const char* name : {"TL", "Cd"}) {
    const auto& p = report["parameters"][name];
    ASSERT_TRUE(p["ci95"].is_array()) << name;
    EXPECT_GT(p["ci95"][1].get<double>() - p["ci95"][0].get<double>(),
              0.01 * p["value"].get<double>())
        << name;
    EXPECT_FALSE(p["at_bound"].get<bool>()) << name;
  }
  EXPECT_NEAR(report["parameters"]["B"]["value"].get<double>(), 2.261e-5, 0.15 * 2.261e-5);
  EXPECT_TRUE(report["warnings"].empty()) << report["warnings"].dump();
}

}  // namespace
}  // namespace blmd::testing
