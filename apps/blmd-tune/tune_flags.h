// blmd-tune's flags (docs/cli.md §4), which fill its settings (TuneSettings, app/tune_run.h);
// the Python package fills the same settings from its keyword arguments (python/blmd).
#pragma once

#include <string>
#include <vector>

#include "../common/app_main.h"
#include "app/tune_run.h"

namespace blmd::app {

// Every flag of blmd-tune (docs/cli.md §4).
struct TuneFlags {
  std::string config_path, report_in_path, loop, report_path, write_config_path, notch;
  std::vector<std::string> limits;
  double crossover_hz = 0.0, phase_margin_deg = 0.0, step = 0.0, duration = 0.0;
  double integral_ratio = 4.0, filter_ratio = 10.0;
  double sample_rate_hz = 0.0, current_bandwidth_hz = 0.0, position_crossover_hz = 0.0;
  int delay_samples = 1;
  int threads = 0;
  bool json = false, quiet = false, fail_on_warning = false;

  void Add(CLI::App& app) {
    app.add_option("--config", config_path, "the model to tune (JSON config)")->required();
    app.add_option("--from-report", report_in_path,
                   "a blmd-ident --report JSON: its final model and 95 % intervals are used");
    app.add_option("--loop", loop,
                   "speed (PI) or position (PID; rigid_load: a P over the speed PI)")
        ->required()
        ->check(CLI::IsMember({"speed", "position"}));
    app.add_option("--crossover", crossover_hz,
                   "open-loop gain crossover, Hz (rigid_load: the speed loop's, on the sampled "
                   "loop)")
        ->required()
        ->check(PositiveNumber());
    app.add_option("--phase-margin", phase_margin_deg, "phase margin at the crossover, degrees")
        ->required()
        ->check(PositiveNumber());
    app.add_option("--limit", limits,
                   "the drive's limit u=VOLTS (default: the config's experiment.pid.u_max) or "
                   "i=AMPS (repeatable); rigid_load: u=MAX or u=LOW:HIGH (an asymmetric drive)");
    app.add_option("--step", step,
                   "reference step of the checked response, rad (speed loop: rad/s); default "
                   "1 rad, or 10 % of the speed u_max gives")
        ->check(PositiveNumber());
    app.add_option("--duration", duration,
                   "length of the simulated step, s (default: from the closed loop's poles)")
        ->check(PositiveNumber());
    app.add_option("--integral-ratio", integral_ratio,
                   "position loop: Ti/Td of the PID (default 4)")
        ->check(PositiveNumber());
    app.add_option("--filter-ratio", filter_ratio,
                   "position loop: derivative filter frequency over the crossover (default 10)")
        ->check(PositiveNumber());
    app.add_option("--sample-rate", sample_rate_hz,
                   "rigid_load: the drive controller's sample rate, Hz (default: the config's "
                   "experiment.pid.sample_rate)")
        ->check(PositiveNumber());
    app.add_option("--delay", delay_samples,
                   "rigid_load: computation delay of the controller's output, samples (default 1)")
        ->check(NonNegativeWholeNumber());
    app.add_option("--current-bandwidth", current_bandwidth_hz,
                   "rigid_load: bandwidth of the current (force) loop, a first-order lag, Hz "
                   "(default: ideal)")
        ->check(PositiveNumber());
    app.add_option("--position-crossover", position_crossover_hz,
                   "rigid_load, position loop: the position P's crossover, Hz (default: a fifth "
                   "of --crossover)")
        ->check(PositiveNumber());
    app.add_option("--notch", notch,
                   "rigid_load, blmd: auto (default: the drive's own experiment.pid.notch kept; "
                   "on a two-mass shaft a notch at the resonance designed when the request "
                   "needs one) or off (none)")
        ->check(CLI::IsMember({"auto", "off"}));
    app.add_option("--report", report_path, "write the JSON report here");
    app.add_option("--write-config", write_config_path,
                   "write the closed-loop config (the tuned step) that blmd-sim runs");
    app.add_flag("--json", json, "print the JSON report on stdout instead of the summary");
    app.add_option("--threads", threads, "worker threads for the box's corners (0: all cores)")
        ->check(NonNegativeWholeNumber());
    app.add_flag("--quiet", quiet, "print nothing but errors");
    app.add_flag("--fail-on-warning", fail_on_warning,
                 "exit 3 when the tuning has a warning (e.g. the report's model is inadequate)");
  }
};

inline blmd::TuneSettings TuneSettingsOf(const CLI::App& app, const TuneFlags& f) {
  blmd::TuneSettings settings;
  settings.loop = f.loop;
  settings.crossover_hz = f.crossover_hz;
  settings.phase_margin_deg = f.phase_margin_deg;
  settings.limits = f.limits;
  settings.step = f.step;
  settings.duration = f.duration;
  if (app.count("--integral-ratio") > 0) settings.integral_ratio = f.integral_ratio;
  if (app.count("--filter-ratio") > 0) settings.filter_ratio = f.filter_ratio;
  if (app.count("--sample-rate") > 0) settings.sample_rate_hz = f.sample_rate_hz;
  if (app.count("--delay") > 0) settings.delay_samples = f.delay_samples;
  if (app.count("--current-bandwidth") > 0) settings.current_bandwidth_hz = f.current_bandwidth_hz;
  if (app.count("--position-crossover") > 0) {
    settings.position_crossover_hz = f.position_crossover_hz;
  }
  if (app.count("--notch") > 0) settings.notch = f.notch;
  settings.threads = f.threads;
  return settings;
}

}  // namespace blmd::app
