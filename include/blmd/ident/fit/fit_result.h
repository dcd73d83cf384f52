// What a fit is asked and what it gives (docs/identification.md): the options every
// optimiser takes, and its result: the values, their estimates with the 95 % intervals, and
// the method's summary. Every layer above the cost (optimisers, intervals, residual checks,
// discovery, reports) speaks these types; the optimisers themselves are in
// optimizers/optimizer.h.
#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "blmd/ident/fit/problem.h"
#include "blmd/ident/fit/progress.h"

namespace blmd {

struct OptimizerOptions {
  std::uint64_t seed = 1;   // random seed (fsd)
  int threads = 0;          // worker threads; 0 = all cores
  int max_evaluations = 0;  // cost evaluations; 0 = the method's default
  // The back-end's own log on stderr (Ceres's glog lines). Off: a command's only stderr line
  // on a failure is its own one-line error (docs/errors.md).
  bool verbose = false;
  // Method-specific options by name, e.g. {"algorithm": "praxis"} for powell; unknown names
  // are an InputError listing the valid ones.
  nlohmann::json method_options = nlohmann::json::object();
  // The iteration limit of a method that has one (ceres's max_iterations) when
  // method_options sets none: a caller's budget for an inner fit (discovery's refits) that the
  // user's own option still overrides. 0: the method's own default.
  int default_max_iterations = 0;
  // Where the fit reports its cost evaluations (progress.h); null: nowhere. Not owned; every
  // fit made with these options (jackknife and discovery refits too) reports to it.
  ProgressObserver* progress = nullptr;
};

// The method's own figures for the report's method_summary.details (settings, schedule, what it
// reached): written, never read by the program (the typed fields of OptimizerSummary carry
// what it reads). One struct per method; report_json.cc renders them.
struct CeresFigures {
  double fd_step = 0.0;                         // search coordinates
  double initial_cost = 0.0, final_cost = 0.0;  // Ceres's: half the weighted sum of squares
  int successful_steps = 0, unsuccessful_steps = 0;
  std::map<std::string, double> residual_rms;  // per observed column, with the intervals
};
struct PowellFigures {
  double initial_step_scaled = 0.0, xtol_abs_scaled = 0.0, ftol_rel = 0.0;
  int max_evaluations = 0;
};
struct FsdPolished {
  std::string source;  // "walker K" or "probe"
  double start_cost = 0.0, end_cost = 0.0;
};
struct FsdFigures {
  std::uint64_t seed = 0;
  std::vector<FsdPolished> polished;
  std::string winner;
  int walkers = 0, bursts = 0, burst_steps = 0, quench_evaluations = 0, probes = 0;
  int polish_evaluations = 0;
  double quench_step = 0.0, cost_scale = 0.0, t0 = 0.0, step_a = 0.0, initial_spread = 0.0;
  double fd_step = 0.0, max_step = 0.0, polish_step = 0.0;
  bool polish = false;
  std::string schedule;
  std::vector<double> walker_best_cost;  // per walker; not finite: none reached (null)
};
struct ClassicFigures {
  std::vector<std::string> notes;
  std::vector<double> tau_s;  // the coast-downs' time constants
  std::size_t plateaus = 0;
};
using MethodFigures =
    std::variant<std::monostate, CeresFigures, PowellFigures, FsdFigures, ClassicFigures>;

// How the 95 % intervals were computed (the report's details.interval).
struct JackknifeRecord {  // leave-one-trace-out (optimizers/trace_jackknife.h)
  bool ok = false;        // it ran
  int traces = 0;
  std::string unavailable;  // why not, "" when it ran
  double t_quantile = 0.0;  // Student t, K - 1 degrees of freedom (when it ran)
  struct Parameter {
    std::string name;
    double std = 0.0;            // physical units
    std::vector<double> refits;  // per left-out trace
  };
  std::vector<Parameter> parameters;  // when it ran
};
struct IntervalRecord {
  std::string method;                            // "hac_prewhitened"; "": no sandwich attempted
  std::map<std::string, double> variance_ratio;  // per free parameter: HAC over white variance
  bool has_bandwidth = false;                    // the sandwich ran
  double bandwidth = 0.0, prewhitening_gain = 0.0;
  double degrees_of_freedom = 0.0;  // of the long-run variance (when it ran)
  double t_quantile = 0.0;          // Student t's 97.5 % point at those degrees of freedom
  std::string unavailable;          // why the sandwich gave no interval
  std::optional<JackknifeRecord> leave_one_trace_out;
};

struct OptimizerSummary {
  std::string method = "none";
  std::string algorithm;  // e.g. "LN_BOBYQA", "LEVENBERG_MARQUARDT"
  bool converged = false;
  std::string termination = "not run";  // short reason it stopped
  std::string message;                  // the back-end's own words
  int raw_code = 0;                     // the back-end's own result code
  long evaluations = 0;                 // cost evaluations (each simulates every trace)
  long failed_evaluations = 0;          // of which diverged or invalid (infinite cost)
  std::map<std::string, long> failure_reasons;
  long iterations = 0;
  double wall_time_s = 0.0;
  // The finite-difference step of the Jacobian the intervals came from (search coordinates),
  // when the method used one; 0 when it did not (the correlation then uses the default step).
  double fd_step = 0.0;
  // Why there is no interval ("" when there is one, or none was attempted).
  std::string interval_unavailable;
  MethodFigures figures;                   // the method's own, for the report
  std::optional<IntervalRecord> interval;  // how the intervals were computed, when attempted
};

struct ParameterEstimate {
  std::string name;
  double value = 0.0;
  double initial = 0.0;
  bool has_interval = false;  // std and ci95 valid
  double std = 0.0;           // standard deviation, physical units
  double ci95_low = 0.0, ci95_high = 0.0;
  std::string interval_method;  // "hac_prewhitened" (docs/uncertainty.md), or the white one's
  // The interval with the residuals taken as white noise (every sample independent): the
  // classic (J^T J)^-1, too narrow when the residuals are correlated; kept for comparison.
  bool has_white_interval = false;
  double std_white = 0.0;
  double ci95_white_low = 0.0, ci95_white_high = 0.0;
  std::string white_method;  // "ceres_covariance" or "gauss_newton"
  // When the spread between traces widened the interval (trace_jackknife.h): the HAC
  // interval it replaced.
  bool has_hac_interval = false;
  double std_hac = 0.0;
  double ci95_hac_low = 0.0, ci95_hac_high = 0.0;
  // The Cramer-Rao bound of this experiment: the standard deviation no unbiased estimator
  // beats with white Gaussian noise of each column's noise variance (the cost's noise weights,
  // else the residual's), sqrt of the diagonal of the inverse Fisher information
  // (docs/uncertainty.md §5). std / std_crb is how far the interval is from the bound.
  bool has_crb = false;
  double std_crb = 0.0;
};

struct FitResult {
  std::vector<double> values;  // free parameters, physical units
  Evaluation evaluation;       // cost at `values`
  std::vector<ParameterEstimate> estimates;
  OptimizerSummary summary;
  // Classic estimates may include parameters that are not free (Kb, Kt): name -> value.
  std::map<std::string, double> extra_estimates;
};

}  // namespace blmd
