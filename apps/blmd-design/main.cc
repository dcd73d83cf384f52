// blmd-design: which experiment to run. Flags -> DesignSettings -> blmd::MakeDesignRequest
// (report/design_report.h) -> blmd::RunDesign -> the report, the config, the input table, the
// summary and the exit code (docs/cli.md §5, docs/design.md).
#include <iostream>
#include <optional>

#include "../common/app_main.h"
#include "../common/trace_flags.h"
#include "app/experiment_design_run.h"
#include "blmd/io/config.h"
#include "blmd/io/csv.h"
#include "blmd/io/files.h"

namespace {

// Every flag of blmd-design (docs/cli.md §5).
struct DesignFlags {
  std::string config_path, report_path, write_config_path, write_input_path, trace_path;
  std::string from_report;
  std::string family = "all", target;
  double duration = 0.0;
  std::vector<std::string> limits, noises;
  int threads = 0;
  bool json = false, quiet = false, fail_on_warning = false;
  blmd::app::TraceFlags trace;

  void Add(CLI::App& app) {
    app.add_option("--config", config_path, "the model at its prior values (JSON)")->required();
    app.add_option("--from-report", from_report,
                   "a blmd-ident report of the config's model: its final values and effects "
                   "(the effects' fitted parameters free) replace the config's");
    app.add_option("--duration", duration,
                   "length of the experiment to design, s (required "
                   "without --trace)")
        ->check(blmd::app::PositiveNumber());
    app.add_option("--limit", limits,
                   "a limit NAME=VALUE: u (largest |u|, required without --trace) or an output "
                   "column's largest |value|, e.g. i=2 (A), w=300 (rad/s) (repeatable)");
    app.add_option("--noise", noises,
                   "noise of an observed column, NAME=SIGMA (its unit) or NAME=P% of its peak "
                   "in the config's experiment, as blmd-sim (repeatable)");
    app.add_option("--family", family, "input families searched: square|steps|prbs|chirp|all")
        ->check(CLI::IsMember({"square", "steps", "prbs", "chirp", "all"}));
    app.add_option("--target", target,
                   "A-optimal for these free parameters, e.g. J (default: D-optimal for all)");
    app.add_option("--trace", trace_path,
                   "evaluate this recorded trace's u column instead of searching (noise from "
                   "its residual where --noise gives none); read with blmd-ident's trace flags");
    trace.Add(app);
    app.add_option("--report", report_path, "write the JSON report here");
    app.add_flag("--json", json, "print the JSON report on stdout instead of the summary");
    app.add_option("--write-config", write_config_path,
                   "write the config with the chosen experiment (blmd-sim runs it)");
    app.add_option("--write-input", write_input_path,
                   "write the chosen input as a CSV table t,u (zero-order hold) a drive plays");
    app.add_option("--threads", threads, "worker threads (0: all cores)")
        ->check(blmd::app::NonNegativeWholeNumber());
    app.add_flag("--quiet", quiet, "print nothing but errors");
    app.add_flag("--fail-on-warning", fail_on_warning,
                 "exit 3 when the design has a warning (no friction, an inadequate report, an "
                 "input below the breakaway)");
  }
};

blmd::DesignSettings Settings(const CLI::App& app, const DesignFlags& f) {
  blmd::DesignSettings settings;
  if (app.count("--duration") > 0) settings.duration = f.duration;
  settings.limits = f.limits;
  settings.noises = f.noises;
  settings.family = f.family;
  settings.target = f.target;
  settings.trace_path = f.trace_path;
  settings.trace = f.trace;
  settings.from_report = f.from_report;
  settings.threads = f.threads;
  return settings;
}

int Run(const CLI::App& app, DesignFlags& f) {
  f.threads = blmd::app::CapThreads(f.threads);
  if (f.trace_path.empty()) {
    for (const char* flag :
         {"--column", "--scale", "--derive", "--select", "--split", "--initial-state"}) {
      if (app.count(flag) > 0) {
        throw blmd::InputError(std::string(flag) + ": only with --trace (it prepares the trace)");
      }
    }
  }
  if (!f.trace_path.empty()) {
    for (const char* flag : {"--write-config", "--write-input"}) {
      if (app.count(flag) > 0) {
        throw blmd::InputError(std::string(flag) +
                               ": not with --trace (a recorded input is evaluated, not designed)");
      }
    }
  }
  blmd::CheckOutputs(
      {{"--report", f.report_path},
       {"--write-config", f.write_config_path},
       {"--write-input", f.write_input_path}},
      {{"--config", f.config_path}, {"--trace", f.trace_path}, {"--from-report", f.from_report}});
  const blmd::Config config = blmd::LoadConfig(f.config_path);
  const blmd::DesignRequest request =
      blmd::MakeDesignRequest(config, f.config_path, Settings(app, f));
  if (!f.report_path.empty() || !f.write_config_path.empty() || !f.write_input_path.empty()) {
    blmd::InstallCleanupOnSignal();
  }
  const blmd::DesignReport report = blmd::RunDesign(request);
  const nlohmann::json report_json = blmd::DesignReportJson(report);
  if (!f.report_path.empty()) blmd::WriteFileAtomically(f.report_path, report_json.dump(2) + "\n");
  if (report.ok && !f.write_config_path.empty()) {
    blmd::WriteFileAtomically(
        f.write_config_path, blmd::DesignConfigJson(request.problem.config, report).dump(2) + "\n");
  }
  if (report.ok && !f.write_input_path.empty()) {
    blmd::WriteTraceCsv(blmd::DesignInputTable(report), f.write_input_path);
  }
  if (f.json) {
    std::cout << report_json.dump(2) << "\n";
  } else if (!f.quiet) {
    std::cout << blmd::DesignSummary(report);
    if (!f.report_path.empty()) std::cout << "report: " << f.report_path << "\n";
    if (report.ok && !f.write_config_path.empty())
      std::cout << "config: " << f.write_config_path << "\n";
    if (report.ok && !f.write_input_path.empty())
      std::cout << "input: " << f.write_input_path << "\n";
  }
  if (!report.ok) {
    std::cerr << "error: no design: " << report.reason << "\n";
    return blmd::kExitFailed;
  }
  if (f.fail_on_warning && !report.warnings.empty()) return blmd::kExitGate;
  return blmd::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "blmd-design: which experiment to run: the predicted precision of J, B (and any "
      "free parameter) and the input that maximises it within the drive's limits"};
  blmd::app::AddVersionFlag(app, "blmd-design");
  blmd::app::AddHelpFooter(app, "blmd-design");
  DesignFlags flags;
  flags.Add(app);
  return blmd::app::Main(app, argc, argv, [&]() -> int { return Run(app, flags); });
}
