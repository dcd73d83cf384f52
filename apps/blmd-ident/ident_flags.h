// blmd-ident's flags (docs/cli.md §2) and their settings: shared by the command, its batch
// rows (batch.h: each manifest row's flags are parsed by this same set) and the Python
// package's fleet runner, so that a flag of the command is a flag of a row, checked by the
// same code.
#pragma once

#include <cmath>
#include <cstdint>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "../common/app_main.h"
#include "../common/error_flags.h"
#include "../common/init_config.h"
#include "../common/trace_flags.h"
#include "app/request.h"
#include "blmd/app/identify.h"
#include "blmd/format.h"

namespace blmd::app {

// Every flag of blmd-ident (docs/cli.md §2).
struct IdentFlags {
  std::string config_path, method, observe_text, free_text, report_path, html_path;
  std::string write_config_path, matlab_path, baseline_path;
  std::vector<std::string> traces, validates, method_options, initials, noise_stds;
  std::string weighting;
  std::uint64_t seed = 1;
  int threads = 0, max_evaluations = 0;
  bool json = false, quiet = false, discover = false, verbose = false;
  bool progress = false, no_progress = false;
  double bic_margin = 10.0;
  double min_share = 0.10;
  int max_effects = 3;
  std::string candidates_text;
  double fail_above = -1.0;
  bool fail_on_warning = false;
  ErrorFlags error_flags;
  TraceFlags trace_flags;

  // --batch (docs/fleet.md): a manifest of rows, each one identification.
  std::string batch_path, out_dir, baseline_dir;
  bool new_baselines = false;
  double drift_alpha = 0.01;

  // --init-config MODEL: a starting config on stdout, alone (as blmd-sim's).
  std::string init_model;

