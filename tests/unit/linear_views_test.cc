// The frequency-domain, step and correlation views of the report (sim/linear_response.h,
// ident/residual/spectral.h, ident/uncertainty/parameter_correlation.h, report/linear_views.h;
// docs/report.md): each against a closed form. The Bode values of a first-order lag and its
// integral, exact and sampled with a zero-order hold; Welch's H1 and coherence on a first-order
// system driven by white noise (noise-free: H1 is the sampled G, γ² = 1; with output noise: γ² and
// the random error of |H1| as Bendat & Piersol predict); the content of a square wave (its odd
// harmonics only); the step figures of a first-order lag (rise ln 9·τ, settling ln 50·τ) and
// of an underdamped second-order system (overshoot exp(-πζ/√(1-ζ²))); the correlation matrix
// (unit diagonal, cov/(σσ), the intervals' σ) and its warning.
#include "blmd/report/linear_views.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>
#include <random>

#include "blmd/ident/fit/trace_input.h"
#include "blmd/ident/residual/spectral.h"
#include "blmd/ident/uncertainty/parameter_correlation.h"
#include "blmd/io/config.h"
#include "blmd/report/report.h"
#include "blmd/run.h"
#include "blmd/sim/linear_model.h"
#include "blmd/sim/linear_response.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

using Complex = std::complex<double>;
constexpr double kPi = std::numbers::pi;

// A rigid shaft without effects: J dw/dt = Kt u - B w, dθ/dt = w (τ = J/B = 0.4 s).
Config RigidConfig(const TempDir& dir, const std::string& experiment) {
  return LoadConfig(dir.Write("rigid.json", R"({
    "name": "rigid", "model": "rigid_load",
    "parameters": { "J": 0.02, "B": 0.05, "Kt": 1.0 },
    "simulation": { "dt": 1e-4 },
    "experiment": )" + experiment + R"(,
    "identification": { "free": ["J", "B"], "observe": ["w"] } })"));
}

LinearModel FirstOrder(double gain, double tau) {
  LinearModel m;
  m.available = true;
  m.input = "u";
  m.states = m.outputs = {"w", "theta"};
  m.A.resize(2, 2);
  m.A << -1.0 / tau, 0.0, 1.0, 0.0;
  m.B.resize(2, 1);
  m.B << gain / tau, 0.0;
  m.C = Eigen::MatrixXd::Identity(2, 2);
  m.D = Eigen::MatrixXd::Zero(2, 1);
  return m;
}

TEST(LinearResponse, ContinuousBodeIsTheClosedForm) {
  TempDir dir;
  const Config config = RigidConfig(dir, R"({"input": {"type": "step", "amplitude": 1}})");
  const LinearModel model = config.model->Linearise(config.parameters);
  ASSERT_TRUE(model.available);
  ASSERT_EQ(model.outputs, (std::vector<std::string>{"w", "theta"}));
  const double J = 0.02, B = 0.05, Kt = 1.0;
  for (double f : {0.01, 0.1, 0.3979, 1.0, 10.0, 100.0}) {
    const Complex s(0.0, 2 * kPi * f);
    const Complex w = Kt / (J * s + B), theta = w / s;
    EXPECT_NEAR(std::abs(FrequencyResponse(model, 0, f) - w), 0.0, 1e-12 * std::abs(w)) << f;
    EXPECT_NEAR(std::abs(FrequencyResponse(model, 1, f) - theta), 0.0, 1e-12 * std::abs(theta));
  }
  // Phase unwrapped: w from 0° to -90°, θ from -90° to -180°, -45° / -135° at the corner.
  std::vector<double> f;
  for (int k = 0; k <= 80; ++k) f.push_back(1e-3 * std::pow(10.0, k / 16.0));
  const BodeCurve w = Bode(model, 0, f), theta = Bode(model, 1, f);
  EXPECT_NEAR(w.phase_deg.front(), -std::atan(2 * kPi * 1e-3 * J / B) * 180 / kPi, 1e-9);
  EXPECT_NEAR(theta.phase_deg.back(), -180.0 + std::atan(B / (2 * kPi * 1e2 * J)) * 180 / kPi,
              1e-9);
  for (std::size_t k = 1; k < f.size(); ++k) EXPECT_LT(theta.phase_deg[k], theta.phase_deg[k - 1]);
  const BodeCurve corner = Bode(model, 0, {B / J / (2 * kPi)});
  EXPECT_NEAR(corner.phase_deg[0], -45.0, 1e-9);
  EXPECT_NEAR(corner.magnitude_db[0], 20 * std::log10(Kt / B / std::sqrt(2.0)), 1e-9);
}

