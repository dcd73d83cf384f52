// The trace preparation flags shared by the commands that fit traces (docs/cli.md §2.2):
// the dialect of a logger's CSV (--delimiter, --duplicate-time, docs/trace-format.md) and
// the mapping, scaling, derivation, selection and splitting of its columns, and where each
// experiment starts (--initial-state).
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "blmd/error.h"
#include "blmd/ident/trace_input.h"
#include "blmd/io/csv.h"
#include "blmd/io/flags.h"

namespace blmd::app {

// --delimiter and --duplicate-time: the dialect of a logger's CSV (every command that reads
// a trace, blmd-sim's --input too).
struct DialectFlags {
  std::string delimiter;       // "", ",", ";" or "tab"
  std::string duplicate_time;  // "", "error", "first" or "mean"

  void Add(CLI::App& app) {
    app.add_option("--delimiter", delimiter,
                   "field separator of the trace files: , ; or tab (default: from the header)")
        ->check(CLI::IsMember({",", ";", "tab"}));
    app.add_option("--duplicate-time", duplicate_time,
                   "rows that repeat a time stamp: error (default), first (keep the first row), "
                   "mean (average the rows of each instant)")
        ->check(CLI::IsMember({"error", "first", "mean"}));
  }

  char Delimiter() const {
    return delimiter == "tab" ? '\t' : delimiter.empty() ? 0 : delimiter[0];
  }
  DuplicateTime Duplicates() const {
    return duplicate_time == "first"  ? DuplicateTime::kFirst
           : duplicate_time == "mean" ? DuplicateTime::kMean
                                      : DuplicateTime::kError;
  }
};

// The dialect and the preparation of the traces a fit or a surface reads.
struct TraceFlags : DialectFlags {
  std::vector<std::string> columns, scales, derives, selects;
  std::string split, initial_state = "config";

  void Add(CLI::App& app) {
    DialectFlags::Add(app);
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
  }

  // The options of LoadFitTraces: every trace must have the observed columns (with the
  // output error; the equation error needs u and the motion, which it checks itself).
  TraceInputOptions Options(const std::vector<std::string>& observe, bool equation_error) const {
    TraceInputOptions options;
    options.delimiter = Delimiter();
    options.duplicate_time = Duplicates();
    for (const auto& text : columns) {
      const auto [name, header] = ParseTextAssignment(text, "--column");
      options.columns[name] = header;
    }
    for (const auto& text : scales) {
      const auto [name, factor] = ParseAssignment(text, "--scale");
      options.scales[name] = factor;
    }
    for (const auto& text : derives) {
      const auto [target, source] = ParseTextAssignment(text, "--derive");
      if (target != "w" || source != "theta") {
        throw InputError("--derive '" + text + "': supported: w=theta");
      }
      options.derive.emplace_back(target, source);
    }
    if (!equation_error) options.required = observe;
    options.initial_from_trace = initial_state == "trace";
    for (const auto& text : selects) options.select.push_back(ParseRowSelection(text));
    options.split = split;
    return options;
  }

  // The row selection as flags (" --select t=60: --split run"), recorded in a surface CSV
  // so that merge tells sweeps of different selections apart; "" when every row is used.
  std::string RowsLine() const {
    std::string line;
    for (const auto& text : selects) line += " --select " + text;
    if (!split.empty()) line += " --split " + split;
    if (initial_state == "trace") line += " --initial-state trace";
    return line;
  }
};

}  // namespace blmd::app
