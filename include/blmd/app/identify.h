// One identification as blmd-ident runs it (docs/architecture.md, "One identification"):
// the fit, the spread between traces in its intervals, discovery, the final model as the
// report's headline, ambiguity and warnings. The commands and the Python package call this;
// they parse their flags into an IdentRequest and write what comes back.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "blmd/ident/discovery/discovery.h"
#include "blmd/ident/fit/problem.h"
#include "blmd/ident/optimizers/noise_model.h"
#include "blmd/ident/optimizers/optimizer.h"
#include "blmd/ident/optimizers/start_scan.h"
#include "blmd/io/config.h"
#include "blmd/report/report.h"

namespace blmd {

struct IdentRequest {
  Config config;            // the model and its set-up (flags such as --initial applied)
  std::string config_path;  // named in the report
  std::vector<FitTrace> traces;
  std::vector<FitTrace> validation;  // held-out traces (--validate), may be empty
  std::vector<std::string> observe;  // the cost's columns
  std::vector<FreeParameter> free;
  std::string method = "ceres";  // an optimiser of OptimizerRegistry()
  // seed, threads (0: every core), evaluation budget, method options, verbose, progress.
  // The trace jackknife's refits and discovery's use the same, without the method options.
  // With options.progress set, Identify reports its stages to it ("first fit (ceres)",
  // "leave-one-trace-out refits", "report", discovery's rounds, "final model: ...") and
  // every fit its evaluations (ident/fit/progress.h); the caller ends it.
  OptimizerOptions options;
  bool discover = false;
  // bic_margin, max_effects, candidates; Identify sets the refit options and the held-out
  // traces (from `validation`).
  DiscoveryOptions discovery;
  // A stored report to guard against (--baseline, docs/export.md): empty for none.
  std::string baseline_path;
  // How the cost weights the observed columns (ident/optimizers/noise_model.h): by their noise,
  // estimated from the residual unless fixed, or by their variance.
  NoiseSettings noise;
};

struct IdentOutcome {
  IdentReport report;  // the final model first; nlohmann::json(report) is the --report JSON
  // The first fit's problem, its traces carrying the noise the cost was weighted by.
  std::unique_ptr<FitProblem> problem;
  FitResult first_fit;  // as the optimiser returned it (after the noise reweighting)
  NoiseModel noise;     // the first model's noise weights
  // The first fit's guard against a side valley (start_scan.h): whether it ran, and whether a
  // restart from the scan replaced the fit from the config's start.
  StartScanRecord start_scan;
  // The default ranges the first fit stopped on and where they were moved (start_scan.h,
  // MoveDefaultRanges); empty when none was.
  std::vector<RangeShift> range_shifts;
  std::unique_ptr<DiscoveryResult> discovery;  // when request.discover
  // The final model (after discovery, else the first fit): its config, its parameters at
  // the fitted values and its free parameters with their bounds (--write-config).
  Config final_config;
  ParameterSet final_parameters;
  std::vector<FreeParameter> final_free;
  bool converged() const { return first_fit.summary.converged; }
};

// Throws InputError for bad input (as the commands' exit 2); a fit that fails or does not
// converge is reported in the outcome, not thrown.
IdentOutcome Identify(IdentRequest request);

}  // namespace blmd