// rigid_load with two_mass keeps the coupling in its linear part: the motor speed's response is
// the two-mass transfer function (docs/effects.md), Wm/U = Kt (Jl s + Bl + Z) / ((Jm s + Bm +
// Z)(Jl s + Bl + Z) - Z^2), Z = K/s + c: a notch at the anti-resonance and a peak at the
// resonance; its transfer function, from the Faddeev-LeVerrier recursion, is the same; the
// shaft handed to the tuner is J, B, Kt and the coupling.
TEST(LinearResponse, TwoMassShaftShowsItsResonance) {
  TempDir dir;
  const Config config = LoadConfig(dir.Write("two-mass.json", R"({
    "name": "two-mass", "model": "rigid_load",
    "parameters": { "J": 2e-3, "B": 0.04, "Kt": 0.5 },
    "effects": { "two_mass": { "inertia_ratio": 1.5, "anti_resonance_hz": 40,
                               "shaft_damping_ratio": 0.05, "load_damping_share": 0.3 } },
    "experiment": {"input": {"type": "step", "amplitude": 1}, "duration": 1},
    "identification": { "free": ["J", "B"], "observe": ["w"] } })"));
  const LinearModel model = config.model->Linearise(config.parameters);
  ASSERT_TRUE(model.available);
  ASSERT_EQ(model.outputs, (std::vector<std::string>{"w", "theta"}));
  ASSERT_TRUE(model.has_shaft);
  EXPECT_EQ(model.shaft.J, 2e-3);
  EXPECT_EQ(model.shaft.B, 0.04);
  EXPECT_EQ(model.shaft.K, 0.5);
  EXPECT_EQ(model.shaft.inertia_ratio, 1.5);
  EXPECT_EQ(model.shaft.anti_resonance_hz, 40.0);
  const double J = 2e-3, B = 0.04, Kt = 0.5, r = 1.5, wa = 2 * kPi * 40.0;
  const double Jm = J / (1 + r), Jl = J - Jm, K = Jl * wa * wa, c = 2 * 0.05 * Jl * wa;
  const double Bl = 0.3 * B, Bm = B - Bl;
  const std::vector<TransferFunction> tfs = TransferFunctions(model);
  ASSERT_EQ(tfs.size(), 2u);
  auto polyval = [](const std::vector<double>& p, Complex s) {
    Complex v = 0.0;
    for (double a : p) v = v * s + a;
    return v;
  };
  for (double f : {1.0, 20.0, 40.0, 63.2456, 120.0}) {
    const Complex s(0.0, 2 * kPi * f);
    const Complex Z = K / s + c;
    const Complex w = Kt * (Jl * s + Bl + Z) / ((Jm * s + Bm + Z) * (Jl * s + Bl + Z) - Z * Z);
    EXPECT_NEAR(std::abs(FrequencyResponse(model, 0, f) - w), 0.0, 1e-9 * std::abs(w)) << f;
    const Complex tf = polyval(tfs[0].numerator, s) / polyval(tfs[0].denominator, s);
    EXPECT_NEAR(std::abs(tf - w), 0.0, 1e-7 * std::abs(w)) << f;
  }
  // The notch and the peak: |w| has a local minimum near the anti-resonance and a local
  // maximum near the resonance, where it stands above the rigid shaft's.
  auto gain = [&](double f) { return std::abs(FrequencyResponse(model, 0, f)); };
  EXPECT_LT(gain(40.0), gain(36.0));
  EXPECT_LT(gain(40.0), gain(44.0));
  EXPECT_GT(gain(63.2456), gain(57.0));
  EXPECT_GT(gain(63.2456), gain(70.0));
  EXPECT_GT(gain(63.2456), 5.0 * std::abs(Kt / (J * Complex(0, 2 * kPi * 63.2456) + B)));
}

