// Evidence for adding an effect when the residuals are correlated (docs/discovery.md §
// "Evidence"): the change in BIC computed on prewhitened residuals.
//
// Plain BIC counts every sample as independent. Coloured noise (a sensor's filter, a slow
// disturbance, any small model error) makes neighbouring samples nearly equal, and a
// candidate effect that bends the simulation a little "explains" a slice of that noise with
// the weight of thousands of samples. Here each (trace, column) residual of the candidate
// model is described by an autoregressive noise model AR(p), chosen by BIC among p = 0..2
// and fitted by Yule-Walker (Levinson-Durbin); the same whitening filter
//   e_t = r_t - a_1 r_{t-1} - ... - a_p r_{t-p}
// is applied to the residuals of the model without the effect and of the model with it,
// and the Gaussian log-likelihood of the innovations is compared:
//   dBIC = sum_c N_c ln(SSE_c^cand / SSE_c^base) + dk ln N,
// the prediction-error (generalised least squares) form of the likelihood ratio (Ljung,
// System Identification, 2nd ed., 1999, §7.3 and §16.4; Box, Jenkins & Reinsel, Time
// Series Analysis, 4th ed., ch. 7 for Yule-Walker and order selection by BIC). With white
// residuals the filter is the identity (p = 0) and this is the plain BIC.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace blmd {

class FitProblem;

struct WhitenedEvidence {
  bool ok = false;
  std::string reason;      // why not ok
  double delta_bic = 0.0;  // candidate minus base, whitened (negative: the candidate is better)
  // Per observed column: the largest AR order used over the traces, and the ratio of the
  // whitened to the raw residual variance of the candidate (1: white; small: strongly
  // correlated noise, much of it predictable from the past).
  std::vector<int> order;
  std::vector<double> innovation_ratio;
};

// The evidence for `candidate` at `candidate_values` (the model with the effect) against the
// model without it, given by its weighted residuals `base_residuals` (FitProblem::Evaluate's,
// over the same traces and columns) and its number of free parameters `base_free`.
WhitenedEvidence PrewhitenedEvidence(const std::vector<double>& base_residuals,
                                     std::size_t base_free, const FitProblem& candidate,
                                     const std::vector<double>& candidate_values);

// Yule-Walker AR(p) coefficients a_1..a_p of `series` (mean removed) for p = 0..max_order,
// the order chosen by BIC (N ln sigma_p^2 + p ln N); empty for white. Exposed for tests.
std::vector<double> FitAutoregression(const std::vector<double>& series, int max_order);

}  // namespace blmd
