#include "blmd/ident/residual/stats.h"

#include <boost/math/special_functions/gamma.hpp>
#include <cmath>
#include <limits>

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

// Boost.Math's regularised incomplete gamma (a maintained library instead of our own
// series and continued fraction). Arguments outside its domain give the limits the callers
// want: Q(a, x <= 0) = 1, Q(a, +inf) = 0; a <= 0 or NaN is no distribution (NaN).
double GammaQ(double a, double x) {
  if (!(a > 0.0) || std::isnan(x)) return std::numeric_limits<double>::quiet_NaN();
  if (x <= 0.0) return 1.0;
  if (std::isinf(x)) return 0.0;
  return boost::math::gamma_q(a, x);
}

double ChiSquareSurvival(double x, double dof) { return GammaQ(0.5 * dof, 0.5 * x); }

}  // namespace blmd