// Sampled with a zero-order hold at T: H(z) = K(1 - a)/(z - a), a = exp(-T/τ).
TEST(LinearResponse, SampledResponseIsTheZeroOrderHoldClosedForm) {
  const double K = 20.0, tau = 0.4, T = 1e-3, a = std::exp(-T / tau);
  const LinearModel model = FirstOrder(K, tau);
  for (double f : {0.1, 1.0, 50.0, 250.0, 499.0}) {
    const Complex z = std::polar(1.0, 2 * kPi * f * T);
    const Complex expected = K * (1 - a) / (z - a);
    EXPECT_NEAR(std::abs(FrequencyResponse(model, 0, f, T) - expected), 0.0,
                1e-10 * std::abs(expected))
        << f;
  }
  // Below a tenth of the sample rate it is G(jω) but for the hold: within 2 % in gain, and
  // the phase lags by about ωT/2.
  for (double f : {1.0, 10.0, 100.0}) {
    const Complex g = FrequencyResponse(model, 0, f), h = FrequencyResponse(model, 0, f, T);
    EXPECT_NEAR(std::abs(h) / std::abs(g), 1.0, 0.02) << f;
    EXPECT_NEAR(std::arg(h / g), -kPi * f * T, 0.01 * kPi * f * T) << f;
  }
}

// White noise through the sampled first-order lag, exactly (ZOH recursion).
struct Record {
  std::vector<double> u, y;
};
Record WhiteNoiseThroughFirstOrder(std::size_t n, double K, double tau, double T,
                                   double noise_sigma, std::uint64_t seed) {
  std::mt19937_64 random(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double a = std::exp(-T / tau);
  Record r;
  double x = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    r.u.push_back(normal(random));
    r.y.push_back(x);
    x = a * x + K * (1 - a) * r.u.back();
  }
  for (double& y : r.y) y += noise_sigma * normal(random);
  return r;
}

TEST(Welch, SegmentLengthGivesEightToSeventeenSegments) {
  EXPECT_EQ(WelchSegmentLength(4001), 512u);  // the demo: 14 segments
  EXPECT_EQ(WelchSegmentLength(100000), 16384u);
  EXPECT_EQ(WelchSegmentLength(71), 0u);  // 2·71/9 < 16
  EXPECT_EQ(WelchSegmentLength(72), 16u);
  for (std::size_t n : {72u, 100u, 4001u, 36864u, 36863u, 1000001u}) {
    const std::size_t L = WelchSegmentLength(n);
    const std::size_t segments = (n - L) / (L / 2) + 1;
    EXPECT_GE(segments, 8u) << n;
    EXPECT_LE(segments, 17u) << n;
  }
}

TEST(Welch, H1OfANoiseFreeFirstOrderSystemIsItsSampledResponse) {
  const double K = 2.0, tau = 0.01, fs = 1000.0, T = 1.0 / fs;
  const Record r = WhiteNoiseThroughFirstOrder(100000, K, tau, T, 0.0, 11);
  const std::size_t L = WelchSegmentLength(r.u.size());
  const WelchSpectra s = EstimateWelchSpectra({{r.u, {r.y}}}, fs, L);
  ASSERT_TRUE(s.ok) << s.reason;
  EXPECT_EQ(s.segments, (100000 - L) / (L / 2) + 1);
  // The Hann window at 50 %: Σ sin²·cos² over half a segment / Σ sin⁴ over all of it = 1/6.
  EXPECT_NEAR(s.overlap_correlation, 1.0 / 6.0, 1e-12);
  const double K_seg = static_cast<double>(s.segments);
  EXPECT_NEAR(s.equivalent_averages, K_seg * K_seg / (K_seg + 2 * (K_seg - 1) / 36.0), 1e-9);
  const LinearModel model = FirstOrder(K, tau);
  double worst_gain = 0.0, worst_phase = 0.0, lowest_coherence = 1.0, worst_continuous = 0.0;
  for (std::size_t m = 0; m < s.f_hz.size(); ++m) {
    const Complex h1 = s.cross_psd[0][m] / s.input_psd[m];
    const Complex truth = FrequencyResponse(model, 0, s.f_hz[m], T);
    worst_gain = std::max(worst_gain, std::abs(std::abs(h1) / std::abs(truth) - 1.0));
    worst_phase = std::max(worst_phase, std::abs(std::arg(h1 / truth)) * 180 / kPi);
    lowest_coherence = std::min(
        lowest_coherence, std::norm(s.cross_psd[0][m]) / (s.input_psd[m] * s.output_psd[0][m]));
    if (s.f_hz[m] <= fs / 10) {  // the analytic |G(jω)| = K/sqrt(1 + (ωτ)²)
      const double w = 2 * kPi * s.f_hz[m];
      worst_continuous =
          std::max(worst_continuous, std::abs(std::abs(h1) / (K / std::hypot(1.0, w * tau)) - 1.0));
    }
  }
  std::cout << "noise-free H1 over " << s.f_hz.size() << " bins: gain within " << worst_gain
            << ", phase within " << worst_phase << " deg, coherence >= " << lowest_coherence
            << "; against |G(jw)| up to fs/10: " << worst_continuous << "\n";
  // What is left is leakage: each segment holds the response to inputs before it, of order
  // τ/T_segment = 10 samples / 16384 per segment, averaged over the segments.
  EXPECT_LT(worst_gain, 5e-3);
  EXPECT_LT(worst_phase, 0.25);
  EXPECT_GT(lowest_coherence, 0.999);
  EXPECT_LT(worst_continuous, 0.02);  // the hold's sinc(f/fs): 1.6 % at fs/10
}

