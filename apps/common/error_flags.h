// --error, --filter-hz and --decimate, shared by blmd-ident and blmd-surface: how the model
// meets the trace (docs/identification.md §8). What they mean (ErrorSettings::Apply) is the
// library's (app/request.h); this adds them to a command line.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "app/request.h"
#include "app_main.h"

namespace blmd::app {

struct ErrorFlags : ErrorSettings {
  void Add(CLI::App& app, const std::string& what) {
    app.add_option("--error", kind,
                   "output|equation: " + what + " (rigid_load; default: config, else output)")
        ->check(CLI::IsMember({"output", "equation"}));
    app.add_option("--filter-hz", filter_hz,
                   "equation error: low-pass cut-off of the measured motion (default fs/10)")
        ->check(PositiveNumber());
    app.add_option("--decimate", decimate,
                   "equation error: keep every N-th sample after an anti-alias filter")
        ->check(CLI::Range(1, 1000));
    CLI::Option* from =
        app.add_option("--simulate-from", simulate_from,
                       "command|reference: what drives the simulation, the trace's u replayed "
                       "open loop or its reference r through the config's experiment.pid "
                       "(default: config, else command)")
            ->check(CLI::IsMember({"command", "reference"}));
    // The closed-loop (indirect) fit by its name: the trace's r drives the config's
    // controller, u may be absent (docs/identification.md §9b).
    app.add_flag_callback(
           "--closed-loop", [this] { simulate_from = "reference"; },
           "the record is of a closed loop: simulate the config's experiment.pid from the "
           "trace's reference r (the same as --simulate-from reference)")
        ->excludes(from);
  }
};

}  // namespace blmd::app
