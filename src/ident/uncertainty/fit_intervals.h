// Private: the intervals of a fit at its values (docs/uncertainty.md), which every optimiser
// attaches to its result: the Jacobian of the cost's weighted residuals in the search
// coordinates, the Cramer-Rao bound, and the prewhitened HAC sandwich (uncertainty.h).
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "blmd/ident/fit/fit_result.h"
#include "blmd/ident/fit/problem.h"

namespace blmd {

// Standard deviations and 95 % intervals at `values`: central-difference Jacobian J of the
// noise-normalised residuals e/s_c (s_c^2 = SSE_c/(N_c - p/C), each observed column its own
// noise level) in the search coordinates (log for log-scale parameters); the headline
// interval from the prewhitened HAC sandwich (uncertainty.h), the white one from
// (J^T J)^-1 ("gauss_newton").
void EstimateUncertainty(const FitProblem& problem, const std::vector<double>& values,
                         std::vector<ParameterEstimate>* estimates);

namespace internal {

// The cost's weighted residuals (FitProblem::Evaluate) at `values` and their central-
// difference Jacobian in the search coordinates (the step of docs/identification.md §4);
// false when a point fails.
bool NormalisedResidualJacobian(const FitProblem& problem, const std::vector<double>& values,
                                Eigen::MatrixXd* jacobian, Eigen::VectorXd* residuals);

// Moves each estimate's interval (the white one a method computed, if any) to its white
// fields and sets the headline interval from the prewhitened HAC sandwich of the cost's
// weighted residuals r and their Jacobian J
// (interval_method "hac_prewhitened"); records the sandwich's bandwidth, prewhitening gain
// and variance ratios in summary.interval, or why it is unavailable.
void SetSandwichIntervals(const FitProblem& problem, const Eigen::MatrixXd& jacobian,
                          const Eigen::VectorXd& residuals, FitResult* result);

// The inverse Fisher information of white Gaussian noise (search coordinates), from the
// cost's weighted residuals r and their Jacobian J: the Cramer-Rao bound of the experiment
// with each trace's column's noise variance (the cost's noise weights when the traces carry
// them, else SSE/(n - p/C) of the residual). Empty when singular.
Eigen::MatrixXd CramerRaoCovariance(const FitProblem& problem, const Eigen::MatrixXd& jacobian,
                                    const Eigen::VectorXd& residuals);

// Sets estimate's std and its interval value -+ quantile * std_search (search coordinates:
// ln x for a log-scale parameter, where the interval is value * exp(-+ quantile * sd)).
// quantile: 1.96 for the normal 95 % interval, Student's t for few degrees of freedom.
void SetInterval(const FreeParameter& parameter, double std_search, const std::string& method,
                 ParameterEstimate* estimate, double quantile = 1.959963984540054);

}  // namespace internal
}  // namespace blmd