// With white output noise of density S_nn the coherence is S_yy/(S_yy + S_nn), estimated with
// the bias (1 - γ²)²/n_d, and |H1| is off by the normalised random error
// sqrt(1 - γ²)/(|γ| sqrt(2 n_d)) (one standard deviation): Bendat & Piersol (2010) ch. 9, with
// n_d Welch's equivalent number of averages.
TEST(Welch, CoherenceAndRandomErrorWithOutputNoiseAreBendatAndPiersols) {
  const double K = 2.0, tau = 0.01, fs = 1000.0, T = 1.0 / fs, sigma = 1.0;
  const Record r = WhiteNoiseThroughFirstOrder(100000, K, tau, T, sigma, 12);
  const WelchSpectra s = EstimateWelchSpectra({{r.u, {r.y}}}, fs, WelchSegmentLength(100000));
  ASSERT_TRUE(s.ok);
  const LinearModel model = FirstOrder(K, tau);
  std::size_t inside = 0, counted = 0;
  double coherence_error = 0.0;
  for (std::size_t m = 0; m < s.f_hz.size(); ++m) {
    const Complex truth = FrequencyResponse(model, 0, s.f_hz[m], T);
    // Both densities of unit-variance white noise: 2/fs one-sided.
    const double true_coherence = std::norm(truth) / (std::norm(truth) + sigma * sigma);
    const double coherence = std::norm(s.cross_psd[0][m]) / (s.input_psd[m] * s.output_psd[0][m]);
    coherence_error += coherence - true_coherence -
                       (1 - true_coherence) * (1 - true_coherence) / s.equivalent_averages;
    const double error = FrequencyResponseRandomError(true_coherence, s.equivalent_averages);
    const double h1 = std::abs(s.cross_psd[0][m] / s.input_psd[m]);
    ++counted;
    inside += std::abs(h1 / std::abs(truth) - 1.0) <= 1.96 * error;
  }
  const double coverage = static_cast<double>(inside) / static_cast<double>(counted);
  std::cout << "with output noise: mean coherence error less the bias " << coherence_error / counted
            << ", |H1| within 1.96 random errors at " << coverage << " of " << counted << " bins\n";
  EXPECT_NEAR(coherence_error / counted, 0.0, 0.01);
  EXPECT_GT(coverage, 0.90);
  EXPECT_LT(coverage, 0.99);
}

TEST(Welch, RandomErrorIsBendatAndPiersolsFormula) {
  EXPECT_NEAR(FrequencyResponseRandomError(0.5, 8.0), std::sqrt(0.5) / (std::sqrt(0.5) * 4.0),
              1e-15);
  EXPECT_EQ(FrequencyResponseRandomError(1.0, 3.0), 0.0);
  EXPECT_TRUE(std::isinf(FrequencyResponseRandomError(0.0, 3.0)));
}

