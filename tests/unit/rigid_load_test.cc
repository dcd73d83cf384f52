// The rigid load (docs/model-rigid-load.md) against its closed forms: the viscous shaft's
// exponential spin-up, the coast-down under viscous and Coulomb friction to a stop at the
// predicted instant, and sticking below the breakaway torque. The zero-order-hold
// discretisation is exact for a torque held constant over each step, so the samples match
// the closed forms to rounding.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <complex>
#include <string>
#include <vector>

#include "blmd/constants.h"
#include "blmd/error.h"
#include "blmd/io/config.h"
#include "blmd/run.h"

namespace blmd::testing {
namespace {

constexpr double kJ = 2.0e-3;  // kg·m²
constexpr double kB = 4.0e-3;  // N·m·s/rad
constexpr double kKt = 0.5;    // N·m per unit of u

Trace Shaft(const std::string& effects, const std::string& input, double w0, double duration) {
  char text[2048];
  std::snprintf(text, sizeof text, R"({
  "name": "shaft", "model": "rigid_load",
  "parameters": { "J": %.17g, "B": %.17g, "Kt": %.17g },
  "effects": { %s },
  "simulation": { "dt": 1e-4 },
  "experiment": { "input": %s, "duration": %.17g, "sample_rate": 1000,
                  "initial": { "w": %.17g } }
})",
                kJ, kB, kKt, effects.c_str(), input.c_str(), duration, w0);
  Trace trace;
  const SimStatus status = RunExperiment(ParseConfig(text, "shaft.json"), &trace);
  EXPECT_TRUE(status.ok()) << status.message;
  return trace;
}

TEST(RigidLoad, ViscousSpinUpIsTheExponentialOfTheClosedForm) {
  // u = 2 from t = 0: w(t) = w_inf (1 - e^{-t/tau}), theta(t) = w_inf (t - tau (1 - e^{-t/tau})),
  // w_inf = Kt u / B = 250 rad/s, tau = J / B = 0.5 s.
  const Trace trace = Shaft("", R"({ "type": "step", "amplitude": 2.0 })", 0.0, 2.0);
  const double w_inf = kKt * 2.0 / kB, tau = kJ / kB;
  const auto& t = trace.Column("t");
  double worst_w = 0.0, worst_theta = 0.0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    const double decay = std::exp(-t[k] / tau);
    worst_w = std::max(worst_w, std::abs(trace.Column("w")[k] - w_inf * (1.0 - decay)));
    worst_theta = std::max(
        worst_theta, std::abs(trace.Column("theta")[k] - w_inf * (t[k] - tau * (1.0 - decay))));
  }
  EXPECT_LT(worst_w, 1e-9 * w_inf);
  EXPECT_LT(worst_theta, 1e-9 * w_inf * 2.0);
  EXPECT_NEAR(trace.Column("w").back(), w_inf * (1.0 - std::exp(-2.0 / tau)), 1e-9 * w_inf);
}

TEST(RigidLoad, CoulombCoastDownStopsAtThePredictedInstantAndStays) {
  // u = 0, w(0) = 100 rad/s, Tc = 0.1 N·m: w(t) = (w0 + Tc/B) e^{-t/tau} - Tc/B until
  // t_stop = tau ln(1 + B w0 / Tc) = 0.5 ln 5 = 0.8047 s, then 0.
  const double w0 = 100.0, Tc = 0.1, tau = kJ / kB;
  const Trace trace = Shaft(R"("coulomb_friction": { "Tc": 0.1 })",
                            R"({ "type": "step", "amplitude": 0.0 })", w0, 1.5);
  const double t_stop = tau * std::log(1.0 + kB * w0 / Tc);
  const auto& t = trace.Column("t");
  const auto& w = trace.Column("w");
  double worst = 0.0;
  std::size_t first_zero = t.size();
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (t[k] < t_stop - 1e-3) {
      worst = std::max(worst, std::abs(w[k] - ((w0 + Tc / kB) * std::exp(-t[k] / tau) - Tc / kB)));
    }
    if (w[k] == 0.0 && first_zero == t.size()) first_zero = k;
    if (t[k] > t_stop + 1e-3) {
      EXPECT_EQ(w[k], 0.0) << "at t = " << t[k];
    }
  }
  EXPECT_LT(worst, 1e-9 * w0);
  ASSERT_LT(first_zero, t.size());
  // The first zero sample is the first sample instant after the stop (1 ms samples).
  EXPECT_GE(t[first_zero], t_stop);
  EXPECT_LT(t[first_zero], t_stop + 1e-3 + 1e-4);
  // The angle stops where the closed form's integral ends.
  const double theta_stop =
      (w0 + Tc / kB) * tau * (1.0 - std::exp(-t_stop / tau)) - Tc / kB * t_stop;
  EXPECT_NEAR(trace.Column("theta").back(), theta_stop, 1e-4 * theta_stop);
}

