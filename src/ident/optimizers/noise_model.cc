#include "blmd/ident/optimizers/noise_model.h"

#include <algorithm>
#include <cmath>

#include "blmd/error.h"

namespace blmd {

double QuantisationStep(const std::vector<double>& y) {
  if (y.size() < 20) return 0.0;
  std::vector<double> sorted;
  sorted.reserve(y.size());
  for (double v : y) {
    if (std::isfinite(v)) sorted.push_back(v);
  }
  if (sorted.size() < 20) return 0.0;
  std::sort(sorted.begin(), sorted.end());
  // Gaps below 1e-9 of the column's range are the rounding of two texts of one value to
  // neighbouring doubles, not a step: a lattice of more than 1e9 steps over the range is no
  // converter's or encoder's (a 10 000-count encoder over 10^5 turns has 1e9), and with such
  // a q every value would lie "on" it, (v - origin) / q being beyond a double's fraction.
  const double negligible = 1e-9 * (sorted.back() - sorted.front());
  double q = 0.0;
  for (std::size_t k = 1; k < sorted.size(); ++k) {
    const double gap = sorted[k] - sorted[k - 1];
    if (gap > negligible && (q == 0.0 || gap < q)) q = gap;
  }
  if (!(q > 0.0)) return 0.0;
  // Values read from text carry rounding of about 1e-15 of their size: a thousandth of a step.
  const double origin = sorted.front();
  std::size_t on_lattice = 0;
  for (double v : sorted) {
    const double m = (v - origin) / q;
    if (std::abs(m - std::round(m)) < 1e-3) ++on_lattice;
  }
  return static_cast<double>(on_lattice) >= 0.95 * static_cast<double>(sorted.size()) ? q : 0.0;
}

std::vector<FitTrace> WithResidualNoise(const FitProblem& problem,
                                        const std::vector<double>& values,
                                        const std::map<std::string, double>& fixed,
                                        NoiseModel* noise) {
  const Evaluation evaluation = problem.Evaluate(values);
  if (!evaluation.ok) return {};  // the caller keeps the weights it has
  const std::size_t columns = problem.observe().size();
  const double p_per_column =
      static_cast<double>(problem.num_free()) / static_cast<double>(columns);
  std::vector<FitTrace> traces = problem.traces();
  noise->columns.assign(columns, ColumnNoise{});
  for (std::size_t c = 0; c < columns; ++c) {
    const std::string& name = problem.observe()[c];
    ColumnNoise& column = noise->columns[c];
    column.column = name;
    const auto fixed_std = fixed.find(name);
    double pooled = 0.0, residual = 0.0, samples = 0.0;
    bool floored = false;
    for (std::size_t k = 0; k < traces.size(); ++k) {
      const double n = static_cast<double>(problem.measured(k).rows());
      const double mse = evaluation.mse_per_trace[k][c];
      double variance = 0.0;
      if (fixed_std != fixed.end()) {
        variance = fixed_std->second * fixed_std->second;
      } else {
        variance = mse * n / std::max(1.0, n - p_per_column);
        const double q = QuantisationStep(problem.measured(k).Column(name));
        column.quantum = std::max(column.quantum, q);
        const double floor = std::max(q * q / 12.0, 1e-12 * problem.variance()[c]);
        if (!(variance > floor)) {
          floored = floored || q > 0.0;
          variance = std::max(floor, 1e-300);
        }
      }
      column.std_per_trace.push_back(std::sqrt(variance));
      pooled += n * variance;
      residual += n * mse;
      samples += n;
    }
    // One sigma per column, pooled over the traces: a trace's own residual holds its own
    // misfit as well as its noise, and weighting each trace by it moved HSM150's J from
    // 1.44e-4 to 1.70e-4 (the catalog's 1.2e-4; docs/identification.md §1a).
    for (auto& trace : traces) trace.noise_variance[name] = pooled / samples;
    column.std = std::sqrt(pooled / samples);
    column.residual_std = std::sqrt(residual / samples);
    column.weight = 1.0 / (column.std * column.std);
    column.source = fixed_std != fixed.end() ? "fixed" : floored ? "quantisation" : "residual";
  }
  return traces;
}

namespace {

// The problem over `traces` with its free parameters started at `values`.
std::unique_ptr<FitProblem> StartedAt(const FitProblem& problem, std::vector<FitTrace> traces,
                                      const std::vector<double>& values) {
  std::vector<FreeParameter> free = problem.free();
  for (std::size_t k = 0; k < free.size() && k < values.size(); ++k) {
    free[k].initial = std::clamp(values[k], free[k].lower, free[k].upper);
  }
  return std::make_unique<FitProblem>(problem.config(), std::move(traces), problem.observe(),
                                      std::move(free));
}

// `weighted` (its traces' noise) with the free parameters' start values of `original`, the
// user's; the fit's estimates say so too (the refits started from the previous optimum).
std::unique_ptr<FitProblem> WithUserStart(const FitProblem& original, const FitProblem& weighted,
                                          FitResult* fit) {
  for (std::size_t k = 0; k < fit->estimates.size() && k < original.num_free(); ++k) {
    fit->estimates[k].initial = original.free()[k].initial;
  }
  return std::make_unique<FitProblem>(original.config(), weighted.traces(), original.observe(),
                                      original.free());
}

// The largest relative change of a sigma between two estimates.
double LargestChange(const NoiseModel& before, const NoiseModel& after) {
  double change = 0.0;
  for (std::size_t c = 0; c < before.columns.size() && c < after.columns.size(); ++c) {
    const auto& a = before.columns[c].std_per_trace;
    const auto& b = after.columns[c].std_per_trace;
    for (std::size_t k = 0; k < a.size() && k < b.size(); ++k) {
      if (a[k] > 0.0) change = std::max(change, std::abs(b[k] / a[k] - 1.0));
    }
  }
  return change;
}

}  // namespace

std::unique_ptr<FitProblem> FitNoiseWeighted(const FitProblem& problem, const FitResult& first,
                                             const Optimizer& optimizer,
                                             const OptimizerOptions& options,
                                             const NoiseSettings& settings, FitResult* fit,
                                             NoiseModel* noise) {
  if (settings.weighting != "noise" && settings.weighting != "variance") {
    throw InputError("unknown weighting '" + InputError::Excerpt(settings.weighting) +
                     "' (valid: noise, variance)");
  }
  *fit = first;
  noise->weighting = settings.weighting;
  noise->evaluations = first.summary.evaluations;
  noise->fits = 1;
  noise->converged = true;
  noise->columns.clear();
  NoiseModel estimate;
  std::vector<FitTrace> traces;
  // A first fit that did not converge says nothing about the noise: its weights stay.
  if (settings.weighting == "noise" && first.evaluation.ok && first.summary.converged) {
    traces = WithResidualNoise(problem, first.values, settings.std, &estimate);
  }
  if (traces.empty()) {  // the variance weighting, asked for or the only one possible
    noise->weighting = "variance";
    traces = problem.traces();
    for (FitTrace& trace : traces) trace.noise_variance.clear();
    for (std::size_t c = 0; c < problem.observe().size(); ++c) {
      ColumnNoise column;
      column.column = problem.observe()[c];
      column.std = std::sqrt(problem.variance()[c]);
      column.weight = 1.0 / problem.variance()[c];
      column.source = "variance";
      if (first.evaluation.ok) column.residual_std = std::sqrt(first.evaluation.mse[c]);
      noise->columns.push_back(column);
    }
    auto copy = std::make_unique<FitProblem>(problem.config(), std::move(traces), problem.observe(),
                                             problem.free());
    return copy;
  }
  // `used`: the problem the current fit was made under (its weights), with the noise model
  // that gave them.
  std::unique_ptr<FitProblem> used = StartedAt(problem, std::move(traces), first.values);
  NoiseModel used_noise = estimate;
  // One column (its sigma pooled over the traces): the weight is a constant factor of the
  // cost and the optimum the same; no refit, the cost rescored under the noise weight.
  if (problem.observe().size() == 1) {
    fit->evaluation = used->Evaluate(fit->values);
    used_noise.weighting = "noise";
    used_noise.fits = 1;
    used_noise.evaluations = first.summary.evaluations;
    *noise = std::move(used_noise);
    return WithUserStart(problem, *used, fit);
  }
  int fits = 1;
  long evaluations = first.summary.evaluations;
  bool converged = false;
  while (fits < settings.max_fits) {
    FitResult refit = optimizer.Minimize(*used, options);
    ++fits;
    evaluations += refit.summary.evaluations;
    if (!refit.evaluation.ok) break;  // keep the weights and the fit before
    NoiseModel next;
    std::vector<FitTrace> next_traces = WithResidualNoise(*used, refit.values, settings.std, &next);
    *fit = std::move(refit);
    if (next_traces.empty()) break;
    if (LargestChange(used_noise, next) <= settings.tolerance) {
      // The weights this fit was made under stand (the next estimate is within the
      // tolerance); the residual's RMS from this fit.
      for (std::size_t c = 0; c < used_noise.columns.size(); ++c)
        used_noise.columns[c].residual_std = next.columns[c].residual_std;
      converged = true;
      break;
    }
    used = StartedAt(*used, std::move(next_traces), fit->values);
    used_noise = std::move(next);
  }
  if (!converged) {
    // The last fit, under weights it was not made with (fits ran out, or a refit failed):
    // scored under the problem it was made under.
    fit->evaluation = used->Evaluate(fit->values);
  }
  used_noise.weighting = "noise";
  used_noise.fits = fits;
  used_noise.evaluations = evaluations;
  used_noise.converged = converged;
  *noise = std::move(used_noise);
  return WithUserStart(problem, *used, fit);
}

}  // namespace blmd
