// The blmd-ident report (docs/report.md) as one typed value,
// IdentReport, from which the JSON (nlohmann to_json), the human summary and the HTML page
// (html_report.h) are all rendered; nothing reads the JSON back. The report layer builds it
// from what the identification layer computed (ident/fit/fit_errors.h,
// ident/residual/diagnostics.h, ident/discovery/discovery.h).
#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "blmd/ident/discovery/discovery.h"
#include "blmd/ident/fit/cutoff_choice.h"
#include "blmd/ident/fit/fit_errors.h"
#include "blmd/ident/fit/problem.h"
#include "blmd/ident/fit/units_check.h"
#include "blmd/ident/optimizers/noise_model.h"
#include "blmd/ident/optimizers/optimizer.h"
#include "blmd/ident/residual/diagnostics.h"
#include "blmd/ident/uncertainty/derived_quantities.h"
#include "blmd/ident/uncertainty/parameter_correlation.h"
#include "blmd/report/linear_views.h"
#include "blmd/sim/linear_model.h"

namespace blmd {

// The report's schema version (docs/report.md): 2 since the headline is the final model
// (parameters, fit, residual and validation after discovery; the first fit under
// discovery.before) and `warnings` was added; 1 (no field) before.
inline constexpr int kReportSchemaVersion = 2;

// Numbers that are not finite are written as null: a report never holds NaN or Inf.

// One parameter of the report's "parameters" block.
struct ParameterReport {
  // Value, initial value and intervals; `has_interval` false: "std" and "ci95" are null.
  ParameterEstimate estimate;
  // False for a classic estimate of a parameter that was not fitted (Kb, Kt): no initial
  // value, no interval, no bounds.
  bool free = true;
  std::string unit;  // the model's unit ("" when it names none: no "unit" key)
  bool has_bounds = false;
  double lower = 0.0, upper = 0.0;
  // The estimate lies on a bound (the bound, not the data, set it): see MakeModelReport.
  bool at_bound = false;
  // WidenForAmbiguity moved ci95 to the hull of the competing models; the interval before.
  bool widened_by_ambiguity = false;
  double ci95_before_ambiguity_low = 0.0, ci95_before_ambiguity_high = 0.0;
};

// An equation-error fit judged as a simulation of the motion (the w, else theta, column):
// `column` empty when that simulation could not be set up (errors.reason says why).
struct SimulatedFit {
  std::string column;
  ErrorFigures errors;
};

// The report's "fit" block: the error of the model on the fit traces.
struct FitReport {
  ErrorFigures errors;
  std::vector<std::string> observe;
  bool equation_error = false;  // "error": {"type": "equation" | "output"}
  double filter_hz = 0.0;       // equation error: the low-pass of the derivatives, Hz
  int decimate = 1;
  std::size_t samples = 0;  // equation error: the samples of the cost over every trace
  // Equation error: the same model as a simulation (absent: the traces lack w and theta).
  std::optional<SimulatedFit> simulated;
};

// One trace of the report's "traces" list with the model's error on it.
struct TraceReport {
  std::string path;
  std::size_t samples = 0;
  std::string sha256;
  bool has_errors = false;  // false when the fit's evaluation failed
  std::map<std::string, double> rmse;
  double nrmse = 0.0;
};

// The report's "residual" block: the diagnostics at the estimate (absent when the fit's
// error could not be computed: then only "whiteness_p": null).
struct ResidualReport {
  std::optional<ResidualAnalysis> analysis;
  std::string note;  // set when the residual is not white and an interval assumes it is
};

// The report's "validation" block: the model's error on held-out traces.
struct ValidationReport {
  ErrorFigures errors;
  std::vector<std::string> traces;  // paths
  bool equation_error = false;
  std::optional<SimulatedFit> simulated;  // equation error: as a simulation
};

// What describes one fitted model: the headline of a report, or discovery.before.
struct ModelReport {
  std::string method;                // the optimiser that fitted it
  std::vector<std::string> effects;  // the model's (after discovery: with the added ones)
  std::map<std::string, ParameterReport> parameters;
  FitReport fit;
  OptimizerSummary summary;  // "method_summary" (with the seed and threads of the run)
  std::uint64_t seed = 1;
  int threads = 1;
  ResidualReport residual;
  bool intervals_optimistic = false;
  std::optional<ValidationReport> validation;
  // The correlation of the free parameters' estimates, from the covariance of the intervals
  // (ident/uncertainty/parameter_correlation.h): "correlation" in the JSON.
  ParameterCorrelation correlation;
  // The enabled effects' derived figures (a two-mass shaft's resonance, its inertias and
  // stiffness) with their delta-method intervals: "derived" in the JSON, when there are any.
  std::vector<DerivedEstimate> derived;
};

// A model that discovery could not tell apart from another (reported, not hidden).
struct CompetingModel {
  std::string effect;
  double nrmse = 0.0, delta_bic = 0.0;
  std::map<std::string, double> parameters;
};
struct AmbiguousGroup {
  std::vector<std::string> effects;
  std::string reason;
  std::vector<CompetingModel> models;
};

// The report's "discovery" block (docs/discovery.md §4).
struct DiscoveryReport {
  std::vector<std::string> added;
  std::vector<DiscoveryStep> steps;
  std::vector<AmbiguousGroup> ambiguous;
  std::vector<CandidateOutcome> last_round;
  // Candidates whose decision did not hold under the stability check (never added).
  std::vector<CandidateOutcome> unstable;
  std::string conclusion;
  ErrorFigures error_before, error_after;
  std::vector<ParameterEstimate> parameters_after;  // the final fit's, with intervals
  std::vector<std::string> effects_after;
  ResidualAnalysis residual_after;
  bool has_validation = false;  // held-out traces: their error before and after
  ErrorFigures validation_before, validation_after;
  // Equation error: the final model as a simulation, on the fit and the held-out traces.
  bool equation_error = false;
  std::optional<SimulatedFit> simulated_after, validation_simulated_after;
  ModelReport before;  // the first fit (the headline is the final model)
  // The stopping rule's noise floor (NRMSE units) and how the record was cut for its
  // cross-validation; the final model's adequacy (adequacy.h).
  double noise_floor_nrmse = 0.0;
  std::string cross_validation_parts;
  bool has_adequacy = false;
  AdequacyReport adequacy;
};

struct Warning {
  std::string code;  // stable (docs/report.md "Warnings")
  std::string message;
};

// One parameter against a stored report (blmd-ident --baseline, docs/export.md "Drift
// guard"): moved when |value - baseline| exceeds the combined 95 % half-widths
// sqrt(h^2 + h_baseline^2) (the difference of two independent estimates).
struct BaselineParameter {
  std::string name;
  std::string verdict;  // "same", "moved", or "not_compared" (reason says why)
  std::string reason;
  double baseline = 0.0, value = 0.0;
  double baseline_ci95_low = 0.0, baseline_ci95_high = 0.0;
  double ci95_low = 0.0, ci95_high = 0.0;
  double shift = 0.0;           // value - baseline
  double combined_limit = 0.0;  // sqrt(h^2 + h_baseline^2)
};
struct BaselineReport {
  std::string path, sha256;
  std::vector<BaselineParameter> parameters;  // the baseline's free parameters, by name
  std::vector<std::string> moved;             // names whose verdict is "moved"
  bool changed() const { return !moved.empty(); }
};

struct IdentReport {
  std::string model;  // the model's registry name
  std::string config_path, config_name;
  std::vector<std::string> config_effects;  // as the input config declared them
  // How the model was integrated (config simulation.*): what reproduces the numbers bit for
  // bit, per method.
  SimulationMethod simulation_method = SimulationMethod::kFixedEuler;
  double simulation_dt = 0.0;        // s, the fixed step (fixed_euler)
  double simulation_max_step = 0.0;  // s, events: the longest segment (0: the default Tpwm/2)
  std::vector<TraceReport> traces;
  ModelReport final_model;  // the headline: the final model (the first fit without discovery)
  std::optional<DiscoveryReport> discovery;
  std::vector<Warning> warnings;
  // The final model's linear part and its transfer functions (docs/export.md).
  LinearModel linear_model;
  // Views of the linear part (report/linear_views.h, docs/report.md): the traces' empirical
  // frequency response against its Bode plot, and its step response. Set by Identify
  // (AddLinearViews); absent from a report made by MakeReport alone.
  std::optional<FrequencyResponseReport> frequency_response;
  std::optional<StepResponseReport> step_response;
  std::optional<BaselineReport> baseline;  // --baseline
  // Signs that a measured column is in other units than the model's (ident/fit/units_check.h):
  // each becomes a warning units_suspect.
  std::vector<UnitsHint> units_hints;
  // How the cost weighted the observed columns, and each column's noise (noise_model.h).
  NoiseModel noise;
  // A plain fit's adequacy check (no discovery; with discovery it is discovery->adequacy):
  // what its residual still depends on (residual/adequacy.h). Set by Identify.
  std::optional<AdequacyReport> adequacy;
  // The equation error's cut-off: the ladder of fits, the plateau and the cut-off in use
  // (cutoff_choice.h; "equation_cutoff" in the JSON). Set by Identify.
  std::optional<CutoffChoice> cutoff;
  // Facts about how the data was used that are not warnings (a closed-loop config fitted from
  // the recorded u; coloured residual noise), one line each.
  std::vector<std::string> notes;

