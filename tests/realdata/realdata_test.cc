// The real rigs of docs/real-data.md, run as a user runs them: the documented commands on
// the recordings in ../shared/realdata (or $BLMD_REALDATA), checked against the numbers
// measured and written there. Absent data is a skip with the reason, never a pass.
// Each case takes under a minute on two cores (HSM150: ~40 s for 8 x 20 000 samples with
// discovery; EMPS: ~35 s for its three output-error discovery runs, ~3 s for its six
// equation-error ones; ODrive: ~50 s for five; the
// coast-downs: ~12 s, most of it discovery on one record).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "blmd/io/csv.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

// $BLMD_REALDATA, else <repo>/../shared/realdata.
std::string RealData() {
  const char* env = std::getenv("BLMD_REALDATA");
  return env && *env ? std::string(env) : SourcePath("../shared/realdata");
}

bool HaveRealData(const std::string& folder, std::string* why) {
  const std::string path = RealData() + "/" + folder;
  if (std::filesystem::is_directory(path)) return true;
  *why = "real data not found at " + path +
         " (set BLMD_REALDATA to the folder holding hsm150/, dev_dyno_spindown/, ...)";
  return false;
}

#define REQUIRE_REAL_DATA(folder)                         \
  do {                                                    \
    std::string why;                                      \
    if (!HaveRealData(folder, &why)) GTEST_SKIP() << why; \
  } while (0)

// Runs blmd-ident with `arguments` (from the repository root, as docs/real-data.md does)
// and returns its JSON report.
nlohmann::json Ident(const std::string& arguments) {
  TempDir dir;
  const std::string report = dir.File("report.json");
  const CommandResult run =
      blmd::testing::Run("cd " + SourcePath("") + " && " + BinPath("blmd-ident") + " " + arguments +
                         " --threads 2 --quiet --report " + report);
  EXPECT_EQ(run.exit_code, 0) << run.err;
  if (run.exit_code != 0) return nlohmann::json::object();
  return nlohmann::json::parse(Slurp(report));
}

double Value(const nlohmann::json& j) { return j.get<double>(); }
// The first fit of a report: under discovery.before when discovery ran (the headline is the
// final model, schema 2), else the report itself.
const nlohmann::json& FirstFit(const nlohmann::json& report) {
  return report.contains("discovery") ? report["discovery"]["before"] : report;
}

// ---------------------------------------------------------------------------------------
// EMPS (Janot, Gautier & Brunot 2019): the axis on the load side in linear units (J = the
// mass M in kg, B = the viscous friction Fv in N s/m, torque = force in N, w in m/s), driven
// by the recorded motor force F_N, observed through the velocity derived from the encoder
// position q_m. Fit on the estimation record, validation on the pulses record. Two commands
// (docs/real-data.md, EMPS): discovery over the whole vocabulary, and discovery restricted
// to the benchmark's own model structure (Coulomb friction and an offset).

std::string EmpsCommand(const std::string& discovery) {
  const std::string d = RealData() + "/emps/";
  return "--config configs/real/emps.json --trace " + d + "emps_estimation.csv --validate " + d +
         "emps_validation_pulses.csv --column t=t_s --column u=F_N --column theta=q_m "
         "--derive w=theta --initial-state trace --discover" +
         discovery;
}

// The same case by the equation error (configs/real/emps-idim.json: the benchmark's own
// IDIM-LS processing, 100 Hz Butterworth on the position, decimation by 10).
std::string EmpsIdimCommand(const std::string& discovery) {
  const std::string d = RealData() + "/emps/";
  return "--config configs/real/emps-idim.json --trace " + d + "emps_estimation.csv --validate " +
         d +
         "emps_validation_pulses.csv --column t=t_s --column u=F_N --column theta=q_m "
         "--derive w=theta --initial-state trace --discover" +
         discovery;
}

// ctest runs every test case in its own process: each case's command (20-45 s on two cores)
// runs once and its report is kept in the build tree as realdata-NAME.json (written to a
// temporary and renamed), keyed by the command and newer than the binary.
nlohmann::json CachedReport(const std::string& name, const std::string& command) {
  const std::string cache = std::string(BLMD_BIN_DIR) + "/../realdata-" + name + ".json";
  if (FileExists(cache)) {
    const nlohmann::json cached = nlohmann::json::parse(Slurp(cache), nullptr, false);
    const auto binary_time = std::filesystem::last_write_time(BinPath("blmd-ident"));
    if (!cached.is_discarded() && cached.value("command", "") == command &&
        std::filesystem::last_write_time(cache) > binary_time) {
      return cached["report"];
    }
  }
  const nlohmann::json report = Ident(command);
  const std::string temporary = cache + ".tmp." + std::to_string(::getpid());
  std::ofstream(temporary) << nlohmann::json{{"command", command}, {"report", report}}.dump();
  std::filesystem::rename(temporary, cache);
  return report;
}

class Emps : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::string why;
    if (!HaveRealData("emps", &why)) return;
    open_ = new nlohmann::json(CachedReport("emps-open", EmpsCommand("")));
    idm_ = new nlohmann::json(
        CachedReport("emps-idm", EmpsCommand(" --candidates coulomb_friction,load_torque")));
    asym_ = new nlohmann::json(CachedReport(
        "emps-asym", EmpsCommand(" --candidates coulomb_friction,load_torque,asymmetric_viscous")));
    idim_ = new nlohmann::json(
        CachedReport("emps-idim", EmpsIdimCommand(" --candidates coulomb_friction,load_torque")));
    idim_open_ = new nlohmann::json(CachedReport("emps-idim-open", EmpsIdimCommand("")));
  }
  static void TearDownTestSuite() {
    for (nlohmann::json** report : {&open_, &idm_, &asym_, &idim_, &idim_open_}) {
      delete *report;
      *report = nullptr;
    }
  }
  void SetUp() override {
    REQUIRE_REAL_DATA("emps");
    ASSERT_NE(open_, nullptr);
    ASSERT_NE(idm_, nullptr);
    ASSERT_NE(asym_, nullptr);
    ASSERT_TRUE(open_->contains("discovery")) << "the command (all candidates) failed";
    ASSERT_TRUE(idm_->contains("discovery"))
        << "the command (--candidates coulomb_friction,load_torque) failed";
    ASSERT_TRUE(asym_->contains("discovery"))
        << "the command (--candidates coulomb_friction,load_torque,asymmetric_viscous) failed";
    ASSERT_NE(idim_, nullptr);
    ASSERT_NE(idim_open_, nullptr);
    ASSERT_TRUE(idim_->contains("discovery")) << "the equation-error command failed";
    ASSERT_TRUE(idim_open_->contains("discovery")) << "the equation-error command (all) failed";
  }
  static double After(const nlohmann::json& report, const char* name) {
    return Value(report["discovery"]["parameters_after"][name]);
  }
  // The parameter's 95 % interval after discovery exists and contains its value.
  static void ExpectIntervalAround(const nlohmann::json& report, const char* name) {
    const auto& ci = report["discovery"]["intervals_after"][name]["ci95"];
    ASSERT_TRUE(ci.is_array()) << name;
    EXPECT_LT(Value(ci[0]), After(report, name)) << name;
    EXPECT_GT(Value(ci[1]), After(report, name)) << name;
  }
  static nlohmann::json* open_;  // --discover, every candidate
  static nlohmann::json* idm_;   // --discover --candidates coulomb_friction,load_torque
  static nlohmann::json* asym_;  // ... coulomb_friction,load_torque,asymmetric_viscous
  // Equation error (emps-idim.json): --candidates coulomb_friction,load_torque, and all.
  static nlohmann::json* idim_;
  static nlohmann::json* idim_open_;
};
nlohmann::json* Emps::open_ = nullptr;
nlohmann::json* Emps::idm_ = nullptr;
nlohmann::json* Emps::asym_ = nullptr;
nlohmann::json* Emps::idim_ = nullptr;
nlohmann::json* Emps::idim_open_ = nullptr;

// --write-config of discovery's final model, refitted from the written config alone (the trace
// flags again, nothing else): the values equal the report's to 1e-9. Before, the final model
// kept discovery's last refit, which stopped on its own tolerances, and the plain fit of the
// written config moved on from it (J by 4.8e-7).
TEST(EmpsRoundTrip, WriteConfigOfTheDiscoveredModelRefitsToTheSameValues) {
  REQUIRE_REAL_DATA("emps");
  TempDir dir;
  const std::string d = RealData() + "/emps/";
  const std::string flags =
      " --column t=t_s --column u=F_N --column theta=q_m --derive w=theta --initial-state trace";
  const nlohmann::json first = Ident(EmpsCommand("") + " --write-config " + dir.File("final.json"));
  ASSERT_TRUE(first.contains("discovery"));
  const nlohmann::json again =
      Ident("--config " + dir.File("final.json") + " --trace " + d + "emps_estimation.csv" + flags);
  ASSERT_TRUE(again.contains("parameters"));
  ASSERT_EQ(again["parameters"].size(), first["parameters"].size());
  for (const auto& [name, parameter] : first["parameters"].items()) {
    const double a = Value(parameter["value"]);
    EXPECT_NEAR(Value(again["parameters"][name]["value"]), a, 1e-9 * std::abs(a)) << name;
  }
}

// Published IDIM-LS reference (EMPS_Description.pdf §3.4).
constexpr double kEmpsM = 95.1089, kEmpsFv = 203.5034, kEmpsFc = 20.3935, kEmpsOffset = -3.1648;
// Its asymmetric model (§4.2): Fv+ = 166.71, Fv- = 240.42, Fc+ = 20.144, Fc- = 20.628 (no
// separate offset: (Fc+ - Fc-)/2 = -0.242 N plays the load torque's part).
constexpr double kEmpsFvPlus = 166.71, kEmpsFvMinus = 240.42;

