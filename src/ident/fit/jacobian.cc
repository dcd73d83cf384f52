#include "ident/fit/jacobian.h"

#include <algorithm>
#include <cmath>

#include "ident/fit/counting_cost.h"

namespace blmd::internal {
namespace {

// The residuals at `points` (search coordinates); ok[m] false where point m failed.
std::vector<bool> Residuals(const FitProblem& problem, CountingCost* counter, bool clamp,
                            const std::vector<std::vector<double>>& points,
                            std::vector<std::vector<double>>* residuals) {
  std::vector<std::vector<double>> values;
  values.reserve(points.size());
  for (const auto& x : points) values.push_back(FromSearchCoordinates(problem, x, clamp));
  const std::vector<Evaluation> evaluations = counter ? counter->EvaluateBatch(values, residuals)
                                                      : problem.EvaluateBatch(values, residuals);
  std::vector<bool> ok(points.size());
  for (std::size_t m = 0; m < points.size(); ++m) ok[m] = evaluations[m].ok;
  return ok;
}

}  // namespace

std::vector<double> ToSearchCoordinates(const FitProblem& problem,
                                        const std::vector<double>& values) {
  std::vector<double> x(values.size());
  for (std::size_t k = 0; k < values.size(); ++k)
    x[k] = problem.free()[k].log_scale ? std::log(values[k]) : values[k];
  return x;
}

std::vector<double> FromSearchCoordinates(const FitProblem& problem, const std::vector<double>& x,
                                          bool clamp) {
  std::vector<double> values(x.size());
  for (std::size_t k = 0; k < x.size(); ++k) {
    const FreeParameter& p = problem.free()[k];
    values[k] = p.log_scale ? std::exp(x[k]) : x[k];
    if (clamp) values[k] = std::clamp(values[k], p.lower, p.upper);
  }
  return values;
}

bool FiniteDifferenceJacobian(const FitProblem& problem, const std::vector<double>& x,
                              const DifferenceRule& rule, CountingCost* counter,
                              std::vector<double>* residuals, Eigen::MatrixXd* jacobian) {
  const std::size_t p = x.size();
  // The point, its forward neighbours and (central) its backward ones, simulated together.
  std::vector<std::vector<double>> points = {x};
  std::vector<double> h(p);
  const double step = rule.step > 0.0 ? rule.step : problem.DifferenceStep();
  for (std::size_t k = 0; k < p; ++k) {
    const FreeParameter& fp = problem.free()[k];
    h[k] = fp.log_scale
               ? step
               : step * std::max(std::abs(x[k]), rule.linear_floor * (fp.upper - fp.lower));
    points.push_back(x);
    points.back()[k] += h[k];
  }
  for (std::size_t k = 0; rule.central && k < p; ++k) {
    points.push_back(x);
    points.back()[k] -= h[k];
  }
  std::vector<std::vector<double>> r;
  const std::vector<bool> ok = Residuals(problem, counter, rule.clamp_to_bounds, points, &r);
  if (!ok[0]) return false;
  const std::size_t n = r[0].size();
  *residuals = r[0];
  jacobian->resize(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(p));
  for (std::size_t k = 0; k < p; ++k) {
    const bool ok_plus = ok[1 + k];
    // Forward differences take the backward side only when the forward side failed.
    std::vector<std::vector<double>> backward;
    bool ok_minus = false;
    if (rule.central) {
      ok_minus = ok[1 + p + k];
    } else if (!ok_plus) {
      std::vector<std::vector<double>> one = {x};
      one[0][k] -= h[k];
      ok_minus = Residuals(problem, counter, rule.clamp_to_bounds, one, &backward)[0];
    }
    if (!ok_plus && !ok_minus) return false;
    if (rule.central && !rule.one_sided_fallback && !(ok_plus && ok_minus)) return false;
    const std::vector<double>& plus = r[1 + k];
    const std::vector<double>& minus =
        rule.central ? r[1 + p + k] : (ok_minus ? backward[0] : r[0]);
    for (std::size_t i = 0; i < n; ++i) {
      double derivative = 0.0;
      if (ok_plus && ok_minus) {
        derivative = (plus[i] - minus[i]) / (2.0 * h[k]);
      } else if (ok_plus) {
        derivative = (plus[i] - r[0][i]) / h[k];
      } else {
        derivative = (r[0][i] - minus[i]) / h[k];
      }
      if (!std::isfinite(derivative)) return false;
      (*jacobian)(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(k)) = derivative;
    }
  }
  return true;
}

}  // namespace blmd::internal
