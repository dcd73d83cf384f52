// The noise floor of a record: each measured column's noise variance from its second
// differences, whatever model is fitted to it. The residual checks (residual/adequacy.h), the
// start scan (optimizers/start_scan.h) and discovery's stopping rule compare a fit's error
// with it.
#pragma once

#include <vector>

#include "blmd/ident/fit/problem.h"

namespace blmd {

// The noise variance of a measured column y(t) from its second differences, robust to the
// signal and to outliers: the pseudo-residuals of Gasser, Sroka & Jennen-Steinmetz (1986,
// Biometrika 73, 625-633), e_k = (a y_{k-1} + b y_{k+1} - y_k) / sqrt(a^2 + b^2 + 1) with
// a = (t_{k+1} - t_k) / (t_{k+1} - t_{k-1}), b = 1 - a, which remove a locally linear
// signal, and sigma = 1.4826 median |e_k| (the normal consistency factor). Coloured noise is
// underestimated (only its fast part shows in second differences): the floor is a lower
// bound, which makes the stopping rule's shares conservative.
double NoiseFloorVariance(const std::vector<double>& t, const std::vector<double>& y);

// The noise floor in the cost's units (NRMSE): sqrt of the mean over observed columns of
// sigma_c^2 / Var_c, sigma_c^2 the NoiseFloorVariance of the measured column, pooled over
// the traces by their sample counts. 0 without observed columns.
double NoiseFloorNrmse(const FitProblem& problem);

}  // namespace blmd
