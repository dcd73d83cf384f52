// --delimiter and --duplicate-time, shared by the commands that read traces: the dialect of
// a logger's CSV (docs/trace-format.md).
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "blmd/io/csv.h"

namespace blmd::app {

struct TraceFlags {
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

}  // namespace blmd::app
