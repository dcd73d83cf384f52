// DC servo (docs/model-dc-servo.md, docs/effects.md): every test compares the simulator
// with an answer derived by hand from the model's equations,
//
//   L di/dt = u_eff - R i - Kb w,   J dw/dt = Kt i - B w - T_effects,   dtheta/dt = w,
//
// never with another run of the simulator's own numerics. The linear responses come from
// the roots of the characteristic polynomial and partial fractions (no matrix exponential),
// the effects from their steady states, stopping instants and torque balances.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include "blmd/io/config.h"
#include "blmd/run.h"
#include "blmd/sim/model.h"
#include "support/test_support.h"

namespace blmd {
namespace {

// Ganesh et al. (2012), no load.
struct Motor {
  double R = 12.6, L = 0.283, Kt = 0.04, Kb = 0.04, J = 2.26e-5, B = 2.261e-5;
  // Denominator of w/u = Kt / (a2 s^2 + a1 s + a0) = Kt / ((R + sL)(Js + B) + Kb Kt).
  double a2() const { return L * J; }
  double a1() const { return R * J + L * B; }
  double a0() const { return R * B + Kb * Kt; }
};

ParameterSet Parameters(const Motor& m = Motor()) {
  ParameterSet p;
  p.Set("R", m.R);
  p.Set("L", m.L);
  p.Set("Kt", m.Kt);
  p.Set("Kb", m.Kb);
  p.Set("J", m.J);
  p.Set("B", m.B);
  return p;
}

// Response of the linear servo (no effects), from rest, to a unit voltage step at t = 0,
// by partial fractions over the roots s1, s2 of a2 s^2 + a1 s + a0 (complex arithmetic so
// that real and complex roots are both handled):
//   w(t)/Kt     = (1/a2) [1/(s1 s2) + e^{s1 t}/(s1 (s1-s2)) + e^{s2 t}/(s2 (s2-s1))]
//   i(t)        = (1/a2) [B/(s1 s2) + (J s1 + B) e^{s1 t}/(s1 (s1-s2)) + (J s2 + B) e^{s2 t}/(s2
//   (s2-s1))] theta(t)/Kt = (1/a2) [t/(s1 s2) + (s1+s2)/(s1 s2)^2 + e^{s1 t}/(s1^2 (s1-s2)) + e^{s2
//   t}/(s2^2 (s2-s1))]
class UnitStep {
 public:
  explicit UnitStep(const Motor& m) : m_(m) {
    const std::complex<double> root =
        std::sqrt(std::complex<double>(m.a1() * m.a1() - 4.0 * m.a2() * m.a0()));
    s1_ = (-m.a1() + root) / (2.0 * m.a2());
    s2_ = (-m.a1() - root) / (2.0 * m.a2());
  }
  double w(double t) const {
    if (t <= 0.0) return 0.0;
    const auto e1 = std::exp(s1_ * t), e2 = std::exp(s2_ * t);
    return m_.Kt / m_.a2() *
           (1.0 / (s1_ * s2_) + e1 / (s1_ * (s1_ - s2_)) + e2 / (s2_ * (s2_ - s1_))).real();
  }
  double i(double t) const {
    if (t <= 0.0) return 0.0;
    const auto e1 = std::exp(s1_ * t), e2 = std::exp(s2_ * t);
    return (1.0 / m_.a2() *
            (m_.B / (s1_ * s2_) + (m_.J * s1_ + m_.B) * e1 / (s1_ * (s1_ - s2_)) +
             (m_.J * s2_ + m_.B) * e2 / (s2_ * (s2_ - s1_))))
        .real();
  }
  double theta(double t) const {
    if (t <= 0.0) return 0.0;
    const auto e1 = std::exp(s1_ * t), e2 = std::exp(s2_ * t);
    const auto p = s1_ * s2_;
    return m_.Kt / m_.a2() *
           (t / p + (s1_ + s2_) / (p * p) + e1 / (s1_ * s1_ * (s1_ - s2_)) +
            e2 / (s2_ * s2_ * (s2_ - s1_)))
               .real();
  }
  std::complex<double> s1() const { return s1_; }
  std::complex<double> s2() const { return s2_; }

 private:
  Motor m_;
  std::complex<double> s1_, s2_;
};

// A piecewise-constant voltage (value levels[k] from instants[k] on, 0 before) applied to
// the linear servo: superposition of shifted unit-step responses.
struct Superposition {
  UnitStep unit;
  std::vector<double> instants, levels;
  double Sum(double t, double (UnitStep::*f)(double) const) const {
    double value = 0.0, previous = 0.0;
    for (std::size_t k = 0; k < instants.size(); ++k) {
      value += (levels[k] - previous) * (unit.*f)(t - instants[k]);
      previous = levels[k];
    }
    return value;
  }
  double w(double t) const { return Sum(t, &UnitStep::w); }
  double i(double t) const { return Sum(t, &UnitStep::i); }
  double theta(double t) const { return Sum(t, &UnitStep::theta); }
};

struct Scenario {
  ParameterSet parameters = Parameters();
  std::vector<std::string> effects;
  Experiment experiment;
  SimulationSettings settings;
  std::vector<double> times;  // empty: experiment.SampleTimes()

