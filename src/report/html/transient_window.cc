// The first transient of a trace, which the HTML report zooms on (docs/report.md).
#include <algorithm>
#include <cmath>
#include <limits>

#include "blmd/report/html/html_report.h"

namespace blmd {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace

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
