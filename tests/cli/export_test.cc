// Taking the model elsewhere (docs/export.md): the linear part against its
// closed forms, --write-config's round trip, --export-matlab run in Octave, and the drift
// guard --baseline.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "blmd/io/config.h"
#include "blmd/io/csv.h"
#include "blmd/sim/linear_model.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

std::vector<double> Column(const std::string& csv_path, const std::string& column) {
  return ReadTraceCsv(csv_path).Column(column);
}

TEST(Export, DcServoTransferFunctionsAreTheClosedForms) {
  const Config config = LoadConfig(SourcePath("configs/ganesh-square.json"));
  const ParameterSet& v = config.parameters;
  const double R = v.Get("R"), L = v.Get("L"), Kt = v.Get("Kt"), Kb = v.Get("Kb"), J = v.Get("J"),
               B = v.Get("B");
  const std::vector<TransferFunction> tfs = TransferFunctions(config.model->Linearise(v));
  ASSERT_EQ(tfs.size(), 3u);
  // Monic denominators: the closed forms divided by L·J.
  const double m = L * J;
  const std::vector<double> den = {1.0, (L * B + R * J) / m, (R * B + Kt * Kb) / m};
  auto near = [](const std::vector<double>& a, const std::vector<double>& b) {
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t k = 0; k < a.size(); ++k) EXPECT_NEAR(a[k], b[k], 1e-12 * std::abs(b[k])) << k;
  };
  EXPECT_EQ(tfs[0].output, "i");
  near(tfs[0].numerator, {J / m, B / m});
  near(tfs[0].denominator, den);
  EXPECT_EQ(tfs[1].output, "w");  // the integrator of theta cancelled
  near(tfs[1].numerator, {Kt / m});
  near(tfs[1].denominator, den);
  EXPECT_EQ(tfs[2].output, "theta");
  near(tfs[2].numerator, {Kt / m});
  near(tfs[2].denominator, {den[0], den[1], den[2], 0.0});
}

TEST(Export, BlmdWithAnOpenCurrentLoopHasNoLinearPart) {
  Config config = LoadConfig(SourcePath("configs/blmd-d31x.json"));
  const LinearModel closed = config.model->Linearise(config.parameters);
  ASSERT_TRUE(closed.available);
  const double expected = 1.5 * config.parameters.Get("Ke") * config.parameters.Get("Kc") /
                          config.parameters.Get("Kf") / config.parameters.Get("J");
  EXPECT_NEAR(closed.B(0, 0), expected, 1e-12 * expected);
  config.parameters.Set("Kf", 0.0);
  const LinearModel open = config.model->Linearise(config.parameters);
  EXPECT_FALSE(open.available);
  EXPECT_NE(open.reason.find("current loop is open"), std::string::npos);
}