  void Effect(const std::string& name,
              std::initializer_list<std::pair<const char*, double>> values) {
    effects.push_back(name);
    for (const auto& [key, value] : values) parameters.Set(key, value);
  }
};

Experiment Step(double amplitude, double duration, double sample_rate) {
  Experiment e;
  e.input.kind = InputSignal::Kind::kStep;
  e.input.amplitude = amplitude;
  e.duration = duration;
  e.sample_rate = sample_rate;
  return e;
}

Trace Simulate(const Scenario& scenario) {
  const Model& model = FindModel("dc_servo");
  const std::vector<double> times =
      scenario.times.empty() ? scenario.experiment.SampleTimes() : scenario.times;
  SimulationRequest request;
  request.parameters = &scenario.parameters;
  request.effects = &scenario.effects;
  request.experiment = &scenario.experiment;
  request.settings = scenario.settings;
  request.sample_times = &times;
  Trace trace;
  const SimStatus status = model.Simulate(request, &trace);
  EXPECT_TRUE(status.ok()) << status.message;
  return trace;
}

// Prints a measured figure so that ctest -V shows it next to its bound.
void Report(const std::string& what, double value, double bound) {
  std::printf("[measured] %s = %.3e (bound %.1e)\n", what.c_str(), value, bound);
  ::testing::Test::RecordProperty(what, std::to_string(value));
}

// ---------------------------------------------------------------------------------------
// Linear model against the closed-form responses.

TEST(DcServoLinear, VoltageStepMatchesPartialFractionResponse) {
  const Motor m;
  const double U = 24.0;
  Scenario s;
  s.experiment = Step(U, 0.5, 10000.0);
  s.settings.dt = 1e-5;
  const Trace trace = Simulate(s);
  const UnitStep unit(m);
  // Distinct real roots for Ganesh's motor: -7.82 and -37.7 rad/s.
  EXPECT_NEAR(unit.s1().real(), -7.81552, 1e-5);
  EXPECT_NEAR(unit.s2().real(), -37.70789, 1e-5);
  EXPECT_EQ(unit.s1().imag(), 0.0);
  const double w_final = m.Kt * U / m.a0();
  const double i_final = m.B * U / m.a0();
  const auto& t = trace.Column("t");
  double w_error = 0.0, i_error = 0.0, theta_error = 0.0, theta_scale = 0.0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    w_error = std::max(w_error, std::abs(trace.Column("w")[k] - U * unit.w(t[k])));
    i_error = std::max(i_error, std::abs(trace.Column("i")[k] - U * unit.i(t[k])));
    theta_error = std::max(theta_error, std::abs(trace.Column("theta")[k] - U * unit.theta(t[k])));
    theta_scale = std::max(theta_scale, std::abs(U * unit.theta(t[k])));
  }
  Report("step max |w - w_exact| / w_final", w_error / w_final, 1e-4);
  Report("step max |i - i_exact| / i_peak-ish (i_final)", i_error / i_final, 1e-4);
  Report("step max |theta - theta_exact| / theta_max", theta_error / theta_scale, 1e-4);
  EXPECT_LT(w_error, 1e-4 * w_final);
  EXPECT_LT(i_error, 1e-4 * i_final);
  EXPECT_LT(theta_error, 1e-4 * theta_scale);
  EXPECT_EQ(trace.Column("u").front(), U);
}

// The discretisation is exact for a piecewise-constant input (zero-order hold), so a step
// 100 times coarser still reproduces the continuous response to rounding error; a
// first-order method would be off by about dt/tau_e = 4 % here.
TEST(DcServoLinear, ZeroOrderHoldIsExactEvenWithCoarseStep) {
  const Motor m;
  const double U = 24.0;
  Scenario s;
  s.experiment = Step(U, 0.5, 1000.0);
  s.settings.dt = 1e-3;
  const Trace trace = Simulate(s);
  const UnitStep unit(m);
  const double w_final = m.Kt * U / m.a0();
  const auto& t = trace.Column("t");
  double w_error = 0.0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    w_error = std::max(w_error, std::abs(trace.Column("w")[k] - U * unit.w(t[k])));
  }
  Report("coarse dt=1e-3 max |w - w_exact| / w_final", w_error / w_final, 1e-9);
  EXPECT_LT(w_error, 1e-9 * w_final);
}

TEST(DcServoLinear, SteadyStateSpeedAndCurrent) {
  const Motor m;
  for (double U : {24.0, -24.0, 6.0}) {
    Scenario s;
    s.experiment = Step(U, 3.0, 100.0);
    const Trace trace = Simulate(s);
    const double w_ss = m.Kt * U / (m.R * m.B + m.Kt * m.Kb);
    const double i_ss = m.B * w_ss / m.Kt;  // Ganesh eq. 8: B = Kt i / w
    const double w_end = trace.Column("w").back(), i_end = trace.Column("i").back();
    Report("steady |w/w_ss - 1| at U=" + std::to_string(U), std::abs(w_end / w_ss - 1.0), 1e-6);
    EXPECT_NEAR(w_end / w_ss, 1.0, 1e-6) << "U = " << U;
    EXPECT_NEAR(i_end / i_ss, 1.0, 1e-6) << "U = " << U;
    // Back EMF (Ganesh eqs. 1-2): u - R i = Kb w at steady state.
    EXPECT_NEAR((U - m.R * i_end) / (m.Kb * w_end), 1.0, 1e-6);
  }
}

// Samples between the simulator's steps are read by linear interpolation: the error is at
// most dt^2/8 max|w''|, and max|w''| = Kt U / (L J) at t = 0+ for this response.
TEST(DcServoLinear, IrregularSampleTimesAreInterpolated) {
  const Motor m;
  const double U = 24.0, dt = 1e-5;
  Scenario s;
  s.experiment = Step(U, 0.3, 1000.0);
  s.settings.dt = dt;
  for (double t = 0.0; t < 0.3; t += 0.00123457) s.times.push_back(t);
  const Trace trace = Simulate(s);
  ASSERT_EQ(trace.rows(), s.times.size());
  const UnitStep unit(m);
  double w_error = 0.0;
  for (std::size_t k = 0; k < s.times.size(); ++k) {
    EXPECT_EQ(trace.Column("t")[k], s.times[k]);
    w_error = std::max(w_error, std::abs(trace.Column("w")[k] - U * unit.w(s.times[k])));
  }
  const double bound = dt * dt / 8.0 * m.Kt * U / (m.L * m.J) + 1e-9 * m.Kt * U / m.a0();
  Report("irregular samples max |w - w_exact| (rad/s)", w_error, bound);
  EXPECT_LE(w_error, bound);
}

// ---------------------------------------------------------------------------------------
// Inputs: the u column is the specified signal, and the model is driven by it.

// Square wave: high (offset + amplitude) on [t0 + nP, t0 + (n + 1/2) P), low otherwise,
// offset before t0. The switching instants lie on the dt grid, halfway between samples.
TEST(DcServoInputs, SquareWaveColumnAndResponse) {
  const Motor m;
  Scenario s;
  s.experiment.input.kind = InputSignal::Kind::kSquare;
  s.experiment.input.amplitude = 10.0;
  s.experiment.input.offset = 2.0;
  s.experiment.input.t0 = 0.00205;
  s.experiment.input.period = 0.01;
  s.experiment.duration = 0.1;
  s.experiment.sample_rate = 10000.0;
  const Trace trace = Simulate(s);
  const auto& t = trace.Column("t");
  const auto& u = trace.Column("u");
  Superposition exact{UnitStep(m), {0.0}, {2.0}};
  for (int n = 0; n < 20; ++n) {
    exact.instants.push_back(0.00205 + 0.005 * n);
    exact.levels.push_back(n % 2 == 0 ? 12.0 : -8.0);
  }
  int mismatches = 0;
  double w_error = 0.0, i_error = 0.0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    double expected = 2.0;
    if (t[k] >= 0.00205) {
      const double periods = (t[k] - 0.00205) / 0.01;
      const double fraction = periods - std::floor(periods);
      expected = fraction < 0.5 ? 12.0 : -8.0;
    }
    if (u[k] != expected) ++mismatches;
    w_error = std::max(w_error, std::abs(trace.Column("w")[k] - exact.w(t[k])));
    i_error = std::max(i_error, std::abs(trace.Column("i")[k] - exact.i(t[k])));
  }
  EXPECT_EQ(mismatches, 0);
  const double w_scale = m.Kt * 12.0 / m.a0(), i_scale = 12.0 / m.R;
  Report("square max |w - w_exact| / (Kt 12/a0)", w_error / w_scale, 1e-9);
  Report("square max |i - i_exact| / (12/R)", i_error / i_scale, 1e-9);
  EXPECT_LT(w_error, 1e-9 * w_scale);
  EXPECT_LT(i_error, 1e-9 * i_scale);
}

