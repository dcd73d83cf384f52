// blmd-tune's run (docs/tuning.md, docs/cli.md §4): the flags' text forms checked against the
// config and turned into a tuning request, and the tuning that fills the typed report
// (report/tune_report.h).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "blmd/report/tune_report.h"
#include "blmd/tune/tune.h"

namespace blmd {

// The flags of blmd-tune as given.
struct TuneSettings {
  std::string loop;                 // --loop speed|position
  double crossover_hz = 0.0;        // --crossover
  double phase_margin_deg = 0.0;    // --phase-margin
  std::vector<std::string> limits;  // --limit u=VOLTS, i=AMPS
  double step = 0.0;                // --step (0: the default)
  double duration = 0.0;            // --duration (0: from the closed loop's poles)
  // --integral-ratio, --filter-ratio: position loop only (nullopt: not given, the defaults).
  std::optional<double> integral_ratio, filter_ratio;
  int threads = 0;
  // rigid_load: the drive's digital loop (nullopt: the config's experiment.pid, else the
  // defaults: no sample rate, 1 sample of delay, an ideal current loop, a fifth of the speed
  // crossover for the position loop).
  std::optional<double> sample_rate_hz, current_bandwidth_hz, position_crossover_hz;
  std::optional<int> delay_samples;
  // --notch auto|off (nullopt: auto; rigid_load and blmd only).
  std::optional<std::string> notch;
};

// Checks the settings against the plant's config in blmd-tune's order: the loop's flags, the
// limits (u defaults to the config's experiment.pid.u_max), the request's own checks.
// InputError naming the flag for bad input.
TuneRequest MakeTuneRequest(const TuneSettings& settings, const Config& config);

// Loads the plant (the config, and the identified model of `report_path` when not empty),
// builds the request and tunes. The report's result is refused (result.refused) when the plant
// cannot meet the request.
TuneReport RunTune(const std::string& config_path, const std::string& report_path,
                   const TuneSettings& settings);
// The same from a config and a report (null: none) that may be texts in memory.
TuneReport RunTune(const JsonSource& config, const JsonSource* report,
                   const TuneSettings& settings);

}  // namespace blmd
