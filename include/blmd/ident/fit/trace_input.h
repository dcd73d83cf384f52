// Preparing a measured trace for a fit (docs/cli.md §2.2): column mapping, unit scaling,
// row selection, splitting a file into experiments, merging repeated time stamps,
// resampling onto a uniform grid, velocity from position, and the recorded input.
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "blmd/ident/fit/problem.h"
#include "blmd/io/csv.h"

namespace blmd {

// One `--select NAME=SPEC`: keep the rows whose column NAME lies in any of the closed
// ranges. SPEC is a comma-separated list of items, each a value `V` ([V, V]) or a range
// `LO:HI`, `LO:` or `:HI` (open ends are infinite). Values compare as doubles (-0 == 0).
struct RowSelection {
  std::string column;
  std::vector<std::pair<double, double>> ranges;  // closed [lo, hi], lo <= hi
  std::string text;                               // as given, "run=0:9", for messages

  bool Matches(double value) const;
};

// Parses the text of `--select` ("run=3", "run=0,2,4", "t=60:", "run=0:9,20:29");
// throws InputError naming the flag.
RowSelection ParseRowSelection(const std::string& text);

struct TraceInputOptions {
  std::map<std::string, std::string> columns;  // standard name -> header in the file
  std::map<std::string, double> scales;        // standard name -> factor (after mapping)
  std::vector<std::pair<std::string, std::string>> derive;  // {"w", "theta"}: w = d theta/dt
  std::vector<std::string> required;  // standard columns needed besides t and the input
  // The column the simulation is driven by: "u" (the drive's command, replayed open loop) or
  // "r" (the loop's reference, identification from the reference: the config's controller
  // closes the loop; docs/identification.md §9b).
  std::string input = "u";
  bool initial_from_trace = false;  // initial w, theta (and i) from each experiment's first sample
  // Rows kept: those matching every selection (all rows when empty). The kept rows of one
  // experiment must be one unbroken block of the file.
  std::vector<RowSelection> select;
  // When not empty: the file is cut into experiments wherever this column's value changes
  // (after selection); each value must occupy one unbroken block of rows.
  std::string split;
  // The file's dialect (docs/trace-format.md): field separator (0: detected from the
  // header) and what to do with rows that repeat a time stamp (--duplicate-time), applied
  // within each experiment, after selection and splitting.
  char delimiter = 0;
  DuplicateTime duplicate_time = DuplicateTime::kError;
  // A file without a header row (--no-header): its columns' names in order; and its rate
  // (--sample-rate, Hz) when it has no time column (CsvReadOptions::names, sample_rate).
  std::vector<std::string> names;
  double sample_rate = 0.0;
  // --resample: each experiment linearly interpolated onto the uniform grid t0 + k step
  // (s), k = 0, 1, ... up to its last time stamp (`open`, a switch, is held, not
  // interpolated); with `resample_median` the step is the experiment's median step. A
  // recorded step longer than kResampleGapSteps grid steps is a gap: the experiment is cut
  // there, each part on its own grid, named "NAME[t=FIRST:LAST]". Neither set: the samples
  // as recorded.
  double resample_step = 0.0;
  bool resample_median = false;
};

// A recorded step longer than this many --resample steps cuts the experiment in two.
inline constexpr double kResampleGapSteps = 5.0;

// Reads, maps, scales, selects, splits, merges repeated time stamps, resamples and derives,
// in that order (docs/cli.md §2.2); throws InputError naming the file (and line and column
// where there is one). One FitTrace per experiment, in file order; without --split (and
// gaps that --resample cuts at) exactly one. An experiment cut from a file is named
// "FILE[COLUMN=VALUE]" (split) or "FILE[SELECTION]" (select only) in `path`.
std::vector<FitTrace> LoadFitTraces(const std::string& path, const TraceInputOptions& options,
                                    const InitialState& default_initial);

// The same for a trace already in memory (read by the caller, or columns from Python): `path`
// names it in messages and reports, `sha256` is recorded as its hash ("" when none). Its
// rows are numbered in messages as lines after its comments and a header (the first row is
// line 2 when it has no comments). The columns the fit reads must be finite.
std::vector<FitTrace> PrepareFitTraces(Trace trace, const std::string& path,
                                       const std::string& sha256, const TraceInputOptions& options,
                                       const InitialState& default_initial);

// The same for a file that must give exactly one experiment (no `split`).
FitTrace LoadFitTrace(const std::string& path, const TraceInputOptions& options,
                      const InitialState& default_initial);

// A trace in memory as one experiment: its `input` column (u, or the reference r) and `open`,
// when present, are the recorded input, held between samples; `initial` is the state at its
// first sample.
FitTrace RecordedFitTrace(Trace trace, const InitialState& initial,
                          const std::string& path = "generated", const std::string& input = "u");

// d theta/dt on a possibly irregular grid: central difference (t_{k+1} - t_{k-1}) inside,
// one-sided at the ends (second-order accurate for smooth signals).
std::vector<double> Differentiate(const std::vector<double>& t, const std::vector<double>& x);

}  // namespace blmd