// Steps input: values[k] from times[k] on, offset before times[0]. Run at several dt: the
// switching instants are on every grid, so the response must match the superposition of
// exact step responses to rounding error whatever the step (a switch one step late costs
// about U dt / L in current, i.e. 1e-4..1e-3 relative).
TEST(DcServoInputs, StepsColumnAndResponseAtSeveralSteps) {
  const Motor m;
  for (double dt : {1e-5, 1e-6, 2e-6, 5e-5}) {
    Scenario s;
    s.experiment.input.kind = InputSignal::Kind::kSteps;
    s.experiment.input.offset = 1.0;
    s.experiment.input.times = {0.005, 0.012, 0.021, 0.03};
    s.experiment.input.values = {5.0, -3.0, 10.0, 24.0};
    s.experiment.duration = 0.05;
    s.experiment.sample_rate = 20000.0;
    s.settings.dt = dt;
    const Trace trace = Simulate(s);
    const Superposition exact{
        UnitStep(m), {0.0, 0.005, 0.012, 0.021, 0.03}, {1.0, 5.0, -3.0, 10.0, 24.0}};
    const auto& t = trace.Column("t");
    int mismatches = 0;
    double i_error = 0.0, w_error = 0.0;
    for (std::size_t k = 0; k < t.size(); ++k) {
      // Sample instants k/20000 and switching instants are both exact multiples of 1e-4 s
      // in decimal; compare on the integer sample index to stay clear of rounding.
      const long index = std::lround(t[k] * 20000.0);
      const double expected = index < 100   ? 1.0
                              : index < 240 ? 5.0
                              : index < 420 ? -3.0
                              : index < 600 ? 10.0
                                            : 24.0;
      if (trace.Column("u")[k] != expected) ++mismatches;
      i_error = std::max(i_error, std::abs(trace.Column("i")[k] - exact.i(t[k])));
      w_error = std::max(w_error, std::abs(trace.Column("w")[k] - exact.w(t[k])));
    }
    EXPECT_EQ(mismatches, 0) << "dt = " << dt;
    const double i_scale = 24.0 / m.R, w_scale = m.Kt * 24.0 / m.a0();
    Report("steps dt=" + std::to_string(dt) + " max |i - i_exact| / (24/R)", i_error / i_scale,
           1e-9);
    EXPECT_LT(i_error, 1e-9 * i_scale) << "dt = " << dt;
    EXPECT_LT(w_error, 1e-9 * w_scale) << "dt = " << dt;
  }
}

// The steady-state sweep of Ganesh §II (several constant voltages, steady i and w at each):
// config type "sweep" holds each level for `hold` seconds from t = 0.
TEST(DcServoInputs, SweepHoldsEachLevelAndReachesEachSteadyState) {
  const Motor m;
  const Config config = ParseConfig(R"({
    "model": "dc_servo",
    "parameters": { "R": 12.6, "L": 0.283, "Kt": 0.04, "Kb": 0.04, "J": 2.26e-5, "B": 2.261e-5 },
    "experiment": { "input": { "type": "sweep", "levels": [6, 12, 24], "hold": 2.5 },
                    "duration": 7.5, "sample_rate": 1000 }
  })",
                                    "sweep.json");
  Trace trace;
  ASSERT_TRUE(RunExperiment(config, &trace).ok());
  const auto& t = trace.Column("t");
  const auto& u = trace.Column("u");
  ASSERT_EQ(t.size(), 7501u);
  for (std::size_t k = 0; k < t.size(); ++k) {
    const double expected = k < 2500 ? 6.0 : (k < 5000 ? 12.0 : 24.0);
    ASSERT_EQ(u[k], expected) << "t = " << t[k];
  }
  for (const auto& [index, U] :
       {std::pair<std::size_t, double>{2499, 6.0}, {4999, 12.0}, {7500, 24.0}}) {
    const double w_ss = m.Kt * U / m.a0(), i_ss = m.B * U / m.a0();
    EXPECT_NEAR(trace.Column("w")[index] / w_ss, 1.0, 1e-6) << "level " << U;
    EXPECT_NEAR(trace.Column("i")[index] / i_ss, 1.0, 1e-6) << "level " << U;
    // Ganesh's classical estimators recover Kb and B from these points (eqs. 1, 2, 8).
    EXPECT_NEAR((U - m.R * trace.Column("i")[index]) / trace.Column("w")[index], m.Kb, 1e-7);
    EXPECT_NEAR(m.Kt * trace.Column("i")[index] / trace.Column("w")[index], m.B, 1e-10);
  }
}

// Recorded input: zero-order hold of the recorded samples (values[k] on [t_k, t_k+1)).
TEST(DcServoInputs, RecordedInputIsHeldBetweenSamples) {
  const Motor m;
  Scenario s;
  s.experiment.input.kind = InputSignal::Kind::kRecorded;
  s.experiment.input.times = {0.0, 0.004, 0.0105, 0.02};
  s.experiment.input.values = {3.0, 12.0, -6.0, 0.0};
  s.experiment.duration = 0.04;
  s.experiment.sample_rate = 10000.0;
  const Trace trace = Simulate(s);
  const Superposition exact{UnitStep(m), {0.0, 0.004, 0.0105, 0.02}, {3.0, 12.0, -6.0, 0.0}};
  double i_error = 0.0;
  for (std::size_t k = 0; k < trace.rows(); ++k) {
    i_error = std::max(i_error, std::abs(trace.Column("i")[k] - exact.i(trace.Column("t")[k])));
  }
  EXPECT_LT(i_error, 1e-9 * 12.0 / m.R);
  EXPECT_EQ(trace.Column("u")[39], 3.0);    // t = 0.0039
  EXPECT_EQ(trace.Column("u")[40], 12.0);   // t = 0.004
  EXPECT_EQ(trace.Column("u")[104], 12.0);  // t = 0.0104
  EXPECT_EQ(trace.Column("u")[105], -6.0);  // t = 0.0105
  EXPECT_EQ(trace.Column("u")[400], 0.0);
}

// Recorded input with an `open` column: 1 opens the armature (coast-down), i = 0 exactly.
TEST(DcServoInputs, RecordedOpenColumnCoastsDown) {
  const Motor m;
  Scenario s;
  s.experiment.input.kind = InputSignal::Kind::kRecorded;
  s.experiment.input.times = {0.0, 2.0};
  s.experiment.input.values = {24.0, 24.0};
  s.experiment.input.open = {0.0, 1.0};
  s.experiment.duration = 3.0;
  s.experiment.sample_rate = 1000.0;
  const Trace trace = Simulate(s);
  const auto& t = trace.Column("t");
  const double w_off = trace.Column("w")[2000];
  EXPECT_NEAR(w_off, 24.0 * UnitStep(m).w(2.0), 1e-9 * w_off);
  double error = 0.0;
  for (std::size_t k = 2001; k < t.size(); ++k) {
    EXPECT_EQ(trace.Column("i")[k], 0.0) << "t = " << t[k];
    error = std::max(error,
                     std::abs(trace.Column("w")[k] - w_off * std::exp(-m.B / m.J * (t[k] - 2.0))));
  }
  EXPECT_LT(error, 1e-6 * w_off);
}

