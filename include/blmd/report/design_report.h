// What blmd-design writes (docs/design.md, docs/cli.md §5): the typed design report, rendered
// as the JSON report and the summary, and the chosen experiment as a config and as an input
// table (t, u). The request and the run are the app layer's (app/experiment_design_run.h).
#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "blmd/ident/experiment_design/experiment_design.h"
#include "blmd/io/config.h"
#include "blmd/sim/trace.h"

namespace blmd {

struct DesignReport {
  bool ok = false;
  std::string reason;  // why no design (exit 1)
  std::string config_path, config_sha256, model;
  bool evaluate_trace = false;
  std::string trace_path, trace_sha256;
  std::string criterion;  // "D-optimal" or "A-optimal"
  std::vector<std::string> target;
  ExperimentDesignOptions options;  // duration and sample rate as used (a trace's own with --trace)
  std::vector<std::string> observe;
  std::vector<double> sigma;
  std::vector<std::string> noise_source;
  std::vector<std::string> units;            // per free parameter
  DesignCandidate chosen;                    // the design, or the trace's input (family "recorded")
  bool chosen_within_limits = true;          // --trace: the recorded peaks within the limits
  std::optional<DesignCandidate> reference;  // the config's own input, same duration
  bool reference_within_limits = true;
  std::vector<DesignCandidate> family_best;
  long evaluated = 0;
  std::map<std::string, long> rejected;
  std::string report_path, report_sha256;  // --from-report ("" without)
  // --from-report: the factor each free parameter's predicted variance was widened by (the
  // report's variance ratio; 1 where it gives none).
  std::map<std::string, double> variance_factor;
  // The torque that holds the shaft at rest (N·m) and the |u| that overcomes it with the
  // margin (docs/design.md §7); 0: none or not known for the model.
  double breakaway_torque = 0.0, breakaway_u = 0.0;
  std::vector<std::pair<std::string, std::string>> warnings;  // code, message
};

// The JSON report (schema/design.schema.json).
nlohmann::json DesignReportJson(const DesignReport& report);
// The human summary on stdout.
std::string DesignSummary(const DesignReport& report);
// `config`'s document with its experiment replaced by the chosen one (input, duration, sample
// rate; the initial state kept; no PID, no coast-down) and the design under "notes".
nlohmann::json DesignConfigJson(const Config& config, const DesignReport& report);
// The chosen input as a table a drive plays: t and u at the sample instants, u held between
// them (zero-order hold).
Trace DesignInputTable(const DesignReport& report);
// An input as a config's experiment.input section.
nlohmann::json InputJson(const InputSignal& input);

}  // namespace blmd
