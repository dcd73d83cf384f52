// dc_servo with a flexible coupling (two_mass; docs/model-dc-servo.md, "A two-mass shaft"):
// the simulated current and motor speed against the closed-form transfer functions of the
// armature driving the two-mass shaft, the linear part against the same, and the speed loop's
// steady state.
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

// The Ganesh servo's armature (R 12.6 ohm, L 0.283 H, Kt = Kb = 0.04) on a two-mass shaft:
// J 2.26e-5 kg·m², B 2.261e-5, r 1.0, fa 30 Hz, zeta 0.05, s 0.3.
constexpr double kR = 12.6, kL = 0.283, kKt = 0.04, kKb = 0.04, kJ = 2.26e-5, kB = 2.261e-5;
constexpr double kRatio = 1.0, kFa = 30.0, kZeta = 0.05, kShare = 0.3;

std::string ConfigText(const std::string& input, const std::string& extra, double dt,
                       double duration, double rate) {
  char text[2048];
  std::snprintf(text, sizeof text, R"({
  "name": "dc two-mass", "model": "dc_servo",
  "parameters": { "R": %.17g, "L": %.17g, "Kt": %.17g, "Kb": %.17g, "J": %.17g, "B": %.17g },
  "effects": { "two_mass": { "inertia_ratio": %.17g, "anti_resonance_hz": %.17g,
                             "shaft_damping_ratio": %.17g, "load_damping_share": %.17g } },
  "simulation": { "dt": %.17g },
  "experiment": { "input": %s, "duration": %.17g, "sample_rate": %.17g %s }
})",
                kR, kL, kKt, kKb, kJ, kB, kRatio, kFa, kZeta, kShare, dt, input.c_str(), duration,
                rate, extra.c_str());
  return text;
}

// The mechanical part W/T with Z = K/s + c (the shaft's impedance):
//   (Jm s + Bm + Z) Wm − Z Wl = T,   −Z Wm + (Jl s + Bl + Z) Wl = 0;
// the armature (L s + R) I = U − Kb Wm, T = Kt I:
//   I/U = 1 / (L s + R + Kb Kt G),   Wm/U = Kt G · I/U,   G = Wm/T.
void ClosedForm(double f, Complex* i_per_u, Complex* w_per_u) {
  const double Jm = kJ / (1.0 + kRatio), Jl = kJ - Jm, wa = kTwoPi * kFa;
  const double K = Jl * wa * wa, c = 2.0 * kZeta * Jl * wa, Bl = kShare * kB, Bm = kB - Bl;
  const Complex s(0.0, kTwoPi * f), Z = K / s + c;
  const Complex G = (Jl * s + Bl + Z) / ((Jm * s + Bm + Z) * (Jl * s + Bl + Z) - Z * Z);
  *i_per_u = 1.0 / (kL * s + kR + kKb * kKt * G);
  *w_per_u = kKt * G * *i_per_u;
}

// The steady response to a sine of 1 V: i and w regressed on sin, cos and 1 over the last
// 0.5 s of 2 s (the slowest transient, the armature and shaft's 0.15 s, has decayed by e^-10),
// below, at and above the anti-resonance and at the resonance fa sqrt(1 + r).
TEST(DcServoTwoMass, CurrentAndMotorSpeedFollowTheTransferFunctions) {
  const double duration = 2.0;
  for (const double f : {5.0, kFa, kFa * std::sqrt(1.0 + kRatio), 90.0}) {
    const std::string input = SineInput(1.0, f);
    Trace trace;
    const SimStatus status =
        RunExperiment(ParseConfig(ConfigText(input, "", 1e-5, duration, 1e4), "dc.json"), &trace);
    ASSERT_TRUE(status.ok()) << status.message;
    const auto& t = trace.Column("t");
    Complex measured[2];
    const char* names[2] = {"i", "w"};
    for (int column = 0; column < 2; ++column) {
      const auto& y = trace.Column(names[column]);
      Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
      Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
      for (std::size_t k = 0; k < t.size(); ++k) {
        if (t[k] < duration - 0.5) continue;
        const Eigen::Vector3d x(std::sin(kTwoPi * f * t[k]), std::cos(kTwoPi * f * t[k]), 1.0);
        normal += x * x.transpose();
        rhs += x * y[k];
      }
      const Eigen::Vector3d a = normal.ldlt().solve(rhs);
      measured[column] = Complex(a(0), a(1));
    }
    Complex i_per_u, w_per_u;
    ClosedForm(f, &i_per_u, &w_per_u);
    EXPECT_LT(std::abs(measured[0] - i_per_u), 2e-3 * std::abs(i_per_u)) << "i at " << f << " Hz";
    EXPECT_LT(std::abs(measured[1] - w_per_u), 2e-3 * std::abs(w_per_u)) << "w at " << f << " Hz";
  }
}

// The linear part keeps the coupling: C (jw I − A)^-1 B equals the closed form to 1e-9.
TEST(DcServoTwoMass, LinearPartIsTheClosedForm) {
  const Config config = ParseConfig(
      ConfigText(R"({ "type": "step", "amplitude": 1 })", "", 1e-5, 0.1, 1e3), "dc.json");
  const LinearModel linear = config.model->Linearise(config.parameters);
  ASSERT_EQ(linear.states.size(), 5u);
  for (const double f : {1.0, 25.0, kFa * std::sqrt(2.0), 200.0}) {
    const Eigen::MatrixXcd m =
        Complex(0.0, kTwoPi * f) * Eigen::MatrixXcd::Identity(5, 5) - linear.A.cast<Complex>();
    const Eigen::VectorXcd x = m.partialPivLu().solve(linear.B.cast<Complex>().col(0));
    const Eigen::VectorXcd y = linear.C.cast<Complex>() * x;
    Complex i_per_u, w_per_u;
    ClosedForm(f, &i_per_u, &w_per_u);
    EXPECT_LT(std::abs(y(0) - i_per_u), 1e-9 * std::abs(i_per_u)) << f;
    EXPECT_LT(std::abs(y(1) - w_per_u), 1e-9 * std::abs(w_per_u)) << f;
  }
}

// The speed loop (a PI) drives the motor's speed to the reference on the flexible shaft; the
// load, coupled by the shaft, turns with it: the current settles where Kt i = B w (no other
// torque at a constant speed; the twist holds Bl w on the load).
TEST(DcServoTwoMass, SpeedLoopSettlesAtTheReference) {
  const Config config =
      ParseConfig(ConfigText(R"({ "type": "step", "amplitude": 50 })",
                             R"(, "pid": { "loop": "speed", "Kp": 0.05, "Ki": 0.5, "u_max": 24 })",
                             1e-5, 4.0, 1e3),
                  "dc.json");
  Trace trace;
  ASSERT_TRUE(RunExperiment(config, &trace).ok());
  EXPECT_NEAR(trace.Column("w").back(), 50.0, 1e-3);
  EXPECT_NEAR(trace.Column("i").back(), kB * 50.0 / kKt, 1e-6);
}

}  // namespace
}  // namespace blmd::testing