TEST_F(Emps, MassAndViscousFrictionAloneAbsorbTheFriction) {
  // J, B only: the missing Coulomb friction (~20 N) is taken up by a doubled viscous term.
  for (const nlohmann::json* report : {open_, idm_, asym_}) {
    const auto& p = FirstFit(*report)["parameters"];
    EXPECT_NEAR(Value(p["J"]["value"]), 106.13, 0.1);
    EXPECT_NEAR(Value(p["B"]["value"]), 429.61, 0.5);
    EXPECT_LT(Value(p["B"]["ci95"][0]), Value(p["B"]["value"]));
    EXPECT_GT(Value(p["B"]["ci95"][1]), Value(p["B"]["value"]));
    EXPECT_NEAR(Value(FirstFit(*report)["fit"]["nrmse"]), 0.1809, 0.0005);
    EXPECT_NEAR(Value(FirstFit(*report)["validation"]["nrmse"]), 0.1834, 0.0005);
  }
}

TEST_F(Emps, MassWithinTwoPercentOfTheReference) {
  // Measured: 94.117 kg (-1.04 %) with the benchmark's structure, 93.248 kg (-1.96 %) with
  // what open discovery adds; with the asymmetric viscous friction 93.027 kg (-2.19 %, see
  // Emps.OneModelMeetsTheMassAndViscousCriteriaTogether).
  EXPECT_NEAR(After(*idm_, "J"), 94.117, 0.1);
  EXPECT_NEAR(After(*open_, "J"), 93.248, 0.1);
  EXPECT_NEAR(After(*asym_, "J"), 93.027, 0.1);
  for (const nlohmann::json* report : {idm_, open_}) {
    EXPECT_LE(std::abs(After(*report, "J") / kEmpsM - 1.0), 0.02);
    ExpectIntervalAround(*report, "J");
  }
}

TEST_F(Emps, ViscousFrictionWithinFivePercentOfTheReferenceOnceItsAsymmetryIsModelled) {
  // With asymmetric_viscous (B+- = B +- dB) next to Coulomb friction, B is the mean of the
  // two directions' damping, as the reference's symmetric Fv (203.50) is the mean of its
  // asymmetric model's Fv+ and Fv- (203.56). Measured: 195.27 (-4.0 %); without the
  // asymmetry 192.85 (-5.2 %, Emps.OneModelMeetsTheMassAndViscousCriteriaTogether). (Before
  // discovery weighed held-out evidence an offset of -0.21 N was added too: B 195.01, dB
  // -37.73.)
  const double fv = After(*asym_, "B"), dB = After(*asym_, "dB");
  EXPECT_NEAR(fv, 195.27, 0.5);
  EXPECT_NEAR(dB, -39.655, 0.3);
  EXPECT_LE(std::abs(fv / kEmpsFv - 1.0), 0.05);
  // The direction is the reference's: stiffer backwards (B- = 234.92 vs 240.42, B+ = 155.61
  // vs 166.71), and physical (|dB| < B).
  EXPECT_LT(std::abs(dB), fv);
  EXPECT_NEAR((fv - dB) / kEmpsFvMinus, 1.0, 0.05);
  EXPECT_NEAR((fv + dB) / kEmpsFvPlus, 1.0, 0.07);
  for (const char* name : {"B", "dB"}) {
    ExpectIntervalAround(*asym_, name);
  }
}

TEST_F(Emps, EquationErrorMeetsTheMassAndViscousCriteria) {
  // The criterion on one fit: M within 2 % and Fv within 5 %, by the benchmark's own
  // method (IDIM-LS: the force the measured motion needs, docs/identification.md §8).
  // Measured: M 95.077 kg (-0.03 %), Fv 202.65 N s/m (-0.42 %).
  const double m = After(*idim_, "J"), fv = After(*idim_, "B");
  EXPECT_NEAR(m, 95.077, 0.01);
  EXPECT_NEAR(fv, 202.65, 0.02);
  EXPECT_LE(std::abs(m / kEmpsM - 1.0), 0.02);
  EXPECT_LE(std::abs(fv / kEmpsFv - 1.0), 0.05);
  for (const char* name : {"J", "B"}) {
    ExpectIntervalAround(*idim_, name);
  }
  EXPECT_EQ((*idim_)["fit"]["error"]["type"], "equation");
  EXPECT_EQ(Value((*idim_)["fit"]["error"]["samples"]), 2484.0);  // 24 839 / 10
}

TEST_F(Emps, EquationErrorIsInsensitiveToTheFilterAndTheDecimation) {
  // The low-pass cut-off and the decimation are the benchmark's (100 Hz, 10); at the corners
  // of 50-200 Hz x decimation 1-20 the criteria still hold. Measured (M, Fv): 50 Hz / 1:
  // 95.052, 203.14; 50 / 20: 95.048, 200.74; 200 / 1: 94.961, 204.23; 200 / 20: 95.085, 201.83.
  for (const auto& [flags, m_expected, fv_expected] :
       {std::tuple<std::string, double, double>{" --filter-hz 50 --decimate 1", 95.052, 203.14},
        {" --filter-hz 50 --decimate 20", 95.048, 200.74},
        {" --filter-hz 200 --decimate 1", 94.961, 204.23},
        {" --filter-hz 200 --decimate 20", 95.085, 201.83}}) {
    const nlohmann::json report =
        Ident(EmpsIdimCommand(" --candidates coulomb_friction,load_torque") + flags);
    ASSERT_TRUE(report.contains("discovery")) << flags;
    EXPECT_EQ(report["discovery"]["added"],
              nlohmann::json::array({"coulomb_friction", "load_torque"}))
        << flags;
    const double m = After(report, "J"), fv = After(report, "B");
    EXPECT_NEAR(m, m_expected, 0.01) << flags;
    EXPECT_NEAR(fv, fv_expected, 0.02) << flags;
    EXPECT_LE(std::abs(m / kEmpsM - 1.0), 0.02) << flags;
    EXPECT_LE(std::abs(fv / kEmpsFv - 1.0), 0.05) << flags;
    EXPECT_NEAR(After(report, "Tc"), kEmpsFc, 0.10 * kEmpsFc) << flags;
    EXPECT_NEAR(After(report, "TL"), kEmpsOffset, 1.0) << flags;
  }
}

TEST_F(Emps, OutputErrorModelsMissOneCriterionEach) {
  // By the output error (the recorded force replayed open loop, the velocity compared), no
  // model meets both criteria: the symmetric model charges the asymmetry to Fv (-5.4 %; on
  // synthetic data of the published asymmetric model the same fit gives -1.9 %); with the
  // asymmetry modelled Fv is within 5 % but M moves to -2.2 % (the output error weighs the
  // closed-loop record's errors differently from IDIM-LS's force error). Measured
  // 2026-11-24, none adopted: observing theta (M +12.5 %, Fv +58.6 %) or theta and w
  // (-2.9 %, -8.8 %), the input one sample later or earlier (Fv -5.2 / -5.6 %), dt 1e-5 s,
  // Powell, the reference as start: Fv -5.3 ... -5.6 %; velocity from +-2, 3, 5, 10
  // samples: Fv -4.8, -6.1, -5.2, -5.9 %. docs/real-data.md, EMPS.
  const double m_idm = After(*idm_, "J") / kEmpsM - 1.0, fv_idm = After(*idm_, "B") / kEmpsFv - 1.0;
  const double m_asym = After(*asym_, "J") / kEmpsM - 1.0;
  const double fv_asym = After(*asym_, "B") / kEmpsFv - 1.0;
  EXPECT_NEAR(100.0 * m_idm, -1.04, 0.1);
  EXPECT_NEAR(100.0 * fv_idm, -5.24, 0.25);
  EXPECT_NEAR(100.0 * m_asym, -2.19, 0.1);
  EXPECT_NEAR(100.0 * fv_asym, -4.05, 0.25);
  EXPECT_FALSE(std::abs(m_idm) <= 0.02 && std::abs(fv_idm) <= 0.05);
  EXPECT_FALSE(std::abs(m_asym) <= 0.02 && std::abs(fv_asym) <= 0.05);
}

TEST_F(Emps, DiscoveryAddsCoulombFrictionAndTheOffset) {
  // The criterion, by the equation error with the benchmark's model vocabulary
  // (Coulomb friction and a constant force): Fc 20.482 N (+0.44 %), offset -3.157 N
  // (0.008 N from the reference), each with its interval.
  const auto& d = (*idim_)["discovery"];
  EXPECT_EQ(d["added"], nlohmann::json::array({"coulomb_friction", "load_torque"}));
  const double Tc = After(*idim_, "Tc"), TL = After(*idim_, "TL");
  EXPECT_NEAR(Tc, 20.482, 0.005);
  EXPECT_NEAR(TL, -3.157, 0.005);
  EXPECT_NEAR(Tc, kEmpsFc, 0.10 * kEmpsFc);
  EXPECT_NEAR(TL, kEmpsOffset, 1.0);
  for (const char* name : {"Tc", "TL"}) {
    ExpectIntervalAround(*idim_, name);
  }
}

TEST_F(Emps, OpenDiscoveryByEquationErrorRefusesAStribeckCurveWithoutAPlateau) {
  // Over the whole vocabulary the equation error's Stribeck friction fades over the whole speed
  // range (ws = 0.124 m/s of 0.127): it reshapes a Coulomb friction instead of showing a dip
  // with its plateau, which discovery's plateau rule refuses (docs/discovery.md §2, §3b).
  // Coulomb friction and the asymmetric viscous friction are added: the benchmark's structure
  // with its asymmetry. Simulated w NRMSE 0.0187 (fit) and 0.0550 (pulses record), against
  // 0.018 and 0.055 with the Stribeck curve before the rule and 0.050 and 0.073 for the
  // benchmark's structure.
  const auto& d = (*idim_open_)["discovery"];
  EXPECT_EQ(d["added"], nlohmann::json::array({"coulomb_friction", "asymmetric_viscous"}));
  bool stribeck_refused = false;
  for (const auto& c : d["steps"][0]["candidates"]) {
    if (c["effect"] != "stribeck") continue;
    stribeck_refused =
        !c["valid"].get<bool>() &&
        c.value("reason", "").find("not well inside the speed range") != std::string::npos;
  }
  EXPECT_TRUE(stribeck_refused) << d["steps"][0]["candidates"].dump();
  EXPECT_NEAR(Value(d["simulated_after"]["nrmse"]), 0.01869, 0.0002);
  EXPECT_NEAR(Value(d["validation"]["simulated_after"]["nrmse"]), 0.05495, 0.0002);
}

