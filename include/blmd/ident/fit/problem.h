// A fit problem (docs/identification.md): a config's model, one or more measured traces,
// the observed columns and the free parameters. Evaluate() simulates every trace with its
// own recorded input u and compares the observed columns at the trace's own sample times.
//
// Cost = (1/C) sum_c (1/N_c) sum_k SSE_kc / S_kc   (C observed columns, N_c samples of
// column c over all traces, SSE_kc trace k's squared errors in column c) with the weight
// variance S_kc: by default the measured column's variance Var_c pooled over the traces
// (cost = (1/C) sum_c MSE_c / Var_c = NRMSE^2, columns of different units alike), or, when
// every trace carries FitTrace::noise_variance for every observed column, each trace's
// column's noise variance (maximum likelihood with Gaussian noise;
// docs/identification.md §1a). Evaluation::nrmse2 is always (1/C) sum_c MSE_c / Var_c:
// NRMSE = sqrt(nrmse2), 0 is a perfect fit, 1 no better than each column's mean.
// A point whose simulation diverges or is invalid has an infinite cost and a reason.
//
// The free parameters are searched in scaled coordinates s in [0,1]: log scale between the
// bounds for positive scale parameters (J, B, R, ...), linear otherwise.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "blmd/ident/fit/equation_error.h"
#include "blmd/io/config.h"
#include "blmd/sim/model.h"
#include "blmd/sim/trace.h"

namespace blmd {

// With the config's identification error "equation" (rigid_load), the comparison is the
// equation error instead (blmd/ident/fit/equation_error.h): the observed column is the input u,
// "simulating" a trace predicts the input the model needs along the measured motion, and
// each trace is compared at its filtered, decimated samples (measured(k)), not its rows.

// One measured experiment prepared for fitting.
struct FitTrace {
  std::string path;      // for reports
  std::string sha256;    // of the file's bytes
  Trace trace;           // t, u and the observed columns (after mapping and scaling)
  InputSignal input;     // zero-order hold of the trace's u (and `open`, if present)
  InitialState initial;  // state at the first sample
  // The noise variance of each measured column (column -> sigma^2, the column's units
  // squared), when known: the cost then weights this trace's column by 1/sigma^2 (maximum
  // likelihood; docs/identification.md §1a). Empty: weighted by the column's variance.
  std::map<std::string, double> noise_variance;
};

struct FreeParameter {
  std::string name;
  double lower = 0.0, upper = 0.0;  // bounds, physical units
  bool log_scale = false;
  double initial = 0.0;  // start value, physical units
};

// How far `value` is from each bound of `p`, in its search coordinates (log for a log-scale
// parameter), with the bounded range in the same units: what "on its bound" is measured by.
struct BoundDistance {
  double span = 0.0, below = 0.0, above = 0.0;
};
BoundDistance DistanceToBounds(const FreeParameter& p, double value);

// The outcome of one cost evaluation.
struct Evaluation {
  bool ok = false;
  std::string reason;       // why not ok
  double cost = 0.0;        // +inf when !ok
  double nrmse2 = 0.0;      // (1/C) sum_c MSE_c / Var_c, whatever the weights; +inf when !ok
  std::vector<double> mse;  // per observed column, pooled over traces
  std::vector<std::vector<double>> mse_per_trace;  // [trace][column]
};

class FitProblem {
 public:
  FitProblem(Config config, std::vector<FitTrace> traces, std::vector<std::string> observe,
             std::vector<FreeParameter> free);

  const Config& config() const { return config_; }
  const std::vector<FitTrace>& traces() const { return traces_; }
  // What trace k's simulated columns are compared with: its trace, or with the equation
  // error its filtered samples (t, u, w, theta at the kept instants).
  const Trace& measured(std::size_t k) const {
    return equation_.empty() ? traces_[k].trace : equation_[k].measured;
  }
  bool equation_error() const { return !equation_.empty(); }
  // Per trace, with the equation error (empty otherwise).
  const std::vector<EquationTrace>& equation_traces() const { return equation_; }
  const std::vector<std::string>& observe() const { return observe_; }
  const std::vector<FreeParameter>& free() const { return free_; }
  std::size_t num_free() const { return free_.size(); }
  // Measured variance of each observed column (pooled): NRMSE's scale, and the cost's
  // weights unless the traces carry their noise.
  const std::vector<double>& variance() const { return variance_; }
  std::size_t num_residuals() const { return num_residuals_; }
  // The weight variances S_kc, [trace][observed column]: Var_c in every trace by default.
  const std::vector<std::vector<double>>& weight_variances() const { return weight_variance_; }
  // True when the weights are the traces' noise variances (FitTrace::noise_variance).
  bool noise_weighted() const { return noise_weighted_; }
  // Observed-column index of each residual, in Evaluate's order, its trace, and each
  // column's weight 1/sqrt(C N_c S_kc) (residual = weight * (sim - meas)).
  const std::vector<int>& residual_columns() const { return residual_columns_; }
  const std::vector<int>& residual_traces() const { return residual_traces_; }
  double column_weight(std::size_t c, std::size_t k = 0) const;
  // The finite-difference step of the Jacobians (search coordinates; ident/fit/jacobian.h):
  // 1e-5 when the model is integrated by the events method (its output is smooth in the
  // parameters: a coarser step's secant overstates the derivatives of a PWM drive's sampled
  // current, and so understates the intervals), else 1e-3 (a fixed step's events shift by
  // whole steps: the cost has micro-jumps a finer step would differentiate).
  double DifferenceStep() const;
  // Per-residual factors that turn weighted residuals into noise-normalised ones, e/s_c,
  // with s_c^2 = SSE_c / (N_c - p/C) estimated from `evaluation` (the fit's residual; per
  // trace and column when the weights differ between traces): the white covariance of a fit
  // needs these.
  std::vector<double> NoiseNormalisation(const Evaluation& evaluation) const;

