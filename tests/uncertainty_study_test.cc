// Calibration of the 95 % intervals on random motors (docs/uncertainty.md): Ganesh-type DC
// servos with random R, L, Kt = Kb, J, B, driven by a +-12 V square wave of eight
// electromechanical time constants, J and B free, 1 % noise (sigma = 1 % of the column's peak)
// on i and w, white or AR(1) with coefficient 0.95. Counts how often the headline interval
// (prewhitened HAC sandwich) and the white-noise interval (Ceres's covariance) cover the
// truth, and the median half-width over the median absolute error (ideal 1.96/0.674 = 2.9).
// STUDY_SEEDS overrides the number of motors (default 100 per noise kind).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "blmd/ident/optimizer.h"
#include "blmd/ident/problem.h"
#include "blmd/io/config.h"
#include "blmd/random.h"
#include "blmd/run.h"

namespace blmd {
namespace {

struct Motor {
  double R, L, K, J, B, tau_m;
};

double LogUniform(Random& random, double lo, double hi) {
  return lo * std::pow(hi / lo, random.Uniform());
}

Motor RandomMotor(Random& random) {
  Motor m{};
  m.R = LogUniform(random, 0.5, 20.0);
  m.L = m.R * LogUniform(random, 2e-4, 5e-3);  // electrical time constant 0.2 .. 5 ms
  m.K = LogUniform(random, 0.02, 0.3);
  m.J = LogUniform(random, 1e-6, 1e-3);
  m.B = LogUniform(random, 1e-6, 1e-3);
  m.tau_m = m.J * m.R / (m.K * m.K + m.R * m.B);
  return m;
}

Config MotorConfig(const Motor& m) {
  // A power-of-two sample rate near 250 samples per time constant and 2048 samples per
  // period (about eight time constants): every edge and sample instant exact in binary.
  const double sample_rate = std::exp2(std::round(std::log2(250.0 / m.tau_m)));
  const double period = 2048.0 / sample_rate;
  char text[2048];
  std::snprintf(text, sizeof text, R"({
  "name": "random-motor", "model": "dc_servo",
  "parameters": { "R": %.17g, "L": %.17g, "Kt": %.17g, "Kb": %.17g, "J": %.17g, "B": %.17g },
  "simulation": { "dt": %.17g },
  "experiment": { "input": { "type": "square", "amplitude": 12.0, "period": %.17g },
                  "duration": %.17g, "sample_rate": %.17g },
  "identification": { "free": ["J", "B"], "initial": { "J": %.17g, "B": %.17g },
                      "bounds": { "J": [%.17g, %.17g], "B": [%.17g, %.17g] },
                      "observe": ["i", "w"], "method": "ceres" }
})",
                m.R, m.L, m.K, m.K, m.J, m.B, 0.25 / sample_rate, period, 2.0 * period, sample_rate,
                2.0 * m.J, 0.5 * m.B, m.J / 100, m.J * 100, m.B / 100, m.B * 100);
  return ParseConfig(text, "random-motor.json");
}

