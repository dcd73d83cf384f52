// The BLMD drive with a flexible coupling (two_mass; docs/model-blmd.md §10a): the motor speed
// against the closed-form two-mass transfer function from the drive's own torque, the linear
// part against the same with ideal current loops, the load-side columns, and a shaft without
// the coupling unchanged whatever the integration method.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <complex>
#include <cstdio>
#include <string>

#include "blmd/constants.h"
#include "blmd/io/config.h"
#include "blmd/run.h"
#include "blmd/sim/linear_model.h"
#include "blmd/sim/model.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

using Complex = std::complex<double>;

// The D31x-class drive of configs/blmd-d31x.json on a two-mass shaft: J 1.19e-3 kg·m²,
// B 5e-4, r 1.5, fa 60 Hz, zeta 0.05, s 0.4.
constexpr double kJ = 1.19e-3, kB = 5e-4, kRatio = 1.5, kFa = 60.0, kZeta = 0.05, kShare = 0.4;
constexpr double kTorquePerVolt = 1.5 * 0.3 * 1.1 / 0.5;  // 1.5 Ke Kc/Kf, N·m per V

std::string ConfigText(const std::string& input, const std::string& method, bool two_mass,
                       double duration, double rate) {
  char effects[512] = "";
  if (two_mass) {
    std::snprintf(effects, sizeof effects, R"(, "effects": { "two_mass": {
      "inertia_ratio": %.17g, "anti_resonance_hz": %.17g, "shaft_damping_ratio": %.17g,
      "load_damping_share": %.17g } })",
                  kRatio, kFa, kZeta, kShare);
  }
  char text[4096];
  std::snprintf(text, sizeof text, R"({
  "name": "blmd two-mass", "model": "blmd",
  "parameters": { "Ud": 310, "Rs": 1.0, "Ls": 0.004, "Ke": 0.3, "p": 3, "Kc": 1.1, "Kf": 0.5,
                  "Kp": 8, "Ki": 16000, "Vtri": 10, "Tpwm": 2e-4, "delta": 2e-5,
                  "J": %.17g, "B": %.17g }%s,
  "simulation": { "method": "%s", "dt": 1e-6, "regula_falsi": true, "diagnostics": true },
  "experiment": { "input": %s, "duration": %.17g, "sample_rate": %.17g }
})",
                kJ, kB, effects, method.c_str(), input.c_str(), duration, rate);
  return text;
}

// W/T of the motor's side: (Jm s + Bm + Z) Wm − Z Wl = T, −Z Wm + (Jl s + Bl + Z) Wl = 0 with
// Z = K/s + c, the shaft's impedance.
Complex MotorSpeedPerTorque(double f) {
  const double Jm = kJ / (1.0 + kRatio), Jl = kJ - Jm, wa = kTwoPi * kFa;
  const double K = Jl * wa * wa, c = 2.0 * kZeta * Jl * wa, Bl = kShare * kB, Bm = kB - Bl;
  const Complex s(0.0, kTwoPi * f), Z = K / s + c;
  return (Jl * s + Bl + Z) / ((Jm * s + Bm + Z) * (Jl * s + Bl + Z) - Z * Z);
}

// The sine and cosine parts at f of a column over t >= from, beside a constant, a ramp and a
// parabola (what is left of the rigid shaft's slow start, J/B = 2.4 s).
Complex Phasor(const Trace& trace, const char* column, double f, double from) {
  const auto& t = trace.Column("t");
  const auto& y = trace.Column(column);
  using Vector5 = Eigen::Matrix<double, 5, 1>;
  Eigen::Matrix<double, 5, 5> normal = Eigen::Matrix<double, 5, 5>::Zero();
  Vector5 rhs = Vector5::Zero();
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (t[k] < from) continue;
    const double tau = t[k] - from;
    Vector5 x;
    x << std::sin(kTwoPi * f * t[k]), std::cos(kTwoPi * f * t[k]), 1.0, tau, tau * tau;
    normal += x * x.transpose();
    rhs += x * y[k];
  }
  const Vector5 a = normal.ldlt().solve(rhs);
  return {a(0), a(1)};
}

