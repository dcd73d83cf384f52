#include "blmd/ident/fit/noise_floor.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace blmd {

double NoiseFloorVariance(const std::vector<double>& t, const std::vector<double>& y) {
  const std::size_t n = std::min(t.size(), y.size());
  if (n < 3) return 0.0;
  std::vector<double> magnitude;
  magnitude.reserve(n - 2);
  for (std::size_t k = 1; k + 1 < n; ++k) {
    const double span = t[k + 1] - t[k - 1];
    if (!(span > 0.0)) continue;
    const double a = (t[k + 1] - t[k]) / span, b = 1.0 - a;
    magnitude.push_back(
        std::abs((a * y[k - 1] + b * y[k + 1] - y[k]) / std::sqrt(a * a + b * b + 1.0)));
  }
  if (magnitude.empty()) return 0.0;
  const auto middle = magnitude.begin() + static_cast<long>(magnitude.size() / 2);
  std::nth_element(magnitude.begin(), middle, magnitude.end());
  const double sigma = 1.482602218505602 * *middle;
  return sigma * sigma;
}

// The noise floor in the cost's units: sqrt of the mean over observed columns of
// sigma_c^2 / Var_c, sigma_c^2 from the measured column's second differences
// (NoiseFloorVariance), pooled over the traces by their sample counts.
double NoiseFloorNrmse(const FitProblem& problem) {
  const std::size_t columns = problem.observe().size();
  if (columns == 0) return 0.0;
  double total = 0.0;
  for (std::size_t c = 0; c < columns; ++c) {
    double weighted = 0.0, count = 0.0;
    for (std::size_t k = 0; k < problem.traces().size(); ++k) {
      const Trace& measured = problem.measured(k);
      const auto n = static_cast<double>(measured.rows());
      weighted +=
          n * NoiseFloorVariance(measured.Column("t"), measured.Column(problem.observe()[c]));
      count += n;
    }
    if (count > 0.0 && problem.variance()[c] > 0.0)
      total += weighted / count / problem.variance()[c];
  }
  return std::sqrt(total / static_cast<double>(columns));
}

}  // namespace blmd
