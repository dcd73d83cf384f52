#include "blmd/tune/loop.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>

#include "blmd/constants.h"

namespace blmd {
namespace {

using Complex = std::complex<double>;

// Refines a change of f between a and b from > 0 to <= 0 (or back) by bisection in log ω to
// 1e-12 of the frequency.
double Bisect(const std::function<double(double)>& f, double a, double b) {
  double fa = f(a);
  for (int k = 0; k < 200 && b - a > 1e-12 * b; ++k) {
    const double mid = std::sqrt(a * b);
    const double fm = f(mid);
    if ((fm > 0.0) == (fa > 0.0)) {
      a = mid;
      fa = fm;
    } else {
      b = mid;
    }
  }
  return std::sqrt(a * b);
}

// Degrees of an angle wrapped to (−180°, 180°].
double WrapDegrees(double degrees) {
  double wrapped = std::fmod(degrees, 360.0);
  if (wrapped <= -180.0) wrapped += 360.0;
  if (wrapped > 180.0) wrapped -= 360.0;
  return wrapped;
}

// Drops leading zero coefficients (keeps at least one).
std::vector<double> Trimmed(std::vector<double> p) {
  std::size_t first = 0;
  while (first + 1 < p.size() && p[first] == 0.0) ++first;
  p.erase(p.begin(), p.begin() + static_cast<std::ptrdiff_t>(first));
  return p;
}

}  // namespace

Complex Controller::At(double omega) const {
  const Complex s(0.0, omega);
  Complex c = kp + ki / s;
  if (kd != 0.0) {
    c += derivative_filter_hz > 0.0 ? kd * s / (1.0 + s / (kTwoPi * derivative_filter_hz)) : kd * s;
  }
  return c;
}

// kp + ki/s + kd s/(1 + s/ωf) = [(kp/ωf + kd) s² + (kp + ki/ωf) s + ki] / (s²/ωf + s); without
// the integral term the common factor s is left out (it would be a closed-loop pole at 0).
std::vector<double> Controller::Numerator() const {
  if (derivative_filter_hz > 0.0) {
    const double wf = kTwoPi * derivative_filter_hz;
    if (ki == 0.0) return Trimmed({kp / wf + kd, kp});
    return Trimmed({kp / wf + kd, kp + ki / wf, ki});
  }
  if (ki == 0.0) return Trimmed({kd, kp});
  return Trimmed({kd, kp, ki});
}

std::vector<double> Controller::Denominator() const {
  if (derivative_filter_hz > 0.0) {
    const double wf = kTwoPi * derivative_filter_hz;
    if (ki == 0.0) return {1.0 / wf, 1.0};
    return {1.0 / wf, 1.0, 0.0};
  }
  if (ki == 0.0) return {1.0};
  return {1.0, 0.0};
}

Complex Polyval(const std::vector<double>& coefficients, Complex s) {
  Complex value = 0.0;
  for (double c : coefficients) value = value * s + c;
  return value;
}

Complex FrequencyResponse(const TransferFunction& g, double omega) {
  const Complex s(0.0, omega);
  return Polyval(g.numerator, s) / Polyval(g.denominator, s);
}

std::vector<double> PolyMultiply(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.empty() || b.empty()) return {};
  std::vector<double> out(a.size() + b.size() - 1, 0.0);
  for (std::size_t i = 0; i < a.size(); ++i)
    for (std::size_t j = 0; j < b.size(); ++j) out[i + j] += a[i] * b[j];
  return out;
}

std::vector<double> PolyAdd(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> out(std::max(a.size(), b.size()), 0.0);
  const std::size_t n = out.size();
  for (std::size_t k = 0; k < a.size(); ++k) out[n - a.size() + k] += a[k];
  for (std::size_t k = 0; k < b.size(); ++k) out[n - b.size() + k] += b[k];
  return out;
}

LoopMargins ComputeMargins(const TransferFunction& plant, const Controller& controller,
                           double low_hz, double high_hz) {
  return ComputeMargins(
      [&](double omega) { return controller.At(omega) * FrequencyResponse(plant, omega); }, low_hz,
      high_hz);
}