  // `batch`: the command line has --batch (--config and --trace then come from its rows) or
  // --init-config (then neither is read).
  void Add(CLI::App& app, bool batch = false) {
    CLI::Option* config =
        app.add_option("--config", config_path, "model and identification set-up (JSON)");
    CLI::Option* trace =
        app.add_option("--trace", traces, "measured trace CSV (repeatable: one fit over all)");
    if (!batch) {
      config->required();
      trace->required();
    }
    AddInitConfigFlag(app, &init_model);
    CLI::Option* manifest = app.add_option(
        "--batch", batch_path,
        "a manifest CSV (id,trace,config,baseline): one identification per row, rows in "
        "parallel over --threads, the other flags apply to every row (docs/fleet.md)");
    app.add_option("--out", out_dir,
                   "--batch: the output folder (<id>.json reports, results.csv, results.jsonl, "
                   "fleet.html); a finished row whose inputs are unchanged is not run again")
        ->needs(manifest);
    app.add_option("--baseline-dir", baseline_dir,
                   "--batch: a folder of baseline reports, <drive>.json, for the rows whose "
                   "baseline column is empty")
        ->needs(manifest);
    app.add_flag("--new-baselines", new_baselines,
                 "--batch: store the first ok record of each drive without a baseline as its "
                 "baseline in --baseline-dir")
        ->needs(manifest);
    app.add_option("--drift-alpha", drift_alpha,
                   "--batch: the drift rule's false-alarm rate per drive (default 0.01)")
        ->check(NumberValidator([](double v) { return v > 0.0 && v < 1.0; }, "a number in (0, 1)",
                                "0<X<1"))
        ->needs(manifest);
    app.add_option("--validate", validates,
                   "held-out trace CSV to report the error on (repeatable)");
    app.add_option("--method", method, "ceres|powell|fsd|classic (default: config, else ceres)");
    app.add_option("--observe", observe_text, "trace columns in the cost, e.g. i,w");
    app.add_option("--free", free_text, "parameters to identify, e.g. J,B");
    app.add_option("--initial", initials, "start value NAME=VALUE (repeatable)");
    app.add_option("--option", method_options,
                   "method option KEY=VALUE (repeatable), e.g. algorithm=praxis");
    app.add_option("--weighting", weighting,
                   "how the cost weighs the observed columns: noise (1/sigma^2 of each "
                   "column's noise, the default) or variance (1/its variance)");
    app.add_option("--noise-std", noise_stds,
                   "fix a column's noise NAME=SIGMA (its units; repeatable) instead of "
                   "estimating it from the residual");
    app.add_option("--max-evaluations", max_evaluations,
                   "cost evaluation budget (0: method default)");
    app.add_flag("--discover", discover, "find the effects the model lacks, add them, refit");
    app.add_option("--bic-margin", bic_margin,
                   "discovery: BIC fall needed to add an effect (default 10)")
        ->check(PositiveNumber());
    app.add_option("--min-share", min_share,
                   "discovery: share of the residual above the noise floor an effect must "
                   "explain (default 0.1)")
        ->check(ShareNumber());
    app.add_option("--max-effects", max_effects, "discovery: most effects to add (default 3)")
        ->check(CLI::Range(1, 20));
    app.add_option("--candidates", candidates_text,
                   "discovery: effects to consider, e.g. coulomb_friction,load_torque");
    app.add_option("--report", report_path, "write the JSON report here");
    app.add_flag("--json", json, "print the JSON report on stdout instead of the summary");
    app.add_option("--html", html_path,
                   "write the visual report (one self-contained HTML file) here");
    app.add_option("--write-config", write_config_path,
                   "write the final model as a config blmd-sim and blmd-ident accept");
    app.add_option("--export-matlab", matlab_path,
                   "write the final model's linear part as MATLAB/Octave ss and tf objects (.m)");
    app.add_option("--baseline", baseline_path,
                   "a stored --report to guard against: exit 3 when a parameter moved beyond "
                   "the combined 95 % intervals (docs/export.md)");
    app.add_option("--seed", seed, "random seed (fsd)")->check(NonNegativeWholeNumber());
    app.add_option("--threads", threads, "worker threads (0: all cores)")
        ->check(NonNegativeWholeNumber());
    app.add_flag("--quiet", quiet, "print nothing but errors (and no progress line)");
    app.add_flag("--progress", progress,
                 "show the progress (stage, evaluations, best cost, time) on stderr, also when "
                 "stderr is not a terminal (default: only on a terminal, without --quiet)");
    app.add_flag("--no-progress", no_progress, "no progress on stderr (wins over --progress)");
    app.add_option("--fail-above-nrmse", fail_above, "exit 3 when the final NRMSE exceeds X")
        ->check(NonNegativeNumber());
    app.add_flag(
        "--fail-on-warning", fail_on_warning,
        "exit 3 when the report has a warning about the final model (docs/identification.md §5)");
    app.add_flag("--verbose", verbose, "also print the solvers' own log (Ceres) on stderr");
    error_flags.Add(app,
                    "simulate and compare the motion, or compare the input the model needs along "
                    "the measured motion");
    trace_flags.Add(app);
  }
};

// The flags as the library's settings (app/request.h): --observe, --free and --candidates
// given empty are refused there, with the valid choices.
inline blmd::IdentSettings Settings(const CLI::App& app, const IdentFlags& f) {
  blmd::IdentSettings settings;
  for (const auto& path : f.traces) settings.traces.push_back({path, std::nullopt});
  for (const auto& path : f.validates) settings.validation.push_back({path, std::nullopt});
  settings.method = f.method;
  settings.baseline = f.baseline_path;
  if (app.count("--observe") > 0) settings.observe = f.observe_text;
  if (app.count("--free") > 0) settings.free = f.free_text;
  if (app.count("--candidates") > 0) settings.candidates = f.candidates_text;
  settings.initials = f.initials;
  settings.method_options = f.method_options;
  settings.seed = f.seed;
  settings.threads = f.threads;
  settings.max_evaluations = f.max_evaluations;
  settings.verbose = f.verbose;
  settings.discover = f.discover;
  settings.bic_margin = f.bic_margin;
  settings.min_share = f.min_share;
  settings.max_effects = f.max_effects;
  settings.weighting = f.weighting;
  settings.noise_stds = f.noise_stds;
  settings.error = f.error_flags;
  settings.preparation = f.trace_flags;
  return settings;
}

// What a finished identification means for its exit code (docs/errors.md): 1 when the fit
// did not converge or is not a fit, 3 when a gate fails (--fail-above-nrmse, --baseline,
// --fail-on-warning), with the line the command prints after "error: ".
struct IdentVerdict {
  int code = blmd::kExitOk;
  std::string message;
};
// `with_baseline` false: the --baseline verdict is left out (a batch judges drift by its own
// rule, app/fleet.h).
inline IdentVerdict Judge(const IdentFlags& f, const blmd::IdentOutcome& outcome,
                          bool with_baseline = true) {
  const blmd::IdentReport& report = outcome.report;
  if (!outcome.converged()) {
    return {blmd::kExitFailed,
            "the fit did not converge: " + outcome.first_fit.summary.termination};
  }
  for (const auto& w : report.warnings) {
    if (w.code == "not_a_fit") {  // NRMSE >= 1 with parameters at their bounds
      return {blmd::kExitFailed, "the fit failed: " + w.message};
    }
  }
  if (f.fail_above >= 0.0) {
    // The final model's NRMSE (after discovery when it ran: its model is the answer).
    const blmd::ErrorFigures& fit = report.final_model.fit.errors;
    const bool known = fit.ok && std::isfinite(fit.nrmse);
    if (!known || fit.nrmse > f.fail_above) {
      std::ostringstream limit;
      limit << f.fail_above;
      return {blmd::kExitGate, "final NRMSE " + (known ? nlohmann::json(fit.nrmse).dump() : "n/a") +
                                   " is above --fail-above-nrmse " + limit.str()};
    }
  }
  if (with_baseline && report.baseline && report.baseline->changed()) {
    return {blmd::kExitGate, "the model moved from the baseline " + report.baseline->path + ": " +
                                 blmd::Join(report.baseline->moved) +
                                 " beyond the combined 95 % intervals (--baseline)"};
  }
  if (f.fail_on_warning && !report.warnings.empty()) {
    std::vector<std::string> codes;
    for (const auto& w : report.warnings) codes.push_back(w.code);
    return {blmd::kExitGate, std::to_string(codes.size()) + " warning" +
                                 (codes.size() > 1 ? "s" : "") + " (" + blmd::Join(codes) +
                                 ") and --fail-on-warning"};
  }
  return {};
}

}  // namespace blmd::app
