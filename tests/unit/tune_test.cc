// The tuning library (include/blmd/tune/, docs/tuning.md) against closed forms: the margins
// of loops whose crossover, phase margin and gain margin are known by hand, the closed-loop
// poles of a second-order loop, and the designed gains checked by evaluating L(jω) with
// hand-written formulas of the plant and the controller (not the library's).
#include "blmd/tune/tune.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <numbers>
#include <regex>

#include "blmd/io/config.h"
#include "blmd/sim/model.h"
#include "blmd/tune/controller_design.h"
#include "blmd/tune/loop.h"
#include "support/test_support.h"

namespace blmd {
namespace {

using Complex = std::complex<double>;
constexpr double kPi = std::numbers::pi;
constexpr double kDeg = 180.0 / kPi;

// Ganesh et al. (2012), no load.
constexpr double R = 12.6, L = 0.283, Kt = 0.04, Kb = 0.04, J = 2.26e-5, B = 2.261e-5;

// Eq. 12 of the paper (speed: without the 1/s), written out here.
Complex GaneshSpeed(double w) {
  const Complex s(0.0, w);
  return Kt / ((R + s * L) * (J * s + B) + Kb * Kt);
}
Complex GaneshPosition(double w) { return GaneshSpeed(w) / Complex(0.0, w); }

Complex Pid(const Controller& c, double w) {
  const Complex s(0.0, w);
  const double wf = 2.0 * kPi * c.derivative_filter_hz;
  return c.kp + c.ki / s + (wf > 0.0 ? c.kd * s / (1.0 + s / wf) : Complex(0.0));
}

TransferFunction Tf(std::vector<double> num, std::vector<double> den) {
  return {"y", std::move(num), std::move(den)};
}

// L = K/(s(s + a)): |L| = 1 at ω² = (−a² + sqrt(a⁴ + 4K²))/2, PM = 90° − atan(ω/a), the phase
// never reaches −180° (no gain margin), closed-loop poles the roots of s² + a s + K.
TEST(TuneLoop, IntegratorAndLagMatchTheClosedForm) {
  const double a = 3.0, K = 20.0;
  Controller c;
  c.kp = K;
  const LoopMargins m = ComputeMargins(Tf({1.0}, {1.0, a, 0.0}), c, 1e-3, 1e3);
  const double wc = std::sqrt((-a * a + std::sqrt(a * a * a * a + 4.0 * K * K)) / 2.0);
  ASSERT_TRUE(m.ok) << m.reason;
  EXPECT_EQ(m.gain_crossovers, 1);
  EXPECT_NEAR(m.crossover_hz, wc / (2.0 * kPi), 1e-10 * wc);
  EXPECT_NEAR(m.phase_margin_deg, 90.0 - std::atan(wc / a) * kDeg, 1e-8);
  EXPECT_TRUE(std::isinf(m.gain_margin_db));
  const ClosedLoopPoles poles = ComputeClosedLoopPoles(Tf({1.0}, {1.0, a, 0.0}), c);
  ASSERT_EQ(poles.poles.size(), 2u);
  EXPECT_TRUE(poles.stable);
  for (const Complex& p : poles.poles) EXPECT_LT(std::abs(p * p + a * p + K), 1e-9 * K);
  EXPECT_NEAR(poles.slowest_time_constant, 2.0 / a, 1e-12);  // complex pair, Re = −a/2
}

// L = K/(s + 1)³: the phase is −180° at ω = √3 where |L| = K/8 (GM = 20 log10(8/K)); |L| = 1 at
// ω = sqrt(K^(2/3) − 1), PM = 180° − 3 atan(ω).
TEST(TuneLoop, ThirdOrderLagMatchesTheClosedForm) {
  const double K = 4.0;
  Controller c;
  c.kp = K;
  const LoopMargins m = ComputeMargins(Tf({1.0}, {1.0, 3.0, 3.0, 1.0}), c, 1e-3, 1e3);
  const double wc = std::sqrt(std::pow(K, 2.0 / 3.0) - 1.0);
  ASSERT_TRUE(m.ok);
  EXPECT_NEAR(m.crossover_hz * 2.0 * kPi, wc, 1e-10);
  EXPECT_NEAR(m.phase_margin_deg, 180.0 - 3.0 * std::atan(wc) * kDeg, 1e-8);
  EXPECT_NEAR(m.gain_margin_db, 20.0 * std::log10(8.0 / K), 1e-9);
  EXPECT_NEAR(m.phase_crossover_hz * 2.0 * kPi, std::sqrt(3.0), 1e-10);
  EXPECT_TRUE(std::isinf(m.lower_gain_margin_db));
  // Above K = 8 the loop is unstable: the margins say so, and so do the poles.
  c.kp = 10.0;
  EXPECT_LT(ComputeMargins(Tf({1.0}, {1.0, 3.0, 3.0, 1.0}), c, 1e-3, 1e3).phase_margin_deg, 0.0);
  EXPECT_FALSE(ComputeClosedLoopPoles(Tf({1.0}, {1.0, 3.0, 3.0, 1.0}), c).stable);
}

// The designed gains put L(jω_c) = C(jω_c)·G(jω_c), both written out by hand here, on the unit
// circle at the phase margin: PID on Ganesh's position plant, PI on his speed plant.
TEST(TuneDesign, PlacesTheCrossoverOnGaneshsPlant) {
  const Config config = LoadConfig(testing::SourcePath("configs/ganesh-noload.json"));
  const auto tfs = TransferFunctions(config.model->Linearise(config.parameters));
  for (const auto loop : {PidSettings::Loop::kPosition, PidSettings::Loop::kSpeed}) {
    const bool position = loop == PidSettings::Loop::kPosition;
    const std::string output = position ? "theta" : "w";
    const TransferFunction& plant = *std::find_if(
        tfs.begin(), tfs.end(), [&](const TransferFunction& tf) { return tf.output == output; });
    for (const double fc : {0.5, 1.0, 2.0, 3.0}) {
      for (const double pm : {45.0, 60.0}) {
        SCOPED_TRACE(output + " " + std::to_string(fc) + " Hz " + std::to_string(pm) + " deg");
        ControllerDesignOptions options;
        options.loop = loop;
        options.crossover_hz = fc;
        options.phase_margin_deg = pm;
        const ControllerDesignResult design = DesignController(plant, options);
        const double w = 2.0 * kPi * fc;
        const Complex g = position ? GaneshPosition(w) : GaneshSpeed(w);
        // PI at low crossovers needs more lag than 90°: refused (checked below).
        if (!position && std::arg(g) * kDeg > pm - 90.0) {
          EXPECT_FALSE(design.ok);
          continue;
        }
        ASSERT_TRUE(design.ok) << design.reason;
        const Controller& c = design.controller;
        const Complex l = Pid(c, w) * g;
        EXPECT_NEAR(std::abs(l), 1.0, 1e-12);
        EXPECT_NEAR(180.0 + std::arg(l) * kDeg, pm, 1e-9);
        // The library's margins find that one crossover, also when it falls exactly on a point
        // of their grid (f_c itself is one: four decades either side).
        const LoopMargins margins = ComputeMargins(plant, c, fc / 1e4, fc * 1e4);
        EXPECT_EQ(margins.gain_crossovers, 1);
        EXPECT_NEAR(margins.crossover_hz, fc, 1e-9 * fc);
        EXPECT_NEAR(margins.phase_margin_deg, pm, 1e-7);
        if (position) {
          EXPECT_NEAR(c.derivative_filter_hz, 10.0 * fc, 1e-12);
          EXPECT_NEAR(4.0 * c.ki * c.kd, c.kp * c.kp, 1e-12 * c.kp * c.kp);  // Ti = 4 Td
        } else {
          EXPECT_EQ(c.kd, 0.0);
          EXPECT_EQ(c.derivative_filter_hz, 0.0);
        }
      }
    }
  }
}

// A PI lags: where the speed plant's phase is below −120° a 60° phase margin needs lead. The
// refusal names the highest crossover that works, which is where arg G_w = −120°, found here
// by bisection on the hand-written plant.
TEST(TuneDesign, RefusesLeadFromAPiAndNamesTheHighestCrossover) {
  const Config config = LoadConfig(testing::SourcePath("configs/ganesh-noload.json"));
  const auto tfs = TransferFunctions(config.model->Linearise(config.parameters));
  ControllerDesignOptions options;
  options.loop = PidSettings::Loop::kSpeed;
  options.crossover_hz = 10.0;
  options.phase_margin_deg = 60.0;
  const ControllerDesignResult design = DesignController(tfs[1], options);
  ASSERT_EQ(tfs[1].output, "w");
  EXPECT_FALSE(design.ok);
  double lo = 0.1, hi = 10.0;  // arg G_w falls through −120° between them
  for (int k = 0; k < 100; ++k) {
    const double mid = 0.5 * (lo + hi);
    (std::arg(GaneshSpeed(2.0 * kPi * mid)) * kDeg > -120.0 ? lo : hi) = mid;
  }
  std::smatch match;
  ASSERT_TRUE(std::regex_search(design.reason, match,
                                std::regex("the highest crossover with 60 deg is ([0-9.]+) Hz")))
      << design.reason;
  EXPECT_NEAR(std::stod(match[1]), lo, 1e-3 * lo);  // printed to 4 digits
  EXPECT_NE(design.reason.find("a PI cannot give 60 deg of phase margin at 10 Hz"),
            std::string::npos);
}

// The PID's lead ends at atan(filter ratio): 84.3° for the default 10.
TEST(TuneDesign, RefusesMoreLeadThanThePidGives) {
  const Config config = LoadConfig(testing::SourcePath("configs/ganesh-noload.json"));
  const auto tfs = TransferFunctions(config.model->Linearise(config.parameters));
  ASSERT_EQ(tfs[2].output, "theta");
  ControllerDesignOptions options;
  options.crossover_hz = 8.0;  // arg G_theta = −90 − 81.2 − 53.1 = −224.3°: 104.3° of lead needed
  options.phase_margin_deg = 60.0;
  const ControllerDesignResult design = DesignController(tfs[2], options);
  EXPECT_FALSE(design.ok);
  EXPECT_NEAR(design.max_controller_phase_deg, std::atan(10.0) * kDeg, 1e-12);
  const double needed = 60.0 - 180.0 - std::arg(GaneshPosition(2.0 * kPi * 8.0)) * kDeg + 360.0;
  EXPECT_NEAR(design.controller_phase_deg, needed, 1e-9);
}

// A wide box (J within ±50 %, B from half to twice): the worst case Tune reports is the worst
// of the hand formula's margins at the four corners and the nominal model, and each corner
// holds the values of its bits (bit j set: parameter j at its upper end).
TEST(TuneBox, WorstCaseOverAWideBoxIsTheHandFormulasAtTheCorners) {
  TuneInput input;
  input.config = LoadConfig(testing::SourcePath("configs/ganesh-noload.json"));
  input.box = {{"J", J, 0.5 * J, 1.5 * J, false}, {"B", B, 0.5 * B, 2.0 * B, false}};
  input.box_source = "test";
  TuneRequest request;
  request.design.crossover_hz = 2.0;
  request.design.phase_margin_deg = 60.0;
  request.u_max = 24.0;
  const TuneResult result = Tune(input, request);
  ASSERT_FALSE(result.refused) << result.refusal;
  ASSERT_EQ(result.corners.size(), 4u);
  double worst_pm = 60.0, low = 2.0, high = 2.0;
  for (std::size_t c = 0; c < 4; ++c) {
    const auto& values = result.corners[c].values;
    ASSERT_EQ(values.size(), 2u);
    const double j = values[0].second, b = values[1].second;
    EXPECT_EQ(j, c & 1u ? 1.5 * J : 0.5 * J);
    EXPECT_EQ(b, c & 2u ? 2.0 * B : 0.5 * B);
    // L(jω) of the corner's plant with the tuned controller, written out; crossover by bisection.
    auto loop = [&](double w) {
      const Complex s(0.0, w);
      const Complex g = Kt / ((R + s * L) * (j * s + b) + Kb * Kt) / s;
      return Pid(result.design.controller, w) * g;
    };
    double lo = 2.0 * kPi * 0.01, hi = 2.0 * kPi * 100.0;
    for (int k = 0; k < 200; ++k) {
      const double mid = std::sqrt(lo * hi);
      (std::abs(loop(mid)) > 1.0 ? lo : hi) = mid;
    }
    const double pm = 180.0 + std::arg(loop(lo)) * kDeg, fc = lo / (2.0 * kPi);
    EXPECT_NEAR(result.corners[c].margins.phase_margin_deg, pm, 1e-7) << c;
    EXPECT_NEAR(result.corners[c].margins.crossover_hz, fc, 1e-9) << c;
    if (pm < worst_pm) worst_pm = pm;
    low = std::min(low, fc);
    high = std::max(high, fc);
  }
  EXPECT_NEAR(result.worst.phase_margin_deg.value, worst_pm, 1e-7);
  EXPECT_NEAR(result.worst.crossover_low_hz.value, low, 1e-9);
  EXPECT_NEAR(result.worst.crossover_high_hz.value, high, 1e-9);
  EXPECT_LT(worst_pm, 55.0);  // the box matters: the margin moves by more than 5 degrees
  std::printf(
      "[ measured ] J +-50 %%, B x0.5..2: crossover %.4g..%.4g Hz, worst phase margin "
      "%.4g deg (corner %d), worst overshoot %.4g %% (corner %d)\n",
      low, high, worst_pm, result.worst.phase_margin_deg.corner,
      result.worst.overshoot_percent.value, result.worst.overshoot_percent.corner);
}

}  // namespace
}  // namespace blmd
