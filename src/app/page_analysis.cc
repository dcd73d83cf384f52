// The page's views computed before it is rendered (page_analysis.h): each model's simulation of
// the traces and its cost slices.
#include "blmd/app/page_analysis.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "blmd/io/config.h"
#include "parallel.h"

namespace blmd {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The model at `values` on every trace of `problem`, with its cost slices.
ModelViews ViewsOf(const FitProblem& problem, const std::vector<double>& values,
                   const HtmlReportOptions& options) {
  ModelViews views;
  views.traces.resize(problem.traces().size());
  views.simulated = true;
  for (std::size_t k = 0; k < problem.traces().size(); ++k) {
    const SimStatus status = problem.Simulate(k, values, &views.traces[k]);
    if (!status.ok()) {
      views.simulated = false;
      views.reason = status.message;
      views.traces.clear();
      break;
    }
  }
  views.sliced = options.slice_points > 0 && problem.num_free() > 0;
  if (views.sliced) {
    views.slices = ComputeCostSlices(problem, values, options.slice_points, options.slice_span,
                                     options.threads);
  }
  return views;
}

}  // namespace

std::vector<CostSlice> ComputeCostSlices(const FitProblem& problem,
                                         const std::vector<double>& values, int points, double span,
                                         int threads) {
  std::vector<CostSlice> slices;
  if (points <= 0 || values.size() != problem.num_free()) return slices;
  points = std::max(3, points);
  span = std::isfinite(span) && span > 0 ? span : 0.2;
  for (std::size_t j = 0; j < problem.num_free(); ++j) {
    const FreeParameter& fp = problem.free()[j];
    CostSlice slice;
    slice.parameter = fp.name;
    slice.index = j;
    slice.estimate = values[j];
    slice.log_scale = fp.log_scale;
    slice.unit = ParameterUnit(problem.config(), fp.name);
    const double v = values[j];
    const bool log = fp.log_scale && v > 0;
    double lo, hi;
    if (log) {
      lo = v / (1.0 + span);
      hi = v * (1.0 + span);
    } else {
      const double half = v != 0.0 ? span * std::abs(v) : 0.1 * span * (fp.upper - fp.lower);
      lo = v - half;
      hi = v + half;
    }
    const bool bounded = fp.upper > fp.lower;
    const bool clipped = bounded && (lo < fp.lower || hi > fp.upper);
    if (bounded) {
      lo = std::max(lo, fp.lower);
      hi = std::min(hi, fp.upper);
    }
    if (!(hi > lo)) continue;
    const std::size_t n = static_cast<std::size_t>(points);
    slice.x.resize(n);
    for (std::size_t m = 0; m < n; ++m) {
      const double f = static_cast<double>(m) / static_cast<double>(n - 1);
      slice.x[m] =
          log ? std::exp(std::log(lo) + f * (std::log(hi) - std::log(lo))) : lo + f * (hi - lo);
    }
    slice.x.front() = lo;
    slice.x.back() = hi;
    // The middle point is the estimate itself when the range was not clipped, else the nearest.
    slice.centre = n / 2;
    if (!clipped && n % 2 == 1) {
      slice.x[slice.centre] = v;
    } else {
      double best = kInf;
      for (std::size_t m = 0; m < n; ++m) {
        const double d = std::abs(slice.x[m] - v);
        if (d < best) {
          best = d;
          slice.centre = m;
        }
      }
    }
    slice.cost.assign(n, kInf);
    slices.push_back(std::move(slice));
  }
  // Every (slice, point) is one evaluation; they run in parallel, each writes its own cell.
  std::vector<std::pair<std::size_t, std::size_t>> tasks;
  for (std::size_t s = 0; s < slices.size(); ++s) {
    for (std::size_t m = 0; m < slices[s].x.size(); ++m) tasks.emplace_back(s, m);
  }
  internal::ParallelFor(tasks.size(), threads, [&](std::size_t t) {
    const auto [s, m] = tasks[t];
    std::vector<double> point = values;
    point[slices[s].index] = slices[s].x[m];
    const Evaluation evaluation = problem.Evaluate(point);
    slices[s].cost[m] = evaluation.ok ? evaluation.cost : kInf;
  });
  for (auto& slice : slices) {
    double best = kInf;
    for (std::size_t m = 0; m < slice.cost.size(); ++m) {
      if (slice.cost[m] < best) {
        best = slice.cost[m];
        slice.argmin = m;
      }
    }
  }
  return slices;
}

PageViews AnalysePage(const FitProblem& problem, const FitResult& result,
                      const DiscoveryResult* discovery, const HtmlReportOptions& options) {
  PageViews views;
  views.slice_span = options.slice_span;
  views.fit = ViewsOf(problem, result.values, options);
  const std::unique_ptr<FitProblem> after = discovery ? FinalProblem(problem, *discovery) : nullptr;
  if (after) {
    views.after = ViewsOf(*after, discovery->final_fit.values, options);
    views.after_label = "after discovery (+" + Join(discovery->added) + ")";
  }
  return views;
}

}  // namespace blmd