// ---------------------------------------------------------------------------------------
// Coast-down (Ganesh eqs. 9-11): armature opened at t_off, i = 0, J dw/dt = -B w - T_effects.

TEST(DcServoCoastDown, ExponentialWithoutEffects) {
  const Motor m;
  Scenario s;
  s.experiment = Step(24.0, 4.0, 1000.0);
  s.experiment.coast_off_time = 2.5;
  const Trace trace = Simulate(s);
  const auto& t = trace.Column("t");
  const std::size_t off = 2500;
  ASSERT_EQ(t[off], 2.5);
  const double w0 = trace.Column("w")[off];
  EXPECT_NEAR(w0, 24.0 * UnitStep(m).w(2.5), 1e-9 * w0);
  double error = 0.0;
  for (std::size_t k = off + 1; k < t.size(); ++k) {
    ASSERT_EQ(trace.Column("i")[k], 0.0) << "t = " << t[k];
    error =
        std::max(error, std::abs(trace.Column("w")[k] - w0 * std::exp(-m.B * (t[k] - 2.5) / m.J)));
  }
  Report("coast-down max |w - w0 exp(-B t/J)| / w0", error / w0, 1e-6);
  EXPECT_LT(error, 1e-6 * w0);
  // Ganesh eq. 11: J = B tau, tau = time to fall to 36.8 % (e^-1) of the initial speed.
  const double tau = m.J / m.B;
  const std::size_t k_tau = off + static_cast<std::size_t>(std::lround(tau * 1000.0));
  EXPECT_NEAR(trace.Column("w")[k_tau] / w0, std::exp(-(t[k_tau] - 2.5) / tau), 1e-9);
}

// The armature opens at t_off on any step grid, also where t_start + k dt rounds below
// t_off (0.034 s with dt = 1e-6 or 2e-6): opening one step late would cost about
// (dw/dt) dt = 1e-5 of the speed, 10^4 times the bound.
TEST(DcServoCoastDown, OpensAtTheInstantOnEveryStepGrid) {
  const Motor m;
  const double t_off = 0.034;
  for (double dt : {1e-5, 1e-6, 2e-6}) {
    Scenario s;
    s.experiment = Step(24.0, 0.06, 10000.0);
    s.experiment.coast_off_time = t_off;
    s.settings.dt = dt;
    const Trace trace = Simulate(s);
    const auto& t = trace.Column("t");
    const double w_off = 24.0 * UnitStep(m).w(t_off);
    double error = 0.0;
    for (std::size_t k = 0; k < t.size(); ++k) {
      const double exact = t[k] <= t_off ? 24.0 * UnitStep(m).w(t[k])
                                         : w_off * std::exp(-m.B * (t[k] - t_off) / m.J);
      error = std::max(error, std::abs(trace.Column("w")[k] - exact));
      if (t[k] > t_off) {
        EXPECT_EQ(trace.Column("i")[k], 0.0) << "t = " << t[k];
      }
    }
    Report("coast at t_off=0.034 dt=" + std::to_string(dt) + " max |w - w_exact| / w_off",
           error / w_off, 1e-9);
    EXPECT_LT(error, 1e-9 * w_off) << "dt = " << dt;
  }
}

// A coast-down trace (RunExperiment marks the open armature in an `open` column) replays
// exactly as a recorded input through its u and open columns.
TEST(DcServoCoastDown, TraceReplaysThroughItsUAndOpenColumns) {
  const Config config = ParseConfig(R"({
    "model": "dc_servo",
    "parameters": { "R": 12.6, "L": 0.283, "Kt": 0.04, "Kb": 0.04, "J": 2.26e-5, "B": 2.261e-5 },
    "effects": { "coulomb_friction": { "Tc": 0.002 } },
    "experiment": { "input": { "type": "step", "amplitude": 24.0 }, "coast_off_time": 1.5,
                    "duration": 4.0, "sample_rate": 1000 }
  })",
                                    "coast.json");
  Trace trace;
  ASSERT_TRUE(RunExperiment(config, &trace).ok());
  ASSERT_TRUE(trace.Has("open"));
  EXPECT_EQ(trace.Column("open")[1499], 0.0);
  EXPECT_EQ(trace.Column("open")[1500], 1.0);
  InputSignal recorded;
  recorded.kind = InputSignal::Kind::kRecorded;
  recorded.times = trace.Column("t");
  recorded.values = trace.Column("u");
  recorded.open = trace.Column("open");
  Config replay_config = config;
  replay_config.experiment.coast_off_time = -1.0;
  Trace replay;
  ASSERT_TRUE(RunExperiment(replay_config, &replay, &recorded).ok());
  EXPECT_EQ(replay.Column("w"), trace.Column("w"));
  EXPECT_EQ(replay.Column("i"), trace.Column("i"));
  EXPECT_EQ(trace.Column("w").back(), 0.0);  // stopped by the friction before 4 s
}

// Coast-down from a given initial speed (armature open from t = 0) under Coulomb friction:
// J dw/dt = -B w - Tc, w(t) = (w0 + Tc/B) e^{-B t/J} - Tc/B, which reaches zero at
// t* = (J/B) ln(1 + B w0 / Tc); after that the shaft stays stopped (w == 0, theta fixed).
TEST(DcServoCoastDown, CoulombFrictionStopsAtTheAnalyticInstant) {
  const Motor m;
  const double w0 = 400.0, Tc = 0.004, fs = 10000.0, dt = 1e-5;
  Scenario s;
  s.Effect("coulomb_friction", {{"Tc", Tc}});
  s.experiment = Step(24.0, 2.0, fs);
  s.experiment.coast_off_time = 0.0;
  s.experiment.initial.w = w0;
  s.settings.dt = dt;
  const Trace trace = Simulate(s);
  const auto& t = trace.Column("t");
  const auto& w = trace.Column("w");
  const auto& theta = trace.Column("theta");
  const double t_stop = m.J / m.B * std::log(1.0 + m.B * w0 / Tc);
  EXPECT_NEAR(t_stop, 1.18150, 1e-4);
  std::size_t first_zero = t.size();
  double error = 0.0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (w[k] == 0.0) {
      first_zero = k;
      break;
    }
    error = std::max(error,
                     std::abs(w[k] - ((w0 + Tc / m.B) * std::exp(-m.B * t[k] / m.J) - Tc / m.B)));
  }
  ASSERT_LT(first_zero, t.size());
  Report("coulomb coast-down max |w - w_exact| / w0", error / w0, 1e-6);
  Report("coulomb coast-down first zero sample - t* (s)", t[first_zero] - t_stop, 1.0 / fs + dt);
  EXPECT_LT(error, 1e-6 * w0);
  EXPECT_LT(t[first_zero - 1], t_stop);
  EXPECT_GE(t[first_zero], t_stop);
  EXPECT_LE(t[first_zero] - t_stop, 1.0 / fs + dt);
  // theta(t*) = (w0 + Tc/B)(J/B)(1 - e^{-B t*/J}) - Tc t*/B; the last partial step is
  // integrated with the trapezoid rule, off by at most (Tc/J) dt^2.
  const double theta_stop =
      (w0 + Tc / m.B) * (m.J / m.B) * (1.0 - std::exp(-m.B * t_stop / m.J)) - Tc * t_stop / m.B;
  EXPECT_NEAR(theta[first_zero], theta_stop, Tc / m.J * dt * dt + 1e-9 * theta_stop);
  for (std::size_t k = first_zero; k < t.size(); ++k) {
    ASSERT_EQ(w[k], 0.0) << "t = " << t[k];
    ASSERT_EQ(theta[k], theta[first_zero]) << "t = " << t[k];
    ASSERT_EQ(trace.Column("i")[k], 0.0);
  }
}

