// The model-adequacy check (include/blmd/ident/residual/adequacy.h, docs/discovery.md §7): the FGLS
// F test's false-alarm rate on white and on strongly coloured noise (against the plain OLS F test,
// which the coloured noise fools), the noise floor from second differences, and the whole check on
// traces of the Ganesh servo with a known structure added to the measured speed: nothing flagged on
// noise alone, the right state named when there is one.
#include "blmd/ident/residual/adequacy.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <string>
#include <vector>

#include "blmd/ident/fit/problem.h"
#include "blmd/ident/fit/trace_input.h"
#include "blmd/ident/optimizers/optimizer.h"
#include "blmd/io/config.h"
#include "blmd/random.h"
#include "blmd/run.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

constexpr double kPi = 3.14159265358979323846;

// AR(1) noise of unit marginal variance.
std::vector<double> Ar1(Random& random, std::size_t n, double rho) {
  std::vector<double> x(n);
  double state = random.Normal();
  for (std::size_t k = 0; k < n; ++k) {
    x[k] = state;
    state = rho * state + std::sqrt(1.0 - rho * rho) * random.Normal();
  }
  return x;
}

// Slow regressors: Legendre-like P1, P2 over the record.
std::vector<std::vector<double>> SlowBasis(std::size_t n) {
  std::vector<double> p1(n), p2(n);
  for (std::size_t k = 0; k < n; ++k) {
    const double x = 2.0 * static_cast<double>(k) / static_cast<double>(n - 1) - 1.0;
    p1[k] = x;
    p2[k] = 0.5 * (3.0 * x * x - 1.0);
  }
  return {p1, p2};
}

// The samples' Nyquist order in angle: a shaft at 100 rad/s sampled every 1 ms advances
// 0.1 rad per sample, so orders up to floor(pi / 0.1) = 31 are resolved; the samples at rest
// (a quarter of the run, |dtheta| = 0) and a slower stretch below a quarter of the fastest
// step do not count; a w column alone gives the same (its trapezoidal angle); no angle: 0.
TEST(AngleNyquistOrder, PiOverTheAngleStepInMotion) {
  FitTrace trace;
  std::vector<double> t, theta, w;
  double angle = 0.0;
  for (int k = 0; k < 4000; ++k) {
    const double speed = k < 1000 ? 0.0 : (k < 1500 ? 10.0 : 100.0);  // rad/s
    t.push_back(1e-3 * k);
    w.push_back(speed);
    theta.push_back(angle);
    angle += speed * 1e-3;
  }
  trace.trace.Set("t", t);
  trace.trace.Set("theta", theta);
  EXPECT_EQ(AngleNyquistOrder({trace}), 31);
  FitTrace speed_only;
  speed_only.trace.Set("t", t);
  std::vector<double> w_steady(w.size(), 100.0);
  speed_only.trace.Set("w", w_steady);
  EXPECT_EQ(AngleNyquistOrder({speed_only}), 31);
  // A glitch (an encoder's wrap of 2 pi) does not set the scale of the steps in motion.
  FitTrace wrapped = trace;
  std::vector<double> theta_wrapped = theta;
  for (std::size_t k = 3000; k < theta_wrapped.size(); ++k)
    theta_wrapped[k] -= 2.0 * 3.141592653589793;
  wrapped.trace.Set("theta", theta_wrapped);
  EXPECT_EQ(AngleNyquistOrder({wrapped}), 31);
  FitTrace no_angle;
  no_angle.trace.Set("t", t);
  EXPECT_EQ(AngleNyquistOrder({no_angle}), 0);
  FitTrace at_rest;
  at_rest.trace.Set("t", t);
  at_rest.trace.Set("theta", std::vector<double>(t.size(), 0.3));
  EXPECT_EQ(AngleNyquistOrder({at_rest}), 0);
}

