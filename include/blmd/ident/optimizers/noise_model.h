// The noise of each observed column and the cost weighted by it (docs/identification.md §1a).
//
// The least-squares cost weights each observed column. Weighted by its signal variance
// (the "variance" weighting), a noisy current and a clean speed count alike, and the
// estimate is as precise as the noisier column allows: with sigma_i = 10 % and sigma_w =
// 0.1 % of each column's peak, J and B scattered 30-75 times their Cramer-Rao bound. For
// Gaussian noise of unknown variance sigma_kc^2 per trace k and column c, the maximum
// likelihood estimate minimises sum_kc SSE_kc / sigma_kc^2 with sigma_kc^2 itself at its
// maximum-likelihood value SSE_kc / n_kc (Bard, Nonlinear Parameter Estimation, 1974,
// §4-8; Ljung, System Identification, 2nd ed., 1999, §7.3: the determinant criterion with a
// diagonal noise covariance). It is computed by iterated reweighting: fit, estimate each
// column's noise from the residual, refit with the weights 1/sigma^2 from the optimum, until
// no sigma moves by more than 5 % (two or three fits).
//
// Floors. A quantised column (an encoder's speed, a converter's steps) has at least the
// quantisation noise q^2/12 (Widrow & Kollar, Quantization Noise, 2008, §4): a residual below
// it is the model following the steps, not a precise column. No sigma falls below 1e-6 of
// the column's standard deviation (a noise-free simulated trace fits to rounding).
//
// The user may fix a column's sigma (--noise-std i=0.014, identification.noise_std): it is
// then kept, and the reweighting estimates only the others.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "blmd/ident/fit/problem.h"
#include "blmd/ident/optimizers/optimizer.h"

namespace blmd {

struct NoiseSettings {
  std::string weighting = "noise";    // "noise" (maximum likelihood) or "variance" (1/Var_c)
  std::map<std::string, double> std;  // fixed sigma per column (the column's units)
  int max_fits = 4;                   // the reweighting's fits at most (the first included)
  double tolerance = 0.05;            // stop when no sigma moves by more than this (relative)
};

// One observed column's noise as the cost used it.
struct ColumnNoise {
  std::string column;
  double std = 0.0;                   // sigma, pooled over the traces (root of the mean variance)
  std::vector<double> std_per_trace;  // sigma of each trace's column
  std::string source;                 // "residual", "fixed", "quantisation", "variance"
  double quantum = 0.0;               // the column's step when quantised (largest over traces)
  double weight = 0.0;                // 1 / sigma^2 (pooled), what a sample's square error counts
  double residual_std = 0.0;          // the final residual's RMS, for comparison
};

struct NoiseModel {
  std::string weighting = "variance";  // as applied
  int fits = 1;                        // fits made (the reweighting's iterations)
  long evaluations = 0;                // cost evaluations of all those fits
  bool converged = true;               // the sigmas settled within the tolerance
  std::vector<ColumnNoise> columns;
};

// The step of a quantised column: the smallest gap q between its distinct values when at
// least 95 % of the values lie on the lattice y_0 + m q (within a thousandth of a step); 0
// when the column is not quantised or has fewer than 20 samples.
double QuantisationStep(const std::vector<double>& y);

// The traces of `problem` with FitTrace::noise_variance set from the residual at `values`:
// per trace and column s^2 = SSE / (n - p/C), floored (quantisation, 1e-12 Var_c); the
// columns in `fixed` (sigma) keep sigma^2. `noise` receives what was set.
std::vector<FitTrace> WithResidualNoise(const FitProblem& problem,
                                        const std::vector<double>& values,
                                        const std::map<std::string, double>& fixed,
                                        NoiseModel* noise);

// The weighted fit: from `first` (the fit of `problem` under its own weights) the noise is
// estimated and the problem refit with the noise weights from the previous optimum, until the
// sigmas settle (NoiseSettings). Returns the weighted problem (its traces carry the noise)
// and its fit in *fit; `noise` says what was done. With weighting "variance" the problem is
// returned as it is (a copy) and *fit = first.
std::unique_ptr<FitProblem> FitNoiseWeighted(const FitProblem& problem, const FitResult& first,
                                             const Optimizer& optimizer,
                                             const OptimizerOptions& options,
                                             const NoiseSettings& settings, FitResult* fit,
                                             NoiseModel* noise);

}  // namespace blmd
