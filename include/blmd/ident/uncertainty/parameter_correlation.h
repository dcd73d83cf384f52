// The correlation matrix of the free parameters' estimates (docs/report.md "Correlation"):
// ρ_jk = cov_jk / (σ_j·σ_k) of the covariance the intervals come from, the prewhitened HAC
// sandwich (uncertainty.h) at the estimate. The covariance is in the search coordinates
// (ln x for a log-scale parameter); the intervals take σ of a log-scale parameter x as
// x·σ_ln x (the delta method), a positive scale of each row and column, which leaves the
// correlation unchanged, so the matrix is that of the physical parameters too.
//
// |ρ| near 1 means the traces determine a combination of the two parameters much better than
// either one: the data hardly separate them (an experiment with other excitation does).
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "blmd/ident/fit/fit_result.h"
#include "blmd/ident/fit/problem.h"

namespace blmd {

// |ρ| above this: the two parameters are poorly separable (a note in the report, the summary
// and the page, docs/report.md; not a warning: the intervals already allow for it).
inline constexpr double kPoorlySeparableCorrelation = 0.95;

struct CorrelatedPair {
  std::string first, second;  // in the problem's order
  double rho = 0.0;
};

struct ParameterCorrelation {
  bool available = false;
  std::string reason;              // why there is none
  std::string method;              // of the covariance: "hac_prewhitened"
  std::vector<std::string> names;  // the free parameters, in the problem's order
  Eigen::MatrixXd covariance;      // search coordinates
  Eigen::MatrixXd correlation;     // unit diagonal, symmetric, entries in [-1, 1]
  // The pairs with |rho| > kPoorlySeparableCorrelation, in the matrix's order.
  std::vector<CorrelatedPair> poorly_separable;
};

// ρ_jk = cov_jk / sqrt(cov_jj·cov_kk), with cov_jk taken as (cov_jk + cov_kj)/2 (a computed
// sandwich is symmetric only to rounding), so ρ is exactly symmetric; NaN in the row and
// column of a variance that is not positive and finite.
Eigen::MatrixXd CorrelationFromCovariance(const Eigen::MatrixXd& covariance);

// The correlation of `result`'s estimates on `problem`: the same Jacobian (central
// differences at the estimate, the method's step: details.fd_step for ceres, else the problem's
// DifferenceStep) and HAC sandwich as the intervals (EstimateUncertainty), evaluated again (2p + 1
// evaluations). Not available when the fit failed, the intervals do not come from that sandwich
// (the classic method), or the sandwich cannot be formed (the reason says which).
ParameterCorrelation EstimateParameterCorrelation(const FitProblem& problem,
                                                  const FitResult& result);

}  // namespace blmd