TEST(FglsFTest, FalseAlarmRateOnWhiteAndColouredNoise) {
  Random random(11);
  constexpr int kRuns = 400;
  constexpr std::size_t kSamples = 2000;
  const auto basis = SlowBasis(kSamples);
  int white_alarms = 0, coloured_alarms = 0, coloured_ols_alarms = 0;
  for (int run = 0; run < kRuns; ++run) {
    const FglsTest white = FglsFTest(Ar1(random, kSamples, 0.0), basis, {0}, 2);
    ASSERT_TRUE(white.ok);
    white_alarms += white.p_value < 0.05;
    const std::vector<double> coloured = Ar1(random, kSamples, 0.95);
    const FglsTest fgls = FglsFTest(coloured, basis, {0}, 2);
    ASSERT_TRUE(fgls.ok);
    coloured_alarms += fgls.p_value < 0.05;
    const FglsTest ols = FglsFTest(coloured, basis, {0}, 0);  // no noise model: plain OLS F
    coloured_ols_alarms += ols.p_value < 0.05;
  }
  std::cout << "false alarms at 0.05 of " << kRuns << ": white " << white_alarms
            << ", AR(1) 0.95 FGLS " << coloured_alarms << ", AR(1) 0.95 OLS " << coloured_ols_alarms
            << "\n";
  // Binomial(400, 0.05): 20 expected, 99 % of draws within [10, 32].
  EXPECT_GE(white_alarms, 10);
  EXPECT_LE(white_alarms, 32);
  // AR(1) 0.95 against slow regressors: FGLS keeps near its level (allowing the small-sample
  // bias of the estimated noise model), OLS does not.
  EXPECT_LE(coloured_alarms, 48) << "FGLS false alarms " << coloured_alarms << " / " << kRuns;
  EXPECT_GE(coloured_ols_alarms, 200) << "OLS false alarms " << coloured_ols_alarms;
}

TEST(FglsFTest, FindsAStructureOfAQuarterOfTheNoise) {
  Random random(5);
  constexpr std::size_t kSamples = 4000;
  const auto basis = SlowBasis(kSamples);
  std::vector<double> y = Ar1(random, kSamples, 0.5);
  for (std::size_t k = 0; k < kSamples; ++k) y[k] += 0.25 * basis[0][k] * std::sqrt(3.0);
  const FglsTest test = FglsFTest(y, basis, {0}, 2);
  ASSERT_TRUE(test.ok);
  EXPECT_LT(test.p_value, 1e-6);
  EXPECT_NEAR(test.share, 0.0625 / 1.0625, 0.02);  // variance 0.25^2 against 1
  EXPECT_EQ(test.ar_order, 1);
}

TEST(NoiseFloor, SecondDifferencesGiveTheNoiseOfASmoothSignal) {
  Random random(3);
  constexpr std::size_t kSamples = 5000;
  std::vector<double> t(kSamples), y(kSamples);
  for (std::size_t k = 0; k < kSamples; ++k) {
    // Irregular sampling (jitter of 20 % of the step) and a smooth signal with a jump.
    t[k] = 1e-3 * (static_cast<double>(k) + 0.2 * (random.Uniform() - 0.5));
    y[k] = std::sin(2.0 * kPi * 3.0 * t[k]) + (t[k] > 2.5 ? 1.0 : 0.0) + 0.01 * random.Normal();
  }
  EXPECT_NEAR(std::sqrt(NoiseFloorVariance(t, y)), 0.01, 0.0008);
}

// The Ganesh servo's square-wave run at its true parameters, with white noise of 1 % of each
// column's peak on i and w, and `structure(t, theta, w)` (rad/s) added to the measured w.
template <typename Structure>
AdequacyReport CheckTrace(std::uint64_t seed, Structure structure, double amplitude_sigmas) {
  const Config config = LoadConfig(SourcePath("configs/ganesh-square.json"));
  Trace trace;
  const SimStatus status = RunExperiment(config, &trace);
  EXPECT_TRUE(status.ok()) << status.message;
  Random random(seed);
  double sigma_w = 0.0;
  for (const char* column : {"i", "w"}) {
    double peak = 0.0;
    for (double v : trace.Column(column)) peak = std::max(peak, std::abs(v));
    if (std::string(column) == "w") sigma_w = 0.01 * peak;
    for (double& v : trace.Column(column)) v += 0.01 * peak * random.Normal();
  }
  auto& w = trace.Column("w");
  const auto& t = trace.Column("t");
  const auto& theta = trace.Column("theta");
  std::vector<double> shape(w.size());
  double rms = 0.0;
  for (std::size_t k = 0; k < w.size(); ++k) {
    shape[k] = structure(t[k], theta[k], w[k]);
    rms += shape[k] * shape[k];
  }
  rms = std::sqrt(rms / static_cast<double>(w.size()));
  for (std::size_t k = 0; k < w.size(); ++k) {
    if (rms > 0.0) w[k] += amplitude_sigmas * sigma_w * shape[k] / rms;
  }
  std::vector<FitTrace> traces = {RecordedFitTrace(std::move(trace), config.experiment.initial)};
  const FitProblem problem(config, std::move(traces), {"i", "w"},
                           MakeFreeParameters(config, {"J", "B"}));
  const std::vector<double> truth = {config.parameters.Get("J"), config.parameters.Get("B")};
  return CheckResidualStructure(problem, truth);
}