TEST_F(Emps, EquationErrorValidationErrorFallsAfterDiscovery) {
  // Pulses record, force error: 0.1792 -> 0.0613; the same models as simulations of the
  // velocity: 0.1973 -> 0.0733 (fit record: 0.189 -> 0.0496).
  const auto& d = (*idim_)["discovery"];
  EXPECT_NEAR(Value(d["validation"]["before"]["nrmse"]), 0.1792, 0.0005);
  EXPECT_NEAR(Value(d["validation"]["after"]["nrmse"]), 0.06133, 0.0005);
  EXPECT_LT(Value(d["validation"]["after"]["nrmse"]),
            0.5 * Value(d["validation"]["before"]["nrmse"]));
  EXPECT_NEAR(Value(FirstFit(*idim_)["validation"]["simulated"]["nrmse"]), 0.1973, 0.0005);
  EXPECT_NEAR(Value(d["validation"]["simulated_after"]["nrmse"]), 0.0733, 0.0005);
  EXPECT_NEAR(Value(FirstFit(*idim_)["fit"]["simulated"]["nrmse"]), 0.189, 0.0005);
  // The headline is the model after discovery.
  EXPECT_EQ((*idim_)["validation"]["simulated"]["nrmse"],
            d["validation"]["simulated_after"]["nrmse"]);
  EXPECT_NEAR(Value(d["simulated_after"]["nrmse"]), 0.04956, 0.0005);
}

TEST_F(Emps, OpenDiscoveryPrefersStribeckFriction) {
  // What open discovery does add (measured): Stribeck friction (ws = 0.061 m/s when added,
  // within half the top speed of 0.139: the curve reaches its plateau), then the asymmetric
  // viscous friction, whose refit moves ws to 0.109; the offset of earlier versions explains
  // 2.2 % of what is left above the noise floor and is no longer added (not material:
  // docs/discovery.md §3b). By BIC the data prefer it to the benchmark's structure
  // (docs/real-data.md).
  const auto& d = (*open_)["discovery"];
  EXPECT_EQ(d["added"], nlohmann::json::array({"stribeck", "asymmetric_viscous"}));
  EXPECT_NEAR(Value(d["steps"][0]["parameters"]["ws"]), 0.0610, 0.001);
  EXPECT_NEAR(After(*open_, "Ts"), 18.635, 0.1);
  EXPECT_NEAR(After(*open_, "ws"), 0.1086, 0.001);
  EXPECT_NEAR(After(*open_, "dB"), -39.694, 0.3);
  EXPECT_NEAR(Value(d["error_after"]["nrmse"]), 0.013976, 0.0002);
  const double bic_open = Value(d["steps"].back()["bic_after"]);
  const double bic_idm = Value((*idm_)["discovery"]["steps"].back()["bic_after"]);
  const double bic_asym = Value((*asym_)["discovery"]["steps"].back()["bic_after"]);
  EXPECT_NEAR(bic_idm - bic_open, 58909.0, 100.0);
  EXPECT_NEAR(bic_asym - bic_open, 421.0, 50.0);  // 916 when open_ also had the offset
}

TEST_F(Emps, CoulombAndOffsetWithTheBenchmarkCandidates) {
  const auto& d = (*idm_)["discovery"];
  EXPECT_EQ(d["added"], nlohmann::json::array({"coulomb_friction", "load_torque"}));
  const double Tc = After(*idm_, "Tc"), TL = After(*idm_, "TL");
  EXPECT_NEAR(Tc, 21.611, 0.05);   // measured: +6.0 %
  EXPECT_NEAR(TL, -3.5468, 0.01);  // measured: 0.38 N below the reference
  EXPECT_NEAR(Tc, kEmpsFc, 0.10 * kEmpsFc);
  EXPECT_NEAR(TL, kEmpsOffset, 1.0);
  for (const char* name : {"Tc", "TL"}) {
    ExpectIntervalAround(*idm_, name);
  }
}

TEST_F(Emps, CoulombAndAsymmetricViscousButNoOffset) {
  // The benchmark's candidates plus asymmetric_viscous: Coulomb friction, then dB (the
  // largest fall of all, NRMSE 0.144 -> 0.0141). An offset would come next by the fit
  // record's BIC, but on the held-out pulses record it makes the error worse (0.04886 ->
  // 0.04914), so it is not added (docs/discovery.md §3): the symmetric model's
  // -3.16 N offset stood in for the asymmetric damping, and what is left, the reference
  // asymmetric model's (Fc+ - Fc-)/2 = -0.24 N, is below what the data can confirm.
  const auto& d = (*asym_)["discovery"];
  EXPECT_EQ(d["added"], nlohmann::json::array({"coulomb_friction", "asymmetric_viscous"}));
  const double Tc = After(*asym_, "Tc");
  EXPECT_NEAR(Tc, 21.325, 0.05);  // +4.6 %
  EXPECT_NEAR(Tc, kEmpsFc, 0.10 * kEmpsFc);
  EXPECT_NEAR(Value(d["error_after"]["nrmse"]), 0.014098, 0.0002);
  const auto& offset = d["last_round"][0];
  EXPECT_EQ(offset["effect"], "load_torque");
  EXPECT_EQ(offset["evidence_rule"], "held_out");
  EXPECT_GT(Value(offset["held_out_nrmse"]["after"]), Value(offset["held_out_nrmse"]["before"]));
}

TEST_F(Emps, ValidationErrorFallsAfterDiscovery) {
  // Pulses record: 0.1834 -> 0.0662 (benchmark structure), -> 0.0489 (with the asymmetric
  // viscous friction), -> 0.0469 (open discovery).
  for (const auto& [report, after_fit, after_validation] :
       {std::tuple<const nlohmann::json*, double, double>{idm_, 0.04575, 0.06618},
        {asym_, 0.014098, 0.04886},
        {open_, 0.013976, 0.04688}}) {
    const auto& d = (*report)["discovery"];
    EXPECT_NEAR(Value(d["error_before"]["nrmse"]), 0.1809, 0.0005);
    EXPECT_NEAR(Value(d["error_after"]["nrmse"]), after_fit, 0.0005);
    EXPECT_NEAR(Value(d["validation"]["before"]["nrmse"]), 0.1834, 0.0005);
    EXPECT_NEAR(Value(d["validation"]["after"]["nrmse"]), after_validation, 0.0005);
    EXPECT_LT(Value(d["validation"]["after"]["nrmse"]),
              0.5 * Value(d["validation"]["before"]["nrmse"]));
  }
}

// ---------------------------------------------------------------------------------------
// HSM150: all eight estimation runs (repeats 1 and 2 of each setting) in one fit, the four
// repeats 3 held out; discovery restricted to the friction/load/drag/damping candidates
// (docs/real-data.md says why cogging is left out).

std::string Hsm150Command() {
  const std::string d = RealData() + "/hsm150/";
  std::string args = "--config configs/real/hsm150.json";
  for (const char* setting : {"neg_0.04", "neg_0.045", "pos_0.06", "pos_0.065"}) {
    for (const char* repeat : {"1", "2"})
      args += " --trace " + d + "idf_" + setting + "_" + repeat + ".csv";
  }
  for (const char* setting : {"neg_0.04", "neg_0.045", "pos_0.06", "pos_0.065"}) {
    args += " --validate " + d + "idf_" + setting + "_3.csv";
  }
  return args +
         " --column t=t_s --column u=tau_cmd_Nm --column w=w_radps --discover"
         " --candidates coulomb_friction,load_torque,stribeck,quadratic_drag,asymmetric_viscous"
         " --max-effects 4";
}

nlohmann::json Hsm150Report() { return CachedReport("hsm150", Hsm150Command()); }

class Hsm150 : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::string why;
    if (HaveRealData("hsm150", &why)) report_ = new nlohmann::json(Hsm150Report());
  }
  static void TearDownTestSuite() {
    delete report_;
    report_ = nullptr;
  }
  void SetUp() override {
    REQUIRE_REAL_DATA("hsm150");
    ASSERT_NE(report_, nullptr);
    ASSERT_TRUE(report_->contains("discovery")) << "the command failed";
  }
  static nlohmann::json* report_;
};
nlohmann::json* Hsm150::report_ = nullptr;

constexpr double kHsmCatalogJ = 1.2e-4;  // kg m^2, stored in every .mat file

TEST_F(Hsm150, DiscoveryFindsCoulombFrictionAndADirectionOffset) {
  const auto& d = (*report_)["discovery"];
  // Coulomb friction, and a constant torque that makes it asymmetric: Tc + TL opposes
  // positive motion, Tc - TL negative motion; then the direction-dependent damping.
  EXPECT_EQ(d["added"],
            nlohmann::json::array({"load_torque", "coulomb_friction", "asymmetric_viscous"}));
  const double Tc = Value(d["parameters_after"]["Tc"]), TL = Value(d["parameters_after"]["TL"]);
  EXPECT_NEAR(Tc, 0.020735, 0.00005);
  EXPECT_NEAR(TL, 0.014480, 0.00005);
  EXPECT_GT(Tc + TL, 2.0 * (Tc - TL));  // friction 0.0352 forwards vs 0.0063 backwards
  ASSERT_TRUE(d["intervals_after"]["Tc"]["ci95"].is_array());
}

TEST_F(Hsm150, DampingIsLargerOnTheNegativeRuns) {
  // asymmetric_viscous: B+ = B + dB = 1.05e-4 forwards, B- = B - dB = 1.66e-4 backwards (the
  // README's per-run step fits: 0.9-1.4e-4 on the positive runs, 2.1-2.7e-4 on the negative).
  const auto& after = (*report_)["discovery"]["parameters_after"];
  const double B = Value(after["B"]), dB = Value(after["dB"]);
  EXPECT_NEAR(dB, -3.046e-5, 0.01e-5);
  EXPECT_NEAR(B, 1.3571e-4, 0.003e-4);
  EXPECT_LT(std::abs(dB), B);           // physical: both directions damped
  EXPECT_GT((B - dB) / (B + dB), 1.5);  // 1.58
  const auto& ci = (*report_)["discovery"]["intervals_after"]["dB"]["ci95"];
  ASSERT_TRUE(ci.is_array());
  EXPECT_LT(Value(ci[1]), 0.0);  // the interval excludes a symmetric damping
}