  // The first fit: discovery->before when discovery ran, else the headline.
  const ModelReport& first_fit() const { return discovery ? discovery->before : final_model; }
  // Discovery ran and added an effect.
  bool discovered() const { return discovery && !discovery->added.empty(); }
};

// The report as JSON (docs/report.md): every key of its schema, non-finite numbers null.
void to_json(nlohmann::json& out, const IdentReport& report);
void to_json(nlohmann::json& out, const ErrorFigures& errors);
void to_json(nlohmann::json& out, const ResidualAnalysis& analysis);
void to_json(nlohmann::json& out, const DiscoveryReport& discovery);
// The report's method_summary.details: the method's own figures and how the intervals were
// computed (OptimizerSummary::figures, interval).
nlohmann::json MethodDetailsJson(const OptimizerSummary& summary);

// A discovery step's parameters by name, as the summary and the page list them: the
// effect's fitted ones (`fitted` points at the estimate, with its interval) and its fixed
// ones (e.g. cogging periods; `fitted` null).
struct StepParameter {
  std::string name;
  double value = 0.0;
  const ParameterEstimate* fitted = nullptr;
};
std::vector<StepParameter> StepParameters(const DiscoveryStep& step);

// The human summary blmd-ident prints (docs/cli.md).
std::string HumanSummary(const IdentReport& report);

struct ReportInputs {
  std::string config_path;
  const FitProblem* problem = nullptr;
  const FitResult* result = nullptr;
  const FitProblem* validation = nullptr;  // held-out traces, may be null
  std::uint64_t seed = 1;
  int threads = 1;
};

// The report of one fit (no discovery, no warnings yet).
IdentReport MakeReport(const ReportInputs& inputs);

// With the equation error: the motion simulated from the recorded input with `config` (its
// error set to "output") at the free parameters `values`, compared on the traces' w (else
// theta) column, so an equation-error fit is also judged as a simulation. Empty for the
// output error, or when a trace lacks the column.
std::optional<SimulatedFit> SimulatedErrors(const FitProblem& problem, const Config& config,
                                            const std::vector<std::string>& free,
                                            const std::vector<double>& values);

// The discovery block from discovery's result: the errors before and after (fit and
// held-out traces), the final residual, the competing models of an ambiguous round.
// `before` is left empty (FinalModelReport fills it).
DiscoveryReport MakeDiscoveryReport(const FitProblem& problem, const FitResult& initial,
                                    const DiscoveryResult& result,
                                    const FitProblem* validation_before,
                                    const FitProblem* validation_after);

// Makes the model after discovery the report's headline: `final_report` (MakeReport of the
// final model) takes `discovery` with the first fit's model under discovery.before, and the
// input config's effects (the final model's are in final_model.effects).
IdentReport FinalModelReport(IdentReport final_report, const IdentReport& first_report,
                             DiscoveryReport discovery);

// When discovery stopped on an ambiguous round, the headline's intervals are widened to
// cover every competing model's value of each parameter (discovery.ambiguous[].models):
// ci95 becomes the hull, the unwidened one is kept in ci95_before_ambiguity and
// interval_method gains "+ambiguity". The data cannot tell those models apart, so the
// answer is no more precise than their disagreement.
void WidenForAmbiguity(IdentReport* report);

// The warnings about the final model (docs/report.md "Warnings"): stable codes, from the
// report's own figures. Sets report->warnings.
// The next step for a record that looks closed loop (ResidualAnalysis::closed_loop on the
// first fit's residual, output error only), "" otherwise.
std::string ClosedLoopAdvice(const IdentReport& report);

void AddWarnings(IdentReport* report);

// Sets report->linear_model from `final_config` at `final_parameters`, and the views of it:
// the frequency response of `problem`'s traces and the step response.
void AddLinearViews(IdentReport* report, const FitProblem& problem, const Config& final_config,
                    const ParameterSet& final_parameters);

// Replaces every non-finite number by null (a report never holds NaN or Inf).
void SanitizeJson(nlohmann::json* value);

}  // namespace blmd
