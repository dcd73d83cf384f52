#include "blmd/ident/optimizers/trace_jackknife.h"

#include <boost/math/distributions/students_t.hpp>
#include <cmath>

#include "ident/optimizers/methods.h"

namespace blmd {

TraceJackknife LeaveOneTraceOut(const FitProblem& problem, const std::vector<double>& values,
                                const OptimizerOptions& options) {
  TraceJackknife out;
  const std::size_t K = problem.traces().size();
  out.traces = static_cast<int>(K);
  if (K < 3) {
    out.reason = "fewer than 3 traces";
    return out;
  }
  std::vector<FreeParameter> free = problem.free();
  for (std::size_t p = 0; p < free.size(); ++p) free[p].initial = values[p];
  const Optimizer& ceres = FindOptimizer("ceres");
  std::vector<std::vector<double>> search;  // per fold, search coordinates
  for (std::size_t left = 0; left < K; ++left) {
    std::vector<FitTrace> kept;
    for (std::size_t k = 0; k < K; ++k) {
      if (k != left) kept.push_back(problem.traces()[k]);
    }
    const FitProblem fold(problem.config(), std::move(kept), problem.observe(), free);
    const FitResult refit = ceres.Minimize(fold, options);
    if (options.progress) options.progress->StepDone();
    if (!refit.evaluation.ok || !refit.summary.converged) {
      out.reason =
          "the refit without trace " + std::to_string(left + 1) + " failed: " +
          (refit.evaluation.ok ? refit.summary.termination + " (" + refit.summary.message + ")"
                               : refit.evaluation.reason);
      return out;
    }
    std::vector<double> s(free.size());
    for (std::size_t p = 0; p < free.size(); ++p) {
      const double v = refit.values[p];
      s[p] = free[p].log_scale ? std::log(v) : v;
      if (!std::isfinite(s[p])) {
        out.reason = "the refit without trace " + std::to_string(left + 1) + " is not finite";
        return out;
      }
    }
    out.refits.push_back(refit.values);
    search.push_back(std::move(s));
  }
  out.std_search.assign(free.size(), 0.0);
  for (std::size_t p = 0; p < free.size(); ++p) {
    double mean = 0.0;
    for (const auto& s : search) mean += s[p];
    mean /= static_cast<double>(K);
    double sum = 0.0;
    for (const auto& s : search) sum += (s[p] - mean) * (s[p] - mean);
    out.std_search[p] = std::sqrt(static_cast<double>(K - 1) / static_cast<double>(K) * sum);
  }
  out.ok = true;
  return out;
}

void WidenByTraceJackknife(const FitProblem& problem, const TraceJackknife& jackknife,
                           FitResult* result) {
  if (!result->summary.interval) result->summary.interval = IntervalRecord{};
  JackknifeRecord& record = result->summary.interval->leave_one_trace_out.emplace();
  record.traces = jackknife.traces;
  if (!jackknife.ok) {
    record.unavailable = jackknife.reason;
    return;
  }
  const double t = boost::math::quantile(
      boost::math::complement(boost::math::students_t(jackknife.traces - 1.0), 0.025));
  record.ok = true;
  record.t_quantile = t;
  for (std::size_t p = 0; p < problem.num_free() && p < result->estimates.size(); ++p) {
    ParameterEstimate& e = result->estimates[p];
    const FreeParameter& f = problem.free()[p];
    const double sd = jackknife.std_search[p];
    std::vector<double> fold_values;
    for (const auto& refit : jackknife.refits) fold_values.push_back(refit[p]);
    record.parameters.push_back({e.name, f.log_scale ? e.value * sd : sd, fold_values});
    ParameterEstimate widened = e;
    internal::SetInterval(f, sd, "leave_one_trace_out", &widened, t);
    if (!widened.has_interval) continue;
    if (e.has_interval && !(widened.ci95_high - widened.ci95_low > e.ci95_high - e.ci95_low))
      continue;
    widened.has_hac_interval = e.has_interval;
    widened.std_hac = e.std;
    widened.ci95_hac_low = e.ci95_low;
    widened.ci95_hac_high = e.ci95_high;
    e = widened;
  }
}

}  // namespace blmd