// A square wave has power at its odd harmonics only: the report keeps those frequencies (the
// bins around them) and leaves out the empty ones between, e.g. its even harmonics.
TEST(FrequencyResponseReport, KeepsOnlyTheOddHarmonicsOfASquareWave) {
  TempDir dir;
  const Config config =
      RigidConfig(dir, R"({"input": {"type": "square", "amplitude": 0.5, "period": 1.0},
              "duration": 100.0, "sample_rate": 200})");
  Trace trace;
  ASSERT_TRUE(RunExperiment(config, &trace).ok());
  std::vector<FitTrace> traces = {RecordedFitTrace(trace, {})};
  const FitProblem problem(config, std::move(traces), {"w"},
                           MakeFreeParameters(config, {"J", "B"}));
  const LinearModel model = config.model->Linearise(config.parameters);
  const FrequencyResponseReport r = MakeFrequencyResponseReport(problem, model);
  ASSERT_TRUE(r.available) << r.reason;
  EXPECT_EQ(r.segment_length, 4096u);  // 20001 samples
  EXPECT_EQ(r.averages, 8u);
  EXPECT_NEAR(r.resolution_hz, 200.0 / 4096, 1e-12);
  ASSERT_EQ(r.outputs.size(), 1u);
  const FrequencyResponseOutput& w = r.outputs[0];
  EXPECT_EQ(w.output, "w");
  // Below 40 Hz a log band (2.3 % wide) is narrower than the 2 Hz between odd harmonics, so
  // each point is one harmonic's bins: within the Hann main lobe (±2 bins) and rounding.
  std::vector<int> near_harmonic(41, 0);
  for (double f : w.f_hz) {
    if (f > 40.0) continue;
    const int harmonic = static_cast<int>(std::lround(f));
    EXPECT_LE(std::abs(f - harmonic), 2.5 * r.resolution_hz) << f;  // at a harmonic
    EXPECT_EQ(harmonic % 2, 1) << f;                                // an odd one
    ++near_harmonic[static_cast<std::size_t>(harmonic)];
  }
  for (int h = 1; h <= 39; h += 2) EXPECT_GE(near_harmonic[static_cast<std::size_t>(h)], 1) << h;
  EXPECT_GT(w.f_hz.back(), 90.0);  // and up to the Nyquist frequency
  std::cout << "square wave: " << r.bins_with_content << " of " << r.bins << " bins kept, "
            << w.f_hz.size() << " points\n";
  // Noise-free, linear: H1 is the sampled model's at the harmonic, in every bin of the
  // harmonic's Hann main lobe (the points up to 2 bins beside it too), but for leakage: a
  // segment of T = 20.48 s holds the response to inputs before it, of order τ/T = 2 % for
  // τ = 0.4 s; the bound is twice that (0.34 dB, 2.2°).
  const double leakage = 2 * 0.4 / (4096 / 200.0);
  for (std::size_t k = 0; k < w.f_hz.size() && w.f_hz[k] <= 40.0; ++k) {
    const double harmonic = std::round(w.f_hz[k]);
    const BodeCurve at = Bode(model, 0, {harmonic}, 1.0 / 200);
    EXPECT_NEAR(w.empirical_mag_db[k], at.magnitude_db[0], 20 * std::log10(1 + leakage))
        << w.f_hz[k];
    EXPECT_NEAR(std::remainder(w.empirical_phase_deg[k] - at.phase_deg[0], 360.0), 0.0,
                leakage * 180 / kPi)
        << w.f_hz[k];
    EXPECT_GT(w.coherence[k], 0.99) << w.f_hz[k];
  }
}

// A broadband input (PRBS) through the Ganesh servo, noise-free and at the true values: up to
// a tenth of the sample rate, wherever the coherence is at least 0.99 the empirical H1 lies on
// the model's sampled Bode curve within 0.5 dB and 3°; a sign, scale or half-sample error
// would be far off (the hold alone is 18° at 200 Hz). Where the coherence is lower, noise-free
// as the data are, it shows leakage: the 2.54 s trace gives segments of 0.512 s, only four
// times the servo's slower time constant (0.128 s), so each segment holds a fair part of the
// response to inputs before it (docs/report.md).
TEST(FrequencyResponseReport, PrbsThroughTheServoMatchesItsModel) {
  const Config config = LoadConfig(SourcePath("configs/ganesh-prbs.json"));
  Trace trace;
  ASSERT_TRUE(RunExperiment(config, &trace).ok());
  std::vector<FitTrace> traces = {RecordedFitTrace(trace, {})};
  const FitProblem problem(config, std::move(traces), {"i", "w"},
                           MakeFreeParameters(config, {"J", "B"}));
  const FrequencyResponseReport r =
      MakeFrequencyResponseReport(problem, config.model->Linearise(config.parameters));
  ASSERT_TRUE(r.available) << r.reason;
  ASSERT_EQ(r.outputs.size(), 2u);
  for (const FrequencyResponseOutput& o : r.outputs) {
    double worst_mag = 0.0, worst_phase = 0.0;
    std::size_t compared = 0;
    std::size_t points = 0;
    for (std::size_t k = 0; k < o.f_hz.size() && o.f_hz[k] <= 200.0; ++k) {
      ++points;
      if (o.coherence[k] < 0.99) continue;
      ++compared;
      worst_mag = std::max(worst_mag, std::abs(o.empirical_mag_db[k] - o.model_mag_db[k]));
      worst_phase =
          std::max(worst_phase, std::abs(o.empirical_phase_deg[k] - o.model_phase_deg[k]));
    }
    std::cout << o.output << ": " << compared << " of " << points
              << " points up to 200 Hz with coherence >= 0.99; worst gap " << worst_mag << " dB, "
              << worst_phase << " deg\n";
    EXPECT_GT(compared, points / 2) << o.output;
    EXPECT_LT(worst_mag, 0.5) << o.output;
    EXPECT_LT(worst_phase, 3.0) << o.output;
  }
}

