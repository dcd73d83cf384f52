#include "blmd/ident/stats.h"

#include <cmath>

namespace blmd {

std::vector<double> Autocorrelation(const std::vector<double>& x, int max_lag) {
  const std::size_t n = x.size();
  if (n < 2 || max_lag < 1) return {};
  double mean = 0.0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(n);
  double c0 = 0.0;
  for (double v : x) c0 += (v - mean) * (v - mean);
  if (!(c0 > 0.0)) return {};
  std::vector<double> r(static_cast<std::size_t>(max_lag), 0.0);
  for (int lag = 1; lag <= max_lag && static_cast<std::size_t>(lag) < n; ++lag) {
    double c = 0.0;
    for (std::size_t k = static_cast<std::size_t>(lag); k < n; ++k) {
      c += (x[k] - mean) * (x[k - static_cast<std::size_t>(lag)] - mean);
    }
    r[static_cast<std::size_t>(lag - 1)] = c / c0;
  }
  return r;
}

LjungBox LjungBoxTest(const std::vector<double>& x, int lags) {
  LjungBox result;
  const double n = static_cast<double>(x.size());
  const std::vector<double> r = Autocorrelation(x, lags);
  if (r.empty()) return result;
  double q = 0.0;
  for (int k = 1; k <= lags; ++k)
    q += r[static_cast<std::size_t>(k - 1)] * r[static_cast<std::size_t>(k - 1)] / (n - k);
  result.lags = lags;
  result.q = n * (n + 2.0) * q;
  result.p_value = ChiSquareSurvival(result.q, lags);
  return result;
}

// Numerical Recipes style: series for x < a + 1, continued fraction otherwise.
double GammaQ(double a, double x) {
  if (x <= 0.0) return 1.0;
  const double log_prefactor = -x + a * std::log(x) - std::lgamma(a);
  if (x < a + 1.0) {
    double sum = 1.0 / a, term = sum, ap = a;
    for (int n = 0; n < 1000; ++n) {
      ap += 1.0;
      term *= x / ap;
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-15) break;
    }
    return std::max(0.0, 1.0 - sum * std::exp(log_prefactor));
  }
  const double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < 1e-15) break;
  }
  return std::min(1.0, std::exp(log_prefactor) * h);
}

double ChiSquareSurvival(double x, double dof) { return GammaQ(0.5 * dof, 0.5 * x); }

}  // namespace blmd
