// The trace preparation flags shared by the commands that fit traces (docs/cli.md §2.2):
// the dialect of a logger's CSV (--delimiter, --duplicate-time, docs/trace-format.md) and
// the mapping, scaling, derivation, selection and splitting of its columns, their resampling
// onto a uniform grid (--resample), and where each experiment starts (--initial-state). What they
// mean (TraceSettings::Options, RowsLine) is the library's (app/request.h); this adds them to a
// command line.
#pragma once

#include <CLI/CLI.hpp>

#include "app/request.h"

namespace blmd::app {

// --delimiter and --duplicate-time (every command that reads a trace, blmd-sim's --input too).
inline void AddDialectFlags(CLI::App& app, DialectSettings* dialect) {
  app.add_option("--delimiter", dialect->delimiter,
                 "field separator of the trace files: , ; or tab (default: from the header)")
      ->check(CLI::IsMember({",", ";", "tab"}));
  app.add_option("--duplicate-time", dialect->duplicate_time,
                 "rows that repeat a time stamp: error (default), first (keep the first row), "
                 "mean (average the rows of each instant)")
      ->check(CLI::IsMember({"error", "first", "mean"}));
  // Two spellings of a headerless file's names: --no-header NAMES, or --no-header --names
  // NAMES. --names is defined first, so that its value is in place when --no-header's
  // callback checks that the names were given once (CLI11 runs the callbacks in the order the
  // options were added).
  CLI::Option* names =
      app.add_option("--names", dialect->no_header,
                     "with --no-header: the columns' names in order, comma separated (e.g. t,u,w)");
  CLI::Option* no_header =
      app.add_option_function<std::string>(
             "--no-header",
             [dialect, names](const std::string& value) {
               if (value.empty() && names->count() == 0) {
                 throw CLI::ValidationError("--no-header",
                                            "name the columns in order: --no-header --names "
                                            "t,u,w (or --no-header t,u,w)");
               }
               if (!value.empty() && names->count() > 0) {
                 throw CLI::ValidationError("--no-header",
                                            "the names are given twice (--no-header NAMES and "
                                            "--names NAMES): give them once");
               }
               if (!value.empty()) dialect->no_header = value;
             },
             "the trace files have no header row: NAMES (comma separated, e.g. u,theta), or "
             "--names NAMES, name their columns in order")
          ->expected(0, 1);
  names->needs(no_header);
  app.add_option("--sample-rate", dialect->sample_rate,
                 "the trace files have no time column: their rows are samples at HZ (t = k/HZ)")
      ->check(CLI::PositiveNumber);
}

struct DialectFlags : DialectSettings {
  void Add(CLI::App& app) { AddDialectFlags(app, this); }
};

// The dialect and the preparation of the traces a fit or a surface reads.
struct TraceFlags : TraceSettings {
  void Add(CLI::App& app) {
    AddDialectFlags(app, this);
    app.add_option("--column", columns,
                   "map a standard column to a header, NAME=HEADER (repeatable)");
    app.add_option("--scale", scales, "multiply a column, NAME=FACTOR (repeatable)");
    app.add_option("--derive", derives, "derive a velocity from a position, e.g. w=theta");
    app.add_option("--select", selects,
                   "keep the rows with NAME in VALUE[,VALUE...] or LO:HI (repeatable)");
    app.add_option("--split", split,
                   "cut each trace into one experiment per block of equal COLUMN values");
    app.add_option("--initial-state", initial_state, "config|trace: initial w, theta, i")
        ->check(CLI::IsMember({"config", "trace"}));
    app.add_option("--resample", resample,
                   "interpolate each experiment onto a uniform step: DT seconds, or auto (its "
                   "median step); a gap over 5 steps cuts it");
  }
};

}  // namespace blmd::app
