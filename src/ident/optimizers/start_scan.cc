#include "blmd/ident/optimizers/start_scan.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>

#include "blmd/format.h"
#include "blmd/ident/fit/noise_floor.h"
#include "blmd/io/config.h"

namespace blmd {
namespace {

// The scan's size: 32 points per free parameter, at most 128 (64 for J and B: a basin a
// tenth of the log range wide in one parameter holds about six of them).
constexpr int kPointsPerParameter = 32;
constexpr int kMaxPoints = 128;
constexpr int kRestarts = 3;
// A restart replaces the first fit only when its cost is lower by more than this share: a
// choice between two fits that differ by less would hinge on the data's last bits.
constexpr double kImprovement = 0.01;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

// Component `dimension` of the Halton sequence's point `index` (index >= 1): the radical
// inverse of index in the dimension's prime base (Halton 1960, Numer. Math. 2, 84-90), a
// low-discrepancy cover of [0,1]^p that a grid of the same size cannot give in p > 1.
double Halton(int index, int dimension) {
  static constexpr int kPrimes[] = {2,  3,  5,  7,  11, 13, 17, 19, 23, 29, 31,
                                    37, 41, 43, 47, 53, 59, 61, 67, 71, 73, 79};
  const int base = kPrimes[dimension % static_cast<int>(std::size(kPrimes))];
  double f = 1.0, value = 0.0;
  for (int i = index; i > 0; i /= base) {
    f /= base;
    value += f * (i % base);
  }
  return value;
}

bool OnBound(const FreeParameter& p, double value) {
  const BoundDistance d = DistanceToBounds(p, value);
  return std::min(d.below, d.above) <= 1e-6 * d.span;
}

// Which end of p's range `value` sits on that a move may pass: -1 the lower, +1 the upper, 0
// none (not on an end, a range the config gave, or the model's own limit).
int MovableEnd(const Config& config, const FreeParameter& p, double value) {
  if (!p.log_scale || config.identification.bounds.count(p.name)) return 0;
  const ParamInfo* info = config.FindParameterInfo(p.name);
  if (!info || !info->positive) return 0;
  const BoundDistance d = DistanceToBounds(p, value);
  if (d.below <= 1e-6 * d.span && p.lower > info->default_lower * (1.0 + 1e-9)) return -1;
  if (d.above <= 1e-6 * d.span && p.upper < info->default_upper * (1.0 - 1e-9)) return 1;
  return 0;
}

}  // namespace

std::string SideValleyReason(const FitProblem& problem, const FitResult& fit) {
  if (!fit.evaluation.ok || !std::isfinite(fit.evaluation.cost)) return "its cost is not finite";
  for (std::size_t k = 0; k < problem.num_free() && k < fit.values.size(); ++k) {
    if (OnBound(problem.free()[k], fit.values[k]))
      return problem.free()[k].name + " stopped on its bound";
  }
  const double nrmse = std::sqrt(fit.evaluation.nrmse2);
  const double floor = NoiseFloorNrmse(problem);
  if (nrmse > 0.1 && nrmse > 3.0 * floor) {
    return "its NRMSE " + FormatSignificant(nrmse, 3) + " is over 3x the data's noise floor " +
           FormatSignificant(floor, 3);
  }
  return "";
}

FitResult MinimizeWithStartScan(const Optimizer& optimizer, const FitProblem& problem,
                                const OptimizerOptions& options, StartScanRecord* record) {
  StartScanRecord local;
  StartScanRecord& out = record ? *record : local;
  out = StartScanRecord{};
  FitResult first = optimizer.Minimize(problem, options);
  const std::string_view method = optimizer.name();
  // FSD is a global search already; the classic estimators minimise no cost.
  if (method == "fsd" || method == "classic" || problem.num_free() == 0) return first;
  out.reason = SideValleyReason(problem, first);
  if (out.reason.empty()) return first;
  out.ran = true;
  const auto started = std::chrono::steady_clock::now();

  const std::size_t p = problem.num_free();
  const int n = std::min(kMaxPoints, kPointsPerParameter * static_cast<int>(p));
  std::vector<std::vector<double>> points;
  points.reserve(static_cast<std::size_t>(n));
  for (int i = 1; i <= n; ++i) {
    std::vector<double> scaled(p);
    for (std::size_t k = 0; k < p; ++k) scaled[k] = Halton(i, static_cast<int>(k));
    points.push_back(problem.FromScaled(scaled));
  }
  const std::vector<Evaluation> costs = problem.EvaluateBatch(points);
  out.points = n;
  if (options.progress) {
    for (const Evaluation& e : costs) options.progress->Evaluated(e.cost);
  }
  std::vector<std::size_t> order(points.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    const double ca = costs[a].ok ? costs[a].cost : kInfinity;
    const double cb = costs[b].ok ? costs[b].cost : kInfinity;
    return ca < cb;
  });