TEST_F(Hsm150, ValidationErrorFallsAfterDiscovery) {
  const auto& v = (*report_)["discovery"]["validation"];
  EXPECT_NEAR(Value(v["before"]["nrmse"]), 0.2151, 0.0005);
  EXPECT_NEAR(Value(v["after"]["nrmse"]), 0.06252, 0.0005);
  EXPECT_LT(Value(v["after"]["nrmse"]), 0.5 * Value(v["before"]["nrmse"]));
  EXPECT_NEAR(Value((*report_)["discovery"]["error_before"]["nrmse"]), 0.2199, 0.0005);
  EXPECT_NEAR(Value((*report_)["discovery"]["error_after"]["nrmse"]), 0.06824, 0.0005);
}

TEST_F(Hsm150, InertiaBeforeAndAfterDiscovery) {
  // Measured: J = 5.09e-4 (+324 %) with J, B alone; 1.4387e-4 (+19.9 %) after discovery
  // (1.519e-4, +26.6 %, without asymmetric_viscous among the candidates).
  EXPECT_NEAR(Value(FirstFit(*report_)["parameters"]["J"]["value"]), 5.088e-4, 0.005e-4);
  EXPECT_EQ((*report_)["parameters"]["J"]["value"],
            (*report_)["discovery"]["parameters_after"]["J"]);
  EXPECT_NEAR(Value((*report_)["discovery"]["parameters_after"]["J"]), 1.4387e-4, 0.002e-4);
}

TEST_F(Hsm150, InertiaWithinTwentyPercentOfTheCatalog) {
  // +19.9 %: inside the criterion, only just. The report's 95 % interval is the
  // leave-one-run-out one, [1.0046, 2.0604]e-4 (-16 ... +72 %), because the eight runs
  // disagree (direction-dependent friction). docs/real-data.md, HSM150.
  const double J = Value((*report_)["discovery"]["parameters_after"]["J"]);
  EXPECT_LE(std::abs(J / kHsmCatalogJ - 1.0), 0.20) << "J = " << J;
}

// ---------------------------------------------------------------------------------------
// Flywheel coast-downs: J = 0.8489 kg m^2 fixed; the coast from t = 60 s (after every
// record's spin-up), no drive torque.

std::string DynoArguments(const std::string& config, const std::string& fit,
                          const std::string& held_out) {
  const std::string d = RealData() + "/dev_dyno_spindown/";
  return "--config configs/real/" + config + " --trace " + d + fit + ".csv --validate " + d +
         held_out +
         ".csv --column t=t_s --column u=current_A --scale u=0 --column "
         "w=w_flywheel_radps --select t=60: --initial-state trace";
}

constexpr double kFlywheelJ = 0.8489;  // kg m^2

// The classical 36.8 % time constant of a coast-down, as `--method classic` computes it
// (src/ident/optimizers/classic.cc, docs/identification.md §3.4 step 5): from the speed w0 at the
// start of the coast, the instant the speed falls to 0.368 w0, located by a least-squares line
// through the samples within +-3 % of w0 of that level. (`--method classic` itself applies
// to dc_servo configs only; docs/real-data.md.)
double ClassicTau(const std::string& file, double t_start) {
  CsvReadOptions options;
  options.time_column = "t_s";
  const Trace trace = ReadTraceCsv(file, options);
  const auto& t = trace.Column("t_s");
  const auto& w = trace.Column("w_flywheel_radps");
  std::size_t k0 = 0;
  while (t[k0] < t_start) ++k0;
  const double w0 = w[k0], target = 0.368 * w0, band = 0.03 * w0;
  double st = 0, sw = 0, stt = 0, stw = 0, n = 0;
  for (std::size_t k = k0; k < t.size(); ++k) {
    if (std::abs(w[k] - target) > band) continue;
    st += t[k];
    sw += w[k];
    stt += t[k] * t[k];
    stw += t[k] * w[k];
    n += 1;
  }
  const double slope = (n * stw - st * sw) / (n * stt - st * st);
  const double intercept = (sw - slope * st) / n;
  return (target - intercept) / slope - t[k0];
}

TEST(DynoCoastdown, MotorUnpluggedBAndCoulombWithIntervals) {
  REQUIRE_REAL_DATA("dev_dyno_spindown");
  const nlohmann::json fit = Ident(DynoArguments(
      "dyno-coastdown-coulomb.json", "motorUnplugged_spindown", "motorUnplugged_spindown_5_28"));
  ASSERT_TRUE(fit.contains("parameters"));
  for (const auto& [name, value] :
       {std::pair<const char*, double>{"B", 2.2548e-3}, {"Tc", 0.070371}}) {
    const auto& p = fit["parameters"][name];
    EXPECT_NEAR(Value(p["value"]), value, 1e-3 * value) << name;
    ASSERT_TRUE(p["ci95"].is_array()) << name;  // reported with its interval
    EXPECT_LT(Value(p["ci95"][0]), Value(p["value"]));
    EXPECT_GT(Value(p["ci95"][1]), Value(p["value"]));
  }
  EXPECT_NEAR(Value(fit["fit"]["nrmse"]), 0.01059, 0.0001);
  EXPECT_NEAR(Value(fit["validation"]["nrmse"]), 0.0288, 0.0002);
  // Without Coulomb friction (J, B only): NRMSE 0.1603 on the fit, 0.1485 on validation.
  const nlohmann::json linear = Ident(DynoArguments(
      "dyno-coastdown.json", "motorUnplugged_spindown", "motorUnplugged_spindown_5_28"));
  ASSERT_TRUE(linear.contains("parameters"));
  EXPECT_NEAR(Value(linear["parameters"]["B"]["value"]), 3.5538e-3, 0.001 * 3.5538e-3);
  EXPECT_NEAR(Value(linear["fit"]["nrmse"]), 0.1603, 0.0005);
  EXPECT_NEAR(Value(linear["validation"]["nrmse"]), 0.1485, 0.0005);
}

TEST(DynoCoastdown, UnloadedBAndCoulombWithIntervals) {
  REQUIRE_REAL_DATA("dev_dyno_spindown");
  const nlohmann::json fit = Ident(
      DynoArguments("dyno-coastdown-coulomb.json", "unloaded_spindown", "unloaded_spindown_5_28"));
  ASSERT_TRUE(fit.contains("parameters"));
  EXPECT_NEAR(Value(fit["parameters"]["B"]["value"]), 1.5832e-3, 1e-3 * 1.5832e-3);
  EXPECT_NEAR(Value(fit["parameters"]["Tc"]["value"]), 0.039790, 1e-3 * 0.039790);
  EXPECT_TRUE(fit["parameters"]["Tc"]["ci95"].is_array());
  EXPECT_NEAR(Value(fit["validation"]["nrmse"]), 0.0820, 0.0005);
}

TEST(DynoCoastdown, ClassicJFromBTauIsBiasedLowByCoulombFriction) {
  REQUIRE_REAL_DATA("dev_dyno_spindown");
  const nlohmann::json fit = Ident(DynoArguments(
      "dyno-coastdown-coulomb.json", "motorUnplugged_spindown", "motorUnplugged_spindown_5_28"));
  ASSERT_TRUE(fit.contains("parameters"));
  const double B = Value(fit["parameters"]["B"]["value"]);
  const double tau =
      ClassicTau(RealData() + "/dev_dyno_spindown/motorUnplugged_spindown.csv", 60.0);
  EXPECT_NEAR(tau, 260.73, 0.01);
  // J = B tau with the viscous B of the fit: 0.588 kg m^2, 30.7 % below the known J: the
  // Coulomb torque speeds the coast up, so tau is short. Equivalently, the classical
  // B = J / tau = 3.256e-3 is 44 % above the fitted viscous B.
  const double J_classic = B * tau;
  EXPECT_NEAR(J_classic, 0.5879, 0.0005);
  EXPECT_NEAR(J_classic / kFlywheelJ - 1.0, -0.307, 0.001);
  EXPECT_NEAR(kFlywheelJ / tau / B - 1.0, 0.444, 0.001);
}

// --discover from J, B alone on the motorUnplugged coast (no input): run once, cached.
nlohmann::json DynoDiscoverReport() {
  return CachedReport("dyno-motorunplugged-discover",
                      DynoArguments("dyno-coastdown.json", "motorUnplugged_spindown",
                                    "motorUnplugged_spindown_5_28") +
                          " --discover");
}

