#include "blmd/app/sweep.h"

#include <chrono>

#include "blmd/io/csv.h"
#include "blmd/report/surface_file.h"
#include "blmd/version.h"

namespace blmd {

double SweepBytes(std::size_t points, std::size_t axes, std::size_t columns, std::size_t traces) {
  // Per point: the result (coordinates, cost, MSE per column and per trace) and its CSV row.
  const auto a = static_cast<double>(axes), c = static_cast<double>(columns);
  return static_cast<double>(points) *
         (160.0 + 8.0 * a + 16.0 * c + static_cast<double>(traces) * (24.0 + 8.0 * c) +
          24.0 * (a + c + 1.0));
}

SweepOutcome Sweep(const SweepRequest& request) {
  SweepOutcome outcome;
  const std::size_t experiments = request.traces.size();
  outcome.trace_sha256 = request.traces.front().sha256;
  // The grid axes are the free parameters; bounds are the grid's (the cost does not clip).
  std::vector<FreeParameter> free;
  for (const auto& axis : request.axes) {
    FreeParameter p;
    p.name = axis.name;
    p.lower = axis.low;
    p.upper = axis.high;
    p.log_scale = axis.log_scale;
    p.initial = request.config.parameters.Get(axis.name);
    free.push_back(p);
  }
  const FitProblem problem(request.config, request.traces, request.observe, free);
  SurfaceOptions options;
  options.threads = request.threads;
  options.shard_index = request.shard_index;
  options.shard_count = request.shard_count;
  options.progress = request.progress;
  const auto started = std::chrono::steady_clock::now();
  outcome.points = ComputeSurface(problem, request.axes, options);
  outcome.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();

  SurfaceMetadata metadata;
  metadata.lines = {"blmd-surface " + std::string(kVersion),
                    "model: " + std::string(request.config.model->name()),
                    "config_sha256: " + request.config_sha256,
                    "trace_sha256: " + outcome.trace_sha256};
  std::string observe_line = "observe: ";
  for (std::size_t c = 0; c < request.observe.size(); ++c)
    observe_line += (c ? "," : "") + request.observe[c];
  metadata.lines.push_back(observe_line);
  if (problem.equation_error()) {
    const EquationTrace& first = problem.equation_traces().front();
    metadata.lines.push_back("error: equation, filter_hz " + FormatSignificant(first.cutoff_hz, 6) +
                             ", decimate " + std::to_string(first.decimate));
  }
  if (!request.rows_line.empty()) {
    metadata.lines.push_back("rows:" + request.rows_line + " (" + std::to_string(experiments) +
                             " experiment" + (experiments == 1 ? "" : "s") + ")");
  }
  for (const auto& axis : request.axes) metadata.lines.push_back("grid: " + axis.Spec());
  metadata.shard_index = request.shard_index;
  metadata.shard_count = request.shard_count;
  outcome.csv = FormatSurfaceCsv(metadata, request.axes, request.observe, outcome.points);

  // Summary figures (on a shard: of that shard only).
  const auto& points = outcome.points;
  outcome.best = points.size();
  for (std::size_t k = 0; k < points.size(); ++k) {
    if (!points[k].evaluation.ok) {
      ++outcome.failed;
      ++outcome.failure_reasons[points[k].evaluation.reason];
      continue;
    }
    if (outcome.best == points.size() ||
        points[k].evaluation.cost < points[outcome.best].evaluation.cost) {
      outcome.best = k;
    }
  }
  if (request.shard_count == 1) outcome.minima = LocalMinima(request.axes, points);
  return outcome;
}

}  // namespace blmd