TEST(ResidualStructure, NothingFlaggedOnWhiteNoise) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const AdequacyReport report = CheckTrace(
        seed, [](double, double, double) { return 0.0; }, 0.0);
    ASSERT_TRUE(report.ok) << report.reason;
    EXPECT_TRUE(report.flagged.empty()) << "seed " << seed << ": " << report.StructureMessage();
    for (const StructureTest& test : report.tests) {
      EXPECT_LT(test.share, 0.02) << test.column << " " << test.Describe();
    }
    EXPECT_EQ(report.tests.size(), 18u);  // 9 bases (the mean, u (past) among them) x 2 columns
  }
}

TEST(ResidualStructure, NamesAPeriodicDisturbanceInTime) {
  const AdequacyReport report = CheckTrace(
      4, [](double t, double, double) { return std::sin(2.0 * kPi * 4.5 * t + 0.4); }, 2.0);
  ASSERT_TRUE(report.ok) << report.reason;
  ASSERT_FALSE(report.flagged.empty());
  const StructureTest& top = report.flagged.front();
  EXPECT_EQ(top.state, "t (periodic)");
  EXPECT_EQ(top.column, "w");
  EXPECT_NEAR(top.frequency_hz, 4.5, 0.05);
  // A sinusoid of twice the noise's RMS is 4/5 of the residual's variance.
  EXPECT_NEAR(top.share, 0.8, 0.05);
  EXPECT_EQ(top.input_harmonic, 0);
  EXPECT_NE(report.StructureMessage().find("residual depends on t (periodic, 4."),
            std::string::npos)
      << report.StructureMessage();
  EXPECT_FALSE(top.bin_x.empty());
  // At 5 Hz, the square wave's fifth harmonic, the message says so.
  const AdequacyReport harmonic = CheckTrace(
      4, [](double t, double, double) { return std::sin(2.0 * kPi * 5.0 * t + 0.4); }, 2.0);
  ASSERT_FALSE(harmonic.flagged.empty());
  EXPECT_EQ(harmonic.flagged.front().input_harmonic, 5);
  EXPECT_EQ(harmonic.flagged.front().Describe(), "t (periodic, 5 Hz, harmonic 5 of the input)");
}

// A residual offset (a current sensor's, a constant torque's): the mean, which every other
// basis keeps in its null model, is named when nothing else explains the residual.
TEST(ResidualStructure, NamesAnOffsetAsTheMean) {
  const AdequacyReport offset = CheckTrace(
      7, [](double, double, double) { return 1.0; }, 0.5);
  ASSERT_TRUE(offset.ok) << offset.reason;
  ASSERT_FALSE(offset.flagged.empty());
  EXPECT_EQ(offset.flagged.front().state, "mean") << offset.StructureMessage();
  // Half the noise's RMS: a fifth of the residual's mean square.
  EXPECT_NEAR(offset.flagged.front().share, 0.2, 0.03);
}