// ---------------------------------------------------------------------------------------
// Effects: sign conventions and numbers by hand. All enter J dw/dt = Kt i - B w - T_effects.

double SteadySpeed(const Motor& m, double U, double T_const) {
  // Kt (U - Kb w)/R = B w + T_const  =>  w = (Kt U - R T_const) / (R B + Kt Kb)
  return (m.Kt * U - m.R * T_const) / m.a0();
}

// Below the breakaway torque the shaft never moves: i settles at u/R (armature alone),
// Kt u/R < Tc, and w, theta stay exactly 0 over a long run.
TEST(DcServoEffects, CoulombSticksBelowTc) {
  const Motor m;
  const double Tc = 0.02;  // Kt u/R = 0.019 N m at 6 V
  for (double U : {6.0, -6.0}) {
    Scenario s;
    s.Effect("coulomb_friction", {{"Tc", Tc}});
    s.experiment = Step(U, 5.0, 1000.0);
    const Trace trace = Simulate(s);
    for (std::size_t k = 0; k < trace.rows(); ++k) {
      ASSERT_EQ(trace.Column("w")[k], 0.0) << "t = " << trace.Column("t")[k];
      ASSERT_EQ(trace.Column("theta")[k], 0.0) << "t = " << trace.Column("t")[k];
    }
    EXPECT_NEAR(trace.Column("i").back(), U / m.R, 1e-12);
  }
}

// Above it the shaft breaks away when Kt i(t) = Tc, i(t) = (u/R)(1 - e^{-R t/L}):
// t_b = -(L/R) ln(1 - R Tc / (Kt u)), and then runs at w = (Kt u - R Tc)/(R B + Kt Kb).
TEST(DcServoEffects, CoulombBreaksAwayAboveTcAtTheAnalyticInstant) {
  const Motor m;
  const double Tc = 0.02, U = 7.0, fs = 10000.0, dt = 1e-5;
  const double t_break = -(m.L / m.R) * std::log(1.0 - m.R * Tc / (m.Kt * U));
  EXPECT_NEAR(t_break, 0.0517, 1e-4);
  double w_positive = 0.0;
  for (double sign : {1.0, -1.0}) {
    Scenario s;
    s.Effect("coulomb_friction", {{"Tc", Tc}});
    s.experiment = Step(sign * U, 4.0, fs);
    s.settings.dt = dt;
    const Trace trace = Simulate(s);
    const auto& t = trace.Column("t");
    const auto& w = trace.Column("w");
    for (std::size_t k = 0; k < t.size(); ++k) {
      if (t[k] <= t_break) {
        ASSERT_EQ(w[k], 0.0) << "t = " << t[k];
      } else if (t[k] >= t_break + dt + 1.0 / fs) {
        ASSERT_GT(sign * w[k], 0.0) << "t = " << t[k];
      }
    }
    const double w_ss = sign * SteadySpeed(m, U, Tc);
    EXPECT_NEAR(w.back() / w_ss, 1.0, 1e-6);
    if (sign > 0) {
      w_positive = w.back();
    } else {
      EXPECT_EQ(w.back(), -w_positive);  // friction is odd in w
    }
  }
}

TEST(DcServoEffects, ReversalAfterAStopIsContinuousInTheInitialState) {
  // Spinning at w0 against -12 V with Coulomb friction: the shaft stops and reverses. w at
  // 0.3 s against w0 from 100 to 101 rad/s, the stop instant moving through steps of 1e-5 s:
  // a reversal that waits for the next step makes w a saw-tooth in w0 (a cost with jumps);
  // breaking away within the step the shaft stopped in leaves it smooth.
  std::vector<double> end;
  for (int k = 0; k <= 100; ++k) {
    Scenario s;
    s.Effect("coulomb_friction", {{"Tc", 0.002}});
    s.experiment = Step(-12.0, 0.3, 1000.0);
    s.experiment.initial.w = 100.0 + 0.01 * k;
    s.settings.dt = 1e-5;
    end.push_back(Simulate(s).Column("w").back());
  }
  double worst = 0.0, slope = 0.0;
  for (std::size_t k = 2; k < end.size(); ++k) {
    worst = std::max(worst, std::abs(end[k] - 2.0 * end[k - 1] + end[k - 2]));
    slope = std::max(slope, std::abs(end[k] - end[k - 1]));
  }
  EXPECT_LT(worst, 1e-3 * slope) << "slope " << slope;
}

TEST(DcServoEffects, LoadTorqueIsSignedAndOpposesPositiveMotion) {
  const Motor m;
  for (double TL : {0.005, -0.005}) {
    Scenario s;
    s.Effect("load_torque", {{"TL", TL}});
    s.experiment = Step(24.0, 3.0, 100.0);
    const Trace trace = Simulate(s);
    const double w_ss = SteadySpeed(m, 24.0, TL);
    EXPECT_NEAR(trace.Column("w").back() / w_ss, 1.0, 1e-6) << "TL = " << TL;
    // Positive TL lowers the speed, negative TL raises it.
    EXPECT_EQ(trace.Column("w").back() < m.Kt * 24.0 / m.a0(), TL > 0.0);
  }
  // With no voltage a positive TL drives the shaft backwards: w = -R TL / (R B + Kt Kb).
  Scenario s;
  s.Effect("load_torque", {{"TL", 0.005}});
  s.experiment = Step(0.0, 3.0, 100.0);
  const Trace trace = Simulate(s);
  EXPECT_NEAR(trace.Column("w").back() / (-m.R * 0.005 / m.a0()), 1.0, 1e-6);
  EXPECT_LT(trace.Column("w").back(), 0.0);
}

