// The intervals of a fit at its values (fit_intervals.h, docs/uncertainty.md): the Jacobian
// of the cost's weighted residuals, the Cramer-Rao bound, the prewhitened HAC sandwich with
// its Student t quantile, and the white interval beside it.
#include "ident/uncertainty/fit_intervals.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "blmd/ident/uncertainty/uncertainty.h"
#include "blmd/sim/effects.h"
#include "ident/fit/jacobian.h"

namespace blmd {

void EstimateUncertainty(const FitProblem& problem, const std::vector<double>& values,
                         std::vector<ParameterEstimate>* estimates) {
  Eigen::MatrixXd jacobian;
  Eigen::VectorXd residuals;
  if (problem.num_residuals() <= problem.num_free()) return;
  if (!internal::NormalisedResidualJacobian(problem, values, &jacobian, &residuals)) return;
  FitResult scratch;
  scratch.estimates = *estimates;
  internal::SetSandwichIntervals(problem, jacobian, residuals, &scratch);
  *estimates = scratch.estimates;
}

namespace internal {

bool NormalisedResidualJacobian(const FitProblem& problem, const std::vector<double>& values,
                                Eigen::MatrixXd* jacobian, Eigen::VectorXd* residuals) {
  // The cost's own weighted residuals (FitProblem::Evaluate): the sandwich must describe the
  // estimator the fit computes, which weights each column by 1/its variance, not by 1/its
  // noise level (uncertainty.h). The same central differences as the ceres method.
  std::vector<double> r;
  if (!FiniteDifferenceJacobian(problem, ToSearchCoordinates(problem, values), DifferenceRule{},
                                nullptr, &r, jacobian))
    return false;
  *residuals = Eigen::Map<const Eigen::VectorXd>(r.data(), static_cast<Eigen::Index>(r.size()));
  return residuals->allFinite();
}

Eigen::MatrixXd CramerRaoCovariance(const FitProblem& problem, const Eigen::MatrixXd& jacobian,
                                    const Eigen::VectorXd& residuals) {
  // Residual i is w_kc e_i (trace k, column c); the Fisher information of white Gaussian
  // noise of variance sigma_kc^2 is sum_i (dr_i/dx)^T (dr_i/dx) / (w_kc^2 sigma_kc^2), with
  // sigma_kc^2 the noise the cost was weighted by, else the residual's own SSE/(n - p/C).
  const std::size_t traces = problem.traces().size(), columns = problem.observe().size();
  const auto& column_of = problem.residual_columns();
  const auto& trace_of = problem.residual_traces();
  const Eigen::Index p = jacobian.cols();
  if (jacobian.rows() != residuals.size() ||
      static_cast<std::size_t>(jacobian.rows()) != column_of.size() || p == 0)
    return {};
  std::vector<std::vector<double>> sum_sq(traces, std::vector<double>(columns, 0.0));
  std::vector<std::vector<double>> count(traces, std::vector<double>(columns, 0.0));
  for (Eigen::Index i = 0; i < residuals.size(); ++i) {
    const auto k = static_cast<std::size_t>(trace_of[static_cast<std::size_t>(i)]);
    const auto c = static_cast<std::size_t>(column_of[static_cast<std::size_t>(i)]);
    sum_sq[k][c] += residuals(i) * residuals(i);
    count[k][c] += 1.0;
  }
  const double p_per_column = static_cast<double>(p) / static_cast<double>(columns);
  // 1 / (w_kc^2 sigma_kc^2) per trace and column.
  std::vector<std::vector<double>> factor(traces, std::vector<double>(columns, 0.0));
  for (std::size_t k = 0; k < traces; ++k) {
    for (std::size_t c = 0; c < columns; ++c) {
      const double w = problem.column_weight(c, k);
      double sigma2 = 0.0;
      if (problem.noise_weighted()) {
        sigma2 = problem.weight_variances()[k][c];
      } else if (count[k][c] > p_per_column) {
        sigma2 = sum_sq[k][c] / (w * w) / (count[k][c] - p_per_column);
      }
      factor[k][c] = sigma2 > 0.0 ? 1.0 / (w * w * sigma2) : 0.0;
    }
  }
  Eigen::MatrixXd fisher = Eigen::MatrixXd::Zero(p, p);
  for (Eigen::Index i = 0; i < jacobian.rows(); ++i) {
    const auto k = static_cast<std::size_t>(trace_of[static_cast<std::size_t>(i)]);
    const auto c = static_cast<std::size_t>(column_of[static_cast<std::size_t>(i)]);
    fisher.noalias() += factor[k][c] * jacobian.row(i).transpose() * jacobian.row(i);
  }
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(fisher);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0.0)) return {};
  Eigen::MatrixXd covariance = ldlt.solve(Eigen::MatrixXd::Identity(p, p));
  return covariance.allFinite() ? covariance : Eigen::MatrixXd{};
}

