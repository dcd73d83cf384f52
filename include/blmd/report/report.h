// The blmd-ident report (interface.md "Report JSON", docs/report.md) and its human summary:
// the report layer renders what the identification layer computed (ident/errors.h,
// ident/diagnostics.h, ident/discovery.h) as JSON and text.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "blmd/ident/diagnostics.h"
#include "blmd/ident/discovery.h"
#include "blmd/ident/errors.h"
#include "blmd/ident/optimizer.h"
#include "blmd/ident/problem.h"

namespace blmd {

nlohmann::json ErrorsJson(const ErrorFigures& errors);

// The residual diagnostics (ident/diagnostics.h) as the report's "residual" block.
nlohmann::json ResidualJson(const ResidualAnalysis& analysis);

// The report's "discovery" block (interface.md) from discovery's result.
nlohmann::json DiscoveryJson(const FitProblem& problem, const FitResult& initial,
                             const DiscoveryResult& result, const FitProblem* validation_before,
                             const FitProblem* validation_after);

// With the equation error: the motion simulated from the recorded input with `config` (its
// error set to "output") at the free parameters `values`, compared on the traces' w (else
// theta) column: {"observe": [...], "nrmse": x} (or {"nrmse": null, "failed": reason}),
// so an equation-error fit is also judged as a simulation. Null for the output error.
nlohmann::json SimulatedErrors(const FitProblem& problem, const Config& config,
                               const std::vector<std::string>& free,
                               const std::vector<double>& values);

// Residual diagnostics at `values`: per observed column the autocorrelation (first lags),
// its 95 % band 1.96/sqrt(n), the Ljung-Box test; overall whiteness_p is the smallest
// column p-value times the number of columns (Bonferroni), capped at 1.
nlohmann::json ResidualDiagnostics(const FitProblem& problem, const std::vector<double>& values);

struct ReportInputs {
  std::string config_path;
  const FitProblem* problem = nullptr;
  const FitResult* result = nullptr;
  const FitProblem* validation = nullptr;  // held-out traces, may be null
  std::uint64_t seed = 1;
  int threads = 1;
};

// The report's schema version (docs/report.md): 2 since the headline is the final model
// (parameters, fit, residual and validation after discovery; the first fit under
// discovery.before) and `warnings` was added; 1 (no field) before.
inline constexpr int kReportSchemaVersion = 2;

nlohmann::json MakeReport(const ReportInputs& inputs);
std::string HumanSummary(const nlohmann::json& report);

// Makes the model after discovery the report's headline: `final_report` (MakeReport of the
// final model) takes `discovery` as its "discovery" block, with the first fit's parameters,
// fit, residual, validation and method summary under discovery.before, and the input
// config's effects under config.effects (the final model's are in "effects").
nlohmann::json FinalModelReport(nlohmann::json final_report, const nlohmann::json& first_report,
                                nlohmann::json discovery);

// When discovery stopped on an ambiguous round, the headline's intervals are widened to
// cover every competing model's value of each parameter (discovery.ambiguous[].models):
// ci95 becomes the hull, the unwidened one is kept in ci95_before_ambiguity and
// interval_method gains "+ambiguity". The data cannot tell those models apart, so the
// answer is no more precise than their disagreement.
void WidenForAmbiguity(nlohmann::json* report);

// The warnings about the final model (docs/report.md "Warnings"): [{code, message}] with
// stable codes, from the report's own figures. Sets report["warnings"].
void AddWarnings(nlohmann::json* report);

// Replaces every non-finite number by null (a report never holds NaN or Inf).
void SanitizeJson(nlohmann::json* value);

}  // namespace blmd