// Kt (u - Kb w)/R = B w + Cd w|w|  =>  for u > 0: Cd w^2 + b w - c = 0 with
// b = B + Kt Kb / R, c = Kt u / R, w = 2c / (b + sqrt(b^2 + 4 Cd c)); odd in u.
TEST(DcServoEffects, QuadraticDragSteadyState) {
  const Motor m;
  const double Cd = 1e-7;
  for (double U : {24.0, -24.0}) {
    Scenario s;
    s.Effect("quadratic_drag", {{"Cd", Cd}});
    s.experiment = Step(U, 3.0, 100.0);
    const Trace trace = Simulate(s);
    const double b = m.B + m.Kt * m.Kb / m.R, c = m.Kt * std::abs(U) / m.R;
    const double w_ss = std::copysign(2.0 * c / (b + std::sqrt(b * b + 4.0 * Cd * c)), U);
    EXPECT_NEAR(trace.Column("w").back() / w_ss, 1.0, 1e-6) << "U = " << U;
    EXPECT_LT(std::abs(w_ss), m.Kt * 24.0 / m.a0());  // drag slows the shaft
  }
}

// T_cog = Tcog sin(periods theta + phase) is subtracted from the drive torque: starting at
// rest with theta = 0, phase = pi/2, it is +Tcog, so the shaft accelerates backwards at
// -Tcog/J.
TEST(DcServoEffects, CoggingTorqueSignAtRest) {
  const Motor m;
  const double Tcog = 0.01;
  Scenario s;
  s.Effect("cogging", {{"Tcog", Tcog}, {"periods", 6.0}, {"phase", std::numbers::pi / 2}});
  s.experiment = Step(0.0, 0.001, 10000.0);
  const Trace trace = Simulate(s);
  const double t1 = trace.Column("t")[1];
  EXPECT_NEAR(trace.Column("w")[1] / (-Tcog / m.J * t1), 1.0, 1e-3);
}

// A constant drive balanced by cogging: at rest Kt u/R = Tcog sin(periods theta + phase); the
// stable equilibrium reached from theta = 0 (phase 0) is periods theta = asin(Kt u/(R Tcog)).
TEST(DcServoEffects, CoggingHoldsTheShaftWhereTheTorquesBalance) {
  const Motor m;
  const double Tcog = 0.01, periods = 6.0;
  const double U = 0.5 * Tcog * m.R / m.Kt;  // Kt i = Tcog / 2
  Scenario s;
  s.Effect("cogging", {{"Tcog", Tcog}, {"periods", periods}, {"phase", 0.0}});
  s.experiment = Step(U, 20.0, 100.0);
  const Trace trace = Simulate(s);
  const double theta_eq = std::asin(0.5) / periods;
  Report("cogging balance |theta - theta_eq| (rad)",
         std::abs(trace.Column("theta").back() - theta_eq), 1e-9);
  EXPECT_NEAR(trace.Column("theta").back(), theta_eq, 1e-9);
  EXPECT_NEAR(trace.Column("i").back(), U / m.R, 1e-12);
  EXPECT_NEAR(trace.Column("w").back(), 0.0, 1e-9);
}

// u_eff = u - Vdt sign(i): the steady state is that of the linear motor at u - Vdt.
TEST(DcServoEffects, DeadTimeLowersTheEffectiveVoltage) {
  const Motor m;
  const double Vdt = 2.0;
  for (double U : {24.0, -24.0}) {
    Scenario s;
    s.Effect("dead_time", {{"Vdt", Vdt}});
    s.experiment = Step(U, 3.0, 100.0);
    const Trace trace = Simulate(s);
    const double u_eff = U - std::copysign(Vdt, U);
    EXPECT_NEAR(trace.Column("w").back() / (m.Kt * u_eff / m.a0()), 1.0, 1e-6) << "U = " << U;
    EXPECT_NEAR(trace.Column("i").back() / (m.B * u_eff / m.a0()), 1.0, 1e-6) << "U = " << U;
    EXPECT_EQ(trace.Column("u").back(), U);  // the column holds the commanded voltage
  }
}

// current_offset changes the measurement only: i column = true i + i0 exactly, w and theta
// identical.
TEST(DcServoEffects, CurrentOffsetAddsToTheMeasuredCurrentOnly) {
  Scenario plain;
  plain.experiment = Step(24.0, 0.2, 10000.0);
  Scenario offset = plain;
  offset.Effect("current_offset", {{"i0", -0.0375}});
  const Trace a = Simulate(plain), b = Simulate(offset);
  ASSERT_EQ(a.rows(), b.rows());
  for (std::size_t k = 0; k < a.rows(); ++k) {
    ASSERT_EQ(b.Column("i")[k], a.Column("i")[k] + -0.0375) << k;
    ASSERT_EQ(b.Column("w")[k], a.Column("w")[k]) << k;
    ASSERT_EQ(b.Column("theta")[k], a.Column("theta")[k]) << k;
  }
}

// Stribeck friction adds Ts exp(-(w/ws)^2) sign(w): breakaway needs Tc + Ts, after which the
// friction falls back to Tc (w >> ws).
TEST(DcServoEffects, StribeckBreakawayNeedsTcPlusTs) {
  const Motor m;
  const double Tc = 0.01, Ts = 0.01, ws = 1.0;
  const double U_stuck = 0.015 * m.R / m.Kt;  // Kt u/R = 0.015 N m: above Tc, below Tc + Ts
  const double U_moves = 0.025 * m.R / m.Kt;  // 0.025 N m
  {
    Scenario s;
    s.Effect("coulomb_friction", {{"Tc", Tc}});
    s.Effect("stribeck", {{"Ts", Ts}, {"ws", ws}});
    s.experiment = Step(U_stuck, 3.0, 1000.0);
    const Trace trace = Simulate(s);
    for (std::size_t k = 0; k < trace.rows(); ++k) ASSERT_EQ(trace.Column("w")[k], 0.0);
    // Coulomb alone (the same drive) breaks away.
    Scenario c;
    c.Effect("coulomb_friction", {{"Tc", Tc}});
    c.experiment = s.experiment;
    EXPECT_NEAR(Simulate(c).Column("w").back() / SteadySpeed(m, U_stuck, Tc), 1.0, 1e-6);
  }
  {
    Scenario s;
    s.Effect("coulomb_friction", {{"Tc", Tc}});
    s.Effect("stribeck", {{"Ts", Ts}, {"ws", ws}});
    s.experiment = Step(U_moves, 4.0, 10000.0);
    const Trace trace = Simulate(s);
    const double t_break = -(m.L / m.R) * std::log(1.0 - m.R * (Tc + Ts) / (m.Kt * U_moves));
    for (std::size_t k = 0; k < trace.rows(); ++k) {
      const double t = trace.Column("t")[k];
      if (t <= t_break) {
        ASSERT_EQ(trace.Column("w")[k], 0.0) << "t = " << t;
      }
      if (t >= t_break + 1e-5 + 1e-4) {
        ASSERT_GT(trace.Column("w")[k], 0.0) << "t = " << t;
      }
    }
    // Running at ~100 rad/s = 100 ws, exp(-(w/ws)^2) = 0: only Tc remains.
    EXPECT_NEAR(trace.Column("w").back() / SteadySpeed(m, U_moves, Tc), 1.0, 1e-6);
  }
}

