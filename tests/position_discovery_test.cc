// Discovery of the position-dependent effects spring and gravity (docs/effects.md,
// docs/discovery.md §2) on round trips with the truth known: blmd-sim makes a DC-servo
// trace (configs/ganesh-square.json, i and w observed with 1 % noise) with a hidden spring
// or gravity torque, and blmd-ident --discover must name it first, with J and B within 2 %.
// Gravity twice: on a shaft that turns several revolutions and on one that swings less
// than one. Slow (BLMD_SLOW_TESTS): each case runs a discovery.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

#include "support/test_support.h"

namespace blmd {
namespace {

constexpr double kJ = 2.26e-5, kB = 2.261e-5;  // configs/ganesh-square.json

struct RoundTrip {
  nlohmann::json discovery;
  double J = 0.0, B = 0.0;
};

// blmd-sim with `effect` and 1 % noise (of each column's peak) under a square wave of
// `amplitude` volts, then blmd-ident --discover from J, B of the config's start.
RoundTrip Discover(const std::string& effect, double amplitude, double period) {
  testing::TempDir dir;
  char text[2048];
  std::snprintf(text, sizeof text, R"({
    "model": "dc_servo",
    "parameters": { "R": 12.6, "L": 0.283, "Kt": 0.04, "Kb": 0.04, "J": 2.26e-5, "B": 2.261e-5 },
    "simulation": { "dt": 1e-5 },
    "experiment": { "input": { "type": "square", "amplitude": %.17g, "period": %.17g },
                    "duration": %.17g, "sample_rate": 1000 },
    "identification": { "free": ["J", "B"], "initial": { "J": 1e-5, "B": 1e-5 },
                        "bounds": { "J": [1e-7, 1e-2], "B": [1e-8, 1e-2] },
                        "observe": ["i", "w"], "method": "ceres" }
  })",
                amplitude, period, 2.0 * period);
  const std::string config = dir.Write("square.json", text);
  const std::string trace = dir.File("trace.csv");
  const testing::CommandResult sim =
      testing::Run(testing::BinPath("blmd-sim") + " --config " + config + " --out " + trace +
                   " --effect " + effect + " --noise i=1% --noise w=1% --seed 5 --quiet");
  EXPECT_EQ(sim.exit_code, 0) << sim.err;
  const testing::CommandResult ident =
      testing::Run(testing::BinPath("blmd-ident") + " --config " + config + " --trace " + trace +
                   " --discover --json --threads 1");
  EXPECT_EQ(ident.exit_code, 0) << ident.err;
  RoundTrip result;
  const nlohmann::json report = nlohmann::json::parse(ident.out);
  result.discovery = report["discovery"];
  result.J = result.discovery["parameters_after"]["J"].get<double>();
  result.B = result.discovery["parameters_after"]["B"].get<double>();
  std::printf("[ measured ] %s: added %s, J error %.3g %%, B error %.3g %%, nrmse %.4g -> %.4g\n",
              effect.c_str(), result.discovery["added"].dump().c_str(),
              100.0 * (result.J / kJ - 1.0), 100.0 * (result.B / kB - 1.0),
              result.discovery["error_before"]["nrmse"].get<double>(),
              result.discovery["error_after"]["nrmse"].get<double>());
  std::printf("[ measured ] parameters after: %s\n",
              result.discovery["parameters_after"].dump().c_str());
  return result;
}

void ExpectFirst(const RoundTrip& run, const std::string& effect) {
  ASSERT_FALSE(run.discovery["added"].empty()) << run.discovery.dump();
  EXPECT_EQ(run.discovery["added"][0], effect) << run.discovery["conclusion"];
  EXPECT_NEAR(run.J, kJ, 0.02 * kJ);
  EXPECT_NEAR(run.B, kB, 0.02 * kB);
}

// 12 V square wave of period 1 s: the shaft turns about 120 rad forwards and back. The
// spring's torque K (theta - theta0) reaches 0.004 N·m, 10 % of the stall torque
// Kt u / R = 0.038 N·m.
TEST(PositionDiscovery, SpringOnADcServo) {
  const RoundTrip run = Discover("spring:K=3.5e-5,theta0=10", 12.0, 1.0);
  ExpectFirst(run, "spring");
  const auto& after = run.discovery["parameters_after"];
  EXPECT_NEAR(after["K"].get<double>(), 3.5e-5, 0.05 * 3.5e-5);
  EXPECT_NEAR(after["theta0"].get<double>(), 10.0, 2.0);
}

// Gravity of 12 % of the stall torque on the shaft that turns about 20 revolutions.
TEST(PositionDiscovery, GravityOverSeveralRevolutions) {
  const RoundTrip run = Discover("gravity:Tg=0.0045,phase=0.6", 12.0, 1.0);
  ExpectFirst(run, "gravity");
  const auto& after = run.discovery["parameters_after"];
  EXPECT_NEAR(after["Tg"].get<double>(), 0.0045, 0.05 * 0.0045);
  EXPECT_NEAR(std::remainder(after["gravity_phase"].get<double>() - 0.6, 2.0 * M_PI), 0.0, 0.05);
}

// A pendulum heavier than the drive: 1 V (stall torque 0.0032 N·m) against Tg = 0.004 N·m,
// so the arm swings back and forth about its equilibrium, less than one revolution.
TEST(PositionDiscovery, GravityOnASwingOfLessThanARevolution) {
  const RoundTrip run = Discover("gravity:Tg=0.004,phase=0.3", 1.0, 1.0);
  ExpectFirst(run, "gravity");
  const auto& after = run.discovery["parameters_after"];
  EXPECT_NEAR(after["Tg"].get<double>(), 0.004, 0.05 * 0.004);
}

}  // namespace
}  // namespace blmd
