// Experiment design (docs/design.md): how precisely a fit would pin the free parameters down
// with a candidate experiment, and the experiment within the drive's limits that pins them
// down best.
//
// Prediction. An experiment's noise-free response y_c(t; theta) at the prior values theta (the
// config's parameters) and its sensitivities S_c = dy_c/dx (x the search coordinates: ln of a
// log-scale parameter, the value otherwise; central differences, FiniteDifferenceJacobian)
// give the covariance of the estimate that blmd-ident's cost makes (identification.md §1:
// weights a_c = 1/(C N_c Var_c), Var_c the measured column's variance, predicted as the
// noise-free response's variance plus sigma_c^2), with white noise of standard deviation
// sigma_c on observed column c:
//   cov = M^-1 (sum_c a_c^2 sigma_c^2 S_c^T S_c) M^-1,   M = sum_c a_c S_c^T S_c
// (Ljung 1999, ch. 9: the asymptotic covariance of a prediction-error estimate whose weights
// are not the inverse noise variances). With a_c = 1/sigma_c^2 it is the inverse of the Fisher
// information F = sum_c S_c^T S_c / sigma_c^2, the Cramér–Rao bound, reported beside it.
//
// Search. Candidate inputs of four families (square, steps, prbs, chirp) on grids of their
// settings, each with the largest amplitude within the limits; the best by the D-criterion
// ln det cov (Goodwin & Payne 1977; Pronzato & Pázman 2013), or, with targets, the
// A-criterion sum of the targets' variances (search coordinates: relative for J, B).
#pragma once

#include <Eigen/Dense>
#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "blmd/ident/fit/problem.h"
#include "blmd/io/config.h"
#include "blmd/sim/experiment.h"
#include "blmd/sim/trace.h"

namespace blmd {

// The input families, in the order they are searched.
const std::vector<std::string>& DesignFamilies();  // square, steps, prbs, chirp

// The predicted precision of one experiment.
struct PrecisionPrediction {
  bool ok = false;
  std::string reason;                  // why not ok (a failed simulation, a singular information)
  std::vector<std::string> names;      // the free parameters
  std::vector<double> values;          // their prior values
  std::vector<bool> log_scale;         // searched as ln value
  Eigen::MatrixXd covariance;          // of the cost's estimate, search coordinates
  Eigen::MatrixXd cramer_rao;          // inverse Fisher information, search coordinates
  std::vector<double> ci95_halfwidth;  // absolute, the parameter's unit
  std::vector<double> cramer_rao_ci95_halfwidth;  // the same from the Cramér–Rao bound
  double log_det = 0.0;                           // ln det covariance (the D-criterion)
  std::map<std::string, double> peaks;            // max |value| of u and each output, noise-free
};

// The 95 % half-width (absolute) of a parameter with value `value` and standard deviation
// `sd` in its search coordinate: log scale (x·(e^{1.96 sd} − e^{−1.96 sd})/2, half the
// width of the report's interval [x e^{−1.96 sd}, x e^{1.96 sd}]) or linear (1.96 sd).
double Ci95HalfWidth(double value, double sd, bool log_scale);

// What the prediction needs besides the experiment.
struct DesignProblem {
  Config config;                     // the model at the prior values; its experiment open loop
  std::vector<std::string> observe;  // the observed columns
  std::vector<FreeParameter> free;   // the free parameters (bounds for the difference step)
  std::vector<double> sigma;         // per observed column: noise standard deviation, its unit
  // Per free parameter (empty: all 1): the factor by which the residual's colour widens its
  // variance beyond the white-noise prediction, as measured on a record (blmd-design
  // --from-report: the report's HAC variance over its white-noise variance). It multiplies the
  // covariance's row and column of the parameter by its square root (the Cramér–Rao bound,
  // a white-noise figure, is left as it is).
  std::vector<double> variance_factor;
};

// A config's design problem: its observed columns and free parameters (identification), the
// experiment made open loop (no PID, no coast-down). `sigma` is filled by the caller.
// InputError for the equation error (design predicts the output error's precision).
DesignProblem MakeDesignProblem(const Config& config);

// The prediction for the noise-free `response` (a trace of the model at the prior values with
// its input `u`, sampled as the experiment would be): the sensitivities of its observed
// columns, the covariance and the half-widths. Not ok, with the reason, when a neighbour's
// simulation fails or the information is singular (a parameter the experiment does not see).
PrecisionPrediction PredictPrecision(const DesignProblem& problem, const Trace& response);

// The noise-free response of the model at the prior values to `input` held between the
// samples of `times` (zero-order hold of input.At(t) at those instants, as a drive plays a
// table), with the experiment's initial state. The trace has t, u and the model's outputs.
SimStatus SimulateSampledInput(const DesignProblem& problem, const InputSignal& input,
                               const std::vector<double>& times, Trace* response);

// One candidate input of a family.
struct DesignCandidate {
  std::string family;     // square, steps, prbs, chirp
  InputSignal input;      // as a config writes it (amplitude within the limits)
  double dwell = 0.0;     // steps: s per level
  int levels = 0;         // steps: levels per direction
  bool feasible = false;  // simulated, within the limits, a prediction made
  std::string rejected;   // why not feasible
  PrecisionPrediction prediction;
  double criterion = 0.0;  // smaller is better (D: ln det cov; A: sum of target variances)
};

struct ExperimentDesignOptions {
  double duration = 0.0;     // s, > 0
  double sample_rate = 0.0;  // Hz, the samples of the input table and of the response
  double input_limit = 0.0;  // |u| <= this, in the model input's unit (V)
  // Output column -> the largest |value| the noise-free response may reach (i in A, w in rad/s).
  std::map<std::string, double> output_limits;
  // The |u| that breaks the shaft free of the model's friction, cogging and load with the
  // margin of docs/design.md §7 (the model input's unit): a candidate whose peak |u| stays
  // below it would leave the shaft stuck, and is rejected. 0: not checked.
  double breakaway_input = 0.0;
  std::vector<std::string> families;  // of DesignFamilies(); empty: all
  // Empty: the D-criterion. Otherwise the A-criterion over these free parameters.
  std::vector<std::string> target;
  int threads = 0;  // 0: every core
};

struct ExperimentDesignResult {
  bool ok = false;
  std::string reason;     // why no design (nothing feasible)
  std::string criterion;  // "D-optimal" or "A-optimal"
  DesignCandidate best;
  std::vector<DesignCandidate> family_best;  // the best of each family searched (feasible)
  long evaluated = 0;                        // candidates simulated and predicted
  std::map<std::string, long> rejected;      // reason -> count
};

// The criterion of a prediction (D: ln det cov; A: the sum of the targets' variances in
// search coordinates); +infinity when not ok.
double DesignCriterion(const PrecisionPrediction& prediction,
                       const std::vector<std::string>& target);

// One input evaluated as a candidate: sampled, simulated, its amplitude lowered (at most four
// times) until the response is within the output limits, predicted.
DesignCandidate EvaluateCandidate(const DesignProblem& problem,
                                  const ExperimentDesignOptions& options,
                                  DesignCandidate candidate);

// The grid search over the families' settings, then a finer search around each family's
// best (docs/design.md §3). InputError for a bad option (an unknown family or target).
ExperimentDesignResult SearchDesign(const DesignProblem& problem,
                                    const ExperimentDesignOptions& options);

// A column's noise standard deviation estimated from a measured trace: the root mean square of
// the measured column minus the model's response to the trace's own recorded input at the
// prior values (an upper bound: a model error counts as noise).
double ResidualNoise(const std::vector<double>& measured, const std::vector<double>& response);

}  // namespace blmd