// A 0.2 V sine of the torque demand below, at and above the anti-resonance and at the
// resonance fa sqrt(1 + r): the motor's speed over the drive's own torque (the diagnostic
// column Te, its PWM ripple far above f) equals the two-mass W/T within 1 % over the last
// 0.4 s of 1.6 s, sampled at 200 kHz so that the PWM ripple's sidebands do not alias onto f
// (the shaft's slowest transient, J/B = 2.4 s, leaves a drift the regression's polynomial
// absorbs; the resonance's decays as e^-(47 t)). The load's speed follows the motor's through
// the shaft: Wl/Wm = Z/(Jl s + Bl + Z).
TEST(BlmdTwoMass, MotorSpeedFollowsTheTwoMassTransferFunction) {
  const double duration = 1.6;
  for (const double f : {15.0, kFa, kFa * std::sqrt(1.0 + kRatio), 200.0}) {
    const std::string input = SineInput(0.2, f);
    Trace trace;
    const SimStatus status = RunExperiment(
        ParseConfig(ConfigText(input, "events", true, duration, 2e5), "blmd.json"), &trace);
    ASSERT_TRUE(status.ok()) << status.message;
    const double from = duration - 0.4;
    const Complex torque = Phasor(trace, "Te", f, from);
    const Complex w = Phasor(trace, "w", f, from), w_load = Phasor(trace, "w_load", f, from);
    const Complex expected = MotorSpeedPerTorque(f);
    EXPECT_LT(std::abs(w / torque - expected), 1e-2 * std::abs(expected)) << "w at " << f;
    const double Jl = kJ * kRatio / (1.0 + kRatio), wa = kTwoPi * kFa;
    const Complex s(0.0, kTwoPi * f), Z = Jl * wa * wa / s + 2.0 * kZeta * Jl * wa;
    const Complex load_per_motor = Z / (Jl * s + kShare * kB + Z);
    EXPECT_LT(std::abs(w_load / w - load_per_motor), 1e-2 * std::abs(load_per_motor))
        << "w_load at " << f;
  }
}

// The linear part keeps the coupling: C (jw I − A)^-1 B equals 1.5 Ke Kc/Kf · W/T to 1e-9,
// and names the shaft the tuning acts on.
TEST(BlmdTwoMass, LinearPartIsTheClosedForm) {
  const Config config = ParseConfig(
      ConfigText(R"({ "type": "step", "amplitude": 1 })", "events", true, 0.01, 1e4), "b.json");
  const LinearModel linear = config.model->Linearise(config.parameters);
  ASSERT_TRUE(linear.available);
  ASSERT_EQ(linear.states.size(), 4u);
  ASSERT_TRUE(linear.has_shaft);
  EXPECT_DOUBLE_EQ(linear.shaft.K, kTorquePerVolt);
  EXPECT_DOUBLE_EQ(linear.shaft.anti_resonance_hz, kFa);
  for (const double f : {1.0, 45.0, kFa * std::sqrt(1.0 + kRatio), 300.0}) {
    const Eigen::MatrixXcd m =
        Complex(0.0, kTwoPi * f) * Eigen::MatrixXcd::Identity(4, 4) - linear.A.cast<Complex>();
    const Eigen::VectorXcd x = m.partialPivLu().solve(linear.B.cast<Complex>().col(0));
    const Complex w = (linear.C.cast<Complex>() * x)(0);
    const Complex expected = kTorquePerVolt * MotorSpeedPerTorque(f);
    EXPECT_LT(std::abs(w - expected), 1e-9 * std::abs(expected)) << f;
  }
}

// The coupling runs on the reference step loop whatever the method: the events and the fixed
// Euler configs give the same trace, bit for bit, with the load's columns; without the
// coupling the two methods differ (each its own integration) and write no load column.
TEST(BlmdTwoMass, RunsOnTheReferenceStepLoopWhateverTheMethod) {
  const std::string step = R"({ "type": "step", "amplitude": 1 })";
  Trace events, euler, rigid_events, rigid_euler;
  ASSERT_TRUE(
      RunExperiment(ParseConfig(ConfigText(step, "events", true, 0.05, 1e4), "a.json"), &events)
          .ok());
  ASSERT_TRUE(
      RunExperiment(ParseConfig(ConfigText(step, "fixed_euler", true, 0.05, 1e4), "b.json"), &euler)
          .ok());
  ASSERT_TRUE(events.Has("theta_load"));
  EXPECT_EQ(events.Column("w"), euler.Column("w"));
  EXPECT_EQ(events.Column("theta_load"), euler.Column("theta_load"));
  ASSERT_TRUE(RunExperiment(ParseConfig(ConfigText(step, "events", false, 0.05, 1e4), "c.json"),
                            &rigid_events)
                  .ok());
  ASSERT_TRUE(
      RunExperiment(ParseConfig(ConfigText(step, "fixed_euler", false, 0.05, 1e4), "d.json"),
                    &rigid_euler)
          .ok());
  EXPECT_FALSE(rigid_events.Has("w_load"));
  EXPECT_NE(rigid_events.Column("w"), rigid_euler.Column("w"));
}

}  // namespace
}  // namespace blmd::testing