TEST(ResidualStructure, NamesTheAngleAndTheSpeed) {
  const AdequacyReport angle = CheckTrace(
      5, [](double, double theta, double) { return theta; }, 1.5);
  ASSERT_TRUE(angle.ok) << angle.reason;
  ASSERT_FALSE(angle.flagged.empty());
  EXPECT_EQ(angle.flagged.front().state, "theta") << angle.StructureMessage();
  const AdequacyReport speed = CheckTrace(
      6, [](double, double, double w) { return w * std::abs(w); }, 1.5);
  ASSERT_TRUE(speed.ok) << speed.reason;
  ASSERT_FALSE(speed.flagged.empty());
  EXPECT_EQ(speed.flagged.front().state, "w") << speed.StructureMessage();
}

// The Ganesh servo's square wave with a load torque of TL_first N·m for the first 1 s and
// TL_second for the second (the state carried across), 1 % noise on i and w; J, B and TL
// fitted on the whole; then the stability check on its two halves.
AdequacyReport LoadStability(double tl_first, double tl_second, std::uint64_t seed) {
  const Config base = LoadConfig(SourcePath("configs/ganesh-square.json"));
  Trace whole;
  InitialState state = base.experiment.initial;
  for (int half = 0; half < 2; ++half) {
    Config config = base;
    ParameterSet load;
    load.Set("TL", half == 0 ? tl_first : tl_second);
    config.AddEffect("load_torque", load);
    config.experiment.duration = 1.0;
    config.experiment.initial = state;
    Trace part;
    const SimStatus status = RunExperiment(config, &part);
    EXPECT_TRUE(status.ok()) << status.message;
    state.i = part.Column("i").back();
    state.w = part.Column("w").back();
    state.theta = part.Column("theta").back();
    if (half == 0) {
      whole = part;
      for (auto* column : {"t", "u", "i", "w", "theta"}) whole.Column(column).pop_back();
    } else {
      for (const auto& name : whole.names()) {
        auto& to = whole.Column(name);
        const auto& from = part.Column(name);
        for (double v : from) to.push_back(name == "t" ? v + 1.0 : v);
      }
    }
  }
  Random random(seed);
  for (const char* column : {"i", "w"}) {
    double peak = 0.0;
    for (double v : whole.Column(column)) peak = std::max(peak, std::abs(v));
    for (double& v : whole.Column(column)) v += 0.01 * peak * random.Normal();
  }
  Config config = base;
  ParameterSet load;
  load.Set("TL", 0.5 * (tl_first + tl_second));
  config.AddEffect("load_torque", load);
  config.identification.bounds["TL"] = {-0.05, 0.05};
  std::vector<FitTrace> traces = {RecordedFitTrace(std::move(whole), base.experiment.initial)};
  const FitProblem problem(config, std::move(traces), {"i", "w"},
                           MakeFreeParameters(config, {"J", "B", "TL"}));
  const FitResult fit = FindOptimizer("ceres").Minimize(problem, OptimizerOptions());
  EXPECT_TRUE(fit.evaluation.ok);
  AdequacyReport report;
  CheckEffectStability(problem, fit.values, {"load_torque"}, OptimizerOptions(), AdequacyOptions(),
                       &report);
  return report;
}

TEST(EffectStability, ALoadThatChangesIsUnstableAConstantOneIsNot) {
  const AdequacyReport constant = LoadStability(0.0015, 0.0015, 7);
  ASSERT_TRUE(constant.stability_checked) << constant.stability_reason;
  ASSERT_EQ(constant.stability.size(), 1u);
  EXPECT_EQ(constant.stability[0].parameter, "TL");
  EXPECT_TRUE(constant.unstable.empty()) << "z = " << constant.stability[0].z;
  EXPECT_NEAR(constant.stability[0].first, 0.0015, 0.0002);
  EXPECT_NEAR(constant.stability[0].second, 0.0015, 0.0002);
  const AdequacyReport changing = LoadStability(0.0010, 0.0020, 7);
  ASSERT_TRUE(changing.stability_checked) << changing.stability_reason;
  EXPECT_EQ(changing.unstable, std::vector<std::string>{"load_torque"})
      << "first " << changing.stability[0].first << " second " << changing.stability[0].second
      << " z " << changing.stability[0].z;
  EXPECT_EQ(changing.parts, "the two halves of the trace");
}

}  // namespace
}  // namespace blmd::testing