TEST(DynoCoastdown, DiscoverySearchesTheLossesOnAPureCoastDown) {
  // With no input the torque scale of the search boxes is B max|w| of the J, B fit
  // (3.554e-3 x 118 rad/s = 0.42 N m), not Kt max|u| = 0 (which made every box [0, 1e-12]
  // and discovery add nothing). Measured: round 1 refits Coulomb friction to Tc = 0.070382,
  // the declared fit's value (dyno-coastdown-coulomb.json, 0.070371). A Stribeck friction
  // fading over the whole speed range (ws = 101 rad/s of 118) lowers BIC more, and the
  // held-out coast's NRMSE a little more (0.1485 -> 0.02785, Coulomb: 0.02880), but it has no
  // plateau inside the record and is refused by the plateau rule (docs/discovery.md §2): Coulomb
  // friction is added, and the report warns that the loss still depends on w
  // (unexplained_structure) and that Tc differs between the fast and the slow half of the
  // coast (effect_unstable): a speed-dependent loss the vocabulary has no word for. A negative
  // constant torque followed before discovery weighed held-out evidence; it raises the
  // held-out NRMSE (0.02785 -> 0.0297) and is no longer added.
  // Round 2 is not asserted beyond the rule: whether cogging (39/rev) passes screening there
  // hangs on the free-running score of a shaft coming to rest in a cogging field, which a
  // 1e-9 change of the data flips (measured: one of five scalings of w by 1 +- 1e-9, 1e-7
  // adds it, and so does the unscaled trace on an AMD EPYC machine but not on the machine
  // that made docs/real-data). docs/real-data.md, "Coast-downs".
  REQUIRE_REAL_DATA("dev_dyno_spindown");
  const nlohmann::json report = DynoDiscoverReport();
  ASSERT_TRUE(report.contains("discovery"));
  const auto& d = report["discovery"];
  ASSERT_GE(d["added"].size(), 1u);
  EXPECT_EQ(d["added"][0], "coulomb_friction");
  const auto& round1 = d["steps"][0]["candidates"];
  ASSERT_GE(round1.size(), 2u);
  EXPECT_EQ(round1[0]["effect"], "stribeck");
  EXPECT_FALSE(round1[0]["valid"].get<bool>());
  EXPECT_NE(round1[0]["reason"].get<std::string>().find("not well inside the speed range"),
            std::string::npos);
  EXPECT_NEAR(Value(round1[0]["delta_bic"]), -218628.5, 5.0);
  EXPECT_EQ(round1[0]["evidence_rule"], "held_out");
  EXPECT_NEAR(Value(round1[0]["held_out_nrmse"]["after"]), 0.02785, 0.0002);
  EXPECT_EQ(round1[1]["effect"], "coulomb_friction");
  EXPECT_NEAR(Value(round1[1]["delta_bic"]), -186152.8, 5.0);
  EXPECT_NEAR(Value(round1[1]["parameters"]["Tc"]), 0.070371, 1e-3 * 0.070371);
  EXPECT_NEAR(Value(round1[1]["nrmse"]), 0.01059, 0.0001);
  EXPECT_NEAR(Value(round1[1]["held_out_nrmse"]["after"]), 0.02880, 0.0002);
  EXPECT_NEAR(Value(round1[0]["parameters"]["Ts"]), 0.06391, 0.0005);
  EXPECT_NEAR(Value(round1[0]["parameters"]["ws"]), 101.16, 0.1);
  EXPECT_NEAR(Value(d["steps"][0]["nrmse_after"]), 0.01059, 0.0001);
  std::set<std::string> codes;
  for (const auto& w : report["warnings"]) codes.insert(w["code"].get<std::string>());
  EXPECT_EQ(codes.count("unexplained_structure"), 1u);
  EXPECT_EQ(codes.count("effect_unstable"), 1u);
  EXPECT_NEAR(Value(d["error_before"]["nrmse"]), 0.1603, 0.0005);
  EXPECT_NEAR(Value(d["validation"]["before"]["nrmse"]), 0.1485, 0.0005);
  // Every later round's addition passed the held-out rule (a fall of more than 1 %), and
  // the constant torque, which raises the held-out error, is never added.
  for (std::size_t k = 1; k < d["steps"].size(); ++k) {
    for (const auto& c : d["steps"][k]["candidates"]) {
      if (c["effect"] != d["steps"][k]["effect"]) continue;
      EXPECT_LT(Value(c["held_out_nrmse"]["after"]), 0.99 * Value(c["held_out_nrmse"]["before"]));
    }
  }
  for (const auto& added : d["added"]) EXPECT_NE(added, "load_torque");
}

TEST(DynoCoastdown, DiscoveryFindsCoulombFrictionOnAPureCoastDown) {
  REQUIRE_REAL_DATA("dev_dyno_spindown");
  const nlohmann::json report = DynoDiscoverReport();
  ASSERT_TRUE(report.contains("discovery"));
  const auto& d = report["discovery"];
  if (d["added"].empty() || d["added"][0] != "coulomb_friction") {
    GTEST_SKIP() << "KNOWN FAILURE: discovery adds " << d["added"].dump()
                 << ", not coulomb_friction first: round 1 refits Coulomb friction to Tc = "
                 << Value(d["steps"][0]["candidates"][1]["parameters"]["Tc"])
                 << " N m (the declared fit's 0.070371) with dBIC "
                 << Value(d["steps"][0]["candidates"][1]["delta_bic"])
                 << ", but Stribeck friction has dBIC " << Value(d["steps"][0]["delta_bic"])
                 << " with ws = " << Value(d["steps"][0]["parameters"]["ws"])
                 << " rad/s (the record tops at 118): a friction that fades over the whole "
                    "speed range, i.e. a reshaped loss curve. Final NRMSE "
                 << Value(d["error_after"]["nrmse"]) << " (Coulomb: 0.01059), validation "
                 << Value(d["validation"]["after"]["nrmse"])
                 << " (Coulomb: 0.0288). docs/real-data.md, flywheel coast-downs.";
  }
  EXPECT_NEAR(Value(d["parameters_after"]["Tc"]), 0.070371, 0.01 * 0.070371);
}

// ---------------------------------------------------------------------------------------
// ODrive cogging (docs/real-data.md, ODrive cogging): current-step spin-ups of a 150 KV BLDC
// motor on an ODrive, without (spinup_4_nocomp) and with (spinup_3_comp) anti-cogging, runs
// 18-25 (|iq_set| 0.9-1.2 A: the first runs above breakaway, in which the rotor turns on every
// record; below, the uncompensated rotor stays in the detent it starts in on some records).
// rigid_load driven by the measured iq_A x Kt (8.27/150 N m/A), observed through the speed
// derived from the encoder angle. The reference is the static cogging map (holding current
// vs angle, one revolution), whose spectrum docs/real-data/odrive-cogging-map.py computes.

constexpr double kOdriveKt = 8.269933431 / 150.0;  // N m/A (spinup_analysis.m)

std::string OdriveCommand(const std::string& file, const std::string& candidates,
                          const std::string& input = "iq_A") {
  return "--config configs/real/odrive.json --trace " + RealData() + "/odrive_cogging/" + file +
         ".csv --split run --select run=18:25 --column t=t_s --column u=" + input +
         " --scale u=0.0551329 --column theta=theta_rad --derive w=theta --initial-state trace "
         "--discover" +
         candidates;
}

// Amplitudes 2|X_k|/N [A] of the harmonics k = 0..N/2-1 (periods/rev) of one map column.
std::vector<double> CoggingMapHarmonics(const std::string& column) {
  std::ifstream in(RealData() + "/odrive_cogging/coggingmap_forward_16.csv");
  std::string line, cell;
  std::getline(in, line);
  std::stringstream header(line);
  int index = -1;
  for (int c = 0; std::getline(header, cell, ','); ++c) {
    if (cell == column) index = c;
  }
  EXPECT_GE(index, 0) << column;
  std::vector<double> x;
  while (std::getline(in, line)) {
    std::stringstream row(line);
    for (int c = 0; std::getline(row, cell, ','); ++c) {
      if (c == index) x.push_back(std::stod(cell));
    }
  }
  const std::size_t n = x.size();
  std::vector<double> amplitude(n / 2, 0.0);
  for (std::size_t k = 1; k < n / 2; ++k) {
    double re = 0, im = 0;
    for (std::size_t m = 0; m < n; ++m) {
      const double a =
          2.0 * 3.14159265358979323846 * static_cast<double>(k * m) / static_cast<double>(n);
      re += x[m] * std::cos(a);
      im -= x[m] * std::sin(a);
    }
    amplitude[k] = 2.0 * std::hypot(re, im) / static_cast<double>(n);
  }
  return amplitude;
}

// The discovery step that added `effect` (null if none).
nlohmann::json AddedStep(const nlohmann::json& report, const std::string& effect) {
  for (const auto& step : report["discovery"]["steps"]) {
    if (step.value("effect", "") == effect) return step;
  }
  return nullptr;
}

class OdriveCogging : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::string why;
    if (!HaveRealData("odrive_cogging", &why)) return;
    nocomp_ =
        new nlohmann::json(CachedReport("odrive-nocomp", OdriveCommand("spinup_4_nocomp", "")));
    nocomp5_ = new nlohmann::json(
        CachedReport("odrive-nocomp-spinup5", OdriveCommand("spinup_5_nocomp", "")));
    nocomp6_ = new nlohmann::json(
        CachedReport("odrive-nocomp-spinup6", OdriveCommand("spinup_6_nocomp", "")));
    comp_ = new nlohmann::json(CachedReport("odrive-comp", OdriveCommand("spinup_3_comp", "")));
    comp_setpoint_ = new nlohmann::json(
        CachedReport("odrive-comp-setpoint", OdriveCommand("spinup_3_comp", "", "iq_set_A")));
  }
  static void TearDownTestSuite() {
    for (nlohmann::json** report : {&nocomp_, &nocomp5_, &nocomp6_, &comp_, &comp_setpoint_}) {
      delete *report;
      *report = nullptr;
    }
  }
  void SetUp() override {
    REQUIRE_REAL_DATA("odrive_cogging");
    for (const nlohmann::json* report : {nocomp_, nocomp5_, nocomp6_, comp_, comp_setpoint_}) {
      ASSERT_NE(report, nullptr);
      ASSERT_TRUE(report->contains("discovery")) << "a command failed";
    }
  }
  static nlohmann::json* nocomp_;         // spinup_4_nocomp, --discover (every candidate)
  static nlohmann::json* nocomp5_;        // spinup_5_nocomp, the same
  static nlohmann::json* nocomp6_;        // spinup_6_nocomp, the same
  static nlohmann::json* comp_;           // spinup_3_comp, --discover (every candidate)
  static nlohmann::json* comp_setpoint_;  // spinup_3_comp, u = iq_set_A, every candidate
};
nlohmann::json* OdriveCogging::nocomp_ = nullptr;
nlohmann::json* OdriveCogging::nocomp5_ = nullptr;
nlohmann::json* OdriveCogging::nocomp6_ = nullptr;
nlohmann::json* OdriveCogging::comp_ = nullptr;
nlohmann::json* OdriveCogging::comp_setpoint_ = nullptr;