TEST(RigidLoad, StaysAtRestBelowTheBreakawayTorque) {
  // Kt u = 0.5 x 0.19 = 0.095 N·m < Tc = 0.1 N·m: the shaft never moves; at 0.21 it does.
  const Trace held = Shaft(R"("coulomb_friction": { "Tc": 0.1 })",
                           R"({ "type": "step", "amplitude": 0.19 })", 0.0, 1.0);
  for (double w : held.Column("w")) ASSERT_EQ(w, 0.0);
  for (double theta : held.Column("theta")) ASSERT_EQ(theta, 0.0);
  const Trace moving = Shaft(R"("coulomb_friction": { "Tc": 0.1 })",
                             R"({ "type": "step", "amplitude": 0.21 })", 0.0, 1.0);
  // Net torque 0.005 N·m: w(1 s) = (0.005 / B)(1 - e^{-2}) = 1.0808 rad/s.
  EXPECT_NEAR(moving.Column("w").back(), 0.005 / kB * (1.0 - std::exp(-1.0 / (kJ / kB))), 1e-6);
}

// w(t) of the shaft started at w0 > 0 against a constant drive torque -T (T > Tc) under Coulomb
// friction Tc: it decelerates, w = (w0 + (T + Tc)/B) e^{-t/tau} - (T + Tc)/B, stops at
// t_s = tau ln(1 + B w0 / (T + Tc)), and breaks away backwards at once,
// w = -((T - Tc)/B) (1 - e^{-(t - t_s)/tau}).
double Reversal(double t, double w0, double T, double Tc) {
  const double tau = kJ / kB, t_s = tau * std::log(1.0 + kB * w0 / (T + Tc));
  if (t <= t_s) return (w0 + (T + Tc) / kB) * std::exp(-t / tau) - (T + Tc) / kB;
  return -(T - Tc) / kB * (1.0 - std::exp(-(t - t_s) / tau));
}

Trace Reversing(double w0, double duration) {
  // Kt u = 0.5 x (-0.6) = -0.3 N·m against Tc = 0.1 N·m.
  return Shaft(R"("coulomb_friction": { "Tc": 0.1 })", R"({ "type": "step", "amplitude": -0.6 })",
               w0, duration);
}

TEST(RigidLoad, BreaksAwayBackwardsWithinTheStepItStopsIn) {
  // The stop at t_s = 0.5 ln(1 + 4e-3 x 10 / 0.4) = 47.655 ms falls inside a 0.1 ms step; the
  // shaft moves backwards for the rest of that step. Breaking away only at the next step
  // lags the closed form by the step's remainder, (T - Tc)/J x 0.1 ms x 0.45 = 4.5e-3 rad/s.
  const double w0 = 10.0, T = 0.3, Tc = 0.1;
  const Trace trace = Reversing(w0, 0.2);
  const auto& t = trace.Column("t");
  const auto& w = trace.Column("w");
  double worst = 0.0;
  for (std::size_t k = 0; k < t.size(); ++k)
    worst = std::max(worst, std::abs(w[k] - Reversal(t[k], w0, T, Tc)));
  EXPECT_LT(worst, 1e-5);  // the stop instant's linear interpolation within its step
}

TEST(RigidLoad, ReversalIsContinuousInTheParameters) {
  // w at 0.2 s against w0 from 10 to 10.1 rad/s: the stop instant moves through five steps.
  // A reversal that waits for the next step makes w a saw-tooth of 2e-3 rad/s per step
  // boundary crossed (and a least-squares cost a staircase); the exact reversal is smooth:
  // its second differences are those of the closed form.
  std::vector<double> end;
  for (int k = 0; k <= 100; ++k) end.push_back(Reversing(10.0 + 1e-3 * k, 0.2).Column("w").back());
  double worst = 0.0, worst_closed_form = 0.0;
  for (std::size_t k = 2; k < end.size(); ++k) {
    worst = std::max(worst, std::abs(end[k] - 2.0 * end[k - 1] + end[k - 2]));
    const double w0 = 10.0 + 1e-3 * static_cast<double>(k);
    worst_closed_form =
        std::max(worst_closed_form,
                 std::abs(Reversal(0.2, w0, 0.3, 0.1) - 2.0 * Reversal(0.2, w0 - 1e-3, 0.3, 0.1) +
                          Reversal(0.2, w0 - 2e-3, 0.3, 0.1)));
  }
  EXPECT_LT(worst, 1e-7);
  EXPECT_LT(worst_closed_form, 1e-7);
}

