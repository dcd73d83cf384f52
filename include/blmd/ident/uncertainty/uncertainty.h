// Parameter covariance that accounts for correlated residuals (docs/uncertainty.md).
//
// The fit minimises sum_k r_k(theta)^2 over the cost's weighted residuals (each observed
// column divided by the square root of its variance times its sample count, FitProblem).
// With Jacobian J = dr/dtheta (in the search coordinates) the estimate's covariance is the
// sandwich
//   cov = (J^T J)^-1  S  (J^T J)^-1,   S = Var(J^T r) = sum_t sum_u E[g_t g_u^T],
// where g_t = sum_c J_{c,t}^T r_{c,t} is the score of time instant t of a trace (all observed
// columns at that instant together, so that the current's and the speed's residuals may be
// correlated with each other as well as in time). The classic (J^T J)^-1 of residuals scaled
// to unit noise is right only when the cost weights each column by its inverse noise
// variance; this cost weights by the column's variance, so even with white noise the
// sandwich is needed: with independent samples S = sum_c s_c^2 J_c^T J_c, s_c^2 the mean
// squared weighted residual of column c (the "white" covariance below). Correlated residuals
// (a sensor filter, coloured noise, any small model error) make S larger still, often by the
// correlation time.
//
// S is estimated by the heteroskedasticity-and-autocorrelation-consistent (HAC) estimator of
// Newey & West (1987) with the Bartlett kernel, after VAR(1) prewhitening of the scores
// (Andrews & Monahan 1992): h_t = g_t - A g_{t-1} with A the least-squares VAR(1) matrix
// (its eigenvalues capped at 0.97 in modulus, as they recommend), S_h the Bartlett-weighted
// sum of h's autocovariances up to lag L, and S = (I - A)^-1 S_h (I - A)^-T. L comes from
// Andrews' (1991) AR(1) plug-in rule for the Bartlett kernel, L = 1.1447 (alpha T)^(1/3),
// applied to the whitened scores. Each trace's scores are a series of its own: no lag
// crosses from one trace into the next.
#pragma once

#include <Eigen/Dense>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace blmd {

// Where each residual sits: trace k's block holds its observed columns one after the other,
// each `rows[k]` long (FitProblem's layout).
struct ResidualLayout {
  std::vector<std::size_t> rows;  // per trace
  std::size_t columns = 0;        // observed columns, the same in every trace
};

struct SandwichCovariance {
  bool ok = false;
  std::string reason;               // why not ok
  Eigen::MatrixXd covariance;       // p x p, search coordinates
  Eigen::MatrixXd white;            // the sandwich with independent samples, for comparison
  double bandwidth = 0.0;           // Bartlett lag window L (whitened scores)
  double max_var_eigenvalue = 0.0;  // largest |eigenvalue| of the prewhitening A (after the cap)
  // Of the long-run variance (Satterthwaite): the 95 % interval uses Student's t with these.
  double degrees_of_freedom = std::numeric_limits<double>::infinity();
  // Per parameter: the HAC variance over the white-noise variance (>= 1 when the residuals
  // are positively correlated); the factor by which the classic interval was too narrow is
  // its square root.
  std::vector<double> variance_ratio;
};

// Student t's 97.5 % point with `degrees_of_freedom` (the normal's 1.95996 when infinite or
// above 1e7); the half-width of a 95 % interval in standard deviations.
double StudentTQuantile975(double degrees_of_freedom);

// The prewhitened HAC sandwich from the cost's weighted residuals r and their Jacobian J
// (rows in `layout` order). Not ok when J^T J is singular (smallest singular value below
// 1e-12 of the largest, after scaling each column of J to unit norm) or a value is not
// finite.
SandwichCovariance HacSandwichCovariance(const Eigen::MatrixXd& jacobian,
                                         const Eigen::VectorXd& residuals,
                                         const ResidualLayout& layout);

}  // namespace blmd
