// The data behind the HTML report's cost slices and transient windows (docs/report.md): the cost
// along each free parameter through the fitted point, and the first transient of a trace.
#include <algorithm>
#include <cmath>
#include <limits>

#include "blmd/report/html/html_report.h"
#include "parallel.h"

namespace blmd {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

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

std::optional<std::pair<double, double>> FirstTransientWindow(const FitProblem& problem,
                                                              std::size_t k,
                                                              const Trace& simulated) {
  const Trace& measured = problem.measured(k);
  const std::vector<double>& t = measured.Column("t");
  const std::size_t n = t.size();
  if (n == 0) return std::nullopt;
  if (n <= 20) return std::make_pair(t.front(), t.back());
  // The input's changes: beyond 5 % of its range.
  std::size_t start = 0, next_change = n;
  if (measured.Has("u")) {
    const std::vector<double>& u = measured.Column("u");
    double u_lo = kInf, u_hi = -kInf;
    for (double v : u) {
      if (!std::isfinite(v)) continue;
      u_lo = std::min(u_lo, v);
      u_hi = std::max(u_hi, v);
    }
    const double threshold = 0.05 * (u_hi - u_lo);
    if (threshold > 0) {
      // At rest with u = 0 the transient starts where u first moves; with u != 0 at once.
      if (std::abs(u[0]) <= threshold) {
        while (start < n && !(std::abs(u[start] - u[0]) > threshold)) ++start;
        if (start == n) start = 0;
        // A step makes most of its move in one sample; a loop's torque, a ramp or a chirp
        // creeps over the 5 %.
        if (start > 0 && std::abs(u[start] - u[start - 1]) < 0.5 * std::abs(u[start] - u[0])) {
          return std::nullopt;
        }
      }
      next_change = start + 1;
      while (next_change < n && !(std::abs(u[next_change] - u[start]) > threshold)) ++next_change;
      if (next_change - start < 20) return std::nullopt;  // u does not hold after the step
    }
  }
  // Per observed column: the time it takes to cover 63.2 % of its change over the segment.
  double settle = 0.0;
  bool any = false;
  for (const auto& column : problem.observe()) {
    const Trace& source = simulated.Has(column) && simulated.rows() == n ? simulated : measured;
    if (!source.Has(column)) continue;
    const std::vector<double>& y = source.Column(column);
    double lo = kInf, hi = -kInf;
    for (double v : y) {
      if (!std::isfinite(v)) continue;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
    const double y0 = y[start], y1 = y[next_change - 1];
    if (!std::isfinite(y0) || !std::isfinite(y1) || !(std::abs(y1 - y0) > 1e-3 * (hi - lo)))
      continue;
    for (std::size_t i = start; i < next_change; ++i) {
      if ((y[i] - y0) / (y1 - y0) >= 0.632) {
        settle = std::max(settle, t[i] - t[start]);
        any = true;
        break;
      }
    }
  }
  if (!any) return std::nullopt;  // nothing observed responds to it
  const double length = 2.0 * settle;
  double begin = std::max(t.front(), t[start] - 0.05 * length);
  double end = std::min(t.back(), t[start] + length);
  // At least 20 samples.
  std::size_t first = 0;
  while (first < n && t[first] < begin) ++first;
  std::size_t count = 0;
  for (std::size_t i = first; i < n && t[i] <= end; ++i) ++count;
  if (count < 20) end = t[std::min(n - 1, first + 19)];
  return std::make_pair(begin, end);
}

}  // namespace blmd
