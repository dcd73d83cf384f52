#include "blmd/ident/uncertainty/parameter_correlation.h"

#include <cmath>
#include <limits>

#include "blmd/ident/uncertainty/uncertainty.h"
#include "ident/fit/jacobian.h"

namespace blmd {
namespace {

// The intervals of `result` come from the HAC sandwich (also when the spread between traces
// widened them afterwards: the sandwich was their first source).
bool IntervalsFromSandwich(const FitResult& result) {
  for (const ParameterEstimate& e : result.estimates) {
    if (!e.has_interval) continue;
    if (e.interval_method.rfind("hac_prewhitened", 0) == 0 ||
        e.interval_method.rfind("leave_one_trace_out", 0) == 0)
      return true;
  }
  return false;
}

}  // namespace

Eigen::MatrixXd CorrelationFromCovariance(const Eigen::MatrixXd& covariance) {
  const Eigen::Index p = covariance.rows();
  Eigen::MatrixXd correlation(p, p);
  for (Eigen::Index j = 0; j < p; ++j) {
    for (Eigen::Index k = 0; k < p; ++k) {
      const double vj = covariance(j, j), vk = covariance(k, k);
      const bool ok = vj > 0.0 && vk > 0.0 && std::isfinite(vj) && std::isfinite(vk);
      correlation(j, k) = !ok ? std::numeric_limits<double>::quiet_NaN()
                          : j == k
                              ? 1.0
                              : 0.5 * (covariance(j, k) + covariance(k, j)) / std::sqrt(vj * vk);
    }
  }
  return correlation;
}

ParameterCorrelation EstimateParameterCorrelation(const FitProblem& problem,
                                                  const FitResult& result) {
  ParameterCorrelation out;
  out.method = "hac_prewhitened";
  for (const auto& p : problem.free()) out.names.push_back(p.name);
  if (!result.evaluation.ok || result.values.size() != problem.num_free()) {
    out.reason = "the fit's cost could not be evaluated";
    return out;
  }
  if (!IntervalsFromSandwich(result)) {
    out.reason = "the intervals do not come from a covariance matrix (no hac_prewhitened interval)";
    return out;
  }
  internal::DifferenceRule rule;
  if (result.summary.fd_step > 0.0) rule.step = result.summary.fd_step;
  std::vector<double> r;
  Eigen::MatrixXd jacobian;
  if (!internal::FiniteDifferenceJacobian(problem,
                                          internal::ToSearchCoordinates(problem, result.values),
                                          rule, nullptr, &r, &jacobian)) {
    out.reason = "the Jacobian at the estimate could not be evaluated";
    return out;
  }
  ResidualLayout layout;
  layout.columns = problem.observe().size();
  for (std::size_t k = 0; k < problem.traces().size(); ++k)
    layout.rows.push_back(problem.measured(k).rows());
  const Eigen::VectorXd residuals =
      Eigen::Map<const Eigen::VectorXd>(r.data(), static_cast<Eigen::Index>(r.size()));
  const SandwichCovariance sandwich = HacSandwichCovariance(jacobian, residuals, layout);
  if (!sandwich.ok) {
    out.reason = sandwich.reason;
    return out;
  }
  out.covariance = sandwich.covariance;
  out.correlation = CorrelationFromCovariance(sandwich.covariance);
  if (!out.correlation.allFinite()) {
    out.reason = "a parameter's variance is zero: the cost does not depend on it";
    return out;
  }
  for (std::size_t j = 0; j < out.names.size(); ++j) {
    for (std::size_t k = j + 1; k < out.names.size(); ++k) {
      const double rho =
          out.correlation(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(k));
      if (std::abs(rho) > kPoorlySeparableCorrelation)
        out.poorly_separable.push_back({out.names[j], out.names[k], rho});
    }
  }
  out.available = true;
  return out;
}

}  // namespace blmd