// simulation.friction_smoothing_w = eps replaces sign(w) by tanh(w/eps), without sticking:
// the steady state solves Kt (u - Kb w)/R = B w + Tc tanh(w/eps) (bisection here), and a
// drive below Tc now creeps instead of sticking.
TEST(DcServoEffects, SmoothedFrictionSteadyStateAndNoSticking) {
  const Motor m;
  const double Tc = 0.01, eps = 1.0;
  for (double U : {24.0, 3.0}) {  // Kt u/R = 0.076 and 0.0095 N m (the latter below Tc)
    Scenario s;
    s.Effect("coulomb_friction", {{"Tc", Tc}});
    s.settings.friction_smoothing_w = eps;
    s.experiment = Step(U, 4.0, 100.0);
    const Trace trace = Simulate(s);
    auto f = [&](double w) {
      return m.Kt * (U - m.Kb * w) / m.R - m.B * w - Tc * std::tanh(w / eps);
    };
    double lo = 0.0, hi = m.Kt * U / m.a0();
    for (int k = 0; k < 200; ++k) (f(0.5 * (lo + hi)) > 0.0 ? lo : hi) = 0.5 * (lo + hi);
    EXPECT_NEAR(trace.Column("w").back() / lo, 1.0, 1e-6) << "U = " << U;
    EXPECT_GT(lo, 0.0);
  }
}

// ---------------------------------------------------------------------------------------
// Run status and time origin.

// A recorded trace need not start at t = 0: the run starts at the first sample instant.
TEST(DcServoRun, StartsAtTheFirstSampleTime) {
  const Motor m;
  Scenario s;
  s.experiment = Step(24.0, 0.0, 10000.0);
  s.experiment.input.t0 = 5.0;
  for (int k = 0; k <= 3000; ++k) s.times.push_back(5.0 + k * 1e-4);
  const Trace trace = Simulate(s);
  const UnitStep unit(m);
  double error = 0.0;
  for (std::size_t k = 0; k < s.times.size(); ++k) {
    error = std::max(error, std::abs(trace.Column("w")[k] - 24.0 * unit.w(s.times[k] - 5.0)));
  }
  EXPECT_LT(error, 1e-9 * m.Kt * 24.0 / m.a0());
}

// A state beyond settings.divergence_limit ends the run with kDiverged at the first step
// end past the crossing: w = 100 rad/s is reached at the t solving 24 w_unit(t) = 100.
TEST(DcServoRun, DivergenceIsAStatusWithItsInstant) {
  const Motor m;
  Scenario s;
  s.experiment = Step(24.0, 1.0, 1000.0);
  s.settings.divergence_limit = 100.0;
  const std::vector<double> times = s.experiment.SampleTimes();
  SimulationRequest request;
  request.parameters = &s.parameters;
  request.effects = &s.effects;
  request.experiment = &s.experiment;
  request.settings = s.settings;
  request.sample_times = &times;
  Trace trace;
  const SimStatus status = FindModel("dc_servo").Simulate(request, &trace);
  EXPECT_EQ(status.code, SimStatus::Code::kDiverged);
  EXPECT_EQ(status.message, "simulation diverged (non-finite or |state| > 100)");
  const UnitStep unit(m);
  double lo = 0.0, hi = 1.0;
  for (int k = 0; k < 100; ++k)
    (24.0 * unit.w(0.5 * (lo + hi)) < 100.0 ? lo : hi) = 0.5 * (lo + hi);
  EXPECT_GE(status.at_time, lo);
  EXPECT_LE(status.at_time, lo + s.settings.dt + 1e-12);
}

TEST(DcServoRun, InvalidParametersAreAStatus) {
  Scenario s;
  s.parameters.Set("J", 0.0);
  s.experiment = Step(24.0, 0.01, 1000.0);
  const std::vector<double> times = s.experiment.SampleTimes();
  SimulationRequest request;
  request.parameters = &s.parameters;
  request.effects = &s.effects;
  request.experiment = &s.experiment;
  request.settings = s.settings;
  request.sample_times = &times;
  Trace trace;
  const SimStatus status = FindModel("dc_servo").Simulate(request, &trace);
  EXPECT_EQ(status.code, SimStatus::Code::kInvalidParameters);
  EXPECT_EQ(status.message, "parameter 'J' must be > 0");
}

// ---------------------------------------------------------------------------------------
// Closed loop (configs/ganesh-pid.json) and the step metrics.

TEST(DcServoClosedLoop, GaneshPidSettlesWithinTwoPercentAndRespectsTheSupply) {
  const Config config = LoadConfig(testing::SourcePath("configs/ganesh-pid.json"));
  ASSERT_TRUE(config.experiment.closed_loop);
  Trace trace;
  ASSERT_TRUE(RunExperiment(config, &trace).ok());
  const auto& t = trace.Column("t");
  const auto& theta = trace.Column("theta");
  const auto& u = trace.Column("u");
  ASSERT_TRUE(trace.Has("r"));
  EXPECT_EQ(trace.Column("r").back(), 1.0);
  double u_peak = 0.0;
  for (double v : u) u_peak = std::max(u_peak, std::abs(v));
  EXPECT_LE(u_peak, 24.0);
  // At t = 0: e = 1 rad, no integral, no derivative yet: u = Kp e = 15 V.
  EXPECT_EQ(u.front(), 15.0);
  // Settled to the reference: the first instant after which |theta - r| <= 2 % of r for
  // the rest of the run.
  double t_settled = t.front();
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (std::abs(theta[k] - 1.0) > 0.02) t_settled = k + 1 < t.size() ? t[k + 1] : 1e300;
  }
  Report("pid settled within 2 % of the reference at (s)", t_settled, 1.0);
  Report("pid |theta_end - 1|", std::abs(theta.back() - 1.0), 0.02);
  EXPECT_LT(t_settled, 1.0);
  // The step metrics read the same response towards its own final value.
  const StepMetrics metrics = ComputeStepMetrics(t, theta, 0.0);
  ASSERT_TRUE(metrics.valid);
  Report("pid overshoot (%)", metrics.overshoot_percent, 100.0);
  Report("pid rise time (s)", metrics.rise_time, 1.0);
  EXPECT_NEAR(metrics.final_value, 1.0, 0.02);
  EXPECT_LT(metrics.settling_time, t_settled + 1e-12);
}