  FitResult best = first;
  long extra_evaluations = first.summary.evaluations + n;
  for (int r = 0; r < kRestarts && r < static_cast<int>(order.size()); ++r) {
    const std::size_t k = order[static_cast<std::size_t>(r)];
    if (!costs[k].ok) break;
    FitResult restarted = optimizer.Minimize(problem.WithStart(points[k]), options);
    ++out.restarts;
    extra_evaluations += restarted.summary.evaluations;
    if (restarted.evaluation.ok &&
        restarted.evaluation.cost < (1.0 - kImprovement) * best.evaluation.cost) {
      best = std::move(restarted);
      out.improved = true;
      out.start = points[k];
    }
  }
  const double scan_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  const double first_s = first.summary.wall_time_s;
  FitResult& kept = out.improved ? best : first;
  kept.summary.evaluations = extra_evaluations;  // the first fit, the scan and every restart
  kept.summary.wall_time_s = first_s + scan_s;
  // The report's "initial" is the user's start, not the scan point's.
  for (std::size_t k = 0; k < kept.estimates.size() && k < p; ++k)
    kept.estimates[k].initial = problem.free()[k].initial;
  out.nrmse_final = std::sqrt(kept.evaluation.nrmse2);
  return kept;
}

RangeMove MoveDefaultRanges(const Optimizer& optimizer, const FitProblem& problem,
                            const FitResult& fit, const OptimizerOptions& options) {
  RangeMove none;
  if (!fit.evaluation.ok || fit.values.size() != problem.num_free()) return none;
  const Config& config = problem.config();
  std::vector<FreeParameter> free = problem.free();
  std::vector<int> shift_of(free.size(), -1);  // index into `shifts`, -1: never moved
  std::vector<RangeShift> shifts;
  std::unique_ptr<FitProblem> moved;
  FitResult current = fit;
  StartScanRecord scan;
  for (int move = 0; move < kMaxRangeMoves; ++move) {
    std::vector<bool> moving(free.size(), false);
    for (std::size_t k = 0; k < free.size(); ++k) {
      const int end = MovableEnd(config, free[k], current.values[k]);
      if (end == 0) continue;
      const ParamInfo& info = *config.FindParameterInfo(free[k].name);
      // Centred on the end it stopped on, three decades either side as Config::Bounds
      // centres the default range on the start.
      const double reached = end < 0 ? free[k].lower : free[k].upper;
      if (shift_of[k] < 0) {
        shift_of[k] = static_cast<int>(shifts.size());
        shifts.push_back({free[k].name, free[k].lower, free[k].upper, 0.0, 0.0});
      }
      free[k].lower = std::max(info.default_lower, reached * 1e-3);
      free[k].upper = std::min(info.default_upper, reached * 1e3);
      free[k].initial = reached;
      moving[k] = true;
    }
    if (std::find(moving.begin(), moving.end(), true) == moving.end()) break;
    // The others go on from where the fit left them.
    for (std::size_t k = 0; k < free.size(); ++k) {
      if (!moving[k]) free[k].initial = std::clamp(current.values[k], free[k].lower, free[k].upper);
    }
    moved = std::make_unique<FitProblem>(problem.WithFree(free));
    current = MinimizeWithStartScan(optimizer, *moved, options, &scan);
    if (!current.evaluation.ok) return none;
  }
  if (!moved) return none;
  for (std::size_t k = 0; k < free.size(); ++k) {
    if (shift_of[k] >= 0 && OnBound(free[k], current.values[k])) return none;  // not freed
  }
  // Freed, and the data say so: the cost lower by more than the start scan's share (a
  // parameter the record hardly determines would leave an end without lowering it; measured on
  // the small motors of docs/real-data.md, the move took the NRMSE from 0.5-1.6 to 0.02-0.2).
  if (!(current.evaluation.cost < (1.0 - kImprovement) * fit.evaluation.cost)) return none;
  for (std::size_t k = 0; k < free.size(); ++k) {
    if (shift_of[k] < 0) continue;
    RangeShift& shift = shifts[static_cast<std::size_t>(shift_of[k])];
    shift.to_lower = free[k].lower;
    shift.to_upper = free[k].upper;
  }
  RangeMove out;
  out.problem = std::move(moved);
  out.fit = std::move(current);
  out.start_scan = std::move(scan);
  out.shifts = std::move(shifts);
  return out;
}

}  // namespace blmd