// 1 % noise on i and w: white (rho = 0) or AR(1) with unit marginal variance scaled to sigma.
FitTrace NoisyTrace(const Config& config, Random& random, double rho) {
  Trace trace;
  const SimStatus status = RunExperiment(config, &trace);
  EXPECT_TRUE(status.ok()) << status.message;
  for (const char* column : {"i", "w"}) {
    double peak = 0.0;
    for (double v : trace.Column(column)) peak = std::max(peak, std::abs(v));
    double state = random.Normal();
    for (double& v : trace.Column(column)) {
      v += (std::getenv("STUDY_NOISE_FREE") ? 0.0 : 0.01) * peak * state;
      state = rho * state + std::sqrt(1.0 - rho * rho) * random.Normal();
    }
  }
  FitTrace fit;
  fit.path = "generated";
  fit.input.kind = InputSignal::Kind::kRecorded;
  fit.input.times = trace.Column("t");
  fit.input.values = trace.Column("u");
  fit.initial = config.experiment.initial;
  fit.trace = std::move(trace);
  return fit;
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

struct Calibration {
  int runs = 0;
  int covered[2] = {0, 0};        // headline interval, J and B
  int covered_white[2] = {0, 0};  // white interval
  // Relative to the truth (random motors differ in precision by orders of magnitude, so
  // absolute widths are not comparable); per run: half-width / |error| (ideal median 2.9).
  std::vector<double> error[2], half[2], half_white[2], per_run[2], per_run_white[2];
};

Calibration Study(double rho, int seeds) {
  Calibration c;
  for (int seed = 1; seed <= seeds; ++seed) {
    Random random(static_cast<std::uint64_t>(seed) * 7919u + (rho > 0.0 ? 1u : 0u));
    Motor motor = RandomMotor(random);
    if (std::getenv("STUDY_MOTOR")) {
      Random fixed(static_cast<std::uint64_t>(std::atoi(std::getenv("STUDY_MOTOR"))) * 7919u);
      motor = RandomMotor(fixed);
    }
    const Config config = MotorConfig(motor);
    std::vector<FitTrace> traces;
    traces.push_back(NoisyTrace(config, random, rho));
    const FitProblem problem(config, std::move(traces), {"i", "w"},
                             MakeFreeParameters(config, {"J", "B"}));
    const FitResult result =
        FindOptimizer(std::getenv("STUDY_METHOD") ? std::getenv("STUDY_METHOD") : "ceres")
            .Minimize(problem, OptimizerOptions{});
    EXPECT_TRUE(result.summary.converged) << "seed " << seed << ": " << result.summary.message;
    ++c.runs;
    const double truth[2] = {motor.J, motor.B};
    for (int k = 0; k < 2; ++k) {
      const ParameterEstimate& e = result.estimates[static_cast<std::size_t>(k)];
      const double error = std::abs(e.value - truth[k]) / truth[k];
      c.error[k].push_back(error);
      if (std::getenv("STUDY_VERBOSE")) std::printf("seed %d %s rel %+.3e half %.3e\n", seed, k ? "B" : "J", e.value / truth[k] - 1, 0.5 * (e.ci95_high - e.ci95_low) / truth[k]);
      if (e.has_interval) {
        c.covered[k] += e.ci95_low <= truth[k] && truth[k] <= e.ci95_high;
        c.half[k].push_back(0.5 * (e.ci95_high - e.ci95_low) / truth[k]);
        c.per_run[k].push_back(0.5 * (e.ci95_high - e.ci95_low) / truth[k] / error);
      }
      if (e.has_white_interval) {
        c.covered_white[k] += e.ci95_white_low <= truth[k] && truth[k] <= e.ci95_white_high;
        c.half_white[k].push_back(0.5 * (e.ci95_white_high - e.ci95_white_low) / truth[k]);
        c.per_run_white[k].push_back(0.5 * (e.ci95_white_high - e.ci95_white_low) / truth[k] /
                                     error);
      }
    }
  }
  const char* names[2] = {"J", "B"};
  for (int k = 0; k < 2; ++k) {
    std::printf("rho %.2f %s: coverage %d/%d (white %d/%d); median relative half-width / median "
                "relative |error| %.2f (white %.2f); median per-run half-width/|error| %.2f "
                "(white %.2f)\n",
                rho, names[k], c.covered[k], c.runs, c.covered_white[k], c.runs,
                Median(c.half[k]) / Median(c.error[k]), Median(c.half_white[k]) / Median(c.error[k]),
                Median(c.per_run[k]), Median(c.per_run_white[k]));
  }
  return c;
}

int Seeds() { return std::getenv("STUDY_SEEDS") ? std::atoi(std::getenv("STUDY_SEEDS")) : 100; }

// The issue's bars: coverage 90-98 % and median half-width at most 6x the median error.
void ExpectCalibrated(const Calibration& c) {
  for (int k = 0; k < 2; ++k) {
    EXPECT_GE(c.covered[k], 0.90 * c.runs) << (k ? "B" : "J");
    EXPECT_LE(c.covered[k], 0.98 * c.runs) << (k ? "B" : "J");
    EXPECT_LE(Median(c.half[k]) / Median(c.error[k]), 6.0) << (k ? "B" : "J");
  }
}

TEST(IntervalCalibration, RandomMotorsWhiteNoise) { ExpectCalibrated(Study(0.0, Seeds())); }

TEST(IntervalCalibration, RandomMotorsAr1Noise095) { ExpectCalibrated(Study(0.95, Seeds())); }

}  // namespace
}  // namespace blmd
