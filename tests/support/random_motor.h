// The random motors of the calibration studies (uncertainty_study_test, discovery_study_test;
// docs/uncertainty.md §3, docs/discovery.md §3a): Ganesh-type DC servos with random R, L,
// Kt = Kb, J, B, driven by a +-12 V square wave of about eight electromechanical time
// constants, and their traces with 1 % white or AR(1) noise on i and w.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "blmd/ident/fit/problem.h"
#include "blmd/ident/fit/trace_input.h"
#include "blmd/io/config.h"
#include "blmd/random.h"
#include "blmd/run.h"

namespace blmd::testing {

struct Motor {
  double R, L, K, J, B, tau_m;
};

inline double LogUniform(Random& random, double lo, double hi) {
  return lo * std::pow(hi / lo, random.Uniform());
}

inline Motor RandomMotor(Random& random) {
  Motor m{};
  m.R = LogUniform(random, 0.5, 20.0);
  m.L = m.R * LogUniform(random, 2e-4, 5e-3);  // electrical time constant 0.2 .. 5 ms
  m.K = LogUniform(random, 0.02, 0.3);
  m.J = LogUniform(random, 1e-6, 1e-3);
  m.B = LogUniform(random, 1e-6, 1e-3);
  m.tau_m = m.J * m.R / (m.K * m.K + m.R * m.B);
  return m;
}

// The motor's config with `effects` (the JSON members of "effects", may be empty): J and B
// free from 2J and B/2, bounds x/÷100. A power-of-two sample rate near 250 samples per time
// constant and 2048 samples per period (about eight time constants): every edge and sample
// instant exact in binary.
inline Config MotorConfig(const Motor& m, const std::string& effects = "",
                          const std::string& name = "random-motor.json") {
  const double sample_rate = std::exp2(std::round(std::log2(250.0 / m.tau_m)));
  const double period = 2048.0 / sample_rate;
  char text[4096];
  std::snprintf(text, sizeof text, R"({
  "name": "random-motor", "model": "dc_servo",
  "parameters": { "R": %.17g, "L": %.17g, "Kt": %.17g, "Kb": %.17g, "J": %.17g, "B": %.17g },
  "effects": { %s },
  "simulation": { "dt": %.17g },
  "experiment": { "input": { "type": "square", "amplitude": 12.0, "period": %.17g },
                  "duration": %.17g, "sample_rate": %.17g },
  "identification": { "free": ["J", "B"], "initial": { "J": %.17g, "B": %.17g },
                      "bounds": { "J": [%.17g, %.17g], "B": [%.17g, %.17g] },
                      "observe": ["i", "w"], "method": "ceres" }
})",
                m.R, m.L, m.K, m.K, m.J, m.B, effects.c_str(), 0.25 / sample_rate, period,
                2.0 * period, sample_rate, 2.0 * m.J, 0.5 * m.B, m.J / 100, m.J * 100, m.B / 100,
                m.B * 100);
  return ParseConfig(text, name);
}

// The config's experiment with 1 % noise (sigma = 1 % of the column's peak) on i and w:
// white (rho = 0) or AR(1) with unit marginal variance scaled to sigma. STUDY_NOISE_FREE
// set: no noise.
inline FitTrace ColouredNoiseTrace(const Config& config, Random& random, double rho) {
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
  return RecordedFitTrace(std::move(trace), config.experiment.initial);
}

}  // namespace blmd::testing
