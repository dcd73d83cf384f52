// Taking the identified model elsewhere (docs/export.md): the final model as a config that
// blmd-sim and blmd-ident accept (--write-config), its linear part as MATLAB/Octave `ss` and
// `tf` objects (--export-matlab). The drift guard against a stored report (--baseline) is the
// app layer's (app/baseline.h).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "blmd/ident/fit/problem.h"
#include "blmd/io/config.h"
#include "blmd/report/report.h"
#include "blmd/sim/linear_model.h"

namespace blmd {

// The linear part as the report's "linear_model" block: the state space and the transfer
// functions u -> each output (null matrices when not available, with the reason).
nlohmann::json LinearModelJson(const LinearModel& model);

// The final model as a config: `config`'s document (its experiment, simulation settings and
// identification set-up as written) with the parameters at `values` (every model and effect
// parameter), the effects of `config` with their values, identification.free the fitted
// parameters with their bounds and no separate start values (the fitted values are the
// start), and under "notes" the provenance: the tool, the traces, the fit's NRMSE and every
// parameter's 95 % interval (a comment: the loader does not read it).
nlohmann::json ModelConfigJson(const Config& config, const ParameterSet& values,
                               const std::vector<FreeParameter>& free, const IdentReport& report);

// A MATLAB/Octave script that builds the linear part: A, B, C, D, `sys = ss(...)` with named
// states, input and outputs, and `G_<output> = tf(num, den)` for each output; the parameters
// and their intervals as comments. Needs the Control System Toolbox (MATLAB) or the control
// package (Octave, `pkg load control`).
std::string MatlabScript(const IdentReport& report);

}  // namespace blmd
