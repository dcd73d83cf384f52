// The input-residual test (include/blmd/ident/residual/input_residual.h, docs/discovery.md §7b):
// its false-alarm rate when the residual is noise independent of the input (white, and AR(1)
// 0.95, under a PRBS, a square wave and a chirp), and what it finds when the residual is the
// response of a resonance to the input: significant, most of the residual's variance, at the
// resonance's frequency. Also over two traces, and not made on a constant input.
#include "blmd/ident/residual/input_residual.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "blmd/random.h"

namespace blmd::testing {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kRate = 2000.0;

std::vector<double> Input(const std::string& kind, Random& random, std::size_t n) {
  std::vector<double> u(n);
  double held = 1.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) / kRate;
    if (kind == "prbs") {
      if (k % 5 == 0) held = random.Uniform() < 0.5 ? -1.0 : 1.0;
      u[k] = held;
    } else if (kind == "square") {
      u[k] = std::sin(2.0 * kPi * 2.0 * t + 1e-9) >= 0.0 ? 1.0 : -1.0;
    } else {  // a logarithmic chirp from 1 to 200 Hz over the record
      const double duration = static_cast<double>(n) / kRate;
      u[k] = std::sin(2.0 * kPi * duration / std::log(200.0) * (std::pow(200.0, t / duration) - 1));
    }
  }
  return u;
}

std::vector<double> Noise(Random& random, std::size_t n, double rho) {
  std::vector<double> x(n);
  double state = random.Normal();
  for (std::size_t k = 0; k < n; ++k) {
    x[k] = state;
    state = rho * state + std::sqrt(1.0 - rho * rho) * random.Normal();
  }
  return x;
}

// The response of a lightly damped resonance (f0 Hz, damping ratio 0.03) to u, by the exact
// discretisation of its impulse-invariant second-order section.
std::vector<double> Resonance(const std::vector<double>& u, double f0) {
  const double w0 = 2.0 * kPi * f0, zeta = 0.03, dt = 1.0 / kRate;
  const double r = std::exp(-zeta * w0 * dt), wd = w0 * std::sqrt(1.0 - zeta * zeta);
  const double a1 = 2.0 * r * std::cos(wd * dt), a2 = -r * r;
  std::vector<double> y(u.size(), 0.0);
  for (std::size_t k = 2; k < u.size(); ++k) y[k] = a1 * y[k - 1] + a2 * y[k - 2] + u[k - 1];
  return y;
}

TEST(InputPast, FalseAlarmsOnNoiseIndependentOfTheInput) {
  // 3 inputs x 2 noises x 20 seeds = 120 records of 8 000 samples; at the level 1e-3 the
  // expected count is 0.12.
  int alarms = 0, records = 0;
  double largest_share = 0.0;
  for (const std::string kind : {"prbs", "square", "chirp"}) {
    for (const double rho : {0.0, 0.95}) {
      for (std::uint64_t seed = 1; seed <= 20; ++seed) {
        Random random(seed);
        const std::vector<double> u = Input(kind, random, 8000);
        const std::vector<double> e = Noise(random, 8000, rho);
        const InputPastTest test = TestInputPast(e, u, {0}, kRate, 25);
        ASSERT_TRUE(test.ok) << kind;
        alarms += test.p_value < 1e-3;
        ++records;
        largest_share = std::max(largest_share, test.share);
      }
    }
  }
  EXPECT_EQ(records, 120);
  EXPECT_LE(alarms, 1);
  EXPECT_LT(largest_share, 0.03);  // about L/n = 0.3 % each
}

TEST(InputPast, FindsAResonanceTheModelLacksAndWhereItIs) {
  for (const std::string kind : {"prbs", "square", "chirp"}) {
    for (const double f0 : {25.0, 60.0}) {
      Random random(7);
      const std::vector<double> u = Input(kind, random, 8000);
      std::vector<double> e = Resonance(u, f0);
      double power = 0.0;
      for (double v : e) power += v * v;
      const double sigma = 0.1 * std::sqrt(power / static_cast<double>(e.size()));
      const std::vector<double> noise = Noise(random, e.size(), 0.95);
      for (std::size_t k = 0; k < e.size(); ++k) e[k] += sigma * noise[k];
      const InputPastTest test = TestInputPast(e, u, {0}, kRate, 25);
      ASSERT_TRUE(test.ok);
      EXPECT_LT(test.p_value, 1e-10) << kind << " " << f0;
      // A square wave drives only its odd harmonics, whose power falls as 1/k^2: the
      // residual's part found from 25 lags is smaller (0.47, 0.48 here) and the frequency is
      // read between harmonics the input hardly drives, so it is not asserted (documented).
      EXPECT_GT(test.share, kind == "square" ? 0.4 : 0.5) << kind << " " << f0;
      if (kind != "square") {
        EXPECT_NEAR(test.frequency_hz, f0, 0.1 * f0) << kind;
      }
      EXPECT_EQ(test.lags, 25);
      EXPECT_EQ(test.ccf.size(), 25u);
      EXPECT_GT(std::abs(test.peak), test.band95);
    }
  }
}

TEST(InputPast, TracesPooledEachFromItsOwnStart) {
  // Two traces, each a resonance's response to its own input from rest: found as in one.
  Random random(3);
  std::vector<double> u = Input("prbs", random, 4000), e = Resonance(u, 40.0);
  const std::vector<double> u2 = Input("prbs", random, 4000), e2 = Resonance(u2, 40.0);
  u.insert(u.end(), u2.begin(), u2.end());
  e.insert(e.end(), e2.begin(), e2.end());
  const std::vector<double> noise = Noise(random, e.size(), 0.0);
  for (std::size_t k = 0; k < e.size(); ++k) e[k] += 0.05 * noise[k];
  const InputPastTest test = TestInputPast(e, u, {0, 4000}, kRate, 25);
  ASSERT_TRUE(test.ok);
  EXPECT_LT(test.p_value, 1e-10);
  EXPECT_NEAR(test.frequency_hz, 40.0, 4.0);
}

TEST(InputPast, NotMadeOnAConstantInputOrAShortRecord) {
  Random random(5);
  const std::vector<double> e = Noise(random, 4000, 0.0);
  EXPECT_FALSE(TestInputPast(e, std::vector<double>(4000, 0.3), {0}, kRate, 25).ok);
  const std::vector<double> short_e(100, 0.0), short_u(100, 1.0);
  EXPECT_FALSE(TestInputPast(short_e, short_u, {0}, kRate, 25).ok);
}

}  // namespace
}  // namespace blmd::testing