// The fit's simulated output, reproduced by blmd-sim from the written config: the RMSE of
// blmd-sim's output against the measured trace equals the report's to 1e-9.
TEST(Export, WriteConfigReproducesTheFitsSimulation) {
  TempDir dir;
  const std::string trace = SourcePath("testdata/dc-hidden-coulomb.csv");
  CommandResult run = blmd::testing::Run(
      BinPath("blmd-ident") + " --config " + SourcePath("configs/ganesh-square.json") +
      " --trace " + trace + " --discover --candidates coulomb_friction,load_torque --threads 2" +
      " --quiet --report " + dir.File("r.json") + " --write-config " + dir.File("final.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json report = nlohmann::json::parse(Slurp(dir.File("r.json")));
  const nlohmann::json config = nlohmann::json::parse(Slurp(dir.File("final.json")));
  ASSERT_EQ(report["discovery"]["added"], nlohmann::json({"coulomb_friction"}));
  EXPECT_EQ(config["effects"]["coulomb_friction"]["Tc"], report["parameters"]["Tc"]["value"]);
  EXPECT_EQ(config["parameters"]["J"], report["parameters"]["J"]["value"]);
  EXPECT_EQ(config["identification"]["free"], nlohmann::json({"J", "B", "Tc"}));
  EXPECT_FALSE(config["identification"].contains("initial"));
  EXPECT_EQ(config["notes"]["parameters"]["J"]["ci95"], report["parameters"]["J"]["ci95"]);
  run = blmd::testing::Run(BinPath("blmd-sim") + " --config " + dir.File("final.json") +
                           " --input " + trace + " --quiet --out " + dir.File("sim.csv"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  for (const char* column : {"i", "w"}) {
    const std::vector<double> measured = Column(trace, column);
    const std::vector<double> simulated = Column(dir.File("sim.csv"), column);
    ASSERT_EQ(measured.size(), simulated.size());
    double sum = 0.0;
    for (std::size_t k = 0; k < measured.size(); ++k) {
      sum += (measured[k] - simulated[k]) * (measured[k] - simulated[k]);
    }
    const double rmse = std::sqrt(sum / static_cast<double>(measured.size()));
    const double expected = report["fit"]["rmse"][column].get<double>();
    EXPECT_NEAR(rmse, expected, 1e-9 * expected) << column;
  }
  // And blmd-ident accepts it: refitting from it moves nothing beyond its intervals.
  run = blmd::testing::Run(BinPath("blmd-ident") + " --config " + dir.File("final.json") +
                           " --trace " + trace + " --threads 2 --quiet --baseline " +
                           dir.File("r.json"));
  EXPECT_EQ(run.exit_code, 0) << run.err;
}

// A parameter that ends on its lower bound on the log scale: exp(ln 1e-8) is
// 9.999999999999982e-09, below the bound, and the written config was refused on the refit
// ("initial value ... is outside its bounds"). The fit's values are inside their bounds.
TEST(Export, WriteConfigOfAParameterAtItsBoundRefits) {
  TempDir dir;
  nlohmann::json config = nlohmann::json::parse(Slurp(SourcePath("configs/ganesh-square.json")));
  config["parameters"]["B"] = 1e-12;  // no friction: B goes to its lower bound
  const std::string truth = dir.Write("truth.json", config.dump());
  CommandResult run = blmd::testing::Run(BinPath("blmd-sim") + " --config " + truth + " --out " +
                                         dir.File("t.csv") + " --noise w=0.5 --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  config["parameters"]["B"] = 2.261e-5;
  config["identification"]["bounds"]["B"] = {1e-8, 1e-2};
  const std::string start = dir.Write("start.json", config.dump());
  run = blmd::testing::Run(BinPath("blmd-ident") + " --config " + start + " --trace " +
                           dir.File("t.csv") + " --quiet --report " + dir.File("r.json") +
                           " --write-config " + dir.File("final.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json report = nlohmann::json::parse(Slurp(dir.File("r.json")));
  EXPECT_TRUE(report["parameters"]["B"]["at_bound"].get<bool>());
  EXPECT_GE(report["parameters"]["B"]["value"].get<double>(), 1e-8);
  run = blmd::testing::Run(BinPath("blmd-ident") + " --config " + dir.File("final.json") +
                           " --trace " + dir.File("t.csv") + " --quiet --report " +
                           dir.File("refit.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json refit = nlohmann::json::parse(Slurp(dir.File("refit.json")));
  const double J = report["parameters"]["J"]["value"].get<double>();
  EXPECT_NEAR(refit["parameters"]["J"]["value"].get<double>(), J, 1e-6 * J);
}

TEST(Export, MatlabScriptRunsInOctave) {
  TempDir dir;
  const CommandResult run = blmd::testing::Run(
      BinPath("blmd-ident") + " --config " + SourcePath("configs/ganesh-noload.json") +
      " --trace " + SourcePath("testdata/ganesh-noload-step.csv") +
      " --threads 2 --quiet --report " + dir.File("r.json") + " --export-matlab " +
      dir.File("servo.m"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json report = nlohmann::json::parse(Slurp(dir.File("r.json")));
  const auto& tf = report["linear_model"]["transfer_functions"]["w"];
  const double gain = tf["numerator"].back().get<double>() / tf["denominator"].back().get<double>();
  const std::string script = Slurp(dir.File("servo.m"));
  EXPECT_NE(script.find("sys = ss(A, B, C, D, 'StateName', {'i', 'w', 'theta'}"),
            std::string::npos);
  if (blmd::testing::Run("command -v octave-cli").exit_code != 0 ||
      blmd::testing::Run("octave-cli --eval 'pkg load control'").exit_code != 0) {
    GTEST_SKIP() << "octave-cli with the control package is not installed (Debian octave, "
                    "octave-control); the script's text was checked";
  }
  const CommandResult octave =
      blmd::testing::Run("cd " + dir.File("") +
                         " && octave-cli --no-gui --eval \"servo; printf('%.15g %d\\n', "
                         "dcgain(G_w), size(sys, 1))\"");
  ASSERT_EQ(octave.exit_code, 0) << octave.err;
  double octave_gain = 0.0;
  int outputs = 0;
  ASSERT_EQ(std::sscanf(octave.out.c_str(), "%lf %d", &octave_gain, &outputs), 2) << octave.out;
  EXPECT_NEAR(octave_gain, gain, 1e-9 * gain);
  EXPECT_EQ(outputs, 3);
}

// The drift guard: the same trace against its own report passes; the same drive with J
// 30 % larger fails with exit 3 and names J.
TEST(Export, BaselineGuardsTheModel) {
  TempDir dir;
  nlohmann::json config = nlohmann::json::parse(Slurp(SourcePath("configs/ganesh-square.json")));
  const std::string base = dir.Write("drive.json", config.dump());
  config["parameters"]["J"] = 1.3 * config["parameters"]["J"].get<double>();
  const std::string heavier = dir.Write("heavier.json", config.dump());
  auto simulate = [&](const std::string& cfg, int seed, const std::string& out) {
    const CommandResult r = blmd::testing::Run(BinPath("blmd-sim") + " --config " + cfg +
                                               " --noise i=1% --noise w=1% --quiet --seed " +
                                               std::to_string(seed) + " --out " + dir.File(out));
    ASSERT_EQ(r.exit_code, 0) << r.err;
  };
  simulate(base, 1, "night1.csv");
  simulate(heavier, 2, "heavier.csv");
  const std::string ident =
      BinPath("blmd-ident") + " --config " + base + " --threads 2 --quiet --trace ";
  CommandResult run =
      blmd::testing::Run(ident + dir.File("night1.csv") + " --report " + dir.File("stored.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  run = blmd::testing::Run(ident + dir.File("night1.csv") + " --baseline " +
                           dir.File("stored.json") + " --report " + dir.File("same.json"));
  EXPECT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json same = nlohmann::json::parse(Slurp(dir.File("same.json")));
  EXPECT_EQ(same["baseline"]["verdict"], "unchanged");
  EXPECT_EQ(same["baseline"]["parameters"]["J"]["shift"], 0.0);
  run = blmd::testing::Run(ident + dir.File("heavier.csv") + " --baseline " +
                           dir.File("stored.json") + " --report " + dir.File("moved.json"));
  EXPECT_EQ(run.exit_code, 3);
  EXPECT_NE(run.err.find("error: the model moved from the baseline"), std::string::npos) << run.err;
  const nlohmann::json moved = nlohmann::json::parse(Slurp(dir.File("moved.json")));
  EXPECT_EQ(moved["baseline"]["verdict"], "changed");
  EXPECT_EQ(moved["baseline"]["parameters"]["J"]["verdict"], "moved");
  EXPECT_NEAR(moved["baseline"]["parameters"]["J"]["relative_shift"].get<double>(), 0.3, 0.02);
}

TEST(Export, BadBaselineIsRefusedBeforeAnyWork) {
  TempDir dir;
  const std::string not_report = dir.Write("x.json", "{\n  \"tool\": \"other\"\n}\n");
  const std::string ident = BinPath("blmd-ident") + " --config " +
                            SourcePath("configs/ganesh-noload.json") + " --trace " +
                            SourcePath("testdata/ganesh-noload-step.csv") + " --quiet --report " +
                            dir.File("r.json");
  CommandResult run = blmd::testing::Run(ident + " --baseline " + not_report);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_EQ(run.err, "error: " + not_report +
                         ":1:1: not a blmd-ident report (no \"tool\": \"blmd-ident\")\n");
  EXPECT_FALSE(std::ifstream(dir.File("r.json")).good());
  const std::string other_model =
      dir.Write("m.json", "{\"tool\": \"blmd-ident\", \"model\": \"blmd\", \"parameters\": {}}");
  run = blmd::testing::Run(ident + " --baseline " + other_model);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find(other_model + ":1:24: the baseline is a report of model \"blmd\""),
            std::string::npos)
      << run.err;
}

// Calibration of the drift guard (docs/export.md §3): 20 nights of the same drive with new
// noise against the report of the first. Each of J and B alarms at 5 % when the intervals
// are calibrated, so up to ~10 % of nights; measured 3/20 (seeds 2-21).
TEST(Export, BaselineFalseAlarmRate) {
  TempDir dir;
  const std::string config = SourcePath("configs/ganesh-square.json");
  auto night = [&](int seed) {
    const std::string out = dir.File("night" + std::to_string(seed) + ".csv");
    const CommandResult r = blmd::testing::Run(BinPath("blmd-sim") + " --config " + config +
                                               " --noise i=1% --noise w=1% --quiet --seed " +
                                               std::to_string(seed) + " --out " + out);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return out;
  };
  const std::string ident = BinPath("blmd-ident") + " --config " + config + " --threads 2 --quiet";
  CommandResult run =
      blmd::testing::Run(ident + " --trace " + night(1) + " --report " + dir.File("stored.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  int alarms = 0;
  for (int seed = 2; seed <= 21; ++seed) {
    run = blmd::testing::Run(ident + " --trace " + night(seed) + " --baseline " +
                             dir.File("stored.json"));
    ASSERT_TRUE(run.exit_code == 0 || run.exit_code == 3) << run.err;
    alarms += run.exit_code == 3 ? 1 : 0;
  }
  std::printf("false alarms: %d of 20 nights\n", alarms);
  EXPECT_LE(alarms, 4);  // binomial(20, 0.1): P(X > 4) = 4 %
}

// The worked CI example: a folder of two drives, one unchanged and one whose J grew 30 %.
TEST(Export, GuardDrivesScriptFlagsTheChangedDrive) {
  TempDir dir;
  nlohmann::json config = nlohmann::json::parse(Slurp(SourcePath("configs/ganesh-square.json")));
  const std::string drives = dir.File("drives");
  for (const char* drive : {"axis-1", "axis-2"}) {
    const std::string folder = drives + "/" + drive;
    ASSERT_EQ(blmd::testing::Run("mkdir -p " + folder).exit_code, 0);
    const std::string path = folder + "/config.json";
    std::ofstream(path) << config.dump();
    CommandResult r = blmd::testing::Run(BinPath("blmd-sim") + " --config " + path +
                                         " --noise i=1% --noise w=1% --quiet --seed 1 --out " +
                                         dir.File(std::string(drive) + "-old.csv"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    r = blmd::testing::Run(BinPath("blmd-ident") + " --config " + path + " --threads 2 --quiet " +
                           "--trace " + dir.File(std::string(drive) + "-old.csv") + " --report " +
                           folder + "/baseline.json");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    nlohmann::json tonight = config;
    if (std::string(drive) == "axis-2") {
      tonight["parameters"]["J"] = 1.3 * config["parameters"]["J"].get<double>();
    }
    const std::string truth = dir.Write(std::string(drive) + "-truth.json", tonight.dump());
    r = blmd::testing::Run(BinPath("blmd-sim") + " --config " + truth +
                           " --noise i=1% --noise w=1% --quiet --seed 5 --out " + folder +
                           "/tonight-1.csv");
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  const CommandResult run = blmd::testing::Run(SourcePath("examples/ci/guard-drives") + " " +
                                               drives + " " + BinPath("blmd-ident"));
  EXPECT_EQ(run.exit_code, 3) << run.err;
  EXPECT_EQ(run.out, "axis-1: unchanged\naxis-2: CHANGED (see " + drives +
                         "/axis-2//tonight.json, key baseline)\n");
}

TEST(Export, WriteConfigKeepsTheSettingsThatShapedTheFit) {
  // The equation error with a cut-off and a weighting from the command line: the written
  // config holds them, and a refit from it alone (no such flags) gives the same values to
  // 1e-9. Before, --filter-hz was dropped and the refit fell back to the default cut-off.
  TempDir dir;
  const std::string trace = SourcePath("testdata/realdata/delta_a3_servo/lorenz_jm_1.csv");
  const std::string config = SourcePath("configs/real/delta-a3.json");
  CommandResult run =
      blmd::testing::Run(BinPath("blmd-ident") + " --config " + config + " --trace " + trace +
                         " --error equation --filter-hz 12 --weighting variance --quiet --report " +
                         dir.File("r.json") + " --write-config " + dir.File("final.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json written = nlohmann::json::parse(Slurp(dir.File("final.json")));
  const nlohmann::json& ident = written["identification"];
  EXPECT_EQ(ident["error"], "equation");
  EXPECT_EQ(ident["filter_hz"], 12.0);
  EXPECT_EQ(ident["weighting"], "variance");
  EXPECT_EQ(ident["observe"], nlohmann::json({"u"}));
  EXPECT_EQ(ident["method"], "ceres");
  run = blmd::testing::Run(BinPath("blmd-ident") + " --config " + dir.File("final.json") +
                           " --trace " + trace + " --quiet --report " + dir.File("again.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json first = nlohmann::json::parse(Slurp(dir.File("r.json")));
  const nlohmann::json again = nlohmann::json::parse(Slurp(dir.File("again.json")));
  EXPECT_EQ(again["fit"]["error"]["filter_hz"], 12.0);
  for (const char* name : {"J", "B"}) {
    const double a = first["parameters"][name]["value"].get<double>();
    const double b = again["parameters"][name]["value"].get<double>();
    EXPECT_NEAR(b, a, 1e-9 * std::abs(a)) << name;
  }
  // The default cut-off, chosen from the data, is written as used.
  run = blmd::testing::Run(BinPath("blmd-ident") + " --config " + config + " --trace " + trace +
                           " --error equation --quiet --report " + dir.File("d.json") +
                           " --write-config " + dir.File("d-final.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json chosen = nlohmann::json::parse(Slurp(dir.File("d.json")));
  const nlohmann::json chosen_config = nlohmann::json::parse(Slurp(dir.File("d-final.json")));
  EXPECT_EQ(chosen_config["identification"]["filter_hz"], chosen["equation_cutoff"]["hz"]);
  EXPECT_EQ(chosen["equation_cutoff"]["user_set"], false);
  EXPECT_EQ(chosen["equation_cutoff"]["hz"], 25.0);
}

}  // namespace
}  // namespace blmd::testing
