// blmd-ident: identify the free parameters of a config's model from measured traces.
// Flags -> IdentSettings -> blmd::MakeIdentRequest (app/request.h) -> blmd::Identify
// (app/identify.h) -> the report, summary, HTML and exit code (docs/cli.md).
#include <sys/ioctl.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>

#include "../common/app_main.h"
#include "../common/error_flags.h"
#include "../common/trace_flags.h"
#include "app/request.h"
#include "blmd/app/identify.h"
#include "blmd/io/config.h"
#include "blmd/io/files.h"
#include "blmd/report/export.h"
#include "blmd/report/html/html_report.h"
#include "blmd/report/progress.h"
#include "blmd/report/report.h"

namespace {

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
  blmd::app::ErrorFlags error_flags;
  blmd::app::TraceFlags trace_flags;

  void Add(CLI::App& app) {
    app.add_option("--config", config_path, "model and identification set-up (JSON)")->required();
    app.add_option("--trace", traces, "measured trace CSV (repeatable: one fit over all)")
        ->required();
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
        ->check(blmd::app::PositiveNumber());
    app.add_option("--min-share", min_share,
                   "discovery: share of the residual above the noise floor an effect must "
                   "explain (default 0.1)")
        ->check(blmd::app::ShareNumber());
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
    app.add_option("--seed", seed, "random seed (fsd)")->check(blmd::app::NonNegativeWholeNumber());
    app.add_option("--threads", threads, "worker threads (0: all cores)")
        ->check(blmd::app::NonNegativeWholeNumber());
    app.add_flag("--quiet", quiet, "print nothing but errors (and no progress line)");
    app.add_flag("--progress", progress,
                 "show the progress (stage, evaluations, best cost, time) on stderr, also when "
                 "stderr is not a terminal (default: only on a terminal, without --quiet)");
    app.add_flag("--no-progress", no_progress, "no progress on stderr (wins over --progress)");
    app.add_option("--fail-above-nrmse", fail_above, "exit 3 when the final NRMSE exceeds X")
        ->check(blmd::app::NonNegativeNumber());
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
blmd::IdentSettings Settings(const CLI::App& app, const IdentFlags& f) {
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

// --progress, --no-progress: the progress line on stderr (docs/cli.md §2.3), by default on a
// terminal only and not with --quiet; null when off.
std::unique_ptr<blmd::ProgressPrinter> MakeProgress(const IdentFlags& f) {
  const bool terminal = isatty(STDERR_FILENO) != 0;
  if (f.no_progress || !(f.progress || (terminal && !f.quiet))) return nullptr;
  int width = 0;  // a file: lines uncut
  winsize size{};
  if (terminal && ioctl(STDERR_FILENO, TIOCGWINSZ, &size) == 0) width = size.ws_col;
  return std::make_unique<blmd::ProgressPrinter>(stderr, "blmd-ident: ", width);
}

// The output files (the HTML page computes its cost curves: a stage of the progress).
void WriteFiles(const IdentFlags& f, const blmd::IdentOutcome& outcome,
                const nlohmann::json& report_json, blmd::ProgressObserver* progress) {
  const blmd::IdentReport& report = outcome.report;
  if (!f.report_path.empty()) blmd::WriteFileAtomically(f.report_path, report_json.dump(2) + "\n");
  if (!f.write_config_path.empty()) {
    const nlohmann::json config = blmd::ModelConfigJson(
        outcome.final_config, outcome.final_parameters, outcome.final_free, report);
    blmd::WriteFileAtomically(f.write_config_path, config.dump(2) + "\n");
  }
  if (!f.matlab_path.empty()) blmd::WriteFileAtomically(f.matlab_path, blmd::MatlabScript(report));
  if (!f.html_path.empty()) {
    if (progress) progress->BeginStage("html report");
    blmd::HtmlReportOptions html_options;
    html_options.threads = f.threads;
    blmd::WriteHtmlReport(
        f.html_path, {&report, outcome.problem.get(), &outcome.first_fit, outcome.discovery.get()},
        html_options);
  }
}

// The report on stdout (--json) or the summary.
void PrintOutputs(const IdentFlags& f, const blmd::IdentOutcome& outcome,
                  const nlohmann::json& report_json) {
  const blmd::IdentReport& report = outcome.report;
  if (f.json) {
    std::cout << report_json.dump(2) << "\n";
  } else if (!f.quiet) {
    std::cout << blmd::HumanSummary(report);
    if (!f.report_path.empty()) std::cout << "report: " << f.report_path << "\n";
    if (!f.html_path.empty()) std::cout << "html report: " << f.html_path << "\n";
    if (!f.write_config_path.empty()) std::cout << "config: " << f.write_config_path << "\n";
    if (!f.matlab_path.empty()) std::cout << "matlab: " << f.matlab_path << "\n";
  }
}

// The exit code (docs/errors.md): 1 when the fit did not converge, 3 when a gate fails.
int ExitCode(const IdentFlags& f, const blmd::IdentOutcome& outcome) {
  const blmd::IdentReport& report = outcome.report;
  if (!outcome.converged()) {
    std::cerr << "error: the fit did not converge: " << outcome.first_fit.summary.termination
              << "\n";
    return blmd::kExitFailed;
  }
  for (const auto& w : report.warnings) {
    if (w.code == "not_a_fit") {  // NRMSE >= 1 with parameters at their bounds
      std::cerr << "error: the fit failed: " << w.message << "\n";
      return blmd::kExitFailed;
    }
  }
  if (f.fail_above >= 0.0) {
    // The final model's NRMSE (after discovery when it ran: its model is the answer).
    const blmd::ErrorFigures& fit = report.final_model.fit.errors;
    const bool known = fit.ok && std::isfinite(fit.nrmse);
    if (!known || fit.nrmse > f.fail_above) {
      std::cerr << "error: final NRMSE " << (known ? nlohmann::json(fit.nrmse).dump() : "n/a")
                << " is above --fail-above-nrmse " << f.fail_above << "\n";
      return blmd::kExitGate;
    }
  }
  if (report.baseline && report.baseline->changed()) {
    std::cerr << "error: the model moved from the baseline " << report.baseline->path << ": "
              << blmd::Join(report.baseline->moved)
              << " beyond the combined 95 % intervals (--baseline)\n";
    return blmd::kExitGate;
  }
  if (f.fail_on_warning && !report.warnings.empty()) {
    std::vector<std::string> codes;
    for (const auto& w : report.warnings) codes.push_back(w.code);
    std::cerr << "error: " << codes.size() << " warning" << (codes.size() > 1 ? "s" : "") << " ("
              << blmd::Join(codes) << ") and --fail-on-warning\n";
    return blmd::kExitGate;
  }
  return blmd::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"blmd-ident: identify J, B (and any other free parameter) from a recorded trace"};
  blmd::app::AddVersionFlag(app, "blmd-ident");
  blmd::app::AddHelpFooter(app, "blmd-ident");
  IdentFlags flags;
  flags.Add(app);
  return blmd::app::Main(
      app, argc, argv,
      [&]() -> int {
        flags.threads = blmd::app::CapThreads(flags.threads);
        // Every output checked before any work: writable, not an input, not another output.
        std::vector<blmd::NamedPath> input_files = {{"--config", flags.config_path}};
        for (const auto& path : flags.traces) input_files.push_back({"--trace", path});
        for (const auto& path : flags.validates) input_files.push_back({"--validate", path});
        if (!flags.baseline_path.empty())
          input_files.push_back({"--baseline", flags.baseline_path});
        blmd::CheckOutputs({{"--report", flags.report_path},
                            {"--html", flags.html_path},
                            {"--write-config", flags.write_config_path},
                            {"--export-matlab", flags.matlab_path}},
                           input_files);
        blmd::IdentRequest request = blmd::MakeIdentRequest(
            blmd::LoadConfig(flags.config_path), flags.config_path, Settings(app, flags));
        if (!flags.report_path.empty() || !flags.html_path.empty() ||
            !flags.write_config_path.empty() || !flags.matlab_path.empty()) {
          blmd::InstallCleanupOnSignal();
        }
        // The progress line ends before anything is printed on stdout (same terminal).
        std::unique_ptr<blmd::ProgressPrinter> progress = MakeProgress(flags);
        request.options.progress = progress.get();
        const blmd::IdentOutcome outcome = blmd::Identify(std::move(request));
        const nlohmann::json report_json = outcome.report;
        WriteFiles(flags, outcome, report_json, progress.get());
        if (progress) progress->Finish();
        PrintOutputs(flags, outcome, report_json);
        return ExitCode(flags, outcome);
      },
      {"--observe", "--free", "--candidates"});
}
