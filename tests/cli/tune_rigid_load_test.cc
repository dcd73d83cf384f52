// blmd-tune on rigid_load (docs/tuning.md §7): the drive's digital speed PI and the position
// P over it, designed on the sampled loop. Every achieved figure is checked against the
// sampled loop's frequency response written out HERE, not with the code under test: the
// zero-order-hold discretisation of Kt/(J s + B) in closed form,
//   G_w(z) = (Kt/B)(1 − a)/(z − a),  a = e^{−B Ts/J}
// (Franklin, Powell & Workman, Digital Control of Dynamic Systems, 1998, ch. 4), and of
// Kt/(s (J s + B)) = K/(s (τ s + 1)), K = Kt/B, τ = J/B,
//   G_θ(z) = K [(Ts − τ(1 − a)) z + (τ(1 − a) − a Ts)] / ((z − 1)(z − a)),
// the PI C(z) = kp + ki Ts z/(z − 1) and the delay z^−d, evaluated at z = e^{jωTs}.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <functional>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <regex>
#include <string>

#include "blmd/io/csv.h"
#include "support/test_support.h"

namespace blmd {
namespace {

using Complex = std::complex<double>;
using nlohmann::json;
using testing::BinPath;
using testing::CommandResult;
using testing::Run;
using testing::Slurp;
using testing::SourcePath;
using testing::TempDir;

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = 180.0 / kPi;

struct Plant {
  double J, B, Kt;
};
// configs/real/hsm150.json's catalog values.
constexpr Plant kHsm150{1.2e-4, 7.03e-5, 1.0};
// EMPS's published IDIM-LS values (configs/real/emps.json's notes): a linear axis, kg and N·s/m.
constexpr Plant kEmps{95.1089, 203.5034, 1.0};

struct Sampled {
  Plant p;
  double ts;
  int delay;
  double kp, ki, kpos = 0.0;

