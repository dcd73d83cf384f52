// blmd-tune on the BLMD (docs/tuning.md §7.5): the drive's digital speed PI (and the position
// P over it) around the identified Guinee & Lyden drive, its own current loops and PWM. The
// design's figures are checked against a frequency response written out HERE, not with the
// code under test:
//  - the plant J dw/dt = K Td − B w with K = 1.5 Ke Kc/Kf (docs/model-blmd.md, "Linear part");
//  - the drive's current loop as a first-order lag at its −3 dB frequency, found here by
//    bisection on |T(jω)|, T = L/(1 + L), L = Kf (Kp + Ki/s) (Ud/(2 Vtri))/(Ls s + Rs);
//  - K/((J s + B)(s/ω_b + 1)) discretised with a zero-order hold by partial fractions
//    (Franklin, Powell & Workman, Digital Control of Dynamic Systems, 1998, ch. 4), the PI
//    C(z) = kp + ki Ts z/(z − 1) and one sample of delay, at z = e^{jωTs}.
// The check of the step runs the real nonlinear model (PWM, dead time, current loops).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <iostream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>

#include "blmd/io/csv.h"
#include "support/test_support.h"

namespace blmd {
namespace {

using Complex = std::complex<double>;
using nlohmann::json;
using testing::BinPath;
using testing::CommandResult;
using testing::Slurp;
using testing::SourcePath;
using testing::TempDir;

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = 180.0 / kPi;

std::string D31x() { return SourcePath("configs/blmd-d31x.json"); }

// configs/blmd-d31x.json's drive.
struct Drive {
  double Ud = 310.0, Rs = 1.0, Ls = 0.004, Ke = 0.3, Kc = 1.1, Kf = 0.5, Kp = 8.0, Ki = 16000.0,
         Vtri = 10.0, J = 0.00119, B = 0.0005;
  double TorquePerVolt() const { return 1.5 * Ke * Kc / Kf; }
  // The closed current loop's −3 dB frequency, rad/s.
  double CurrentBandwidth() const {
    auto gain = [&](double w) {
      const Complex s(0.0, w);
      const Complex loop = Kf * (Kp + Ki / s) * (Ud / (2.0 * Vtri)) / (Ls * s + Rs);
      return std::abs(loop / (1.0 + loop));
    };
    double lo = 1.0, hi = 1e7;  // |T| ≈ 1 at 1 rad/s, ≪ 1 at 1e7 rad/s
    for (int k = 0; k < 200; ++k) {
      const double mid = std::sqrt(lo * hi);
      (gain(mid) > 1.0 / std::sqrt(2.0) ? lo : hi) = mid;
    }
    return std::sqrt(lo * hi);
  }
};

// The sampled speed loop L(e^{jωTs}) with the current lag and one sample of delay.
Complex SpeedLoop(const Drive& d, double ts, double kp, double ki, double w) {
  const double p1 = d.B / d.J, p2 = d.CurrentBandwidth(), k = d.TorquePerVolt() / d.B;
  const double a1 = std::exp(-p1 * ts), a2 = std::exp(-p2 * ts);
  const double r1 = -k * p2 / (p2 - p1), r2 = k * p1 / (p2 - p1);
  const Complex z = std::polar(1.0, w * ts);
  const Complex g = k + r1 * (z - 1.0) / (z - a1) + r2 * (z - 1.0) / (z - a2);
  return (kp + ki * ts * z / (z - 1.0)) * g / z;
}

struct Margins {
  double crossover_hz, phase_margin_deg;
};

// |L| falls through 1 once between 1e-2 Hz and just below the Nyquist frequency: bisection.
Margins HandMargins(const Drive& d, double ts, double kp, double ki) {
  auto loop = [&](double w) { return SpeedLoop(d, ts, kp, ki, w); };
  double lo = 2.0 * kPi * 1e-2, hi = kPi / ts * 0.999;
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
  return testing::Run(BinPath("blmd-tune") + " " + arguments);
}

json TuneJson(const std::string& arguments) {
  const CommandResult run = Tune(arguments + " --json");
  EXPECT_EQ(run.exit_code, 0) << run.err;
  if (run.exit_code != 0) return json::object();
  return json::parse(run.out);
}

// The d31x drive with 95 % intervals on J and B in its notes, as blmd-ident --write-config
// records them (docs/export.md §1): the box blmd-tune checks.
std::string D31xWithIntervals(const TempDir& dir) {
  json config = json::parse(Slurp(D31x()));
  config["notes"]["identified_by"] = "blmd-ident (a test's stand-in for an identification)";
  config["notes"]["parameters"] = {{"J", {{"ci95", {0.00113, 0.00125}}}},
                                   {"B", {{"ci95", {0.0004, 0.0006}}}}};
  return dir.Write("d31x-intervals.json", config.dump(2));
}

// The speed loop at 1 kHz with one sample of delay: the request met on the sampled loop
// computed here, the current loop's bandwidth the one computed here, the step simulated on
// the nonlinear drive settling on the reference within the drive's ±10 V.
TEST(TuneBlmd, SpeedLoopMeetsTheRequestOnTheSampledLoop) {
  const Drive drive;
  for (const auto& [fc, pm] : {std::pair{50.0, 60.0}, std::pair{20.0, 45.0}}) {
    SCOPED_TRACE(std::to_string(fc) + " Hz");
    const json report =
        TuneJson("--config " + D31x() + " --loop speed --crossover " + std::to_string(fc) +
                 " --phase-margin " + std::to_string(pm) + " --sample-rate 1000");
    ASSERT_TRUE(report.contains("sampled_loop"));
    const json& sampled = report["sampled_loop"];
    EXPECT_NEAR(sampled["current_bandwidth_hz"].get<double>(),
                drive.CurrentBandwidth() / (2.0 * kPi), 1e-6 * drive.CurrentBandwidth());
    EXPECT_EQ(sampled["limits"]["u_max"], 10.0);  // the drive's own ±10 V
    EXPECT_NEAR(sampled["speed_limit_rad_s"].get<double>(), 310.0 / (2.0 * 0.3), 1e-9);
    const json& speed = sampled["speed_loop"];
    const Margins hand =
        HandMargins(drive, 1e-3, speed["kp"].get<double>(), speed["ki"].get<double>());
    std::cout << "[ measured ] blmd " << fc << " Hz / " << pm << " deg: sampled loop by hand "
              << hand.crossover_hz << " Hz / " << hand.phase_margin_deg << " deg\n";
    EXPECT_NEAR(hand.crossover_hz, fc, 0.05 * fc);
    EXPECT_NEAR(hand.phase_margin_deg, pm, 2.0);
    const json& step = report["step_response"]["nominal"];
    ASSERT_TRUE(step["valid"].get<bool>()) << step.dump();
    const double reference = report["request"]["step"];
    EXPECT_NEAR(step["final_value"].get<double>(), reference, 0.01 * reference);
    EXPECT_FALSE(step["saturated"].get<bool>());
    EXPECT_LT(step["peak_u"].get<double>(), 10.0);
    EXPECT_GT(step["peak_i"].get<double>(), 0.0);  // the phase current of the simulated drive
    EXPECT_LT(step["peak_w"].get<double>(), 0.2 * 310.0 / (2.0 * 0.3) * 1.3);
  }
}

// A crossover the delay does not allow: refused (exit 1) naming the highest feasible one.
TEST(TuneBlmd, RefusesAnInfeasibleCrossoverNamingTheHighest) {
  const CommandResult run = Tune("--config " + D31x() +
                                 " --loop speed --crossover 80 --phase-margin 60 "
                                 "--sample-rate 1000");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("the highest crossover with 60 deg on the sampled loop is 53.6"),
            std::string::npos)
      << run.err;
  const json feasible = TuneJson("--config " + D31x() +
                                 " --loop speed --crossover 53 --phase-margin 60 "
                                 "--sample-rate 1000");
  EXPECT_GE(feasible["sampled_loop"]["speed_loop"]["highest_feasible_crossover_hz"].get<double>(),
            53.0);
}

// The box of the config's 95 % intervals: every corner's sampled loop and simulated step,
// the worst case named; the corners' margins agree with the hand computation at each corner.
TEST(TuneBlmd, WorstCaseOverTheBox) {
  TempDir dir;
  const json report = TuneJson("--config " + D31xWithIntervals(dir) +
                               " --loop speed --crossover 40 --phase-margin 60 --sample-rate 1000");
  const json& robustness = report["robustness"];
  EXPECT_EQ(robustness["box_source"], "config notes");
  ASSERT_EQ(robustness["corners"].size(), 4u);
  const json& speed = report["sampled_loop"]["speed_loop"];
  double lowest_pm = 1e9;
  for (const json& corner : robustness["corners"]) {
    Drive d;
    d.J = corner["parameters"]["J"];
    d.B = corner["parameters"]["B"];
    const Margins hand = HandMargins(d, 1e-3, speed["kp"].get<double>(), speed["ki"].get<double>());
    EXPECT_NEAR(corner["phase_margin_deg"].get<double>(), hand.phase_margin_deg, 0.05);
    EXPECT_NEAR(corner["crossover_hz"].get<double>(), hand.crossover_hz, 1e-3 * hand.crossover_hz);
    EXPECT_TRUE(corner["step"]["valid"].get<bool>());
    lowest_pm = std::min(lowest_pm, hand.phase_margin_deg);
  }
  EXPECT_NEAR(robustness["worst_case"]["phase_margin_deg"].get<double>(), lowest_pm, 0.05);
}

// The written closed-loop config runs in blmd-sim on the real drive, and its command is the
// designed controller: u_k = C(e_{k-1}) for a delay of one sample, with the PI's backward
// Euler sum I_k = I_{k-1} + ki Ts e_k, read off the simulated w at the controller's samples.
TEST(TuneBlmd, ClosedLoopConfigRunsTheDesignedController) {
  TempDir dir;
  const CommandResult run =
      Tune("--config " + D31x() +
           " --loop speed --crossover 30 --phase-margin 55 "
           "--sample-rate 1000 --report " +
           dir.File("tune.json") + " --write-config " + dir.File("closed.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  json closed = json::parse(Slurp(dir.File("closed.json")));
  EXPECT_FALSE(closed["experiment"]["pid"].contains("current_bandwidth"));
  closed["experiment"]["sample_rate"] = 1000.0;  // one row per controller sample
  const std::string config = dir.Write("closed-1k.json", closed.dump(2));
  const CommandResult sim =
      testing::Run(BinPath("blmd-sim") + " --config " + config + " --out " + dir.File("s.csv"));
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const Trace trace = ReadTraceCsv(dir.File("s.csv"));
  ASSERT_TRUE(trace.Has("r"));
  const auto& u = trace.Column("u");
  const auto& w = trace.Column("w");
  const auto& r = trace.Column("r");
  const json report = json::parse(Slurp(dir.File("tune.json")));
  const double kp = report["sampled_loop"]["speed_loop"]["kp"];
  const double ki = report["sampled_loop"]["speed_loop"]["ki"];
  double integral = 0.0, command = 0.0, worst = 0.0;
  for (std::size_t k = 0; k < u.size(); ++k) {
    worst = std::max(worst, std::abs(u[k] - command));  // computed at k - 1, applied at k
    const double e = r[k] - w[k];
    integral += ki * 1e-3 * e;
    command = kp * e + integral;
  }
  std::cout << "[ measured ] blmd closed loop: u against the PI written here, worst " << worst
            << " V over " << u.size() << " samples\n";
  EXPECT_LT(worst, 1e-9);
  EXPECT_NEAR(w.back(), r.back(), 0.01 * r.back());
}

TEST(TuneBlmd, BadInput) {
  const CommandResult bandwidth = Tune("--config " + D31x() +
                                       " --loop speed --crossover 20 --phase-margin 60 "
                                       "--sample-rate 1000 --current-bandwidth 500");
  EXPECT_EQ(bandwidth.exit_code, 2);
  EXPECT_NE(bandwidth.err.find("carries its own current loops"), std::string::npos)
      << bandwidth.err;
  TempDir dir;
  json config = json::parse(Slurp(D31x()));
  config["experiment"]["pid"] = {{"loop", "speed"}, {"Kp", 0.3}, {"current_bandwidth", 100}};
  const CommandResult key =
      testing::Run(BinPath("blmd-sim") + " --config " + dir.Write("bad.json", config.dump(2)) +
                   " --out " + dir.File("x.csv"));
  EXPECT_EQ(key.exit_code, 2);
  EXPECT_NE(key.err.find("current_bandwidth"), std::string::npos) << key.err;
  EXPECT_FALSE(testing::FileExists(dir.File("x.csv")));
  // A speed step beyond what the DC bus holds (Ud/(2 Ke) = 517 rad/s) is refused.
  const CommandResult fast = Tune("--config " + D31x() +
                                  " --loop speed --crossover 5 --phase-margin 60 "
                                  "--sample-rate 1000 --step 560 --limit u=1000");
  EXPECT_EQ(fast.exit_code, 1);
  EXPECT_NE(fast.err.find("at which the DC bus leaves no voltage"), std::string::npos) << fast.err;
}

}  // namespace
}  // namespace blmd
