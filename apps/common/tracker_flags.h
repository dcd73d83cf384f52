// The online J tracker's settings (docs/export.md §7), shared by blmd-track (which runs it over
// a record) and blmd-export --format c --tracker-rate (which writes it as C): the same flags,
// defaults and checks fill one TrackerSettings.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "app_main.h"
#include "tune/inertia_tracker.h"

namespace blmd::app {

struct TrackerFlags : TrackerSettings {
  // `prefix`: the help's lead ("tracker: " where the command has other flags too).
  void Add(CLI::App& app, const std::string& prefix = "") {
    app.add_option("--filter-hz", filter_hz,
                   prefix + "the state-variable filter's corner (default fs/50 within 1-50 Hz)")
        ->check(PositiveNumber());
    app.add_option("--memory", memory_s,
                   prefix + "forgetting time constant of J over excited time, s (default 1)")
        ->check(PositiveNumber());
    app.add_option(
           "--gate", gate,
           prefix + "J updates where |filtered acceleration| > GATE x its noise (default 3)")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--change-margin", change_margin,
                   prefix +
                       "'changed' when J's 95 % interval leaves the offline one by this "
                       "fraction (default 0.05)")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--speed-noise", speed_noise,
                   prefix +
                       "the speed's noise std, rad/s (default: the report's for w; "
                       "blmd-track: else 1 % of the trace's RMS speed)")
        ->check(CLI::NonNegativeNumber);
  }
};

}  // namespace blmd::app
