// blmd-tune as a user runs it (docs/tuning.md, docs/cli.md §4): gains tuned on the model that
// blmd-ident found from a noisy trace of the Ganesh servo, checked on the TRUE plant (the
// paper's parameters) with the loop transfer function written out by hand here and its
// crossover found by bisection; the worst case over the 95 % box against the same hand
// formula at the box's corners; the closed-loop config run by blmd-sim; the refusals (exit 1)
// and bad input (exit 2, nothing written).
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <iostream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <regex>
#include <string>
#include <vector>

#include "support/test_support.h"

namespace blmd {
namespace {

using Complex = std::complex<double>;
using nlohmann::json;
using testing::BinPath;
using testing::CommandResult;
using testing::FileExists;
using testing::Run;
using testing::Slurp;
using testing::SourcePath;
using testing::TempDir;

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = 180.0 / kPi;

struct Motor {
  double R = 12.6, L = 0.283, Kt = 0.04, Kb = 0.04, J = 2.26e-5, B = 2.261e-5;  // Ganesh, no load
};

// L(jω) = C(jω)·G(jω): G from eq. 12 of Ganesh et al. (2012) (speed: without the 1/s), C the
// report's kp + ki/s + kd s/(1 + s/(2π f_d)), both written out here.
Complex Loop(const Motor& m, const json& controller, bool position, double w) {
  const Complex s(0.0, w);
  Complex g = m.Kt / ((m.R + s * m.L) * (m.J * s + m.B) + m.Kb * m.Kt);
  if (position) g /= s;
  const double kp = controller["kp"], ki = controller["ki"], kd = controller["kd"];
  const double fd = controller["derivative_filter_hz"];
  Complex c = kp + ki / s;
  if (fd > 0.0) c += kd * s / (1.0 + s / (2.0 * kPi * fd));
  return c * g;
}

struct Margins {
  double crossover_hz, phase_margin_deg;
};

// |L| falls through 1 once on [0.01, 1000] Hz for these loops: bisection on log |L|.
Margins HandMargins(const Motor& m, const json& controller, bool position) {
  double lo = 2.0 * kPi * 0.01, hi = 2.0 * kPi * 1000.0;
  EXPECT_GT(std::abs(Loop(m, controller, position, lo)), 1.0);
  EXPECT_LT(std::abs(Loop(m, controller, position, hi)), 1.0);
  for (int k = 0; k < 200; ++k) {
    const double mid = std::sqrt(lo * hi);
    (std::abs(Loop(m, controller, position, mid)) > 1.0 ? lo : hi) = mid;
  }
  const double wc = std::sqrt(lo * hi);
  return {wc / (2.0 * kPi), 180.0 + std::arg(Loop(m, controller, position, wc)) * kDeg};
}

CommandResult Tune(const std::string& arguments) {
  return Run(BinPath("blmd-tune") + " " + arguments);
}

// One identification of the noisy square-wave trace, shared by the tests.
class TuneCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir;
    const CommandResult fit = testing::Run(
        BinPath("blmd-ident") + " --config " + SourcePath("configs/ganesh-square.json") +
        " --trace " + SourcePath("testdata/ganesh-square.csv") + " --report " +
        dir_->File("fit.json") + " --write-config " + dir_->File("model.json") + " --quiet");
    ASSERT_EQ(fit.exit_code, 0) << fit.err;
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static std::string FitReport() { return dir_->File("fit.json"); }
  static std::string Base() {
    return "--config " + SourcePath("configs/ganesh-square.json") + " --from-report " + FitReport();
  }
  static TempDir* dir_;
};
TempDir* TuneCli::dir_ = nullptr;

// The tuned loop on the true plant: crossover and phase margin within 10 % of the request;
// on the identified model (the report's `achieved`) the request to 1e-6; the box's worst case
// equal to the hand formula's at the box's corners.
void CheckLoop(const std::string& loop, double fc, double pm, const std::string& fit_path,
               const std::string& base) {
  SCOPED_TRACE(loop);
  TempDir dir;
  const bool position = loop == "position";
  const CommandResult run =
      Tune(base + " --loop " + loop + " --crossover " + std::to_string(fc) + " --phase-margin " +
           std::to_string(pm) + " --limit u=24 --limit i=4 --report " + dir.File("tune.json") +
           " --write-config " + dir.File("closed.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json report = json::parse(Slurp(dir.File("tune.json")));
  const json& controller = report["controller"];
  EXPECT_EQ(controller["structure"], position ? "PID" : "PI");
  const Margins truth = HandMargins(Motor{}, controller, position);
  std::cout << "[ measured ] " << loop << " loop, request " << fc << " Hz / " << pm
            << " deg: true plant " << truth.crossover_hz << " Hz / " << truth.phase_margin_deg
            << " deg; kp " << controller["kp"] << " ki " << controller["ki"] << " kd "
            << controller["kd"] << " f_d " << controller["derivative_filter_hz"] << "\n";
  EXPECT_NEAR(truth.crossover_hz, fc, 0.1 * fc);
  EXPECT_NEAR(truth.phase_margin_deg, pm, 0.1 * pm);
  EXPECT_NEAR(report["achieved"]["crossover_hz"].get<double>(), fc, 1e-6 * fc);
  EXPECT_NEAR(report["achieved"]["phase_margin_deg"].get<double>(), pm, 1e-6);
  EXPECT_TRUE(report["achieved"]["stable"].get<bool>());
  EXPECT_EQ(report["warnings"], json::array());

  // The box: J and B with the identification's 95 % intervals; the worst phase margin and
  // the crossover's range over its four corners by the hand formula.
  const json fit = json::parse(Slurp(fit_path));
  const json& box = report["robustness"]["parameters"];
  ASSERT_EQ(box.size(), 2u);
  for (const char* name : {"J", "B"}) {
    EXPECT_EQ(box[name]["ci95"], fit["parameters"][name]["ci95"]) << name;
  }
  ASSERT_EQ(report["robustness"]["corners"].size(), 4u);
  double worst_pm = 1e9, low_fc = 1e9, high_fc = 0.0;
  for (const json& corner : report["robustness"]["corners"]) {
    Motor m;
    m.J = corner["parameters"]["J"];
    m.B = corner["parameters"]["B"];
    const Margins at = HandMargins(m, controller, position);
    EXPECT_NEAR(corner["phase_margin_deg"].get<double>(), at.phase_margin_deg, 1e-6);
    EXPECT_NEAR(corner["crossover_hz"].get<double>(), at.crossover_hz, 1e-8 * fc);
    worst_pm = std::min(worst_pm, at.phase_margin_deg);
    low_fc = std::min(low_fc, at.crossover_hz);
    high_fc = std::max(high_fc, at.crossover_hz);
  }
  const json& worst = report["robustness"]["worst_case"];
  std::cout << "[ measured ] " << loop << " loop, 95 % box worst case: crossover " << low_fc
            << " to " << high_fc << " Hz, phase margin " << worst_pm << " deg, gain margin "
            << worst["gain_margin_db"] << " dB; step worst "
            << report["step_response"]["worst_case"].dump() << "\n";
  EXPECT_NEAR(worst["phase_margin_deg"].get<double>(), std::min(worst_pm, pm), 1e-6);
  EXPECT_NEAR(worst["crossover_hz_min"].get<double>(), std::min(low_fc, fc), 1e-8 * fc);
  EXPECT_NEAR(worst["crossover_hz_max"].get<double>(), std::max(high_fc, fc), 1e-8 * fc);

  // blmd-sim runs the closed-loop config and prints the step figures the report gives.
  const CommandResult sim = Run(BinPath("blmd-sim") + " --config " + dir.File("closed.json") +
                                " --out " + dir.File("closed.csv"));
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const json& nominal = report["step_response"]["nominal"];
  std::smatch match;
  ASSERT_TRUE(std::regex_search(
      sim.out, match,
      std::regex("rise time \\(10-90 %\\) ([-0-9.e]+) s, overshoot ([-0-9.e]+) %, settling "
                 "\\(2 %\\) ([-0-9.e]+) s")))
      << sim.out;
  EXPECT_NEAR(std::stod(match[1]), nominal["rise_time_s"].get<double>(),
              1e-3 * nominal["rise_time_s"].get<double>());
  EXPECT_NEAR(std::stod(match[2]), nominal["overshoot_percent"].get<double>(),
              1e-3 * nominal["overshoot_percent"].get<double>() + 1e-9);
  EXPECT_NEAR(std::stod(match[3]), nominal["settling_time_s"].get<double>(),
              1e-3 * nominal["settling_time_s"].get<double>());
  EXPECT_LE(nominal["peak_u"].get<double>(), 24.0);
  EXPECT_FALSE(nominal["saturated"].get<bool>());
}

TEST_F(TuneCli, GaneshPositionLoopMeetsTheRequestOnTheTruePlant) {
  CheckLoop("position", 2.0, 60.0, FitReport(), Base());
}

TEST_F(TuneCli, GaneshSpeedLoopMeetsTheRequestOnTheTruePlant) {
  CheckLoop("speed", 3.0, 60.0, FitReport(), Base());
}

// The config blmd-ident --write-config wrote carries the intervals in its notes: without
// --from-report they are the box, the same as the report's, and the gains are the same.
TEST_F(TuneCli, TheWrittenConfigsNotesGiveTheSameBox) {
  const std::string request =
      " --loop position --crossover 2 --phase-margin 60 --limit u=24 --json";
  const CommandResult from_notes = Tune("--config " + dir_->File("model.json") + request);
  const CommandResult from_report = Tune(Base() + request);
  ASSERT_EQ(from_notes.exit_code, 0) << from_notes.err;
  ASSERT_EQ(from_report.exit_code, 0) << from_report.err;
  const json notes = json::parse(from_notes.out), report = json::parse(from_report.out);
  EXPECT_EQ(notes["robustness"]["box_source"], "config notes");
  EXPECT_EQ(report["robustness"]["box_source"], "report");
  EXPECT_EQ(notes["robustness"]["parameters"], report["robustness"]["parameters"]);
  EXPECT_EQ(notes["controller"], report["controller"]);
  EXPECT_EQ(notes["robustness"]["worst_case"], report["robustness"]["worst_case"]);
}

// Exit 1, one line with the reason, nothing written.
void ExpectRefused(const CommandResult& result, const TempDir& dir, const std::string& reason) {
  EXPECT_EQ(result.exit_code, 1) << result.err;
  EXPECT_EQ(result.err.rfind("error: cannot tune: ", 0), 0u) << result.err;
  EXPECT_NE(result.err.find(reason), std::string::npos) << result.err;
  EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1);
  EXPECT_EQ(result.out, "");
  EXPECT_FALSE(FileExists(dir.File("tune.json")));
  EXPECT_FALSE(FileExists(dir.File("closed.json")));
}

TEST_F(TuneCli, RefusesWhatThePlantCannotMeet) {
  TempDir dir;
  const std::string outputs =
      " --report " + dir.File("tune.json") + " --write-config " + dir.File("closed.json");
  // A PI speed loop at 10 Hz: the plant lags by 142°, a 60° margin needs lead.
  ExpectRefused(
      Tune(Base() + " --loop speed --crossover 10 --phase-margin 60 --limit u=24" + outputs), dir,
      "a PI cannot give 60 deg of phase margin at 10 Hz");
  // A 100 rad step at 2 Hz needs more than 24 V (kp·100 at once).
  const CommandResult volts =
      Tune(Base() + " --loop position --crossover 2 --phase-margin 60 --limit u=24 --step 100" +
           outputs);
  ExpectRefused(volts, dir, "beyond the drive's 24 V");
  std::smatch match;
  ASSERT_TRUE(std::regex_search(volts.err, match, std::regex("needs ([0-9.e+]+) V for a 100 rad")));
  EXPECT_GT(std::stod(match[1]), 24.0);
  // The same loop within the voltage, but a 0.05 A drive.
  ExpectRefused(Tune(Base() + " --loop speed --crossover 3 --phase-margin 60 --limit u=24 " +
                     "--limit i=0.05" + outputs),
                dir, "beyond the drive's 0.05 A");
}

// Exit 2, one line "error: ...", nothing written.
void ExpectBadInput(const CommandResult& result, const TempDir& dir, const std::string& part) {
  EXPECT_EQ(result.exit_code, 2) << result.err;
  EXPECT_EQ(result.err.rfind("error: ", 0), 0u) << result.err;
  EXPECT_NE(result.err.find(part), std::string::npos) << result.err;
  EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
  EXPECT_EQ(result.out, "");
  EXPECT_FALSE(FileExists(dir.File("tune.json")));
  EXPECT_FALSE(FileExists(dir.File("closed.json")));
}

TEST_F(TuneCli, BadInputWritesNothing) {
  TempDir dir;
  const std::string outputs =
      " --report " + dir.File("tune.json") + " --write-config " + dir.File("closed.json");
  const std::string request = " --crossover 2 --phase-margin 60 --limit u=24";
  ExpectBadInput(Tune(Base() + " --loop torque" + request + outputs), dir, "--loop");
  ExpectBadInput(
      Tune(Base() + " --loop position --crossover -1 --phase-margin 60 --limit u=24" + outputs),
      dir, "--crossover");
  ExpectBadInput(
      Tune(Base() + " --loop position --crossover 2 --phase-margin 200 --limit u=24" + outputs),
      dir, "phase margin must be between 0 and 180");
  ExpectBadInput(Tune(Base() + " --loop position" + request + " --limit w=3" + outputs), dir,
                 "--limit: unknown limit 'w'");
  ExpectBadInput(Tune(Base() + " --loop speed" + request + " --filter-ratio 5" + outputs), dir,
                 "--filter-ratio applies to the position loop");
  // No voltage limit: the config has no pid.
  ExpectBadInput(Tune(Base() + " --loop position --crossover 2 --phase-margin 60" + outputs), dir,
                 "--limit u=VOLTS is needed");
  // A config given as the report: not a blmd-ident report, named with its line and column.
  ExpectBadInput(
      Tune("--config " + SourcePath("configs/ganesh-square.json") + " --from-report " +
           SourcePath("configs/ganesh-noload.json") + " --loop position" + request + outputs),
      dir, "ganesh-noload.json:1:1: not a blmd-ident report");
  // A report of another model.
  ExpectBadInput(
      Tune("--config " + SourcePath("configs/ganesh-square.json") + " --from-report " +
           SourcePath("docs/real-data/emps.json") + " --loop position" + request + outputs),
      dir, "the report is of model");
  // The report given as the config: which flag takes it.
  ExpectBadInput(Tune("--config " + FitReport() + " --loop position" + request + outputs), dir,
                 "a blmd-ident report, not a config: give it with --from-report");
  // A drive without a linear part: the BLMD with its current loop open (Kf = 0).
  json open_loop = json::parse(Slurp(SourcePath("configs/blmd-d31x.json")));
  open_loop["parameters"]["Kf"] = 0.0;
  open_loop["parameters"]["Ki"] = 0.0;
  ExpectBadInput(Tune("--config " + dir.Write("open.json", open_loop.dump()) +
                      " --loop speed --crossover 2 --phase-margin 60 --sample-rate 1000" + outputs),
                 dir, "open.json: model blmd has no linear part at these values: Kf = 0");
}

// A coarse simulation step: the sampled PID's derivative filter at 20 Hz with dt = 1 ms
// (2π·20·0.001 = 0.126 > 0.1) is warned about, and the step still runs.
TEST_F(TuneCli, WarnsWhenTheSampledControllerIsCoarse) {
  TempDir dir;
  json config = json::parse(Slurp(SourcePath("configs/ganesh-noload.json")));
  config["simulation"]["dt"] = 1e-3;
  const std::string path = dir.Write("coarse.json", config.dump());
  const CommandResult run = Tune("--config " + path +
                                 " --loop position --crossover 2 --phase-margin 60 --limit u=24 "
                                 "--json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json report = json::parse(run.out);
  std::vector<std::string> codes;
  for (const json& w : report["warnings"]) codes.push_back(w["code"]);
  EXPECT_EQ(codes, (std::vector<std::string>{"no_intervals", "sampled_controller"}));
  EXPECT_TRUE(report["step_response"]["nominal"]["valid"].get<bool>());
}

}  // namespace
}  // namespace blmd
