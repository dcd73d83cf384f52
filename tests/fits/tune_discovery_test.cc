// blmd-tune on a model whose Coulomb friction blmd-ident discovered (docs/tuning.md §3.2, §7):
// the servo of testdata/dc-hidden-coulomb.csv (Ganesh's motor with a friction its config does
// not declare) identified with --discover, then tuned from the report. The friction enters the
// simulated step (the shaft sticks short of the reference), its 95 % interval is an axis of the
// box, and the gains still meet the request on the true linear plant. Slow: the discovery fit
// takes about 30 s (BLMD_SLOW_TESTS).
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <iostream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

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

// The true plant's loop (Ganesh et al. 2012, no load; eq. 12) with the report's controller.
Complex TrueLoop(const json& c, double w) {
  const double R = 12.6, L = 0.283, Kt = 0.04, Kb = 0.04, J = 2.26e-5, B = 2.261e-5;
  const Complex s(0.0, w);
  const Complex g = Kt / ((R + s * L) * (J * s + B) + Kb * Kt) / s;
  const double fd = c["derivative_filter_hz"];
  const Complex pid = c["kp"].get<double>() + c["ki"].get<double>() / s +
                      c["kd"].get<double>() * s / (1.0 + s / (2.0 * kPi * fd));
  return pid * g;
}

TEST(TuneDiscovery, FrictionEntersTheStepAndTheBox) {
  TempDir dir;
  const CommandResult fit =
      testing::Run(BinPath("blmd-ident") + " --config " + SourcePath("configs/ganesh-square.json") +
                   " --trace " + SourcePath("testdata/dc-hidden-coulomb.csv") +
                   " --discover --report " + dir.File("fit.json") + " --quiet");
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  const std::string request = " --loop position --crossover 2 --phase-margin 60 --limit u=24";
  const CommandResult tuned =
      testing::Run(BinPath("blmd-tune") + " --config " + SourcePath("configs/ganesh-square.json") +
                   " --from-report " + dir.File("fit.json") + request + " --report " +
                   dir.File("tune.json") + " --write-config " + dir.File("closed.json"));
  ASSERT_EQ(tuned.exit_code, 0) << tuned.err;
  const json report = json::parse(Slurp(dir.File("tune.json")));
  EXPECT_EQ(report["plant"]["effects"], json::array({"coulomb_friction"}));
  ASSERT_EQ(report["robustness"]["parameters"].size(), 3u);  // J, B and Tc
  EXPECT_TRUE(report["robustness"]["parameters"].contains("Tc"));
  EXPECT_EQ(report["robustness"]["corners"].size(), 8u);

  // The true plant's crossover (bisection on the hand-written L) and phase margin: within 10 %.
  double lo = 2.0 * kPi * 0.01, hi = 2.0 * kPi * 1000.0;
  for (int k = 0; k < 200; ++k) {
    const double mid = std::sqrt(lo * hi);
    (std::abs(TrueLoop(report["controller"], mid)) > 1.0 ? lo : hi) = mid;
  }
  const double fc = lo / (2.0 * kPi);
  const double pm = 180.0 + std::arg(TrueLoop(report["controller"], lo)) * 180.0 / kPi;
  EXPECT_NEAR(fc, 2.0, 0.2);
  EXPECT_NEAR(pm, 60.0, 6.0);

  // The step with the friction: the closed-loop config replays it in blmd-sim, whose final
  // theta (the mean of the last 2 % of the samples) is the report's final value.
  const CommandResult sim =
      testing::Run(BinPath("blmd-sim") + " --config " + dir.File("closed.json") + " --out " +
                   dir.File("closed.csv") + " --quiet");
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const Trace trace = ReadTraceCsv(dir.File("closed.csv"));
  const std::vector<double>& theta = trace.Column("theta");
  const std::size_t tail = std::max<std::size_t>(1, theta.size() / 50);
  double sum = 0.0;
  for (std::size_t k = theta.size() - tail; k < theta.size(); ++k) sum += theta[k];
  const json& nominal = report["step_response"]["nominal"];
  // The CSV holds each value's shortest exact text: the same numbers.
  EXPECT_NEAR(sum / static_cast<double>(tail), nominal["final_value"].get<double>(), 1e-12);
  // Without the friction (the config's own model, no report) the same request ends at the
  // reference; with it the shaft is still held short at the end of the simulated step.
  const CommandResult plain =
      testing::Run(BinPath("blmd-tune") + " --config " + SourcePath("configs/ganesh-square.json") +
                   request + " --json");
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  const json without = json::parse(plain.out);
  const double error_with = nominal["steady_state_error"];
  const double error_without = without["step_response"]["nominal"]["steady_state_error"];
  std::cout << "[ measured ] true plant " << fc << " Hz / " << pm
            << " deg; steady-state error of the 1 rad step with the discovered friction "
            << error_with << " rad (without: " << error_without << " rad); worst over the box "
            << report["step_response"]["worst_case"].dump() << "\n";
  EXPECT_LT(std::abs(error_without), 2e-3);
  EXPECT_GT(std::abs(error_with), 10.0 * std::abs(error_without));
  ASSERT_EQ(report["warnings"].size(), 1u);
  EXPECT_EQ(report["warnings"][0]["code"], "steady_state_error");
  EXPECT_EQ(without["warnings"][0]["code"], "no_intervals");
}

}  // namespace
}  // namespace blmd
