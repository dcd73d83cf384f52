#include "blmd/ident/uncertainty/derived_quantities.h"

#include <cmath>

#include "blmd/sim/effects.h"

namespace blmd {

std::vector<DerivedEstimate> EstimateDerived(const FitProblem& problem, const FitResult& result,
                                             const ParameterCorrelation& correlation) {
  std::vector<DerivedEstimate> out;
  const std::size_t p = problem.num_free();
  const bool covariance = correlation.available && result.values.size() == p &&
                          correlation.covariance.rows() == static_cast<Eigen::Index>(p) &&
                          result.summary.interval && result.summary.interval->t_quantile > 0.0;
  const ParameterSet at = problem.Parameters(result.values);
  for (const auto& effect : problem.config().effects) {
    for (const auto& info : FindEffect(effect).derived) {
      DerivedEstimate d;
      d.name = info.name;
      d.effect = effect;
      d.unit = info.unit;
      d.meaning = info.meaning;
      d.value = info.value(at);
      if (!std::isfinite(d.value)) {
        d.reason = "the figure is not finite at the estimate";
        out.push_back(d);
        continue;
      }
      if (!covariance) {
        d.reason = correlation.available ? "the fit has no interval"
                                         : "no covariance: " + correlation.reason;
        out.push_back(d);
        continue;
      }
      // The gradient in the search coordinates (ln x for a log-scale parameter).
      Eigen::VectorXd g(static_cast<Eigen::Index>(p));
      bool finite = true;
      for (std::size_t k = 0; k < p; ++k) {
        const FreeParameter& free = problem.free()[k];
        const double x = result.values[k];
        const double h = 1e-6 * (free.log_scale ? 1.0 : std::max(std::abs(x), 1e-12));
        auto moved = [&](double step) {
          std::vector<double> values = result.values;
          values[k] = free.log_scale ? x * std::exp(step) : x + step;
          return info.value(problem.Parameters(values));
        };
        const double plus = moved(h), minus = moved(-h);
        g(static_cast<Eigen::Index>(k)) = (plus - minus) / (2.0 * h);
        finite = finite && std::isfinite(plus) && std::isfinite(minus);
      }
      const double variance = g.dot(correlation.covariance * g);
      if (!finite || !(variance >= 0.0) || !std::isfinite(variance)) {
        d.reason = "the delta method's variance is not finite";
        out.push_back(d);
        continue;
      }
      const double t = result.summary.interval->t_quantile;
      d.std = std::sqrt(variance);
      if (d.value > 0.0) {
        d.ci95_low = d.value * std::exp(-t * d.std / d.value);
        d.ci95_high = d.value * std::exp(t * d.std / d.value);
      } else {
        d.ci95_low = d.value - t * d.std;
        d.ci95_high = d.value + t * d.std;
      }
      d.has_interval = true;
      d.interval_method = "delta_method";
      out.push_back(d);
    }
  }
  return out;
}

}  // namespace blmd
