// blmd-tune: PI (speed loop) or PID (position loop) gains from the identified model for a
// requested crossover and phase margin, checked over the parameters' 95 % box and on the
// nonlinear model in closed loop (docs/tuning.md, docs/cli.md §4).
// Flags -> TuneSettings -> blmd::RunTune (app/tune_run.h: the plant, the request, the tuning)
// -> the typed report, rendered as JSON, the closed-loop config and the summary; the exit code.
#include <iostream>

#include "../common/app_main.h"
#include "app/tune_run.h"
#include "blmd/io/files.h"

namespace {

// Every flag of blmd-tune (docs/cli.md §4).
struct TuneFlags {
  std::string config_path, report_in_path, loop, report_path, write_config_path;
  std::vector<std::string> limits;
  double crossover_hz = 0.0, phase_margin_deg = 0.0, step = 0.0, duration = 0.0;
  double integral_ratio = 4.0, filter_ratio = 10.0;
  double sample_rate_hz = 0.0, current_bandwidth_hz = 0.0, position_crossover_hz = 0.0;
  int delay_samples = 1;
  int threads = 0;
  bool json = false, quiet = false;

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
        ->check(blmd::app::PositiveNumber());
    app.add_option("--phase-margin", phase_margin_deg, "phase margin at the crossover, degrees")
        ->required()
        ->check(blmd::app::PositiveNumber());
    app.add_option("--limit", limits,
                   "the drive's limit u=VOLTS (default: the config's experiment.pid.u_max) or "
                   "i=AMPS (repeatable); rigid_load: u=MAX or u=LOW:HIGH (an asymmetric drive)");
    app.add_option("--step", step,
                   "reference step of the checked response, rad (speed loop: rad/s); default "
                   "1 rad, or 10 % of the speed u_max gives")
        ->check(blmd::app::PositiveNumber());
    app.add_option("--duration", duration,
                   "length of the simulated step, s (default: from the closed loop's poles)")
        ->check(blmd::app::PositiveNumber());
    app.add_option("--integral-ratio", integral_ratio,
                   "position loop: Ti/Td of the PID (default 4)")
        ->check(blmd::app::PositiveNumber());
    app.add_option("--filter-ratio", filter_ratio,
                   "position loop: derivative filter frequency over the crossover (default 10)")
        ->check(blmd::app::PositiveNumber());
    app.add_option("--sample-rate", sample_rate_hz,
                   "rigid_load: the drive controller's sample rate, Hz (default: the config's "
                   "experiment.pid.sample_rate)")
        ->check(blmd::app::PositiveNumber());
    app.add_option("--delay", delay_samples,
                   "rigid_load: computation delay of the controller's output, samples (default 1)")
        ->check(blmd::app::NonNegativeWholeNumber());
    app.add_option("--current-bandwidth", current_bandwidth_hz,
                   "rigid_load: bandwidth of the current (force) loop, a first-order lag, Hz "
                   "(default: ideal)")
        ->check(blmd::app::PositiveNumber());
    app.add_option("--position-crossover", position_crossover_hz,
                   "rigid_load, position loop: the position P's crossover, Hz (default: a fifth "
                   "of --crossover)")
        ->check(blmd::app::PositiveNumber());
    app.add_option("--report", report_path, "write the JSON report here");
    app.add_option("--write-config", write_config_path,
                   "write the closed-loop config (the tuned step) that blmd-sim runs");
    app.add_flag("--json", json, "print the JSON report on stdout instead of the summary");
    app.add_option("--threads", threads, "worker threads for the box's corners (0: all cores)")
        ->check(blmd::app::NonNegativeWholeNumber());
    app.add_flag("--quiet", quiet, "print nothing but errors");
  }
};

blmd::TuneSettings Settings(const CLI::App& app, const TuneFlags& f) {
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
  settings.threads = f.threads;
  return settings;
}

int Run(const CLI::App& app, TuneFlags& f) {
  f.threads = blmd::app::CapThreads(f.threads);
  blmd::CheckOutputs({{"--report", f.report_path}, {"--write-config", f.write_config_path}},
                     {{"--config", f.config_path}, {"--from-report", f.report_in_path}});
  if (!f.report_path.empty() || !f.write_config_path.empty()) blmd::InstallCleanupOnSignal();
  const blmd::TuneReport tuned = blmd::RunTune(f.config_path, f.report_in_path, Settings(app, f));
  if (tuned.result.refused) {
    // A request the plant cannot meet: exit 1, the reason, nothing written.
    std::cerr << "error: cannot tune: " << tuned.result.refusal << "\n";
    return blmd::kExitFailed;
  }
  const nlohmann::json report = tuned;
  if (!f.report_path.empty()) blmd::WriteFileAtomically(f.report_path, report.dump(2) + "\n");
  if (!f.write_config_path.empty()) {
    const nlohmann::json config = blmd::ClosedLoopConfigJson(tuned);
    blmd::WriteFileAtomically(f.write_config_path, config.dump(2) + "\n");
  }
  if (f.json) {
    std::cout << report.dump(2) << "\n";
  } else if (!f.quiet) {
    std::cout << blmd::TuneSummary(tuned);
    if (!f.report_path.empty()) std::cout << "report: " << f.report_path << "\n";
    if (!f.write_config_path.empty()) std::cout << "config: " << f.write_config_path << "\n";
  }
  return blmd::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "blmd-tune: PI or PID gains from the identified model for a crossover and phase margin, "
      "checked over the parameters' 95 % box"};
  blmd::app::AddVersionFlag(app, "blmd-tune");
  blmd::app::AddHelpFooter(app, "blmd-tune");
  TuneFlags flags;
  flags.Add(app);
  return blmd::app::Main(app, argc, argv, [&]() -> int { return Run(app, flags); });
}
