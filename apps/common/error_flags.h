// --error, --filter-hz and --decimate, shared by blmd-ident and blmd-surface: how the model
// meets the trace (docs/identification.md §8).
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "app_main.h"
#include "blmd/io/config.h"
#include "blmd/io/flags.h"

namespace blmd::app {

struct ErrorFlags {
  std::string kind;        // "", "output" or "equation"; "" keeps the config's
  double filter_hz = 0.0;  // 0 keeps the config's
  int decimate = 0;        // 0 keeps the config's

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
  }

  // Writes the flags into the config and returns the observed columns: `observe_text`
  // parsed (else the config's), `u` for the equation error. Throws InputError for a filter
  // setting without the equation error, another model, or another observed column.
  std::vector<std::string> Apply(Config* config, const std::string& observe_text) const {
    IdentificationSettings& ident = config->identification;
    if (!kind.empty()) ident.error = kind;
    if (filter_hz > 0.0) ident.filter_hz = filter_hz;
    if (decimate > 0) ident.decimate = decimate;
    const bool equation = ident.error == "equation";
    if (!equation && (filter_hz > 0.0 || decimate > 0)) {
      throw InputError(std::string(filter_hz > 0.0 ? "--filter-hz" : "--decimate") +
                       " applies to the equation error only (--error equation)");
    }
    if (equation && config->model->name() != "rigid_load") {
      throw InputError(
          "--error equation needs model rigid_load (its input is the drive torque); model " +
          std::string(config->model->name()) + "'s drive torque is a state of the model");
    }
    std::vector<std::string> observe =
        observe_text.empty() ? ident.observe : ParseNameList(observe_text, "--observe");
    if (equation && observe_text.empty()) observe = {"u"};
    if (equation && observe != std::vector<std::string>{"u"}) {
      throw InputError("--observe: the equation error compares the input: observe u");
    }
    return observe;
  }
};

}  // namespace blmd::app