TEST_F(OdriveCogging, MapDominantOrderAndAmplitude) {
  // Trial a16 (adjacent motor present): 7/rev dominates, 0.869 A = 0.0479 N m; the map
  // measured without crosstalk (iso16) has 28/rev on top (0.514 A) and 7/rev at 0.257 A.
  const std::vector<double> a16 = CoggingMapHarmonics("iq_hold_A_a16");
  const auto peak = std::max_element(a16.begin(), a16.end()) - a16.begin();
  EXPECT_EQ(peak, 7);
  EXPECT_NEAR(a16[7] * kOdriveKt, 0.0479, 0.0005);
  EXPECT_NEAR(a16[28] * kOdriveKt, 0.0311, 0.0005);
  const std::vector<double> iso = CoggingMapHarmonics("iq_hold_A_iso16");
  EXPECT_EQ(std::max_element(iso.begin(), iso.end()) - iso.begin(), 28);
  EXPECT_NEAR(iso[7] * kOdriveKt, 0.0142, 0.0005);
}

TEST_F(OdriveCogging, DiscoveryFindsCoggingOnUncompensatedRunsAtTheMapsDominantOrder) {
  // Scored at the measured angle (docs/discovery.md §6): cogging at the map's 7/rev first
  // (NRMSE 0.344 -> 0.157), then Coulomb friction (-> 0.0949); a spring and a 1/rev torque
  // (gravity) are refit and do not generalise. The final model: J 2.139e-4 kg m^2, Tc 0.0203
  // N m (the repo's "0.4 A": 0.022), Tcog 0.0491 N m.
  const auto& d = (*nocomp_)["discovery"];
  EXPECT_EQ(d["added"], nlohmann::json::array({"cogging", "coulomb_friction"}));
  const nlohmann::json step = AddedStep(*nocomp_, "cogging");
  ASSERT_FALSE(step.is_null()) << "no cogging added on the uncompensated runs";
  const std::vector<double> map = CoggingMapHarmonics("iq_hold_A_a16");
  const auto map_order = std::max_element(map.begin(), map.end()) - map.begin();
  EXPECT_EQ(Value(step["parameters"]["periods"]), static_cast<double>(map_order));  // 7
  EXPECT_EQ(step["candidates"][0]["evidence_rule"], "prewhitened_bic");
  EXPECT_NEAR(Value(d["parameters_after"]["J"]), 2.139e-4, 0.01e-4);
  EXPECT_NEAR(Value(d["parameters_after"]["Tc"]), 0.02031, 0.0002);
  EXPECT_NEAR(Value(d["parameters_after"]["Tcog"]), 0.0491, 0.0005);
  EXPECT_NEAR(Value(d["error_before"]["nrmse"]), 0.3444, 0.002);
  EXPECT_NEAR(Value(d["error_after"]["nrmse"]), 0.0949, 0.002);
  // Nothing is unstable between the odd and the even runs; what is left depends on t (the
  // spin-ups' speed-dependent losses) and the report says so.
  EXPECT_EQ(d["adequacy"]["stability"]["unstable"], nlohmann::json::array());
  std::set<std::string> codes;
  for (const auto& w : (*nocomp_)["warnings"]) codes.insert(w["code"].get<std::string>());
  EXPECT_EQ(codes.count("unexplained_structure"), 1u);
  EXPECT_EQ(codes.count("effect_unstable"), 0u);
}

TEST_F(OdriveCogging, UncompensatedRecordsAddTheMapsCoggingWithinFifteenPercent) {
  // Each uncompensated record adds cogging at the map's dominant order, 7/rev, and its final
  // amplitude lies within 15 % of the map's 7/rev (a16: 0.0479 N m): 0.0491, 0.0524, 0.0544
  // N m (+2.5, +9.5, +13.7 %). One harmonic takes up a little of the map's other orders
  // (28/rev at 0.031 N m, 14/rev at 0.019), as much as the angles a record dwells at allow.
  // None is degenerate: B inside its bounds, NRMSE 0.068-0.095.
  const std::vector<double> map = CoggingMapHarmonics("iq_hold_A_a16");
  const auto map_order = std::max_element(map.begin(), map.end()) - map.begin();
  const double map_tcog = map[map_order] * kOdriveKt;
  const std::vector<std::pair<const nlohmann::json*, double>> expected = {
      {nocomp_, 0.0491}, {nocomp5_, 0.0524}, {nocomp6_, 0.0544}};
  for (const auto& [report, tcog] : expected) {
    const auto& d = (*report)["discovery"];
    const nlohmann::json step = AddedStep(*report, "cogging");
    ASSERT_FALSE(step.is_null()) << d["conclusion"];
    EXPECT_EQ(Value(step["parameters"]["periods"]), static_cast<double>(map_order));
    EXPECT_NEAR(Value(d["parameters_after"]["Tcog"]), tcog, 0.0005);
    EXPECT_LT(std::abs(Value(d["parameters_after"]["Tcog"]) / map_tcog - 1.0), 0.15);
    EXPECT_LT(Value(d["error_after"]["nrmse"]), 0.1);
    for (const auto& w : (*report)["warnings"]) EXPECT_NE(w["code"], "parameter_at_bound");
  }
  EXPECT_EQ((*nocomp5_)["discovery"]["added"],
            nlohmann::json::array({"cogging", "coulomb_friction"}));
  EXPECT_NEAR(Value((*nocomp5_)["discovery"]["error_after"]["nrmse"]), 0.0685, 0.002);
  EXPECT_EQ((*nocomp6_)["discovery"]["added"],
            nlohmann::json::array({"cogging", "coulomb_friction", "gravity"}));
  EXPECT_NEAR(Value((*nocomp6_)["discovery"]["error_after"]["nrmse"]), 0.0682, 0.002);
}

TEST_F(OdriveCogging, CompensationLeavesNoCoggingInTheTorqueTheUserAskedFor) {
  // Driven by the setpoint iq_set_A (the torque the user asked for, without the anti-cogging
  // feed-forward), the compensated record adds no cogging: refit in each round, it explains
  // at most 9.1 % of the residual above the noise floor (the rule needs 10 %), and 3.5 % in
  // the last (Tcog 0.0067 N m, a seventh of the uncompensated 0.0491).
  EXPECT_EQ(AddedStep(*comp_setpoint_, "cogging"), nullptr)
      << (*comp_setpoint_)["discovery"]["conclusion"];
  const nlohmann::json& last = (*comp_setpoint_)["discovery"]["steps"].back();
  bool refit = false;
  for (const auto& c : last["candidates"]) {
    if (c["effect"] != "cogging") continue;
    refit = true;
    EXPECT_LT(Value(c["parameters"]["Tcog"]),
              0.25 * Value((*nocomp_)["discovery"]["parameters_after"]["Tcog"]));
  }
  EXPECT_TRUE(refit);
  // Driven by the measured current iq_A, which carries the feed-forward, the motor's own
  // cogging shows again: the compensation is in the input.
  EXPECT_EQ((*comp_)["discovery"]["added"], nlohmann::json::array({"coulomb_friction", "cogging"}));
  EXPECT_NEAR(Value((*comp_)["discovery"]["parameters_after"]["Tcog"]), 0.0386, 0.0005);
}

std::vector<std::string> WarningCodes(const nlohmann::json& report) {
  std::vector<std::string> codes;
  for (const auto& w : report["warnings"]) codes.push_back(w["code"].get<std::string>());
  return codes;
}

bool Has(const std::vector<std::string>& codes, const std::string& code) {
  return std::find(codes.begin(), codes.end(), code) != codes.end();
}

TEST_F(OdriveCogging, CrossValidatedChoiceThatTheCopiesScatterAcrossIsAmbiguous) {
  // spinup_8 (compensated): in round 1 cogging, by cross-validation, takes the place of the
  // Stribeck friction that is best by BIC (cross-validated NRMSE 0.2227 against 0.2282). The
  // stability check's two copies of the data, changed by 1e-9 of their values, make the same
  // choice (Stribeck 0.2262 and 0.2258), but the ratio the choice compares with 0.99 scatters
  // from 0.976 to 0.986: a further copy's could lie from 0.954 to 1.01 (the Student-t
  // prediction interval), and on 10 perturbed copies of the record 6 chose Stribeck friction.
  // Before this check the record as recorded was reported with cogging and nothing ambiguous.
  const nlohmann::json report =
      CachedReport("odrive-comp-spinup8", OdriveCommand("spinup_8_comp", ""));
  const auto& d = report["discovery"];
  EXPECT_EQ(d["added"], nlohmann::json::array({"cogging", "coulomb_friction"}));
  ASSERT_EQ(d["ambiguous"].size(), 1u) << d["conclusion"];
  EXPECT_EQ(d["ambiguous"][0]["effects"], nlohmann::json::array({"cogging", "stribeck"}));
  EXPECT_NE(d["ambiguous"][0]["reason"].get<std::string>().find(
                "a further copy's ratio could lie anywhere from"),
            std::string::npos)
      << d["ambiguous"][0]["reason"];
  // The data first, then each copy.
  std::map<std::string, std::vector<double>> nrmse;
  for (const auto& c : d["steps"][0]["candidates"]) {
    if (c["effect"] != "cogging" && c["effect"] != "stribeck") continue;
    std::vector<double>& v = nrmse[c["effect"].get<std::string>()];
    v.push_back(Value(c["cross_validated_nrmse"]["after"]));
    ASSERT_EQ(c["cross_validated_nrmse"]["perturbed"].size(), 2u);
    for (const auto& p : c["cross_validated_nrmse"]["perturbed"]) v.push_back(Value(p));
  }
  const std::vector<double>& cogging = nrmse["cogging"];
  const std::vector<double>& stribeck = nrmse["stribeck"];
  ASSERT_EQ(cogging.size(), 3u);
  ASSERT_EQ(stribeck.size(), 3u);
  EXPECT_NEAR(cogging[0], 0.2227, 0.001);
  EXPECT_NEAR(stribeck[0], 0.2282, 0.001);
  // No copy reverses the choice: on the data and on each copy cogging predicts better by
  // more than the rule's 1 % margin (DiscoveryOptions::held_out_margin). The scatter alone
  // marks it.
  for (std::size_t c = 0; c < 3; ++c) EXPECT_LT(cogging[c], 0.99 * stribeck[c]) << c;
  EXPECT_TRUE(Has(WarningCodes(report), "discovery_ambiguous"));
}