TEST(FrequencyResponseReport, IsNotAvailableInClosedLoopOrWithoutALinearPart) {
  const Config pid = LoadConfig(SourcePath("configs/ganesh-pid.json"));
  Trace trace;
  ASSERT_TRUE(RunExperiment(pid, &trace).ok());
  std::vector<FitTrace> traces = {RecordedFitTrace(trace, {})};
  const FitProblem problem(pid, std::move(traces), {"i", "w"}, MakeFreeParameters(pid, {"J", "B"}));
  const FrequencyResponseReport closed =
      MakeFrequencyResponseReport(problem, pid.model->Linearise(pid.parameters));
  EXPECT_FALSE(closed.available);
  EXPECT_NE(closed.reason.find("closed-loop"), std::string::npos) << closed.reason;
  const FrequencyResponseReport none = MakeFrequencyResponseReport(problem, LinearModel{});
  EXPECT_FALSE(none.available);
  EXPECT_EQ(none.reason.rfind("no linear part", 0), 0u);
}

TEST(StepResponse, FirstOrderRisesInLn9TauAndSettlesInLn50Tau) {
  TempDir dir;
  const Config config = RigidConfig(dir, R"({"input": {"type": "step", "amplitude": 1}})");
  const StepResponse s = ComputeStepResponse(config.model->Linearise(config.parameters));
  ASSERT_TRUE(s.ok) << s.reason;
  const double tau = 0.02 / 0.05;
  EXPECT_NEAR(s.duration_s, 8 * tau, 1e-12);
  ASSERT_EQ(s.figures.size(), 2u);
  const StepFigures& w = s.figures[0];
  ASSERT_TRUE(w.ok) << w.reason;
  EXPECT_NEAR(w.final_value, 1.0 / 0.05, 1e-9);
  EXPECT_NEAR(w.rise_time_s, std::log(9.0) * tau, 1e-5 * tau);  // 2.197 τ
  EXPECT_NEAR(w.settling_time_s, std::log(50.0) * tau, 1e-5 * tau);
  EXPECT_EQ(w.overshoot_percent, 0.0);
  // Every sample is the closed form K(1 - exp(-t/τ)).
  for (std::size_t i = 0; i < s.t_s.size(); i += 97)
    EXPECT_NEAR(s.y[0][i], 20.0 * (1 - std::exp(-s.t_s[i] / tau)), 1e-11);
  // The angle integrates: no final value.
  EXPECT_FALSE(s.figures[1].ok);
  EXPECT_NE(s.figures[1].reason.find("integrating"), std::string::npos);
}

TEST(StepResponse, UnderdampedSecondOrderOvershootsAsTheClosedForm) {
  const double zeta = 0.3, wn = 10.0;
  LinearModel m;
  m.available = true;
  m.outputs = m.states = {"y", "dy"};
  m.A.resize(2, 2);
  m.A << 0.0, 1.0, -wn * wn, -2 * zeta * wn;
  m.B.resize(2, 1);
  m.B << 0.0, wn * wn;
  m.C = Eigen::MatrixXd::Identity(2, 2);
  m.D = Eigen::MatrixXd::Zero(2, 1);
  const StepResponse s = ComputeStepResponse(m);
  ASSERT_TRUE(s.ok);
  const StepFigures& y = s.figures[0];
  ASSERT_TRUE(y.ok) << y.reason;
  const double wd = wn * std::sqrt(1 - zeta * zeta);
  EXPECT_NEAR(y.final_value, 1.0, 1e-12);
  EXPECT_NEAR(y.overshoot_percent, 100 * std::exp(-kPi * zeta / std::sqrt(1 - zeta * zeta)), 1e-3);
  EXPECT_NEAR(y.peak_time_s, kPi / wd, s.dt_s);
  // The velocity returns to zero: a final value of 0, no figures.
  EXPECT_FALSE(s.figures[1].ok);
}

