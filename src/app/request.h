// Requests as the commands' flags state them (docs/cli.md): the flags' own text forms ("J,B",
// "J=1e-5", "i=1%", "J=log:1e-5:5e-5:21") checked against the config and turned into the
// request of Identify (identify.h), Sweep (sweep.h) or a simulation (run.h), with the
// commands' defaults and their error messages. blmd-ident, blmd-surface, blmd-sim and the
// Python package (docs/python.md) build their requests here, so they agree on every default
// and every message. Every function throws InputError for bad input, naming the flag.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "blmd/app/identify.h"
#include "blmd/app/sweep.h"
#include "blmd/ident/fit/surface.h"
#include "blmd/ident/fit/trace_input.h"
#include "blmd/io/config.h"
#include "blmd/io/csv.h"
#include "blmd/sim/experiment.h"
#include "blmd/sim/model.h"
#include "blmd/sim/trace.h"

namespace blmd {

// --delimiter and --duplicate-time: the dialect of a logger's CSV (docs/trace-format.md).
struct DialectSettings {
  std::string delimiter;       // "", ",", ";" or "tab" ("": detected from the header)
  std::string duplicate_time;  // "", "error", "first" or "mean" ("": error)
  std::string no_header;       // --no-header NAMES: comma-separated column names ("": a header)
  double sample_rate = 0.0;    // --sample-rate HZ: the time column made from the rate (0: read)

  std::vector<std::string> Names() const;  // no_header's names (ParseNameList)

  char Delimiter() const;
  DuplicateTime Duplicates() const;
};

// The preparation of the traces a fit or a surface reads (docs/cli.md §2.2).
struct TraceSettings : DialectSettings {
  std::vector<std::string> columns;      // --column NAME=HEADER
  std::vector<std::string> scales;       // --scale NAME=FACTOR
  std::vector<std::string> derives;      // --derive w=theta
  std::vector<std::string> selects;      // --select NAME=SPEC
  std::string split;                     // --split COLUMN ("": none)
  std::string initial_state = "config";  // --initial-state config|trace
  std::string resample;                  // --resample DT|auto ("": as recorded)

  // The options of LoadFitTraces: every trace must have the observed columns (with the
  // output error; the equation error needs u and the motion, which it checks itself).
  // `reference`: the trace's r drives the simulation (identification.simulate_from "reference").
  TraceInputOptions Options(const std::vector<std::string>& observe, bool equation_error,
                            bool reference = false) const;
  // The rows as flags (" --select t=60: --split run --resample auto"): what selects, merges
  // or resamples them, recorded in a surface CSV so that merge tells sweeps of different
  // rows apart; "" when every row is used as recorded.
  std::string RowsLine() const;
};

// --error, --filter-hz and --decimate: how the model meets the trace (identification.md §8).
struct ErrorSettings {
  std::string kind;        // "", "output" or "equation"; "" keeps the config's
  double filter_hz = 0.0;  // 0 keeps the config's
  int decimate = 0;        // 0 keeps the config's
  std::string
      simulate_from;  // "", "command" or "reference" (identification.simulate_from); "" keeps it