  Complex Z(double w) const { return std::polar(1.0, w * ts); }
  Complex Gw(double w) const {
    const double a = std::exp(-p.B * ts / p.J);
    return (p.Kt / p.B) * (1.0 - a) / (Z(w) - a);
  }
  Complex Gtheta(double w) const {
    const double a = std::exp(-p.B * ts / p.J), k = p.Kt / p.B, tau = p.J / p.B;
    const Complex z = Z(w);
    return k * ((ts - tau * (1.0 - a)) * z + (tau * (1.0 - a) - a * ts)) / ((z - 1.0) * (z - a));
  }
  Complex Pi(double w) const { return kp + ki * ts * Z(w) / (Z(w) - 1.0); }
  Complex Delay(double w) const { return std::pow(Z(w), -delay); }
  Complex SpeedLoop(double w) const { return Pi(w) * Gw(w) * Delay(w); }
  // The cascade: u_d = z^−d C (w_ref − w), w_ref = kpos (r − θ): the open loop at r.
  Complex PositionLoop(double w) const {
    const Complex cd = Pi(w) * Delay(w);
    return kpos * Gtheta(w) * cd / (1.0 + cd * Gw(w));
  }
};

struct Margins {
  double crossover_hz, phase_margin_deg;
};

// |L| falls through 1 once between 1e-3 Hz and just below the Nyquist frequency for these
// loops: bisection on |L| − 1.
template <typename Loop>
Margins HandMargins(const Loop& loop, double nyquist_hz) {
  double lo = 2.0 * kPi * 1e-3, hi = 2.0 * kPi * nyquist_hz * 0.999;
  EXPECT_GT(std::abs(loop(lo)), 1.0);
  EXPECT_LT(std::abs(loop(hi)), 1.0);
  for (int k = 0; k < 200; ++k) {
    const double mid = std::sqrt(lo * hi);
    (std::abs(loop(mid)) > 1.0 ? lo : hi) = mid;
  }
  const double wc = std::sqrt(lo * hi);
  double pm = 180.0 + std::arg(loop(wc)) * kDeg;
  if (pm > 180.0) pm -= 360.0;
  return {wc / (2.0 * kPi), pm};
}

CommandResult Tune(const std::string& arguments) {
  return Run(BinPath("blmd-tune") + " " + arguments);
}

std::string Hsm150() { return SourcePath("configs/real/hsm150.json"); }

// A linear axis with EMPS's values (kg, N·s/m), Coulomb friction and a force offset.
std::string EmpsConfig(const TempDir& dir) {
  json config = json::parse(Slurp(SourcePath("configs/real/emps.json")));
  config["axis"] = "linear";
  config["parameters"]["J"] = kEmps.J;
  config["parameters"]["B"] = kEmps.B;
  config["effects"] = {{"coulomb_friction", {{"Tc", 20.3935}}}, {"load_torque", {{"TL", -3.1648}}}};
  return dir.Write("emps-linear.json", config.dump(2));
}

json TuneJson(const std::string& arguments) {
  const CommandResult run = Tune(arguments + " --json");
  EXPECT_EQ(run.exit_code, 0) << run.err;
  if (run.exit_code != 0) return json::object();
  return json::parse(run.out);
}

// The speed PI's achieved crossover and phase margin on the hand-written sampled loop.
Margins CheckSpeed(const json& report, const Plant& plant, double fc, double pm,
                   const std::string& what) {
  SCOPED_TRACE(what);
  const json& speed = report["sampled_loop"]["speed_loop"];
  const double fs = report["sampled_loop"]["controller_sample_rate_hz"];
  const Sampled loop{plant, 1.0 / fs, report["sampled_loop"]["delay_samples"].get<int>(),
                     speed["kp"].get<double>(), speed["ki"].get<double>()};
  const Margins hand = HandMargins([&](double w) { return loop.SpeedLoop(w); }, 0.5 * fs);
  std::cout << std::setprecision(7) << "[ measured ] " << what << ": request " << fc << " Hz / "
            << pm << " deg; sampled loop by hand " << hand.crossover_hz << " Hz / "
            << hand.phase_margin_deg << " deg (off by " << std::scientific << std::setprecision(2)
            << hand.crossover_hz / fc - 1.0 << " relative, " << hand.phase_margin_deg - pm
            << " deg)" << std::defaultfloat << std::setprecision(7) << "; continuous (report) "
            << speed["continuous"]["crossover_hz"] << " Hz / "
            << speed["continuous"]["phase_margin_deg"] << " deg; kp " << speed["kp"] << " ki "
            << speed["ki"] << "\n";
  EXPECT_NEAR(hand.crossover_hz, fc, 0.05 * fc);
  EXPECT_NEAR(hand.phase_margin_deg, pm, 2.0);
  // The report's own figures agree with the hand computation.
  EXPECT_NEAR(speed["sampled"]["crossover_hz"].get<double>(), hand.crossover_hz,
              1e-3 * hand.crossover_hz);
  EXPECT_NEAR(speed["sampled"]["phase_margin_deg"].get<double>(), hand.phase_margin_deg, 0.05);
  EXPECT_NEAR(speed["per_sample"]["ki_ts"].get<double>(), loop.ki / fs, 1e-12 + 1e-9 * loop.ki);
  return hand;
}

// The HSM150 shaft at 5 Hz and 60 deg, no sample rate given (the model was refused before).
TEST(TuneRigidLoad, SpeedLoopMeetsTheRequestOnTheSampledLoop) {
  const std::string base = "--config " + Hsm150() +
                           " --loop speed --phase-margin 60 --limit u=0.3 --sample-rate 1000 "
                           "--delay 1";
  for (double fc : {5.0, 50.0}) {
    const json report = TuneJson(base + " --crossover " + std::to_string(fc));
    ASSERT_TRUE(report.contains("sampled_loop"));
    CheckSpeed(report, kHsm150, fc, 60.0, "hsm150 speed " + std::to_string(fc) + " Hz");
    EXPECT_EQ(report["request"]["step_unit"], "rad/s");
    EXPECT_EQ(report["controller"]["units"]["kp"], "N·m·s/rad");
  }
  // The delay and hold cost phase: at 50 Hz the continuous loop with the same gains has
  // more margin than the sampled one (about 360·f_c·(d + 1/2)·Ts = 27 deg).
  const json report = TuneJson(base + " --crossover 50");
  const json& speed = report["sampled_loop"]["speed_loop"];
  const double lost = speed["continuous"]["phase_margin_deg"].get<double>() -
                      speed["sampled"]["phase_margin_deg"].get<double>();
  EXPECT_NEAR(lost, 360.0 * 50.0 * 1.5 / 1000.0, 3.0);
}

// A linear axis: the units are the model's (m, m/s, N), the figures checked the same way,
// the step simulated with the friction and offset.
TEST(TuneRigidLoad, LinearAxisSpeedLoopInItsUnits) {
  TempDir dir;
  const json report = TuneJson("--config " + EmpsConfig(dir) +
                               " --loop speed --crossover 20 --phase-margin 60 --limit u=300 "
                               "--sample-rate 1000");
  ASSERT_TRUE(report.contains("sampled_loop"));
  CheckSpeed(report, kEmps, 20.0, 60.0, "emps speed 20 Hz");
  EXPECT_EQ(report["sampled_loop"]["axis"], "linear");
  EXPECT_EQ(report["request"]["step_unit"], "m/s");
  EXPECT_EQ(report["controller"]["units"]["kp"], "N·s/m");
  EXPECT_EQ(report["controller"]["units"]["ki"], "N/m");
  EXPECT_EQ(report["plant"]["effects"], json::array({"coulomb_friction", "load_torque"}));
  const json& step = report["step_response"]["nominal"];
  EXPECT_TRUE(step["valid"].get<bool>());
  for (const char* figure : {"rise_time_s", "overshoot_percent", "settling_time_s", "peak_u"}) {
    ASSERT_TRUE(step[figure].is_number()) << figure;
    EXPECT_TRUE(std::isfinite(step[figure].get<double>())) << figure;
  }
  EXPECT_GT(step["rise_time_s"].get<double>(), 0.0);
  EXPECT_LT(step["rise_time_s"].get<double>(), 0.1);  // about 1.8/ω_c = 14 ms
  EXPECT_LE(step["peak_u"].get<double>(), 300.0);
  EXPECT_NEAR(step["steady_state_error"].get<double>(), 0.0,
              0.02 * report["request"]["step"].get<double>());
}

// Beyond what the delay allows: refused (exit 1) naming the highest feasible crossover, and
// that crossover, asked for, is met.
TEST(TuneRigidLoad, RefusesAnInfeasibleCrossoverNamingTheHighest) {
  const std::string base =
      "--config " + Hsm150() + " --loop speed --phase-margin 60 --limit u=0.3 --sample-rate 1000";
  const CommandResult refused = Tune(base + " --crossover 300");
  EXPECT_EQ(refused.exit_code, 1) << refused.err;
  std::cout << "[ measured ] refusal: " << refused.err;
  const std::regex named(
      "the highest crossover with 60 deg on the sampled loop is ([0-9.e+-]+) Hz");
  std::smatch match;
  ASSERT_TRUE(std::regex_search(refused.err, match, named)) << refused.err;
  EXPECT_EQ(std::count(refused.err.begin(), refused.err.end(), '\n'), 1);
  const double highest = std::stod(match[1]);
  // One sample of delay and the hold (1.5 samples) and the plant's 90 deg leave 30 deg:
  // 360·f·1.5/1000 = 30 at f = 55.6 Hz, a little less with the plant's pole.
  EXPECT_GT(highest, 40.0);
  EXPECT_LT(highest, 60.0);
  const json report = TuneJson(base + " --crossover " + match[1].str());
  ASSERT_TRUE(report.contains("sampled_loop"));
  CheckSpeed(report, kHsm150, highest, 60.0, "hsm150 at the named highest crossover");
  // Just above it: refused.
  EXPECT_EQ(Tune(base + " --crossover " + std::to_string(highest * 1.02)).exit_code, 1);
}

// The cascade: the speed loop at the request, the position P at a fifth of it (the
// default), each loop's margins on the hand-written sampled cascade.
TEST(TuneRigidLoad, PositionCascadeMargins) {
  const json report = TuneJson("--config " + Hsm150() +
                               " --loop position --crossover 40 --phase-margin 60 --limit u=0.3 "
                               "--sample-rate 1000 --delay 1");
  ASSERT_TRUE(report.contains("sampled_loop"));
  const Margins speed = CheckSpeed(report, kHsm150, 40.0, 60.0, "hsm150 cascade, speed loop");
  const json& position = report["sampled_loop"]["position_loop"];
  EXPECT_EQ(report["controller"]["structure"], "P over the speed PI (cascade)");
  EXPECT_EQ(position["crossover_hz_requested"].get<double>(), 8.0);
  const json& s = report["sampled_loop"]["speed_loop"];
  const Sampled loop{
      kHsm150, 1e-3, 1, s["kp"].get<double>(), s["ki"].get<double>(), position["kp"].get<double>()};
  const Margins hand = HandMargins([&](double w) { return loop.PositionLoop(w); }, 500.0);
  std::cout << "[ measured ] cascade: speed " << speed.crossover_hz << " Hz / "
            << speed.phase_margin_deg << " deg; position by hand " << hand.crossover_hz << " Hz / "
            << hand.phase_margin_deg << " deg (report " << position["sampled"]["crossover_hz"]
            << " Hz / " << position["sampled"]["phase_margin_deg"] << " deg); kpos "
            << position["kp"] << "\n";
  EXPECT_NEAR(hand.crossover_hz, 8.0, 0.05 * 8.0);
  EXPECT_NEAR(position["sampled"]["crossover_hz"].get<double>(), hand.crossover_hz,
              1e-3 * hand.crossover_hz);
  EXPECT_NEAR(position["sampled"]["phase_margin_deg"].get<double>(), hand.phase_margin_deg, 0.05);
  EXPECT_GT(hand.phase_margin_deg, 60.0);
  EXPECT_TRUE(report["achieved"]["stable"].get<bool>());
  const json& step = report["step_response"]["nominal"];
  EXPECT_TRUE(step["valid"].get<bool>());
  EXPECT_TRUE(std::isfinite(step["settling_time_s"].get<double>()));
  EXPECT_EQ(report["request"]["step_unit"], "rad");
}

// The box of a config's notes: the worst case over its corners exists, with finite figures.
TEST(TuneRigidLoad, WorstCaseOverTheBox) {
  TempDir dir;
  json config = json::parse(Slurp(Hsm150()));
  config["notes"] = {
      {"identified_by", "blmd-ident test"},
      {"parameters", {{"J", {{"ci95", {1.1e-4, 1.3e-4}}}}, {"B", {{"ci95", {6e-5, 8e-5}}}}}}};
  config["effects"] = {{"coulomb_friction", {{"Tc", 0.002}}}};
  const std::string path = dir.Write("hsm150-box.json", config.dump(2));
  const json report = TuneJson("--config " + path +
                               " --loop speed --crossover 20 --phase-margin 60 --limit u=0.3 "
                               "--sample-rate 1000");
  ASSERT_TRUE(report.contains("robustness"));
  EXPECT_EQ(report["robustness"]["corners"].size(), 4u);
  const json& worst = report["robustness"]["worst_case"];
  std::cout << "[ measured ] box: phase margin " << worst["phase_margin_deg"] << " deg, crossover "
            << worst["crossover_hz_min"] << " to " << worst["crossover_hz_max"] << " Hz\n";
  // The inertia's ±8 % moves the crossover about as much, and the phase margin a little.
  EXPECT_GT(worst["crossover_hz_min"].get<double>(), 20.0 * 0.85);
  EXPECT_LT(worst["crossover_hz_max"].get<double>(), 20.0 * 1.15);
  EXPECT_GT(worst["phase_margin_deg"].get<double>(), 55.0);
  EXPECT_LT(worst["phase_margin_deg"].get<double>(), 60.0 + 1e-6);
  EXPECT_EQ(worst["unstable_corners"], 0);
  const json& step = report["step_response"]["worst_case"];
  for (const char* figure : {"rise_time_s", "overshoot_percent", "settling_time_s", "peak_u"}) {
    EXPECT_TRUE(step[figure].is_number()) << figure;
  }
}

// The command that used to fail with "model rigid_load has no closed-loop experiment
// (experiment.pid, dc_servo only)": now tuned, the controller's rate taken from the
// simulation step (1 kHz) and said in a warning.
TEST(TuneRigidLoad, Hsm150NoLongerRefusedForItsModel) {
  const CommandResult run =
      Tune("--config " + Hsm150() + " --loop speed --crossover 5 --phase-margin 60 --limit u=0.3");
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.err.find("has no closed-loop experiment"), std::string::npos) << run.err;
  EXPECT_NE(run.out.find("sampled at 1000 Hz"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("sample_rate_assumed"), std::string::npos) << run.out;
}

// Tuning from a report whose model is incomplete: the committed HSM150 report carries
// unexplained_structure, so the tuning says the gains rest on an inadequate model
// (report_inadequate, naming why) and --fail-on-warning makes that exit 3; the gains are the
// same either way.
TEST(TuneRigidLoad, InadequateReportIsWarnedAndFailOnWarningRefuses) {
  const std::string arguments = "--config " + Hsm150() + " --from-report " +
                                SourcePath("docs/real-data/hsm150.json") +
                                " --loop speed --crossover 5 --phase-margin 60 --limit u=0.3 "
                                "--sample-rate 1000";
  const json report = TuneJson(arguments);
  std::string message;
  for (const auto& w : report["warnings"]) {
    if (w["code"] == "report_inadequate") message = w["message"];
  }
  EXPECT_NE(message.find("warning unexplained_structure"), std::string::npos) << message;
  // The report ran --discover: the advice is a better record, not --discover again.
  EXPECT_EQ(message.find("--discover"), std::string::npos) << message;
  EXPECT_NE(message.find("identify again from a better record"), std::string::npos) << message;
  const CommandResult strict = Tune(arguments + " --fail-on-warning --json");
  EXPECT_EQ(strict.exit_code, 3) << strict.err;
  EXPECT_EQ(json::parse(strict.out)["sampled_loop"]["speed_loop"]["kp"],
            report["sampled_loop"]["speed_loop"]["kp"]);
}

// The identified ODrive motor (the committed report of a compensated spin-up: Coulomb
// friction and a 7/rev cogging that discovery added, its periods fixed, so not among the
// report's fitted parameters) tuned at 20 Hz and 60 deg, 1 kHz, one sample of delay: the
// report's model is taken whole (a report with a discovered cogging was refused before:
// "effect 'cogging' needs parameter 'periods'"), the sampled loop meets the request by the
// hand computation on the report's J and B, and the simulated step has its figures.
TEST(TuneRigidLoad, OdriveFromItsReportWithDiscoveredCogging) {
  const std::string path = SourcePath("docs/real-data/odrive-comp.json");
  const json identified = json::parse(Slurp(path));
  const Plant plant{identified["parameters"]["J"]["value"].get<double>(),
                    identified["parameters"]["B"]["value"].get<double>(), 1.0};
  const json report =
      TuneJson("--config " + SourcePath("configs/real/odrive.json") + " --from-report " + path +
               " --loop speed --crossover 20 --phase-margin 60 --limit u=0.13 "
               "--sample-rate 1000 --delay 1");
  ASSERT_TRUE(report.contains("sampled_loop")) << report.dump();
  CheckSpeed(report, plant, 20.0, 60.0, "odrive speed 20 Hz");
  const json& step = report["step_response"]["nominal"];
  EXPECT_TRUE(step["valid"].get<bool>()) << step.dump();
  for (const char* figure : {"rise_time_s", "overshoot_percent", "settling_time_s", "peak_u"}) {
    ASSERT_TRUE(step[figure].is_number()) << figure;
    EXPECT_TRUE(std::isfinite(step[figure].get<double>())) << figure;
  }
}

// The written closed-loop config runs in blmd-sim with the same step figures.
TEST(TuneRigidLoad, ClosedLoopConfigRunsInBlmdSim) {
  TempDir dir;
  const CommandResult run =
      Tune("--config " + Hsm150() +
           " --loop position --crossover 40 --phase-margin 60 --limit u=0.3 --sample-rate 1000 "
           "--report " +
           dir.File("tune.json") + " --write-config " + dir.File("closed.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json closed = json::parse(Slurp(dir.File("closed.json")));
  EXPECT_EQ(closed["experiment"]["pid"]["loop"], "position");
  EXPECT_EQ(closed["experiment"]["pid"]["sample_rate"], 1000.0);
  EXPECT_EQ(closed["experiment"]["pid"]["delay"], 1);
  const CommandResult sim =
      testing::Run(BinPath("blmd-sim") + " --config " + dir.File("closed.json") + " --out " +
                   dir.File("step.csv"));
  EXPECT_EQ(sim.exit_code, 0) << sim.err;
  EXPECT_NE(sim.out.find("closed loop: rise time"), std::string::npos) << sim.out;
}

// The simulated sampled loop against its difference equations written out here: the
// exact ZOH plant w_{k+1} = a w_k + (Kt/B)(1 − a) u_{k−d}, the PI's backward Euler sum
// I_k = I_{k−1} + ki Ts e_k, u_k = kp e_k + I_k. Without effects and below the limit the
// simulated w at the samples must be these to rounding: the delay, the hold and the
// integral's form are the designed ones.
TEST(TuneRigidLoad, SimulatedLoopIsTheDesignedDifferenceEquation) {
  TempDir dir;
  const CommandResult run =
      Tune("--config " + Hsm150() +
           " --loop speed --crossover 30 --phase-margin 50 --limit u=0.3 --sample-rate 1000 "
           "--delay 2 --report " +
           dir.File("tune.json") + " --write-config " + dir.File("closed.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json report = json::parse(Slurp(dir.File("tune.json")));
  const json& speed = report["sampled_loop"]["speed_loop"];
  CheckSpeed(report, kHsm150, 30.0, 50.0, "hsm150 speed, 2 samples of delay");
  const CommandResult sim = testing::Run(BinPath("blmd-sim") + " --config " +
                                         dir.File("closed.json") + " --out " + dir.File("s.csv"));
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const Trace trace = ReadTraceCsv(dir.File("s.csv"));
  const auto& t = trace.Column("t");
  const auto& w = trace.Column("w");
  const double ts = 1e-3, r = report["request"]["step"];
  const double kp = speed["kp"], ki = speed["ki"];
  const double a = std::exp(-kHsm150.B * ts / kHsm150.J), b = (kHsm150.Kt / kHsm150.B) * (1.0 - a);
  std::vector<double> u_history(3, 0.0);  // u_{k}, u_{k−1}, u_{k−2}
  double wk = 0.0, integral = 0.0, worst = 0.0, peak = 0.0;
  std::size_t row = 0;
  for (int k = 0; k < 2000 && row < t.size(); ++k) {
    while (row < t.size() && t[row] < k * ts - 1e-9) ++row;
    if (row < t.size() && std::abs(t[row] - k * ts) < 1e-9) {
      worst = std::max(worst, std::abs(w[row] - wk));
      peak = std::max(peak, std::abs(wk));
    }
    const double e = r - wk;
    integral += ki * ts * e;
    u_history = {kp * e + integral, u_history[0], u_history[1]};
    wk = a * wk + b * u_history[2];
  }
  std::cout << "[ measured ] sampled loop: simulated w against the difference equation, worst "
            << worst << " rad/s of a " << peak << " rad/s peak\n";
  EXPECT_GT(peak, r);  // it overshoots (50 deg of margin)
  EXPECT_LT(worst, 1e-9 * peak);
}

// The current loop as a first-order lag of bandwidth ω_b: the plant
// K p1 p2/((s + p1)(s + p2)), p1 = B/J, p2 = ω_b, K = Kt/B, discretised with a zero-order hold
// by partial fractions here: G(z) = K + r1 (z − 1)/(z − a1) + r2 (z − 1)/(z − a2) with
// a_i = e^{−p_i Ts}, r1 = −K p2/(p2 − p1), r2 = K p1/(p2 − p1).
TEST(TuneRigidLoad, CurrentLoopLagIsInTheSampledDesign) {
  const double fb = 200.0;
  const json report = TuneJson("--config " + Hsm150() +
                               " --loop speed --crossover 20 --phase-margin 60 --limit u=0.3 "
                               "--sample-rate 1000 --current-bandwidth " +
                               std::to_string(fb));
  ASSERT_TRUE(report.contains("sampled_loop"));
  EXPECT_EQ(report["sampled_loop"]["current_bandwidth_hz"], fb);
  const json& speed = report["sampled_loop"]["speed_loop"];
  const double ts = 1e-3, kp = speed["kp"], ki = speed["ki"];
  const double p1 = kHsm150.B / kHsm150.J, p2 = 2.0 * kPi * fb, k = kHsm150.Kt / kHsm150.B;
  const double a1 = std::exp(-p1 * ts), a2 = std::exp(-p2 * ts);
  const double r1 = -k * p2 / (p2 - p1), r2 = k * p1 / (p2 - p1);
  auto loop = [&](double w) {
    const Complex z = std::polar(1.0, w * ts);
    const Complex g = k + r1 * (z - 1.0) / (z - a1) + r2 * (z - 1.0) / (z - a2);
    return (kp + ki * ts * z / (z - 1.0)) * g / z;  // one sample of delay
  };
  const Margins hand = HandMargins(loop, 500.0);
  std::cout << std::setprecision(7) << "[ measured ] current loop " << fb
            << " Hz: sampled loop by hand " << hand.crossover_hz << " Hz / "
            << hand.phase_margin_deg << " deg; kp " << kp << " ki " << ki << "\n";
  EXPECT_NEAR(hand.crossover_hz, 20.0, 0.05 * 20.0);
  EXPECT_NEAR(hand.phase_margin_deg, 60.0, 2.0);
  // Without the lag the same request gives other gains: the lag's phase was designed for.
  const json ideal = TuneJson("--config " + Hsm150() +
                              " --loop speed --crossover 20 --phase-margin 60 --limit u=0.3 "
                              "--sample-rate 1000");
  EXPECT_GT(std::abs(ideal["sampled_loop"]["speed_loop"]["ki"].get<double>() / ki - 1.0), 0.05);
}

// An asymmetric drive: the lower limit reaches the report and the written config, and the
// default step keeps within the smaller side.
TEST(TuneRigidLoad, AsymmetricLimit) {
  TempDir dir;
  const CommandResult run =
      Tune("--config " + Hsm150() +
           " --loop speed --crossover 20 --phase-margin 60 --limit u=-0.1:0.3 --sample-rate 1000 "
           "--report " +
           dir.File("tune.json") + " --write-config " + dir.File("closed.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json report = json::parse(Slurp(dir.File("tune.json")));
  EXPECT_EQ(report["sampled_loop"]["limits"]["u_min"], -0.1);
  EXPECT_EQ(report["sampled_loop"]["limits"]["u_max"], 0.3);
  const json closed = json::parse(Slurp(dir.File("closed.json")));
  EXPECT_EQ(closed["experiment"]["pid"]["u_min"], -0.1);
  const double kp = report["sampled_loop"]["speed_loop"]["kp"];
  EXPECT_LE(report["request"]["step"].get<double>() * kp, 0.5 * 0.1 * (1.0 + 1e-12));
  EXPECT_LE(report["step_response"]["nominal"]["peak_u"].get<double>(), 0.3);
}

// Bad input, exit 2 and nothing written: the sampled flags on dc_servo, the PID's ratios on
// rigid_load, a bad asymmetric limit, a linear axis on dc_servo.
TEST(TuneRigidLoad, BadInput) {
  TempDir dir;
  const std::string rigid =
      "--config " + Hsm150() + " --crossover 20 --phase-margin 60 --sample-rate 1000";
  struct Case {
    std::string arguments, message;
  };
  const std::vector<Case> cases = {
      {"--config " + SourcePath("configs/ganesh-noload.json") +
           " --loop speed --crossover 3 --phase-margin 60 --limit u=24 --sample-rate 1000",
       "--sample-rate applies to models rigid_load and blmd"},
      {rigid + " --loop position --limit u=0.3 --filter-ratio 8",
       "--filter-ratio applies to dc_servo's position PID"},
      {rigid + " --loop speed --limit u=0.3:-0.1", "LOW must be < 0 and HIGH > 0"},
      {rigid + " --loop speed --limit u=0.3 --position-crossover 2",
       "--position-crossover applies to the position loop"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.arguments);
    const CommandResult run = Tune(c.arguments + " --report " + dir.File("r.json"));
    EXPECT_EQ(run.exit_code, 2) << run.err;
    EXPECT_NE(run.err.find(c.message), std::string::npos) << run.err;
    EXPECT_FALSE(testing::FileExists(dir.File("r.json")));
  }
  json config = json::parse(Slurp(SourcePath("configs/ganesh-noload.json")));
  config["axis"] = "linear";
  const CommandResult linear = Tune("--config " + dir.Write("linear-dc.json", config.dump()) +
                                    " --loop speed --crossover 3 --phase-margin 60 --limit u=24");
  EXPECT_EQ(linear.exit_code, 2);
  EXPECT_NE(linear.err.find("a linear axis applies to model rigid_load"), std::string::npos)
      << linear.err;
}

// The gain crossovers of a sampled PI (kp, ki; 1 kHz, one sample of delay) on the two-mass
// shaft of docs/tuning.md §7.6 (J 2e-3, B 0.04, Kt 0.5, r 1.5, fa 40 Hz, zeta 0.02), computed
// here: the exact zero-order hold of the four-state shaft by a Taylor series, the PI and the
// delay on a fine grid of the unit circle, times `notch`(f) (1: none). Each crossing: its
// frequency and phase margin wrapped to (-180, 180].
std::vector<std::pair<double, double>> TwoMassCrossings(
    double kp, double ki, const std::function<Complex(double f)>& notch) {
  const double J = 2e-3, B = 0.04, Kt = 0.5, r = 1.5, wa = 2 * kPi * 40.0, ts = 1e-3;
  const double Jm = J / (1 + r), Jl = J - Jm, K = Jl * wa * wa, c = 2 * 0.02 * Jl * wa;
  Eigen::Matrix4d aug = Eigen::Matrix4d::Zero();
  aug.topLeftCorner<3, 3>() << -(B + c) / Jm, c / Jm, -K / Jm, c / Jl, -c / Jl, K / Jl, 1.0, -1.0,
      0.0;
  aug(0, 3) = Kt / Jm;
  aug *= ts;
  Eigen::Matrix4d expm = Eigen::Matrix4d::Identity(), term = Eigen::Matrix4d::Identity();
  for (int k = 1; k < 30; ++k) {
    term = term * aug / k;
    expm += term;
  }
  const Eigen::Matrix3d phi = expm.topLeftCorner<3, 3>();
  const Eigen::Vector3d gamma = expm.topRightCorner<3, 1>();
  auto loop = [&](double f) {
    const Complex z = std::polar(1.0, 2 * kPi * f * ts);
    const Eigen::Vector3cd x = (z * Eigen::Matrix3cd::Identity() - phi.cast<Complex>())
                                   .partialPivLu()
                                   .solve(gamma.cast<Complex>());
    return (kp + ki * ts * z / (z - 1.0)) * x(0) / z * notch(f);
  };
  std::vector<std::pair<double, double>> crossings;  // f, phase margin wrapped
  double previous = std::abs(loop(0.01));
  for (int k = 1; k <= 40000; ++k) {
    const double f = 0.01 * std::pow(499.0 / 0.01, k / 40000.0);
    const Complex l = loop(f);
    if ((std::abs(l) > 1.0) != (previous > 1.0)) {
      double pm = 180.0 + std::arg(l) * kDeg;
      if (pm > 180.0) pm -= 360.0;
      crossings.emplace_back(f, pm);
    }
    previous = std::abs(l);
  }
  return crossings;
}

const char* const kTwoMassShaft = R"({
    "name": "two-mass", "model": "rigid_load",
    "parameters": { "J": 2e-3, "B": 0.04, "Kt": 0.5 },
    "effects": { "two_mass": { "inertia_ratio": 1.5, "anti_resonance_hz": 40,
                               "shaft_damping_ratio": 0.02, "load_damping_share": 0.0 } },
    "experiment": { "input": { "type": "step", "amplitude": 1 }, "duration": 1 } })";

// A two-mass shaft (two_mass): the loop is designed and checked on it. Asked for more than the
// resonance allows with no notch (--notch off), refused (exit 1) in one line naming the
// resonance and the highest crossover that keeps the phase margin at every crossing; asked for
// that crossover, tuned, and its gains give on the two-mass plant (TwoMassCrossings) the
// crossover and margin asked for, every other crossing (the resonance's peak) at least the
// margin from -180°.
TEST(TuneRigidLoad, TwoMassShaftLimitsTheCrossoverByItsResonance) {
  TempDir dir;
  const std::string config = dir.Write("two-mass.json", kTwoMassShaft);
  const std::string base = "--config " + config +
                           " --loop speed --phase-margin 60 --limit u=5 --sample-rate 1000"
                           " --notch off";
  const CommandResult refused = Tune(base + " --crossover 20");
  EXPECT_EQ(refused.exit_code, 1) << refused.err;
  EXPECT_EQ(std::count(refused.err.begin(), refused.err.end(), '\n'), 1) << refused.err;
  EXPECT_NE(refused.err.find("on the two-mass shaft (resonance 63.2 Hz)"), std::string::npos)
      << refused.err;
  EXPECT_NE(refused.err.find("(or allow a notch on the torque command: --notch auto)"),
            std::string::npos)
      << refused.err;
  const std::regex named("at every crossing on the two-mass shaft is ([0-9.e+-]+) Hz");
  std::smatch match;
  ASSERT_TRUE(std::regex_search(refused.err, match, named)) << refused.err;
  const double highest = std::stod(match[1].str());
  EXPECT_GT(highest, 1.0);
  EXPECT_LT(highest, 20.0);
  const CommandResult tuned = Tune(base + " --crossover " + match[1].str() + " --json");
  ASSERT_EQ(tuned.exit_code, 0) << tuned.err;
  const auto report = nlohmann::json::parse(tuned.out);
  const auto& speed = report["sampled_loop"]["speed_loop"];
  EXPECT_TRUE(report["sampled_loop"]["notch"].is_null());
  const auto crossings = TwoMassCrossings(speed["kp"].get<double>(), speed["ki"].get<double>(),
                                          [](double) { return Complex(1.0); });
  ASSERT_FALSE(crossings.empty());
  EXPECT_NEAR(crossings[0].first, highest, 2e-3 * highest);
  EXPECT_NEAR(crossings[0].second, 60.0, 0.2);
  for (std::size_t k = 1; k < crossings.size(); ++k)
    EXPECT_GE(std::abs(crossings[k].second), 59.9) << crossings[k].first << " Hz";
  std::cout << "[ measured ] highest crossover " << highest
            << " Hz; crossings on the two-mass plant:";
  for (const auto& [f, pm] : crossings) std::cout << " " << f << " Hz " << pm << " deg";
  std::cout << "\n";
}

// The same request (20 Hz, 60°) with the default --notch auto: tuned with a notch at the
// resonance on the torque command, named in the report with the crossover the resonance
// allows without it (15.7 Hz). Its gains and notch, applied to the two-mass plant computed here
// (the notch's digital response from its prototype N(s) at the bilinear transform's warped
// frequency, docs/tuning.md §7.7), cross at 20 Hz with 60° and keep every other crossing at least
// 59.9° from -180°; the written closed-loop config carries the notch and blmd-sim runs it.
TEST(TuneRigidLoad, NotchAtTheResonanceLetsTheLoopCrossAboveItsLimit) {
  TempDir dir;
  const std::string config = dir.Write("two-mass.json", kTwoMassShaft);
  const std::string written = dir.File("closed.json");
  const CommandResult tuned = Tune("--config " + config +
                                   " --loop speed --phase-margin 60 --limit u=5 --sample-rate "
                                   "1000 --crossover 20 --json --write-config " +
                                   written);
  ASSERT_EQ(tuned.exit_code, 0) << tuned.err;
  const auto report = nlohmann::json::parse(tuned.out);
  const auto& sampled = report["sampled_loop"];
  ASSERT_TRUE(sampled["notch"].is_object()) << sampled.dump();
  EXPECT_EQ(sampled["notch"]["source"], "designed");
  EXPECT_NEAR(sampled["resonance_hz"].get<double>(), 40.0 * std::sqrt(2.5), 1e-9);
  EXPECT_NEAR(sampled["resonance_limited_crossover_hz"].get<double>(), 15.7, 0.05);
  const double fn = sampled["notch"]["frequency_hz"], width = sampled["notch"]["width_hz"];
  const double depth = sampled["notch"]["depth"];
  EXPECT_NEAR(fn, 40.0 * std::sqrt(2.5), 1e-9);
  const double ts = 1e-3, wn = 2 * kPi * fn, zp = width / (2 * fn), zz = depth * zp;
  auto notch = [&](double f) {
    const Complex s(0.0, wn * std::tan(kPi * f * ts) / std::tan(0.5 * wn * ts));
    return (s * s + 2 * zz * wn * s + wn * wn) / (s * s + 2 * zp * wn * s + wn * wn);
  };
  const auto crossings = TwoMassCrossings(sampled["speed_loop"]["kp"].get<double>(),
                                          sampled["speed_loop"]["ki"].get<double>(), notch);
  ASSERT_FALSE(crossings.empty());
  EXPECT_NEAR(crossings[0].first, 20.0, 2e-3 * 20.0);
  EXPECT_NEAR(crossings[0].second, 60.0, 0.2);
  for (std::size_t k = 1; k < crossings.size(); ++k)
    EXPECT_GE(std::abs(crossings[k].second), 59.9) << crossings[k].first << " Hz";
  const json closed = json::parse(Slurp(written));
  EXPECT_EQ(closed["experiment"]["pid"]["notch"]["frequency"].get<double>(), fn);
  EXPECT_EQ(closed["experiment"]["pid"]["notch"]["depth"].get<double>(), depth);
  EXPECT_EQ(
      testing::Run(BinPath("blmd-sim") + " --config " + written + " --out " + dir.File("s.csv"))
          .exit_code,
      0);
  std::cout << "[ measured ] notch " << fn << " Hz, width " << width << " Hz, depth " << depth
            << "; crossings:";
  for (const auto& [f, pm] : crossings) std::cout << " " << f << " Hz " << pm << " deg";
  std::cout << "\n";
}

// A rigid fit of a two-mass record (blmd-sim with two_mass, a PRBS, 0.5 % noise; blmd-ident
// with J and B only, no --discover): its adequacy check flags the input's past near the
// resonance (fa sqrt(1 + r) = 63.2 Hz), and blmd-tune from that report says where, in its
// report_inadequate warning, with the advice to run --discover.
TEST(TuneRigidLoad, RigidReportOfATwoMassRecordNamesWhereItsResidualFollowsTheInput) {
  TempDir dir;
  // A two-mass shaft (resonance 63.2 Hz) under a PRBS torque (configs/two-mass-prbs.json).
  const std::string truth = testing::SourcePath("configs/two-mass-prbs.json");
  const std::string rigid = dir.Write("rigid.json", R"({
    "name": "rigid", "model": "rigid_load",
    "parameters": { "J": 1e-3, "B": 0.02, "Kt": 0.5 },
    "simulation": { "dt": 1e-4 },
    "experiment": { "input": { "type": "step", "amplitude": 1 }, "duration": 1 },
    "identification": { "free": ["J", "B"], "observe": ["w"] } })");
  const std::string trace = dir.File("trace.csv"), report = dir.File("report.json");
  ASSERT_EQ(testing::Run(BinPath("blmd-sim") + " --config " + truth + " --out " + trace +
                         " --noise w=0.5% --seed 7")
                .exit_code,
            0);
  const CommandResult fitted = testing::Run(BinPath("blmd-ident") + " --config " + rigid +
                                            " --trace " + trace + " --quiet --report " + report);
  ASSERT_EQ(fitted.exit_code, 0) << fitted.err;
  const json tuned = TuneJson("--config " + rigid + " --from-report " + report +
                              " --loop speed --crossover 20 --phase-margin 60 --limit u=5"
                              " --sample-rate 2000");
  std::string message;
  for (const auto& w : tuned["warnings"]) {
    if (w["code"] == "report_inadequate") message = w["message"];
  }
  const std::regex named("its residual follows the input's past, most near ([0-9.]+) Hz");
  std::smatch match;
  ASSERT_TRUE(std::regex_search(message, match, named)) << message;
  EXPECT_NEAR(std::stod(match[1].str()), 63.25, 0.15 * 63.25) << message;
  EXPECT_NE(message.find("or identify with --discover"), std::string::npos) << message;
}

}  // namespace
}  // namespace blmd