TEST(StepResponse, DcServoFinalValuesAreItsDcGains) {
  const Config config = LoadConfig(SourcePath("configs/ganesh-square.json"));
  const ParameterSet& v = config.parameters;
  const StepResponse s = ComputeStepResponse(config.model->Linearise(v));
  ASSERT_TRUE(s.ok);
  const double den = v.Get("R") * v.Get("B") + v.Get("Kt") * v.Get("Kb");
  EXPECT_NEAR(s.figures[0].final_value, v.Get("B") / den, 1e-12 * v.Get("B") / den);    // i
  EXPECT_NEAR(s.figures[1].final_value, v.Get("Kt") / den, 1e-12 * v.Get("Kt") / den);  // w
  EXPECT_FALSE(s.figures[2].ok);                                                        // theta
  // The samples have settled at the end of the run.
  EXPECT_NEAR(s.y[1].back(), v.Get("Kt") / den, 1e-3 * v.Get("Kt") / den);
}

TEST(StepFigures, AreMeasuredBetweenSamples) {
  const std::vector<double> t = {0, 1, 2, 3, 4, 5};
  const std::vector<double> y = {0, 0.5, 1.2, 0.95, 1.01, 1.0};
  const StepFigures f = MeasureStep(t, y, 1.0);
  ASSERT_TRUE(f.ok);
  EXPECT_NEAR(f.rise_time_s, (1 + 0.4 / 0.7) - 0.2, 1e-12);  // 10 % at 0.2, 90 % at 1.571
  EXPECT_NEAR(f.overshoot_percent, 20.0, 1e-12);
  EXPECT_EQ(f.peak_time_s, 2.0);
  EXPECT_NEAR(f.settling_time_s, 3 + 0.03 / 0.06, 1e-12);  // 0.95 -> 1.01 enters 0.98 at 3.5
  EXPECT_FALSE(MeasureStep(t, y, 0.0).ok);
  EXPECT_FALSE(MeasureStep(t, {0, 0.1, 0.2, 0.3, 0.4, 0.5}, 1.0).ok);
}

TEST(Correlation, IsCovarianceOverTheProductOfDeviations) {
  Eigen::MatrixXd cov(3, 3);
  cov << 4, 2, -5.4, 2, 9, 0, -5.4, 0, 9;
  const Eigen::MatrixXd rho = CorrelationFromCovariance(cov);
  EXPECT_EQ(rho(0, 0), 1.0);
  EXPECT_EQ(rho(1, 1), 1.0);
  EXPECT_EQ(rho(2, 2), 1.0);
  EXPECT_NEAR(rho(0, 1), 2.0 / 6.0, 1e-15);
  EXPECT_NEAR(rho(0, 2), -5.4 / 6.0, 1e-15);
  EXPECT_EQ(rho(1, 2), 0.0);
  EXPECT_EQ(rho(1, 0), rho(0, 1));
  cov(1, 1) = 0.0;  // a parameter the cost does not see
  const Eigen::MatrixXd partial = CorrelationFromCovariance(cov);
  EXPECT_TRUE(std::isnan(partial(1, 0)) && std::isnan(partial(1, 1)) && std::isnan(partial(2, 1)));
  EXPECT_NEAR(partial(0, 2), -0.9, 1e-15);
}

// A fit of the bundled no-load step: the matrix has a unit diagonal, is symmetric, and its
// covariance gives the very standard deviations of the report's intervals.
TEST(Correlation, ComesFromTheCovarianceOfTheIntervals) {
  const Config config = LoadConfig(SourcePath("configs/ganesh-noload.json"));
  TraceInputOptions input;
  input.required = config.identification.observe;
  std::vector<FitTrace> traces = {LoadFitTrace(SourcePath("testdata/ganesh-noload-step.csv"), input,
                                               config.experiment.initial)};
  const FitProblem problem(config, std::move(traces), config.identification.observe,
                           MakeFreeParameters(config, config.identification.free));
  OptimizerOptions options;
  options.threads = 2;
  for (const char* method : {"ceres", "powell"}) {
    SCOPED_TRACE(method);
    const FitResult result = FindOptimizer(method).Minimize(problem, options);
    const ParameterCorrelation c = EstimateParameterCorrelation(problem, result);
    ASSERT_TRUE(c.available) << c.reason;
    ASSERT_EQ(c.names, (std::vector<std::string>{"J", "B"}));
    EXPECT_EQ(c.correlation(0, 0), 1.0);
    EXPECT_EQ(c.correlation(1, 1), 1.0);
    EXPECT_EQ(c.correlation(0, 1), c.correlation(1, 0));
    EXPECT_NEAR(c.correlation(0, 1),
                c.covariance(0, 1) / std::sqrt(c.covariance(0, 0) * c.covariance(1, 1)), 1e-15);
    for (std::size_t k = 0; k < 2; ++k) {  // log-scale J, B: std = value·σ_ln
      const ParameterEstimate& e = result.estimates[k];
      ASSERT_TRUE(e.has_interval);
      const auto kk = static_cast<Eigen::Index>(k);
      EXPECT_NEAR(e.value * std::sqrt(c.covariance(kk, kk)), e.std, 1e-9 * e.std) << e.name;
    }
    std::cout << method << ": rho(J, B) = " << c.correlation(0, 1) << "\n";
  }
}