TEST_F(OdriveCogging, CoggingThatOnlyTheCrossValidationsLastBitsWouldAddIsUndecided) {
  // spinup_7 (compensated), round 2: the halves predict each other with NRMSE 0.2271 against
  // 0.1132 fitted, 0.3 % over the limit of twice the fitted (0.2264) under which they judge a
  // candidate; a copy of the data changed by 1e-9 can fall under it (0.2259 on one of 10),
  // and so can a build with FMA contractions. Cogging passes its evidence; where the halves
  // judge it, it does not generalise (0.2271 -> 0.2575). Before this check it was added on
  // the evidence alone on the data as recorded and refused on that copy; now it is undecided.
  const nlohmann::json report =
      CachedReport("odrive-one-motor-spinup_7_comp", OdriveCommand("spinup_7_comp", ""));
  const auto& d = report["discovery"];
  EXPECT_EQ(d["added"], nlohmann::json::array({"coulomb_friction"})) << d["conclusion"];
  ASSERT_EQ(d["unstable"].size(), 1u);
  EXPECT_EQ(d["unstable"][0]["effect"], "cogging");
  EXPECT_NE(d["unstable"][0]["reason"].get<std::string>().find(
                "whether the record's parts can judge it is too close to call"),
            std::string::npos)
      << d["unstable"][0]["reason"];
  EXPECT_NE(d["cross_validation_parts"].get<std::string>().find(
                "in round 2, whether the parts can judge a candidate is too close to call"),
            std::string::npos)
      << d["cross_validation_parts"];
  // Its parts' fits are chaotic (the copies move their NRMSE by about 0.5 %), so 0.3 % from
  // the limit is too close to call whatever the two copies say (DiscoveryOptions::usable_band):
  // a build with FMA contractions, whose copies happened to agree, gives the same verdict.
  EXPECT_NE(d["cross_validation_parts"].get<std::string>().find(
                "within 5 % of the limit of twice the fitted"),
            std::string::npos);
  EXPECT_NEAR(Value(d["unstable"][0]["cross_validated_nrmse"]["before"]), 0.2271, 0.001);
  EXPECT_NEAR(Value(d["unstable"][0]["cross_validated_nrmse"]["after"]), 0.2575, 0.002);
  EXPECT_TRUE(Has(WarningCodes(report), "decision_unstable"));
}

// One motor, one inertia: the six spin-up records (compensated 3, 7, 8; uncompensated 4, 5, 6),
// runs 18-25, the documented flags (the measured current as input, --discover). Measured
// (2026-12-02): J = 2.044, 2.139, 2.047, 2.051, 2.145, 2.060 e-4 (3, 4, 5, 6, 7, 8); the median
// 2.056e-4 is 18 % below the repo's rough 2.5e-4 and matches its own least-squares check
// (about 2.0e-4); every record lies within 4.4 % of it.
TEST_F(OdriveCogging, OneMotorOneInertia) {
  std::vector<std::pair<std::string, double>> inertia;
  for (const char* file : {"spinup_3_comp", "spinup_4_nocomp", "spinup_5_nocomp", "spinup_6_nocomp",
                           "spinup_7_comp", "spinup_8_comp"}) {
    // Five records' reports are cached under the names the other tests use (the same commands).
    const std::map<std::string, std::string> fixture = {
        {"spinup_3_comp", "odrive-comp"},
        {"spinup_4_nocomp", "odrive-nocomp"},
        {"spinup_5_nocomp", "odrive-nocomp-spinup5"},
        {"spinup_6_nocomp", "odrive-nocomp-spinup6"},
        {"spinup_8_comp", "odrive-comp-spinup8"}};
    const auto known = fixture.find(file);
    const std::string name =
        known != fixture.end() ? known->second : std::string("odrive-one-motor-") + file;
    const nlohmann::json report = CachedReport(name, OdriveCommand(file, ""));
    ASSERT_TRUE(report.contains("parameters")) << file;
    inertia.emplace_back(file, Value(report["parameters"]["J"]["value"]));
  }
  std::vector<double> values;
  for (const auto& [file, J] : inertia) values.push_back(J);
  std::sort(values.begin(), values.end());
  const double median = 0.5 * (values[2] + values[3]);
  EXPECT_NEAR(median, 2.056e-4, 0.01e-4);
  EXPECT_LT(std::abs(median / 2.5e-4 - 1), 0.25);
  for (const auto& [file, J] : inertia) {
    EXPECT_LT(std::abs(J / median - 1), 0.10) << file << ": J " << J;
  }
  EXPECT_NEAR(values.back() / median - 1, 0.044, 0.005);  // the largest, spinup_7
}

// ---------------------------------------------------------------------------------------
// HSLU lab DC motor with an eddy-current brake (docs/real-data.md, HSLU): voltage in, speed
// out, no current. J and B are the voltage-referred J' = J R/Kt and B' = Kb + B R/Kt.

std::string HsluCommand(const std::string& record, const std::string& extra = "") {
  const std::string d = RealData() + "/hslu_dcmotor_speed/";
  return "--config configs/real/hslu.json --trace " + d + record +
         ".csv --column t=t_s --column u=u_V --column w=w_radps --initial-state trace --discover" +
         extra;
}

TEST(Hslu, BrakeRecordAddsNothingAndSaysWhyTheDeadBandIsRefused) {
  // The plain BIC added a 30/rev cogging here. Now nothing is added. The Coulomb
  // candidate fits the dead band the steady states show (0.876 V; the brake-off record's two
  // steady states cross u = 0.71 V) and lowers the NRMSE 0.0872 -> 0.0551, but its evidence
  // on the prewhitened residuals is positive: the residual is 99.8 % predictable from its own
  // past (a model error, not sensor noise), which leaves one record no power for a slow effect.
  REQUIRE_REAL_DATA("hslu_dcmotor_speed");
  const nlohmann::json report =
      CachedReport("hslu-brake05", HsluCommand("openloop_step_5to15V_brake05"));
  const auto& d = report["discovery"];
  EXPECT_TRUE(d["added"].empty());
  EXPECT_NEAR(Value(report["parameters"]["B"]["value"]), 0.06705, 0.0001);
  EXPECT_NEAR(Value(report["fit"]["nrmse"]), 0.08716, 0.0001);
  // Now the same dead band is also refit as a constant torque (load_torque, TL = 0.876,
  // the same torque on a record whose speed never changes sign) with the same verdict: its
  // whitened evidence is +76.9. Whether Coulomb friction is refit too depends on the order of
  // the screening's near-equal scores; when it is, its evidence is positive as well.
  bool cogging_added = false, dead_band_seen = false;
  for (const auto& c : d["last_round"]) {
    cogging_added = cogging_added || (c["effect"] == "cogging" && c["valid"].get<bool>());
    if (c["effect"] != "coulomb_friction" && c["effect"] != "load_torque") continue;
    if (!c["fitted"].get<bool>()) continue;
    dead_band_seen = true;
    EXPECT_EQ(c["evidence_rule"], "prewhitened_bic");
    EXPECT_NEAR(std::abs(Value(c["parameters"].begin().value())), 0.8757, 0.002);
    EXPECT_NEAR(Value(c["nrmse"]), 0.05507, 0.0002);
    EXPECT_NEAR(Value(c["delta_bic"]), 76.8, 1.0);
    EXPECT_NEAR(Value(c["delta_bic_white"]), -1004.0, 2.0);
    EXPECT_LT(Value(c["noise_model"]["w"]["innovation_ratio"]), 0.003);
  }
  EXPECT_TRUE(dead_band_seen);
  EXPECT_FALSE(cogging_added);
  // The report says what is left: a residual that depends on t ("unexplained: residual depends
  // on t ... , also on u"; the brake is not linear in speed), a warning; that the residual is
  // also coloured is a note, not a warning.
  std::set<std::string> codes;
  for (const auto& w : report["warnings"]) codes.insert(w["code"].get<std::string>());
  EXPECT_EQ(codes, (std::set<std::string>{"unexplained_structure"}));
  bool coloured_note = false;
  for (const auto& note : report["notes"])
    coloured_note =
        coloured_note || note.get<std::string>().rfind("the residual is coloured", 0) == 0;
  EXPECT_TRUE(coloured_note);
  EXPECT_EQ(d["conclusion"].get<std::string>().rfind("unexplained: ", 0), 0u) << d["conclusion"];
}

TEST(Hslu, HeldOutSpeedLoopRecordRefusesEveryCandidate) {
  // The speed-loop record at the same brake setting, its voltage replayed open loop: 17-24 V at
  // 210-270 rad/s, outside the step record's range, and the brake is not linear in speed:
  // held-out NRMSE 1.889 (warned), and every candidate raises it.
  REQUIRE_REAL_DATA("hslu_dcmotor_speed");
  const nlohmann::json report = CachedReport(
      "hslu-brake05-validated",
      HsluCommand("openloop_step_5to15V_brake05",
                  " --validate " + RealData() +
                      "/hslu_dcmotor_speed/closedloop_step_2000to2500rpm_brake05.csv"));
  const auto& d = report["discovery"];
  EXPECT_TRUE(d["added"].empty());
  EXPECT_NEAR(Value(report["validation"]["nrmse"]), 1.889, 0.002);
  // Every candidate refit either raises the held-out error or is not valid: the cogging
  // (refit, like every position-dependent candidate whose screening lowers BIC)
  // lowers it 1.889 -> 1.863 with Tcog on its search bound.
  int held_out = 0;
  for (const auto& c : d["last_round"]) {
    if (!c.contains("held_out_nrmse")) continue;
    ++held_out;
    if (!c["valid"].get<bool>()) continue;
    EXPECT_GT(Value(c["held_out_nrmse"]["after"]), Value(c["held_out_nrmse"]["before"]))
        << c["effect"];
  }
  EXPECT_GE(held_out, 3);  // measured 4: spring, Stribeck, load, cogging
  bool warned = false;
  for (const auto& w : report["warnings"]) warned = warned || w["code"] == "nrmse_at_least_one";
  EXPECT_TRUE(warned);
}