  // Physical values <-> scaled coordinates in [0,1].
  std::vector<double> ToScaled(const std::vector<double>& values) const;
  std::vector<double> FromScaled(const std::vector<double>& scaled) const;
  std::vector<double> InitialValues() const;
  // The same problem (weights, forced angles) started from `values` (physical units, each
  // clamped into its bounds): a restart of a local fit.
  FitProblem WithStart(const std::vector<double>& values) const;
  // The same problem with other ranges and starts for its free parameters (the same names in
  // the same order): a search box moved (start_scan.h, MoveDefaultRanges).
  FitProblem WithFree(std::vector<FreeParameter> free) const;
  // The same problem (weights, forced angles, start) simulated on a fixed step of `dt` s.
  FitProblem WithStep(double dt) const;

  // The full parameter set with the free values substituted.
  ParameterSet Parameters(const std::vector<double>& values) const;

  // Cost at physical values (thread-safe: the problem is const, each call has its own
  // scratch). When `residuals` is given it receives the weighted residuals, trace after
  // trace, column after column: r = (sim - meas) / sqrt(C N_c Var_c), so sum r^2 = cost.
  Evaluation Evaluate(const std::vector<double>& values,
                      std::vector<double>* residuals = nullptr) const;
  // Evaluate() at several points at once, each result (and, when `residuals` is given, each
  // point's residual vector) equal to Evaluate's: every trace is simulated for all the points
  // together through Model::SimulateBatch (the blmd model runs up to 8 points in SIMD lanes).
  // Surfaces, FSD's probes and gradients and Ceres's finite-difference Jacobians use it.
  std::vector<Evaluation> EvaluateBatch(
      const std::vector<std::vector<double>>& points,
      std::vector<std::vector<double>>* residuals = nullptr) const;

  // Position-dependent effects (cogging) see each trace's measured angle instead of the
  // simulated one (SimulationSettings::effect_angle; MeasuredAngle). Returns false, and
  // changes nothing, when a trace records neither theta nor w.
  bool ForceEffectAngle();
  bool effect_angle_forced() const { return !effect_angles_.empty(); }

  // Simulates trace k at the given values (outputs at its sample times; with the equation
  // error, the input the model needs at measured(k)'s instants).
  SimStatus Simulate(std::size_t k, const std::vector<double>& values, Trace* out) const;

 private:
  // The request that simulates trace k with `parameters` (borrowed).
  SimulationRequest Request(std::size_t k, const ParameterSet* parameters) const;
  // Adds trace k's squared errors per observed column to *sum_sq and its per-trace MSEs to
  // *evaluation (weighted residuals to *residuals if given); false, with the reason in
  // *evaluation, when a simulated column is not finite.
  bool Compare(std::size_t k, const Trace& simulated, std::vector<double>* sum_sq,
               Evaluation* evaluation, std::vector<double>* residuals) const;
  // The per-column MSEs and the cost from the summed squared errors.
  void Finish(const std::vector<double>& sum_sq, Evaluation* evaluation) const;
  // "a.csv, b.csv: " naming the traces for an error message ("" when they have no path).
  std::string Where() const;

  Config config_;
  std::vector<FitTrace> traces_;
  std::vector<Experiment> experiments_;  // per trace: its input and initial state, open loop
  std::vector<std::string> observe_;
  std::vector<FreeParameter> free_;
  std::vector<double> variance_;
  std::vector<std::vector<double>> weight_variance_;  // [trace][column], S_kc
  bool uniform_weights_ = true;
  bool noise_weighted_ = false;
  std::vector<std::size_t> samples_per_column_;
  std::vector<int> residual_columns_;
  std::vector<int> residual_traces_;
  std::size_t num_residuals_ = 0;
  std::vector<std::vector<double>> effect_angles_;  // per trace, when forced
  std::vector<EquationTrace> equation_;             // per trace, with the equation error
};

// The measured shaft angle (rad) at a trace's samples: its theta column, else the
// trapezoidal integral of its w from the initial angle; empty when it has neither.
std::vector<double> MeasuredAngle(const FitTrace& trace);

// The highest order (periods per revolution) of a ripple in the shaft angle that the traces'
// samples resolve (Shannon): a ripple of order m advances m |dtheta| radians between two
// samples and, once that passes pi, is aliased to a lower order at the samples (at a steady
// speed it is indistinguishable from it). The median of pi / |dtheta| over the samples in
// motion (|dtheta| above a quarter of its 99th percentile in the trace, so that a glitch or
// an encoder's wrap does not set the scale), from the measured angle;
// 0 when no trace records an angle or the shaft does not move.
int AngleNyquistOrder(const std::vector<FitTrace>& traces);

// Builds the free-parameter list from the config (bounds, initial values, log scale).
// Throws InputError for an unknown parameter or an initial value outside its bounds.
// Free parameters by name only (no bounds, no start), for a problem that is evaluated at
// given values and never searched (validation after discovery, the simulated check).
std::vector<FreeParameter> NamedFreeParameters(const std::vector<std::string>& names);

std::vector<FreeParameter> MakeFreeParameters(const Config& config,
                                              const std::vector<std::string>& names);

}  // namespace blmd
