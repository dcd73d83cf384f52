// One cost surface as blmd-surface computes it (docs/surfaces.md): the grid axes become the
// free parameters, the cost is evaluated at every point of the shard, and the result is
// rendered as the surface CSV with the metadata that identifies the sweep. The command and
// the Python package call this; they parse flags and write what comes back.
#pragma once

#include <cstddef>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "blmd/ident/fit/problem.h"
#include "blmd/ident/fit/surface.h"
#include "blmd/io/config.h"

namespace blmd {

struct SweepRequest {
  Config config;              // the model (flags such as --error applied)
  std::string config_sha256;  // of the config file, recorded in the CSV
  std::vector<FitTrace> traces;
  std::vector<std::string> observe;
  std::vector<GridAxis> axes;  // one or two, parameters of `config`
  std::string rows_line;       // the trace selection as flags (" --select t=60:"), or ""
  int threads = 0;             // 0: every core
  int shard_index = 1, shard_count = 1;
  std::function<void(std::size_t, std::size_t)> progress;  // (done, total), may be empty
};

struct SweepOutcome {
  std::vector<SurfacePoint> points;  // the shard's points, grid order
  std::string csv;                   // the surface CSV (docs/surfaces.md)
  std::string trace_sha256;          // of the first trace
  std::size_t best;                  // index of the lowest cost (points.size(): none finite)
  std::vector<std::size_t> minima;   // local minima (whole grid only: empty on a shard)
  std::size_t failed = 0;            // points whose simulation failed (cost inf)
  std::map<std::string, long> failure_reasons;
  double wall_time_s = 0.0;
};

// The sweep's estimated memory (result and CSV row per point), bytes: a typo in N must not
// ask for gigabytes (blmd-surface refuses more than 1e6 points or 1 GB without --force).
double SweepBytes(std::size_t points, std::size_t axes, std::size_t columns, std::size_t traces);

// The request is only read: its traces are copied once, into the fit problem.
SweepOutcome Sweep(const SweepRequest& request);

}  // namespace blmd