// ---------------------------------------------------------------------------------------
// Records found for this release (testdata/realdata, docs/real-data.md): committed with the
// repository, so these run everywhere. The Delta servo under its PD position loop, fitted as a
// new user would from the starting config: the output error says the record is closed loop
// and advises the equation error; the equation error chooses its cut-off from the data and
// gives J within 10 % of the record's independent 1.93e-4 with an interval that covers it,
// friction added and neither spring nor gravity on the free rotor.

std::string DeltaCommand(int run, const std::string& extra) {
  return "--config configs/real/delta-a3.json --trace testdata/realdata/delta_a3_servo/lorenz_jm_" +
         std::to_string(run) + ".csv --discover" + extra;
}

TEST(DeltaServo, TheOutputErrorSaysTheRecordIsClosedLoopAndAdvisesTheEquationError) {
  const nlohmann::json report = CachedReport("delta-1-output", DeltaCommand(1, ""));
  EXPECT_TRUE(FirstFit(report)["residual"]["closed_loop"].get<bool>());
  bool advised = false;
  for (const auto& w : report["warnings"])
    advised =
        advised || w["message"].get<std::string>().find("--error equation") != std::string::npos;
  EXPECT_TRUE(advised);
  bool noted = false;
  for (const auto& note : report["notes"])
    noted = noted || note.get<std::string>().rfind("the record looks closed loop", 0) == 0;
  EXPECT_TRUE(noted);
}

TEST(DeltaServo, TheEquationErrorGivesJWithinTenPercentOnBothRuns) {
  constexpr double kIndependentJ = 1.93e-4;
  for (int run : {1, 2}) {
    SCOPED_TRACE(run);
    const nlohmann::json report = CachedReport("delta-" + std::to_string(run) + "-equation",
                                               DeltaCommand(run, " --error equation"));
    EXPECT_EQ(Value(report["equation_cutoff"]["hz"]), 25.0);
    EXPECT_FALSE(report["equation_cutoff"]["user_set"].get<bool>());
    const auto& added = report["discovery"]["added"];
    auto has = [&](const char* effect) {
      return std::find(added.begin(), added.end(), effect) != added.end();
    };
    EXPECT_TRUE(has("coulomb_friction"));
    EXPECT_FALSE(has("spring"));
    EXPECT_FALSE(has("gravity"));
    const auto& j = report["parameters"]["J"];
    EXPECT_LT(std::abs(Value(j["value"]) / kIndependentJ - 1.0), 0.10);
    EXPECT_LE(Value(j["ci95"][0]), kIndependentJ);
    EXPECT_GE(Value(j["ci95"][1]), kIndependentJ);
  }
}

// The starting config's J 0.02 and B 0.05 (a 10 kg·cm² axis) on small motors: their B lies
// below B's default range [5e-05, 50] and the gearmotor's J below J's [2e-05, 20]. The fit
// stops on those ends, and the ranges are moved past them (docs/identification.md §2b): the
// new user's run gives what --initial B=5e-06 --initial J=2e-06 gave by hand. Measured: J
// 7.016e-06 [5.148e-06, 9.562e-06] against the record's regression 7.15e-06.
std::string NewUserCommand(const std::string& traces, const std::string& extra = "") {
  return "--config configs/real/delta-a3.json " + traces + " --discover" + extra;
}

TEST(NewRigs, TheDefaultRangesMoveToTheGearmotorWithoutItsFlywheel) {
  constexpr double kIndependentJ = 7.15e-6;
  const nlohmann::json report = CachedReport(
      "gearmotor-noflywheel",
      NewUserCommand("--trace testdata/realdata/ultra_mk2_odrive_flywheel/noflywheel_steps.csv"));
  const auto& j = report["parameters"]["J"];
  EXPECT_LT(std::abs(Value(j["value"]) / kIndependentJ - 1.0), 0.10);
  EXPECT_LE(Value(j["ci95"][0]), kIndependentJ);
  EXPECT_GE(Value(j["ci95"][1]), kIndependentJ);
  EXPECT_FALSE(Has(WarningCodes(report), "parameter_at_bound"));
  bool moved = false;
  for (const auto& note : report["notes"]) {
    moved = moved || note.get<std::string>().find(
                         "J from [2e-05, 20] to [2e-08, 0.02]; B from [5e-05, 50] to [5e-08, "
                         "0.05]") != std::string::npos;
  }
  EXPECT_TRUE(moved) << report["notes"].dump();
}

// A record that turns one way only (voltage steps of the QNET motor, 4 V then 6 V): B + dB
// forwards is all it shows, so the direction-dependent damping is not a candidate there
// (docs/discovery.md §2). Before, it was added with no interval for J; now Coulomb friction
// (a constant drag, one way) is, and J is -0.7 % of the record's regression 2.08e-05, its
// interval [2.011e-05, 2.121e-05] covering it.
TEST(NewRigs, AOneWayRecordGetsNoDirectionDependentDamping) {
  constexpr double kIndependentJ = 2.08e-5;
  const nlohmann::json report = CachedReport(
      "qnet-4v6v",
      NewUserCommand("--trace testdata/realdata/mcgill_qnet_dcmotor/qnet_step4V6V_torque.csv"));
  const auto& added = report["discovery"]["added"];
  EXPECT_EQ(std::find(added.begin(), added.end(), "asymmetric_viscous"), added.end());
  bool refused = false;
  for (const auto& c : report["discovery"]["steps"][0]["candidates"]) {
    refused = refused || (c["effect"] == "asymmetric_viscous" &&
                          c.value("reason", "").find("turned one way only") != std::string::npos);
  }
  EXPECT_TRUE(refused) << report["discovery"]["steps"][0]["candidates"].dump();
  const auto& j = report["parameters"]["J"];
  ASSERT_TRUE(j.contains("ci95"));
  EXPECT_LT(std::abs(Value(j["value"]) / kIndependentJ - 1.0), 0.10);
  EXPECT_LE(Value(j["ci95"][0]), kIndependentJ);
  EXPECT_GE(Value(j["ci95"][1]), kIndependentJ);
}

// Two SRV02 servos' bump tests, the load shaft's angle alone logged (no speed column). The
// plain command names the two ways to fit such a record; on the six steps with the angle
// observed, J is +2.4 % of the datasheet's 3.83e-3 (home pose) with an interval that covers
// it. A single step from rest at the record's middle has a first half at rest: the block
// cross-validation cannot use it and says so (before, the command failed with exit 2).
TEST(NewRigs, AnAngleOnlyRecordIsFittedOnTheAngle) {
  const std::string dir = "testdata/realdata/asb_srv02_cnc_steps/";
  const CommandResult plain = blmd::testing::Run(
      "cd " + SourcePath("") + " && " + BinPath("blmd-ident") + " " +
      NewUserCommand("--trace " + dir + "m0_p2V.csv") + " --quiet --report /dev/null");
  EXPECT_EQ(plain.exit_code, 2);
  EXPECT_NE(plain.err.find("fit it (--observe theta) or the speed derived from it (--derive "
                           "w=theta)"),
            std::string::npos)
      << plain.err;
  std::string six;
  for (const char* f : {"m0_p0V5", "m0_m0V5", "m0_p1V", "m0_m1V", "m0_p2V", "m0_m2V"})
    six += std::string(" --trace ") + dir + f + ".csv";
  constexpr double kDatasheetJ = 3.83e-3;
  const nlohmann::json pooled =
      CachedReport("srv02-six", NewUserCommand(six.substr(1), " --observe theta"));
  const auto& j = pooled["parameters"]["J"];
  EXPECT_LT(std::abs(Value(j["value"]) / kDatasheetJ - 1.0), 0.10);
  EXPECT_LE(Value(j["ci95"][0]), kDatasheetJ);
  EXPECT_GE(Value(j["ci95"][1]), kDatasheetJ);
  const nlohmann::json one = CachedReport(
      "srv02-p2v", NewUserCommand("--trace " + dir + "m0_p2V.csv", " --observe theta"));
  EXPECT_NE(one["discovery"]
                .value("cross_validation_parts", "")
                .find("(not used: a part of the record cannot be fitted alone"),
            std::string::npos)
      << one["discovery"].dump();
}

// EMPS from its reference (configs/real/emps-reference.json, docs/real-data.md "From its
// reference"): the benchmark's cascade in the config, with the rig's velocity estimate (the
// angle's difference over two samples), the simulation driven by the recorded reference qg and
// compared on the measured position. Measured: M 94.749 kg (-0.38 % of the IDIM-LS reference
// 95.109, whose value the interval covers), Fv 217.92 (+7.1 %), Fc 19.321 (-5.3 %), offset
// -3.1719 (+0.2 %). With the exact speed fed back instead (speed_difference_samples 0), M is
// 86.26 (-9.3 %): the controller as written decides M.
TEST(EmpsFromTheReference, TheBenchmarksCascadeInTheConfig) {
  REQUIRE_REAL_DATA("emps");
  const std::string d = RealData() + "/emps/";
  const nlohmann::json report =
      Ident("--config configs/real/emps-reference.json --trace " + d +
            "emps_estimation.csv --column t=t_s --column theta=q_m --column r=qref_m "
            "--column u=u_V --initial-state trace");
  ASSERT_TRUE(report.contains("parameters"));
  const nlohmann::json& p = report["parameters"];
  EXPECT_NEAR(Value(p["J"]["value"]), 94.749, 0.3);
  EXPECT_NEAR(Value(p["B"]["value"]), 217.92, 1.0);
  EXPECT_NEAR(Value(p["Tc"]["value"]), 19.321, 0.1);
  EXPECT_NEAR(Value(p["TL"]["value"]), -3.1719, 0.02);
  EXPECT_LE(std::abs(Value(p["J"]["value"]) / 95.1089 - 1.0), 0.01);
  EXPECT_LE(Value(p["J"]["ci95"][0]), 95.1089);
  EXPECT_GE(Value(p["J"]["ci95"][1]), 95.1089);
  EXPECT_LE(std::abs(Value(p["B"]["value"]) / 203.5034 - 1.0), 0.10);
  EXPECT_LE(std::abs(Value(p["Tc"]["value"]) / 20.3935 - 1.0), 0.06);
  EXPECT_LE(std::abs(Value(p["TL"]["value"]) / -3.1648 - 1.0), 0.05);
}

}  // namespace
}  // namespace blmd::testing
