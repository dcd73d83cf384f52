// blmd-design end to end (docs/cli.md §5, docs/design.md): the search writes a report, a config
// blmd-sim runs with exactly the written input table, and the input table; --trace evaluates a
// recording (its noise from the residual, against the sigma its file records) and agrees with
// the search's evaluation of the same input; no design is exit 1 with the report; bad input is
// exit 2 with one line and nothing written.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "blmd/io/csv.h"
#include "blmd/random.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

std::string Design() {
  return BinPath("blmd-design") + " --config " + SourcePath("configs/ganesh-square.json");
}

TEST(DesignCli, SearchWritesReportConfigAndInputThatBlmdSimPlays) {
  TempDir dir;
  const CommandResult run = testing::Run(
      Design() + " --duration 2 --limit u=12 --limit theta=20 --noise i=0.014 --noise w=2.5" +
      " --report " + dir.File("r.json") + " --write-config " + dir.File("c.json") +
      " --write-input " + dir.File("u.csv"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.err, "");
  EXPECT_NE(run.out.find("predicted 95 % half-width"), std::string::npos) << run.out;
  const nlohmann::json r = nlohmann::json::parse(Slurp(dir.File("r.json")));
  EXPECT_EQ(r["tool"], "blmd-design");
  EXPECT_EQ(r["mode"], "search");
  EXPECT_EQ(r["criterion"], "D-optimal");
  EXPECT_EQ(r["ok"], true);
  for (const char* p : {"J", "B"}) {
    const double hw = r["predicted"][p]["ci95_halfwidth"].get<double>();
    EXPECT_GT(hw, 0.0);
    EXPECT_LT(hw, 0.05 * r["predicted"][p]["prior"].get<double>());
    EXPECT_DOUBLE_EQ(r["design"]["predicted"][p]["ci95_halfwidth"].get<double>(), hw);
  }
  EXPECT_EQ(r["predicted"]["J"]["unit"], "kg·m²");
  EXPECT_LE(r["design"]["peaks"]["theta"].get<double>(), 20.0);
  EXPECT_LE(r["design"]["peaks"]["u"].get<double>(), 12.0);
  // The config's own square wave, lowered to 2.29 V to stay within 20 rad, does J 3x worse.
  EXPECT_EQ(r["reference"]["family"], "config");
  EXPECT_GE(r["reference"]["halfwidth_over_design"]["J"].get<double>(), 2.0);
  EXPECT_EQ(r["families"].size(), 4u);

  // blmd-sim runs the written config; its u is the written table's, sample for sample.
  const CommandResult sim = testing::Run(BinPath("blmd-sim") + " --config " + dir.File("c.json") +
                                         " --out " + dir.File("sim.csv") + " --quiet");
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const Trace simulated = ReadTraceCsv(dir.File("sim.csv"));
  const Trace table = ReadTraceCsv(dir.File("u.csv"));
  EXPECT_EQ(table.names(), (std::vector<std::string>{"t", "u"}));
  ASSERT_EQ(simulated.rows(), table.rows());
  EXPECT_EQ(simulated.rows(), 4001u);
  EXPECT_EQ(simulated.Column("u"), table.Column("u"));
  EXPECT_EQ(simulated.Column("t"), table.Column("t"));

  // --trace of the played table, with the same noise: the same prediction.
  const CommandResult again = testing::Run(Design() + " --trace " + dir.File("sim.csv") +
                                           " --noise i=0.014 --noise w=2.5 --json");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  const nlohmann::json t = nlohmann::json::parse(again.out);
  EXPECT_EQ(t["mode"], "trace");
  for (const char* p : {"J", "B"}) {
    EXPECT_NEAR(t["predicted"][p]["ci95_halfwidth"].get<double>(),
                r["predicted"][p]["ci95_halfwidth"].get<double>(),
                1e-9 * r["predicted"][p]["ci95_halfwidth"].get<double>());
  }
}

// testdata/ganesh-square.csv: the config's square wave with noise sigma_i = 0.013907 A,
// sigma_w = 2.4821 rad/s (its comment lines). The residual estimates them; with them given,
// the prediction equals the config input's.
TEST(DesignCli, TraceNoiseFromTheResidualAndThePredictionOfItsInput) {
  const std::string trace = SourcePath("testdata/ganesh-square.csv");
  CommandResult run = testing::Run(Design() + " --trace " + trace + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  nlohmann::json r = nlohmann::json::parse(run.out);
  EXPECT_EQ(r["noise"]["i"]["source"], "trace");
  EXPECT_NEAR(r["noise"]["i"]["sigma"].get<double>(), 0.013906856197717934, 0.03 * 0.0139);
  EXPECT_NEAR(r["noise"]["w"]["sigma"].get<double>(), 2.482116377753937, 0.03 * 2.482);
  EXPECT_FALSE(r.contains("families"));
  EXPECT_EQ(r["design"]["family"], "recorded");

  run = testing::Run(Design() + " --trace " + trace +
                     " --noise i=0.013906856197717934 --noise w=2.482116377753937 --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  r = nlohmann::json::parse(run.out);
  EXPECT_EQ(r["noise"]["w"]["source"], "flag");
  for (const char* p : {"J", "B"}) {
    EXPECT_NEAR(r["predicted"][p]["ci95_halfwidth"].get<double>(),
                r["reference"]["predicted"][p]["ci95_halfwidth"].get<double>(),
                1e-9 * r["predicted"][p]["ci95_halfwidth"].get<double>());
  }
}

// The identified model with its effects (docs/design.md §7): the committed HSM150 report adds
// Coulomb friction, a load torque and an asymmetric viscous friction to a config that has none.
// Without it the config gets the no_friction warning (exit 3 with --fail-on-warning); with it
// the design's input breaks the shaft free with the margin, the effects' fitted parameters are
// predicted too, and the report's own unexplained_structure makes report_inadequate. A limit
// below the breakaway leaves no candidate (exit 1).
TEST(DesignCli, FromReportDesignsForTheIdentifiedFrictionAndMovesTheShaft) {
  const std::string base = BinPath("blmd-design") + " --config " +
                           SourcePath("configs/real/hsm150.json") +
                           " --duration 20 --limit w=300 --noise w=0.63 --threads 2 --json";
  CommandResult run = testing::Run(base + " --limit u=0.1");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  nlohmann::json r = nlohmann::json::parse(run.out);
  ASSERT_EQ(r["warnings"].size(), 1u);
  EXPECT_EQ(r["warnings"][0]["code"], "no_friction");
  EXPECT_TRUE(r["breakaway"].is_null());
  EXPECT_EQ(testing::Run(base + " --limit u=0.1 --fail-on-warning").exit_code, 3);

  const std::string report = SourcePath("docs/real-data/hsm150.json");
  run = testing::Run(base + " --limit u=0.1 --from-report " + report);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  r = nlohmann::json::parse(run.out);
  std::vector<std::string> codes;
  for (const auto& w : r["warnings"]) codes.push_back(w["code"]);
  EXPECT_EQ(codes, std::vector<std::string>{"report_inadequate"});
  const nlohmann::json stored = nlohmann::json::parse(Slurp(report));
  const double Tc = stored["parameters"]["Tc"]["value"], TL = stored["parameters"]["TL"]["value"];
  const double Kt = 1.0;  // configs/real/hsm150.json: u is the torque (N m)
  EXPECT_NEAR(r["breakaway"]["torque"].get<double>(), Tc + std::abs(TL), 1e-12);
  EXPECT_NEAR(r["breakaway"]["u"].get<double>(), 1.2 * (Tc + std::abs(TL)) / Kt, 1e-12);
  EXPECT_GE(r["design"]["peaks"]["u"].get<double>(), r["breakaway"]["u"].get<double>());
  for (const char* p : {"J", "B", "Tc", "TL", "dB"}) EXPECT_TRUE(r["predicted"].contains(p)) << p;
  EXPECT_EQ(r["from_report"]["path"], report);

  run = testing::Run(base + " --limit u=0.03 --from-report " + report);
  EXPECT_EQ(run.exit_code, 1) << run.err;
  r = nlohmann::json::parse(run.out);
  EXPECT_FALSE(r["ok"].get<bool>());
  EXPECT_EQ(r["search"]["rejected"].begin().key(),
            "its peak |u| stays below the breakaway (the shaft would not move)");
}

// The breakaway counts every torque that holds or loads a shaft at rest, as each effect's
// registry entry says (docs/design.md §7): friction's static level and a gravity torque's
// amplitude (an unbalanced arm can rest anywhere). Before, gravity was left out and the
// design's input could stay below what the arm's weight needs.
TEST(DesignCli, BreakawayCountsGravity) {
  TempDir dir;
  nlohmann::json config = nlohmann::json::parse(Slurp(SourcePath("configs/real/hsm150.json")));
  const double Tc = 0.02, Tg = 0.03;
  config["effects"] = {{"coulomb_friction", {{"Tc", Tc}}},
                       {"gravity", {{"Tg", Tg}, {"phase", 0.0}}}};
  const std::string path = dir.Write("arm.json", config.dump());
  const CommandResult run =
      testing::Run(BinPath("blmd-design") + " --config " + path +
                   " --duration 20 --limit w=300 --limit u=0.2 --noise w=0.63 --threads 2 --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json r = nlohmann::json::parse(run.out);
  const double Kt = config["parameters"]["Kt"].get<double>();
  EXPECT_NEAR(r["breakaway"]["torque"].get<double>(), Tc + Tg, 1e-12);
  EXPECT_NEAR(r["breakaway"]["u"].get<double>(), 1.2 * (Tc + Tg) / Kt, 1e-12);
  EXPECT_GE(r["design"]["peaks"]["u"].get<double>(), r["breakaway"]["u"].get<double>());
}

// Design from what was achieved (docs/design.md §7a): a record with AR(1) noise (rho = 0.95,
// 0.5 % of each column's peak) identified, then the same record replayed with --from-report.
// The prediction takes the report's variance ratios (the colour's cost), so its half-widths
// come within 25 % of the report's intervals, where the white-noise prediction is 3-5x too
// narrow; without --trace the noise is the report's (source "report"). A report whose
// effect was fitted outside the effect's default bounds (the EMPS Stribeck friction, Ts
// 18.6 N against [0, 10]) designs in the bounds the report searched (before: exit 2).
TEST(DesignCli, FromReportPredictsWhatTheRecordAchieved) {
  TempDir dir;
  const std::string config = SourcePath("configs/ganesh-square.json");
  CommandResult run = testing::Run(BinPath("blmd-sim") + " --config " + config + " --out " +
                                   dir.File("clean.csv") + " --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  Trace noisy = ReadTraceCsv(dir.File("clean.csv"), CsvReadOptions{});
  Random random(5);
  for (const char* column : {"i", "w"}) {
    std::vector<double>& y = noisy.Column(column);
    double peak = 0.0;
    for (double v : y) peak = std::max(peak, std::abs(v));
    const double sigma = 0.005 * peak;
    double e = sigma * random.Normal();
    for (double& v : y) {
      v += e;
      e = 0.95 * e + std::sqrt(1.0 - 0.95 * 0.95) * sigma * random.Normal();
    }
  }
  WriteTraceCsv(noisy, dir.File("ar1.csv"));
  run = testing::Run(BinPath("blmd-ident") + " --config " + config + " --trace " +
                     dir.File("ar1.csv") + " --quiet --report " + dir.File("report.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json report = nlohmann::json::parse(Slurp(dir.File("report.json")));
  run = testing::Run(BinPath("blmd-design") + " --config " + config + " --trace " +
                     dir.File("ar1.csv") + " --from-report " + dir.File("report.json") + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  nlohmann::json r = nlohmann::json::parse(run.out);
  for (const char* p : {"J", "B"}) {
    SCOPED_TRACE(p);
    const double achieved = 0.5 * (report["parameters"][p]["ci95"][1].get<double>() -
                                   report["parameters"][p]["ci95"][0].get<double>());
    const double factor = r["from_report"]["variance_factor"][p].get<double>();
    EXPECT_NEAR(factor,
                report["method_summary"]["details"]["interval"]["variance_ratio"][p].get<double>(),
                1e-12 * factor);
    const double predicted = r["predicted"][p]["ci95_halfwidth"].get<double>();
    EXPECT_GT(predicted / achieved, 0.8);
    EXPECT_LT(predicted / achieved, 1.25);
    EXPECT_LT(predicted / std::sqrt(factor) / achieved, 0.4);  // the white-noise prediction
  }
  run = testing::Run(BinPath("blmd-design") + " --config " + config +
                     " --duration 2 --limit u=12 --from-report " + dir.File("report.json") +
                     " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  r = nlohmann::json::parse(run.out);
  for (const char* c : {"i", "w"}) {
    EXPECT_EQ(r["noise"][c]["source"], "report");
    EXPECT_EQ(r["noise"][c]["sigma"], report["noise"]["columns"][c]["std"]);
  }
  run = testing::Run(BinPath("blmd-design") + " --config " + SourcePath("configs/real/emps.json") +
                     " --duration 5 --limit u=150 --noise w=0.0014 --threads 2 --from-report " +
                     SourcePath("docs/real-data/emps.json") + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  r = nlohmann::json::parse(run.out);
  EXPECT_TRUE(r["predicted"].contains("Ts"));
}

// A record that starts at speed (a coast-down, then a torque step) replayed with
// --initial-state trace: the recorded speed's start is the replay's (before, the config's
// state at rest was used, and the prediction was of another experiment: here half the speed).
TEST(DesignCli, TraceReplaysFromTheRecordedInitialState) {
  TempDir dir;
  const std::string coast = dir.Write("coast.json", R"({
    "name": "coast", "model": "rigid_load",
    "parameters": { "J": 0.01, "B": 0.02, "Kt": 1.0 },
    "experiment": { "input": { "type": "steps", "times": [0, 1], "values": [0, 0.5] },
                    "initial": { "w": 50.0 },
                    "duration": 2.0, "sample_rate": 1000 },
    "identification": { "free": ["J", "B"], "observe": ["w"] } })");
  CommandResult run = testing::Run(BinPath("blmd-sim") + " --config " + coast + " --out " +
                                   dir.File("coast.csv") + " --noise w=0.05 --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string at_rest = dir.Write("at_rest.json", R"({
    "name": "at-rest", "model": "rigid_load",
    "parameters": { "J": 0.01, "B": 0.02, "Kt": 1.0 },
    "experiment": { "input": { "type": "steps", "times": [0, 1], "values": [0, 0.5] },
                    "duration": 2.0, "sample_rate": 1000 },
    "identification": { "free": ["J", "B"], "observe": ["w"] } })");
  const std::string base = BinPath("blmd-design") + " --config " + at_rest + " --trace " +
                           dir.File("coast.csv") + " --json";
  run = testing::Run(base + " --initial-state trace");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json r = nlohmann::json::parse(run.out);
  EXPECT_TRUE(r["ok"].get<bool>());
  EXPECT_NEAR(r["design"]["peaks"]["w"].get<double>(), 50.0, 1.0);
  const nlohmann::json from_rest = nlohmann::json::parse(testing::Run(base).out);
  EXPECT_LT(from_rest["design"]["peaks"]["w"].get<double>(), 30.0);
}

// --trace reads a logger's CSV through blmd-ident's flags: renamed and rescaled columns give
// the prediction of the standard file; a preparation flag without --trace is bad input.
TEST(DesignCli, TraceTakesTheColumnAndScaleFlagsOfBlmdIdent) {
  TempDir dir;
  const std::string plain = SourcePath("testdata/ganesh-square.csv");
  const Trace trace = ReadTraceCsv(plain, CsvReadOptions{});
  Trace renamed;
  renamed.Append("time_ms", trace.Column("t"));
  for (double& t : renamed.Column("time_ms")) t *= 1000.0;
  renamed.Append("volts", trace.Column("u"));
  renamed.Append("amps", trace.Column("i"));
  renamed.Append("speed", trace.Column("w"));
  WriteTraceCsv(renamed, dir.File("log.csv"));
  const std::string noise = " --noise i=0.013906856197717934 --noise w=2.482116377753937 --json";
  CommandResult run = testing::Run(Design() + " --trace " + plain + noise);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json expected = nlohmann::json::parse(run.out);
  run = testing::Run(Design() + " --trace " + dir.File("log.csv") +
                     " --column t=time_ms --scale t=0.001 --column u=volts --column i=amps "
                     "--column w=speed" +
                     noise);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json got = nlohmann::json::parse(run.out);
  for (const char* p : {"J", "B"}) {
    EXPECT_NEAR(got["predicted"][p]["ci95_halfwidth"].get<double>(),
                expected["predicted"][p]["ci95_halfwidth"].get<double>(),
                1e-6 * expected["predicted"][p]["ci95_halfwidth"].get<double>());
  }
  run = testing::Run(Design() +
                     " --duration 2 --limit u=12 --noise i=0.014 --noise w=2.5 "
                     "--column t=time_ms");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_EQ(run.err, "error: --column: only with --trace (it prepares the trace)\n");
}

TEST(DesignCli, NoDesignIsExitOneWithTheReport) {
  TempDir dir;
  // Six free parameters from w alone: the transfer function shows four coefficients.
  const std::string config = dir.Write("six.json", R"({"model": "dc_servo",
        "parameters": {"R": 12.6, "L": 0.283, "Kt": 0.04, "Kb": 0.04, "J": 2.26e-5, "B": 2.261e-5},
        "experiment": {"input": {"type": "square", "amplitude": 12, "period": 1}, "duration": 2, "sample_rate": 2000},
        "identification": {"free": ["R", "L", "Kt", "Kb", "J", "B"], "observe": ["w"]}})");
  const CommandResult run = testing::Run(
      BinPath("blmd-design") + " --config " + config + " --duration 1 --limit u=12 --noise w=1" +
      " --family square --report " + dir.File("r.json") + " --write-config " + dir.File("c.json"));
  EXPECT_EQ(run.exit_code, 1) << run.err;
  EXPECT_NE(run.err.find("error: no design: no candidate input is feasible"), std::string::npos)
      << run.err;
  EXPECT_NE(run.err.find("singular"), std::string::npos) << run.err;
  const nlohmann::json r = nlohmann::json::parse(Slurp(dir.File("r.json")));
  EXPECT_EQ(r["ok"], false);
  EXPECT_FALSE(r.contains("predicted"));
  EXPECT_FALSE(FileExists(dir.File("c.json")));
}

struct Bad {
  std::string flags;
  std::string message;  // a part of the one error line
};

TEST(DesignCli, BadInputIsExitTwoWithOneLineAndNothingWritten) {
  const std::string trace = SourcePath("testdata/ganesh-square.csv");
  const std::vector<Bad> cases = {
      {"--duration 2 --noise i=0.01 --noise w=2", "--limit u=V is required"},
      {"--limit u=12 --noise i=0.01 --noise w=2", "--duration is required"},
      {"--duration 2 --limit u=12 --noise i=0.01", "no noise level for the observed column 'w'"},
      {"--duration 2 --limit u=12 --noise i=0.01 --noise w=2 --noise theta=1",
       "--noise theta: not an observed column (observed: i, w)"},
      {"--duration 2 --limit u=12 --noise i=0 --noise w=2", "--noise i: sigma must be > 0"},
      {"--duration 2 --limit u=12 --limit x=3 --noise i=0.01 --noise w=2",
       "--limit x: not the input or an output of dc_servo (valid: u, i, w, theta)"},
      {"--duration 2 --limit u=-1 --noise i=0.01 --noise w=2", "--limit u: must be > 0"},
      {"--duration 0 --limit u=12 --noise i=0.01 --noise w=2", "must be a number > 0"},
      {"--duration 2 --limit u=12 --noise i=0.01 --noise w=2 --family sine", "--family"},
      {"--duration 2 --limit u=12 --noise i=0.01 --noise w=2 --target R",
       "--target R: not a free parameter (free: J, B)"},
      {"--duration 1e9 --limit u=12 --noise i=0.01 --noise w=2",
       "--duration 1e+09: a run of 1e+09 s"},
      {"--trace " + trace + " --duration 2", "--duration: not with --trace"},
      {"--trace " + trace + " --write-input OUT", "--write-input: not with --trace"},
      {"--trace /nonexistent.csv", "/nonexistent.csv: cannot read"},
  };
  for (const Bad& bad : cases) {
    SCOPED_TRACE(bad.flags);
    TempDir dir;
    std::string flags = bad.flags;
    if (const auto at = flags.find("OUT"); at != std::string::npos)
      flags.replace(at, 3, dir.File("out.csv"));
    const CommandResult run =
        testing::Run(Design() + " " + flags + " --report " + dir.File("r.json"));
    EXPECT_EQ(run.exit_code, 2);
    EXPECT_EQ(run.out, "");
    EXPECT_EQ(run.err.find('\n'), run.err.size() - 1) << run.err;  // one line
    EXPECT_EQ(run.err.rfind("error: ", 0), 0u) << run.err;
    EXPECT_NE(run.err.find(bad.message), std::string::npos) << run.err;
    EXPECT_FALSE(FileExists(dir.File("r.json")));
    EXPECT_FALSE(FileExists(dir.File("out.csv")));
  }
}

TEST(DesignCli, EquationErrorConfigIsRefused) {
  const CommandResult run = testing::Run(BinPath("blmd-design") + " --config " +
                                         SourcePath("tests/schema/rigid-fit.json") +
                                         " --duration 2 --limit u=1 --noise u=0.01");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("the equation error"), std::string::npos) << run.err;
  // With the next step: design for the output error of the same model, whose experiment
  // drives the motion the equation error differentiates.
  EXPECT_NE(run.err.find("next: design with \"error\": \"output\""), std::string::npos) << run.err;
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1);
}

}  // namespace
}  // namespace blmd::testing