// A supply of 10 V below the first demand Kp e = 15 V: the output is clipped to exactly
// 10 V, and the loop still settles.
TEST(DcServoClosedLoop, SaturatesExactlyAtTheSupply) {
  Config config = LoadConfig(testing::SourcePath("configs/ganesh-pid.json"));
  config.experiment.pid.u_max = 10.0;
  Trace trace;
  ASSERT_TRUE(RunExperiment(config, &trace).ok());
  double u_peak = 0.0;
  for (double v : trace.Column("u")) u_peak = std::max(u_peak, std::abs(v));
  EXPECT_EQ(u_peak, 10.0);
  EXPECT_EQ(trace.Column("u").front(), 10.0);
  EXPECT_NEAR(trace.Column("theta").back(), 1.0, 0.02);
}

// The speed loop ("loop": "speed"): the PID measures w and the reference is a speed. With
// Kp alone the closed loop settles where Kp (r - w) G_w(0) = w, G_w(0) = Kt/(R B + Kt Kb)
// (docs/model-dc-servo.md §1): w = r Kp G_w(0)/(1 + Kp G_w(0)); u(0) = Kp r exactly; with
// the integral term w reaches r.
TEST(DcServoClosedLoop, SpeedLoopSettlesWhereTheClosedFormSays) {
  Config config = LoadConfig(testing::SourcePath("configs/ganesh-pid.json"));
  config.experiment.pid = {PidSettings::Loop::kSpeed, 0.1, 0.0, 0.0, 1e-3, 1e3};
  config.experiment.input.amplitude = 50.0;  // rad/s
  config.experiment.duration = 3.0;
  const double R = 12.6, Kt = 0.04, Kb = 0.04, B = 2.261e-5, Kp = 0.1, r = 50.0;
  const double g0 = Kt / (R * B + Kt * Kb);
  Trace trace;
  ASSERT_TRUE(RunExperiment(config, &trace).ok());
  EXPECT_EQ(trace.Column("u").front(), Kp * r);
  const double expected = r * Kp * g0 / (1.0 + Kp * g0);
  Report("speed loop P: |w_end - closed form| (rad/s)",
         std::abs(trace.Column("w").back() - expected), 1e-6);
  EXPECT_NEAR(trace.Column("w").back(), expected, 1e-6 * expected);
  config.experiment.pid.Ki = 2.0;
  ASSERT_TRUE(RunExperiment(config, &trace).ok());
  EXPECT_NEAR(trace.Column("w").back(), r, 1e-3 * r);
}

// The u column of a closed-loop trace is the voltage applied from each sample instant on
// (the open-loop convention), so replaying it as a recorded input, sampled at every step,
// reproduces the closed-loop run exactly.
TEST(DcServoClosedLoop, TraceReplaysOpenLoopThroughItsUColumn) {
  Config config = LoadConfig(testing::SourcePath("configs/ganesh-pid.json"));
  config.experiment.duration = 0.3;
  config.experiment.sample_rate = 1.0 / config.simulation.dt;
  Trace closed;
  ASSERT_TRUE(RunExperiment(config, &closed).ok());
  InputSignal recorded;
  recorded.kind = InputSignal::Kind::kRecorded;
  recorded.times = closed.Column("t");
  recorded.values = closed.Column("u");
  Config open = config;
  open.experiment.closed_loop = false;
  Trace replay;
  ASSERT_TRUE(RunExperiment(open, &replay, &recorded).ok());
  double error = 0.0;
  for (std::size_t k = 0; k < closed.rows(); ++k) {
    error = std::max(error, std::abs(replay.Column("theta")[k] - closed.Column("theta")[k]));
  }
  Report("closed-loop replay max |theta diff| (rad)", error, 1e-9);
  EXPECT_LT(error, 1e-9);
}

// First order y = 1 - e^{-t/tau}: 10-90 % rise time tau ln 9, 2 % settling time tau ln 50,
// no overshoot; both are read off samples, so within one sample period h.
TEST(StepMetrics, FirstOrderCurve) {
  const double tau = 0.01, h = 1e-6;
  std::vector<double> t, y;
  for (long k = 0; k <= 400000; ++k) {
    t.push_back(k * h);
    y.push_back(1.0 - std::exp(-t.back() / tau));
  }
  const StepMetrics metrics = ComputeStepMetrics(t, y);
  ASSERT_TRUE(metrics.valid);
  EXPECT_NEAR(metrics.rise_time, tau * std::log(9.0), h);
  EXPECT_NEAR(metrics.settling_time, tau * std::log(50.0), h);
  EXPECT_EQ(metrics.overshoot_percent, 0.0);
  EXPECT_NEAR(metrics.final_value, 1.0, 1e-12);
}

// The same curve falling from 3 to 1, starting at t_step = 0.1: the figures do not change.
TEST(StepMetrics, FallingDelayedStep) {
  const double tau = 0.01, h = 1e-6, t_step = 0.1;
  std::vector<double> t, y;
  for (long k = 0; k <= 500000; ++k) {
    t.push_back(k * h);
    const double since = t.back() - t_step;
    y.push_back(since < 0.0 ? 3.0 : 3.0 - 2.0 * (1.0 - std::exp(-since / tau)));
  }
  const StepMetrics metrics = ComputeStepMetrics(t, y, t_step);
  ASSERT_TRUE(metrics.valid);
  EXPECT_NEAR(metrics.rise_time, tau * std::log(9.0), 2 * h);
  EXPECT_NEAR(metrics.settling_time, tau * std::log(50.0), 2 * h);
  EXPECT_EQ(metrics.overshoot_percent, 0.0);
  EXPECT_NEAR(metrics.final_value, 1.0, 1e-12);
}

// Underdamped second order: peak overshoot exp(-zeta pi / sqrt(1 - zeta^2)).
TEST(StepMetrics, SecondOrderOvershoot) {
  const double zeta = 0.3, wn = 100.0, h = 1e-6;
  const double wd = wn * std::sqrt(1.0 - zeta * zeta);
  std::vector<double> t, y;
  for (long k = 0; k <= 1000000; ++k) {
    t.push_back(k * h);
    const double x = t.back();
    y.push_back(1.0 -
                std::exp(-zeta * wn * x) *
                    (std::cos(wd * x) + zeta / std::sqrt(1.0 - zeta * zeta) * std::sin(wd * x)));
  }
  const StepMetrics metrics = ComputeStepMetrics(t, y);
  ASSERT_TRUE(metrics.valid);
  const double expected = 100.0 * std::exp(-zeta * std::numbers::pi / std::sqrt(1.0 - zeta * zeta));
  EXPECT_NEAR(metrics.overshoot_percent, expected, 1e-4);
  EXPECT_NEAR(expected, 37.23, 0.01);
}

TEST(StepMetrics, FlatCurveIsNotValid) {
  const std::vector<double> t = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
  const std::vector<double> y(t.size(), 2.0);
  EXPECT_FALSE(ComputeStepMetrics(t, y).valid);
}

}  // namespace
}  // namespace blmd