void SetSandwichIntervals(const FitProblem& problem, const Eigen::MatrixXd& jacobian,
                          const Eigen::VectorXd& residuals, FitResult* result) {
  const Eigen::MatrixXd crb = CramerRaoCovariance(problem, jacobian, residuals);
  ResidualLayout layout;
  layout.columns = problem.observe().size();
  for (std::size_t k = 0; k < problem.traces().size(); ++k) {
    layout.rows.push_back(problem.measured(k).rows());
  }
  const SandwichCovariance sandwich = HacSandwichCovariance(jacobian, residuals, layout);
  IntervalRecord record;
  record.method = "hac_prewhitened";
  const double t_quantile = sandwich.ok ? StudentTQuantile975(sandwich.degrees_of_freedom) : 0.0;
  for (std::size_t k = 0; k < result->estimates.size(); ++k) {
    ParameterEstimate& e = result->estimates[k];
    const auto index = static_cast<Eigen::Index>(k);
    e.has_interval = e.has_white_interval = false;
    e.std = e.ci95_low = e.ci95_high = 0.0;
    e.std_white = e.ci95_white_low = e.ci95_white_high = 0.0;
    e.interval_method.clear();
    e.white_method.clear();
    e.has_crb = false;
    e.std_crb = 0.0;
    if (crb.rows() == static_cast<Eigen::Index>(result->estimates.size()) &&
        crb(index, index) > 0.0) {
      ParameterEstimate bound = e;
      SetInterval(problem.free()[k], std::sqrt(crb(index, index)), "cramer_rao", &bound);
      e.has_crb = bound.has_interval;
      e.std_crb = bound.std;
    }
    if (!sandwich.ok) continue;
    // A variance of exactly 0 (the cost does not depend on the parameter) is no interval.
    if (sandwich.white(index, index) > 0.0) {
      ParameterEstimate white = e;
      SetInterval(problem.free()[k], std::sqrt(sandwich.white(index, index)), "white_sandwich",
                  &white);
      e.has_white_interval = white.has_interval;
      e.std_white = white.std;
      e.ci95_white_low = white.ci95_low;
      e.ci95_white_high = white.ci95_high;
      e.white_method = white.interval_method;
    }
    if (sandwich.covariance(index, index) > 0.0) {
      SetInterval(problem.free()[k], std::sqrt(sandwich.covariance(index, index)),
                  "hac_prewhitened", &e, t_quantile);
      record.variance_ratio[e.name] = sandwich.variance_ratio[k];
    }
  }
  if (sandwich.ok) {
    record.has_bandwidth = true;
    record.bandwidth = sandwich.bandwidth;
    record.prewhitening_gain = sandwich.max_var_eigenvalue;
    record.degrees_of_freedom = sandwich.degrees_of_freedom;
    record.t_quantile = t_quantile;
  } else {
    record.unavailable = sandwich.reason;
  }
  result->summary.interval_unavailable = sandwich.ok ? "" : sandwich.reason;
  result->summary.interval = std::move(record);
}

void SetInterval(const FreeParameter& parameter, double std_search, const std::string& method,
                 ParameterEstimate* estimate, double quantile) {
  if (parameter.log_scale) {
    estimate->std = estimate->value * std_search;  // delta method
    estimate->ci95_low = estimate->value * std::exp(-quantile * std_search);
    estimate->ci95_high = estimate->value * std::exp(quantile * std_search);
  } else {
    estimate->std = std_search;
    estimate->ci95_low = estimate->value - quantile * std_search;
    estimate->ci95_high = estimate->value + quantile * std_search;
    // A share cannot leave [0, 1] (ParamInfo::share): its interval is cut to that domain, which
    // keeps at least the interval's coverage.
    if (IsShareParameter(parameter.name)) {
      estimate->ci95_low = std::max(estimate->ci95_low, 0.0);
      estimate->ci95_high = std::min(estimate->ci95_high, 1.0);
    }
  }
  estimate->has_interval = std::isfinite(estimate->std) && std::isfinite(estimate->ci95_low) &&
                           std::isfinite(estimate->ci95_high);
  estimate->interval_method = method;
}

}  // namespace internal
}  // namespace blmd
