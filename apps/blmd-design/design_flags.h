// blmd-design's flags (docs/cli.md §5), which fill its settings (DesignSettings,
// app/experiment_design_run.h); the Python package fills the same settings from its keyword
// arguments (python/blmd).
#pragma once

#include <string>
#include <vector>

#include "../common/app_main.h"
#include "../common/trace_flags.h"
#include "app/experiment_design_run.h"

namespace blmd::app {

// Every flag of blmd-design (docs/cli.md §5).
struct DesignFlags {
  std::string config_path, report_path, write_config_path, write_input_path, trace_path;
  std::string from_report;
  std::string family = "all", target;
  double duration = 0.0;
  std::vector<std::string> limits, noises;
  int threads = 0;
  bool json = false, quiet = false, fail_on_warning = false;
  TraceFlags trace;

  void Add(CLI::App& app) {
    app.add_option("--config", config_path, "the model at its prior values (JSON)")->required();
    app.add_option("--from-report", from_report,
                   "a blmd-ident report of the config's model: its final values and effects "
                   "(the effects' fitted parameters free) replace the config's");
    app.add_option("--duration", duration,
                   "length of the experiment to design, s (required "
                   "without --trace)")
        ->check(PositiveNumber());
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
        ->check(NonNegativeWholeNumber());
    app.add_flag("--quiet", quiet, "print nothing but errors");
    app.add_flag("--fail-on-warning", fail_on_warning,
                 "exit 3 when the design has a warning (no friction, an inadequate report, an "
                 "input below the breakaway)");
  }
};

inline blmd::DesignSettings DesignSettingsOf(const CLI::App& app, const DesignFlags& f) {
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

}  // namespace blmd::app