  // Writes the settings into the config and returns the observed columns: `observe_text`
  // parsed (else the config's), `u` for the equation error. Throws InputError for a filter
  // setting without the equation error, another model, or another observed column.
  std::vector<std::string> Apply(Config* config, const std::string& observe_text) const;
};

// One measured trace: the CSV file `path`, or, when `data` is set, columns in memory that
// `path` names in the report and in messages (their rows numbered as the lines of the CSV
// file they would make: the header is line 1, the first row line 2).
struct TraceSource {
  std::string path;
  std::optional<Trace> data;
};

// LoadFitTraces for a file, PrepareFitTraces for columns in memory.
std::vector<FitTrace> LoadTraceSource(const TraceSource& source, const TraceInputOptions& options,
                                      const InitialState& default_initial);

// ---- blmd-ident (docs/cli.md §2) ----

struct IdentSettings {
  std::vector<TraceSource> traces;      // --trace (at least one)
  std::vector<TraceSource> validation;  // --validate
  std::string method;                   // --method; "": the config's, else ceres
  // --observe, --free, --candidates: nullopt when not given (the config's observe and free,
  // every effect); given empty, they are refused with the valid choices.
  std::optional<std::string> observe, free, candidates;
  std::vector<std::string> initials;        // --initial NAME=VALUE
  std::vector<std::string> method_options;  // --option KEY=VALUE
  std::uint64_t seed = 1;
  int threads = 0;          // 0: every core
  int max_evaluations = 0;  // 0: the method's default
  bool verbose = false, discover = false;
  double bic_margin = 10.0;
  double min_share = 0.10;  // discovery's stopping rule (DiscoveryOptions::min_explained_share)
  int max_effects = 3;
  std::string weighting;                // --weighting noise|variance ("": the config's)
  std::vector<std::string> noise_stds;  // --noise-std NAME=SIGMA (repeatable)
  std::string baseline;                 // --baseline: a stored report to compare with
  ErrorSettings error;
  TraceSettings preparation;
};

// Checks the settings against the config (to which --initial and --error are applied) and
// reads the traces, in blmd-ident's order: the request blmd::Identify runs.
IdentRequest MakeIdentRequest(Config config, const std::string& config_path,
                              const IdentSettings& settings);

// ---- blmd-surface (docs/cli.md §3) ----

// The largest sweep blmd-surface runs without --force.
inline constexpr std::size_t kMaxSurfacePoints = 1000000;
inline constexpr double kMaxSurfaceBytes = 1e9;

struct SweepSettings {
  TraceSource trace;                   // --trace
  std::vector<std::string> grids;      // --grid P=LO:HI:N or P=log:LO:HI:N, one or two
  std::optional<std::string> observe;  // --observe; nullopt: the config's
  std::string shard;                   // --shard K/N; "": 1/1
  bool force = false;                  // --force: beyond the size cap
  int threads = 0;
  ErrorSettings error;
  TraceSettings preparation;
};

// One or two --grid axes (blmd-surface checks it before it reads the config).
void CheckGridCount(const std::vector<std::string>& grids);
// --shard K/N (1-based; "": 1/1).
std::pair<int, int> ParseShard(const std::string& text);

// Checks the settings against the config (--error applied), reads the trace and refuses a
// sweep beyond the size cap without `force`, in blmd-surface's order. The request's
// config_sha256 and progress are the caller's to fill.
SweepRequest MakeSweepRequest(Config config, const SweepSettings& settings);

// ---- blmd-sim (docs/cli.md §1) ----

// --noise NAME=SIGMA (absolute, column units) or NAME=P% (P % of the column's peak |value|).
struct NoiseSpec {
  std::string column;
  double sigma = 0.0;
  bool relative = false;
};
std::vector<NoiseSpec> ParseNoise(const std::vector<std::string>& specs);

// Reads the --input CSV: t and u (and the open-armature switch `open`), other columns may
// hold text.
Trace ReadInputTrace(const std::string& path, const DialectSettings& dialect);
// The recorded input (t, u held between samples, and `open` if any) that RunRecordedInput
// runs; InputError "<path>: ..." when the span is too long for the config's step.
InputSignal RecordedInput(const Trace& input, const std::string& path, const Config& config);

// Adds the noise to the simulated columns, generator seeded with `seed`, column by column in
// the order given; a relative sigma becomes absolute (scaled by the column's peak |value|).
void AddNoise(std::vector<NoiseSpec>* noise, std::uint64_t seed, Trace* trace);

// blmd-sim's one line (after "error: ") when a run failed: where, why, and for a divergence
// what to change.
std::string SimulationFailureMessage(const std::string& config_path, const Config& config,
                                     const SimStatus& status);

}  // namespace blmd