LoopMargins ComputeMargins(const std::function<Complex(double omega)>& loop, double low_hz,
                           double high_hz) {
  LoopMargins margins;
  auto log_gain = [&](double omega) { return std::log(std::abs(loop(omega))); };
  auto imaginary = [&](double omega) { return loop(omega).imag(); };
  constexpr int kPerDecade = 400;
  const int points = static_cast<int>(std::ceil(std::log10(high_hz / low_hz) * kPerDecade)) + 1;
  std::vector<double> omega(static_cast<std::size_t>(points));
  std::vector<Complex> value(omega.size());
  for (std::size_t k = 0; k < omega.size(); ++k) {
    omega[k] = kTwoPi * low_hz * std::pow(10.0, static_cast<double>(k) / kPerDecade);
    value[k] = loop(omega[k]);
  }
  for (std::size_t k = 0; k + 1 < omega.size(); ++k) {
    // Above 1 or not: a point exactly on |L| = 1 (the design puts ω_c on the grid) belongs to
    // one side, so the crossing is counted once.
    const double g0 = std::log(std::abs(value[k])), g1 = std::log(std::abs(value[k + 1]));
    if ((g0 > 0.0) == (g1 > 0.0)) continue;
    const double wc = Bisect(log_gain, omega[k], omega[k + 1]);
    const double pm = WrapDegrees(180.0 + std::arg(loop(wc)) * 180.0 / std::numbers::pi);
    ++margins.gain_crossovers;
    // The crossing nearest -1: the smallest |margin| (wrapped to (-180°, 180°]). At a second
    // crossing (a resonance's peak) a margin of -170° is a phase of +10°, far from -1.
    if (!(std::abs(pm) >= std::abs(margins.phase_margin_deg))) {  // NaN at first
      margins.phase_margin_deg = pm;
      margins.crossover_hz = wc / kTwoPi;
    }
  }
  for (std::size_t k = 0; k + 1 < omega.size(); ++k) {
    const double i0 = value[k].imag(), i1 = value[k + 1].imag();
    if ((i0 > 0.0) == (i1 > 0.0)) continue;
    const double w180 = Bisect(imaginary, omega[k], omega[k + 1]);
    const Complex l = loop(w180);
    if (!(l.real() < 0.0)) continue;
    const double db = -20.0 * std::log10(std::abs(l));
    if (db > 0.0 && db < margins.gain_margin_db) {
      margins.gain_margin_db = db;
      margins.phase_crossover_hz = w180 / kTwoPi;
    } else if (db < 0.0 && db > margins.lower_gain_margin_db) {
      margins.lower_gain_margin_db = db;
    }
  }
  margins.ok = margins.gain_crossovers > 0;
  if (!margins.ok) {
    margins.reason = "|L(jw)| does not cross 1 between " + std::to_string(low_hz) + " and " +
                     std::to_string(high_hz) + " Hz";
  }
  return margins;
}

ClosedLoopPoles ComputeClosedLoopPoles(const TransferFunction& plant,
                                       const Controller& controller) {
  ClosedLoopPoles out;
  const std::vector<double> p =
      Trimmed(PolyAdd(PolyMultiply(controller.Denominator(), plant.denominator),
                      PolyMultiply(controller.Numerator(), plant.numerator)));
  const int n = static_cast<int>(p.size()) - 1;
  if (n < 1 || p.front() == 0.0) return out;
  // s = sigma·z with sigma the geometric mean of the roots' magnitudes (|p_n/p_0|^(1/n)), so
  // that the companion matrix is well scaled whatever the units.
  double sigma = std::pow(std::abs(p.back() / p.front()), 1.0 / n);
  if (!(sigma > 0.0) || !std::isfinite(sigma)) sigma = 1.0;
  Eigen::MatrixXd companion = Eigen::MatrixXd::Zero(n, n);
  for (int k = 1; k <= n; ++k)
    companion(0, k - 1) = -p[static_cast<std::size_t>(k)] / p.front() / std::pow(sigma, k);
  for (int k = 1; k < n; ++k) companion(k, k - 1) = 1.0;
  const Eigen::EigenSolver<Eigen::MatrixXd> solver(companion, false);
  out.stable = solver.info() == Eigen::Success;
  double slowest = std::numeric_limits<double>::infinity();
  for (int k = 0; k < n; ++k) {
    const Complex pole = solver.eigenvalues()(k) * sigma;
    out.poles.push_back(pole);
    if (!(pole.real() < 0.0)) out.stable = false;
    slowest = std::min(slowest, -pole.real());
  }
  if (out.stable) out.slowest_time_constant = 1.0 / slowest;
  return out;
}

}  // namespace blmd
