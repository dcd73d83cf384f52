// blmd-design's run (docs/design.md, docs/cli.md §5): the flags' text forms checked against the
// config and turned into a design request, and the design run (a search, or the evaluation of a
// recorded input) that fills the typed report (report/design_report.h).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "app/request.h"
#include "blmd/ident/experiment_design/experiment_design.h"
#include "blmd/io/config.h"
#include "blmd/report/design_report.h"
#include "blmd/sim/trace.h"

namespace blmd {

// The flags of blmd-design as given.
struct DesignSettings {
  std::optional<double> duration;   // --duration S (search; not with --trace)
  std::vector<std::string> limits;  // --limit NAME=VALUE (u: the input; outputs: the response)
  std::vector<std::string> noises;  // --noise NAME=SIGMA or NAME=P% (as blmd-sim)
  std::string family = "all";       // --family square|steps|prbs|chirp|all
  std::string target;               // --target NAME[,NAME] ("": D-optimal)
  std::string trace_path;           // --trace: evaluate its u column instead of searching
  std::optional<Trace> trace_data;  // set: --trace's columns in memory, trace_path labels them
  TraceSettings trace;              // how to read and prepare --trace (blmd-ident's flags)
  std::string from_report;          // --from-report: a blmd-ident report of the config's model
  std::optional<std::string> from_report_text;  // set: that report's JSON text in memory
  int threads = 0;
};

struct DesignRequest {
  std::string config_path, config_sha256;
  DesignProblem problem;                  // sigma filled
  std::vector<std::string> noise_source;  // per observed column: "flag", "flag_percent", "trace"
  ExperimentDesignOptions options;
  bool evaluate_trace = false;
  std::string trace_path, trace_sha256;
  Trace trace;                             // --trace: t, u and the observed columns as read
  InputSignal recorded;                    // --trace: its u (and open) held between samples
  std::string report_path, report_sha256;  // --from-report
  // --from-report: each observed column's noise and each free parameter's variance ratio (the
  // residual's colour on that record) as the report gives them.
  std::map<std::string, double> report_noise, report_variance_ratio;
  // The drive torque the shaft must overcome to move (N·m; friction, cogging, load) and the
  // |u| that gives it at standstill; 0 when the model has none or the model's torque per
  // unit input at standstill is not known (docs/design.md §7).
  double breakaway_torque = 0.0, breakaway_u = 0.0;
  std::vector<std::pair<std::string, std::string>> warnings;  // code, message
};

// Checks the settings against the config in blmd-design's order (docs/cli.md §5): limits,
// noise, duration or trace, family, target. InputError naming the flag for bad input.
// With --from-report, the report's final model (values and effects; the effects' parameters
// that the report fitted become free) replaces the config's first.
DesignRequest MakeDesignRequest(Config config, const std::string& config_path,
                                const DesignSettings& settings);
// The same for a config that may be a text in memory (config_source.path labels it).
DesignRequest MakeDesignRequest(Config config, const JsonSource& config_source,
                                const DesignSettings& settings);

// Runs the request: SearchDesign, or the recorded input's prediction; and the config's own
// input over the same duration and samples, for comparison (when it is one of the families
// or a step).
DesignReport RunDesign(const DesignRequest& request);

}  // namespace blmd