// two_mass (docs/effects.md): the motor speed's steady response to a sinusoidal drive torque
// is the two-mass transfer function. With Z = K/s + c the shaft's impedance,
//   (Jm s + Bm + Z) Wm - Z Wl = T,   -Z Wm + (Jl s + Bl + Z) Wl = 0,
//   Wm/T = (Jl s + Bl + Z) / ((Jm s + Bm + Z)(Jl s + Bl + Z) - Z^2),
// the input read at each step's midpoint and held (no delay to first order). Checked below the
// anti-resonance, near it (the notch), at the resonance fr = fa sqrt(1 + r) and above; the
// load side's columns w_load and theta_load likewise.
TEST(TwoMass, MotorSpeedFollowsTheTwoMassTransferFunction) {
  const double J = 2e-3, B = 0.04, Kt = 0.5, r = 1.5, fa = 40.0, zeta = 0.05, s = 0.3;
  const double dt = 1e-5, rate = 1e4, duration = 1.5;
  const double Jm = J / (1.0 + r), Jl = J - Jm, wa = 2.0 * kPi * fa;
  const double K = Jl * wa * wa, c = 2.0 * zeta * Jl * wa, Bl = s * B, Bm = B - Bl;
  for (const double f : {20.0, 0.97 * fa, fa * std::sqrt(1.0 + r), 120.0}) {
    char text[2048];
    std::snprintf(text, sizeof text, R"({
  "name": "two-mass", "model": "rigid_load",
  "parameters": { "J": %.17g, "B": %.17g, "Kt": %.17g },
  "effects": { "two_mass": { "inertia_ratio": %.17g, "anti_resonance_hz": %.17g,
                             "shaft_damping_ratio": %.17g, "load_damping_share": %.17g } },
  "simulation": { "dt": %.17g },
  "experiment": { "input": { "type": "chirp", "amplitude": 1.0, "f0": %.17g, "f1": %.17g },
                  "duration": %.17g, "sample_rate": %.17g }
})",
                  J, B, Kt, r, fa, zeta, s, dt, f, f, duration, rate);
    Trace trace;
    const SimStatus status = RunExperiment(ParseConfig(text, "two-mass.json"), &trace);
    ASSERT_TRUE(status.ok()) << status.message;
    // The steady response: w regressed on sin, cos and 1 over the last 0.5 s (the transients
    // have decayed by e^-20 by then).
    const auto& t = trace.Column("t");
    const auto& w = trace.Column("w");
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < t.size(); ++k) {
      if (t[k] < duration - 0.5) continue;
      const Eigen::Vector3d x(std::sin(2.0 * kPi * f * t[k]), std::cos(2.0 * kPi * f * t[k]), 1.0);
      normal += x * x.transpose();
      rhs += x * w[k];
    }
    const Eigen::Vector3d a = normal.ldlt().solve(rhs);
    const std::complex<double> measured(a(0), a(1));  // w = Im(G e^{j w t}) = a0 sin + a1 cos
    const std::complex<double> jw(0.0, 2.0 * kPi * f);
    const std::complex<double> Z = K / jw + c;
    const std::complex<double> G =
        (Jl * jw + Bl + Z) / ((Jm * jw + Bm + Z) * (Jl * jw + Bl + Z) - Z * Z);
    const std::complex<double> expected = Kt * G;
    EXPECT_LT(std::abs(measured - expected), 1e-3 * std::abs(expected)) << "at " << f << " Hz";
    // The load side's columns (a second encoder): Wl = Z Wm / (Jl s + Bl + Z), and the twist
    // theta - theta_load, (Wm - Wl)/(j w) (without the drift of the angles themselves).
    const auto& wl = trace.Column("w_load");
    const auto& thl = trace.Column("theta_load");
    const auto& th = trace.Column("theta");
    Eigen::Vector3d rhs_load = Eigen::Vector3d::Zero(), rhs_twist = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < t.size(); ++k) {
      if (t[k] < duration - 0.5) continue;
      const Eigen::Vector3d x(std::sin(2.0 * kPi * f * t[k]), std::cos(2.0 * kPi * f * t[k]), 1.0);
      rhs_load += x * wl[k];
      rhs_twist += x * (th[k] - thl[k]);
    }
    const Eigen::Vector3d b = normal.ldlt().solve(rhs_load), d = normal.ldlt().solve(rhs_twist);
    const std::complex<double> expected_load = expected * Z / (Jl * jw + Bl + Z);
    const std::complex<double> expected_twist = (expected - expected_load) / jw;
    EXPECT_LT(std::abs(std::complex<double>(b(0), b(1)) - expected_load),
              1e-3 * std::abs(expected_load))
        << "w_load at " << f << " Hz";
    EXPECT_LT(std::abs(std::complex<double>(d(0), d(1)) - expected_twist),
              1e-3 * std::abs(expected_twist))
        << "twist at " << f << " Hz";
  }
}

// A share outside [0, 1] is refused with the file, line and column of its value.
TEST(TwoMass, ConfigRefusesAShareAboveOne) {
  const std::string text = R"({
  "name": "two-mass", "model": "rigid_load",
  "parameters": { "J": 1e-3, "B": 1e-3 },
  "effects": { "two_mass": { "inertia_ratio": 1, "anti_resonance_hz": 30,
                             "shaft_damping_ratio": 0.05, "load_damping_share": 1.5 } },
  "experiment": { "input": { "type": "step", "amplitude": 1.0 }, "duration": 1 }
})";
  try {
    ParseConfig(text, "two-mass.json");
    FAIL() << "a share of 1.5 was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("two-mass.json:5:", 0), 0u) << e.what();
    EXPECT_NE(std::string(e.what()).find("must be in [0, 1] (got 1.5)"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace blmd::testing
