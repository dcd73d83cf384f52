// Preparing a measured trace for a fit (docs/cli.md): column mapping, unit scaling,
// velocity from position, and the recorded input.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "blmd/ident/problem.h"

namespace blmd {

struct TraceInputOptions {
  std::map<std::string, std::string> columns;  // standard name -> header in the file
  std::map<std::string, double> scales;        // standard name -> factor (after mapping)
  std::vector<std::pair<std::string, std::string>> derive;  // {"w", "theta"}: w = d theta/dt
  std::vector<std::string> required;           // standard columns needed besides t and u
  bool initial_from_trace = false;  // initial w, theta (and i) from the first sample
};

// Reads, maps, scales and derives; throws InputError naming the file.
FitTrace LoadFitTrace(const std::string& path, const TraceInputOptions& options,
                      const InitialState& default_initial);

// d theta/dt on a possibly irregular grid: central difference (t_{k+1} - t_{k-1}) inside,
// one-sided at the ends (second-order accurate for smooth signals).
std::vector<double> Differentiate(const std::vector<double>& t, const std::vector<double>& x);

}  // namespace blmd
