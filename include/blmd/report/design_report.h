// blmd-design (docs/design.md, docs/cli.md §5): the flags' text forms checked against the
// config and turned into a design request, the design run (a search, or the evaluation of a
// recorded input), and what it writes: the JSON report, the summary, the chosen experiment as
// a config and as an input table (t, u).
#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "blmd/ident/design.h"
#include "blmd/io/config.h"
#include "blmd/report/request.h"
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
  DialectSettings dialect;          // how to read --trace
  int threads = 0;
};

struct DesignRequest {
  std::string config_path, config_sha256;
  DesignProblem problem;                  // sigma filled
  std::vector<std::string> noise_source;  // per observed column: "flag", "flag_percent", "trace"
  DesignOptions options;
  bool evaluate_trace = false;
  std::string trace_path, trace_sha256;
  Trace trace;           // --trace: t, u and the observed columns as read
  InputSignal recorded;  // --trace: its u (and open) held between samples
};

// Checks the settings against the config in blmd-design's order (docs/cli.md §5): limits,
// noise, duration or trace, family, target. InputError naming the flag for bad input.
DesignRequest MakeDesignRequest(const Config& config, const std::string& config_path,
                                const DesignSettings& settings);

struct DesignReport {
  bool ok = false;
  std::string reason;  // why no design (exit 1)
  std::string config_path, config_sha256, model;
  bool evaluate_trace = false;
  std::string trace_path, trace_sha256;
  std::string criterion;  // "D-optimal" or "A-optimal"
  std::vector<std::string> target;
  DesignOptions options;  // duration and sample rate as used (a trace's own with --trace)
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
};

// Runs the request: SearchDesign, or the recorded input's prediction; and the config's own
// input over the same duration and samples, for comparison (when it is one of the families
// or a step).
DesignReport RunDesign(const DesignRequest& request);

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