// J and B from a quarter of a time constant of a step, long before the speed levels off: the
// data see the slope Kt/J and hardly B apart from J, so the two are strongly correlated and
// the report, its summary and its JSON say so (a note, not a warning).
TEST(Correlation, NotesWhenTwoParametersAreHardlySeparable) {
  TempDir dir;
  const Config config = RigidConfig(
      dir, R"({"input": {"type": "step", "amplitude": 1}, "duration": 0.1, "sample_rate": 1000})");
  Trace trace;
  ASSERT_TRUE(RunExperiment(config, &trace).ok());
  std::mt19937_64 random(5);
  std::normal_distribution<double> normal(0.0, 0.05);
  for (double& w : trace.Column("w")) w += normal(random);
  std::vector<FitTrace> traces = {RecordedFitTrace(trace, {})};
  const FitProblem problem(config, std::move(traces), {"w"},
                           MakeFreeParameters(config, {"J", "B"}));
  OptimizerOptions options;
  options.threads = 2;
  const FitResult result = FindOptimizer("ceres").Minimize(problem, options);
  ReportInputs inputs;
  inputs.problem = &problem;
  inputs.result = &result;
  IdentReport report = MakeReport(inputs);
  AddWarnings(&report);
  const ParameterCorrelation& c = report.final_model.correlation;
  ASSERT_TRUE(c.available) << c.reason;
  const double rho = c.correlation(0, 1);
  std::cout << "a quarter of a time constant of a step: rho(J, B) = " << rho << "\n";
  EXPECT_GT(std::abs(rho), kPoorlySeparableCorrelation);
  ASSERT_EQ(c.poorly_separable.size(), 1u);
  EXPECT_EQ(c.poorly_separable[0].first, "J");
  EXPECT_EQ(c.poorly_separable[0].second, "B");
  EXPECT_EQ(c.poorly_separable[0].rho, rho);
  EXPECT_NE(HumanSummary(report).find("note: J and B are correlated (rho = "), std::string::npos);
  // The JSON carries the matrix and the pair.
  const nlohmann::json json = report;
  EXPECT_EQ(json["correlation"]["names"], (nlohmann::json{"J", "B"}));
  EXPECT_EQ(json["correlation"]["matrix"][0][0], 1.0);
  EXPECT_EQ(json["correlation"]["matrix"][0][1], rho);
  EXPECT_EQ(json["correlation"]["poorly_separable"][0]["parameters"], (nlohmann::json{"J", "B"}));
  // A whole step (eight time constants) separates them.
  const Config long_config = RigidConfig(
      dir, R"({"input": {"type": "step", "amplitude": 1}, "duration": 3.2, "sample_rate": 1000})");
  Trace long_trace;
  ASSERT_TRUE(RunExperiment(long_config, &long_trace).ok());
  for (double& w : long_trace.Column("w")) w += normal(random);
  std::vector<FitTrace> long_traces = {RecordedFitTrace(long_trace, {})};
  const FitProblem long_problem(long_config, std::move(long_traces), {"w"},
                                MakeFreeParameters(long_config, {"J", "B"}));
  const ParameterCorrelation separated = EstimateParameterCorrelation(
      long_problem, FindOptimizer("ceres").Minimize(long_problem, options));
  ASSERT_TRUE(separated.available);
  std::cout << "eight time constants: rho(J, B) = " << separated.correlation(0, 1) << "\n";
  EXPECT_LT(std::abs(separated.correlation(0, 1)), kPoorlySeparableCorrelation);
  EXPECT_TRUE(separated.poorly_separable.empty());
}

}  // namespace
}  // namespace blmd::testing
