#include "blmd/ident/fit/problem.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "blmd/error.h"
#include "blmd/io/csv.h"
#include "blmd/sim/effects.h"

namespace blmd {

FitProblem::FitProblem(Config config, std::vector<FitTrace> traces,
                       std::vector<std::string> observe, std::vector<FreeParameter> free)
    : config_(std::move(config)),
      traces_(std::move(traces)),
      observe_(std::move(observe)),
      free_(std::move(free)) {
  // Each trace's experiment, made once: a recorded input replayed open loop from the trace's
  // initial state (copying the input on every evaluation cost a tenth of a fast one).
  for (const auto& fit_trace : traces_) {
    Experiment experiment = config_.experiment;
    experiment.input = fit_trace.input;
    experiment.initial = fit_trace.initial;
    // A recorded u is replayed open loop; a recorded reference drives the config's closed loop.
    experiment.closed_loop = config_.identification.simulate_from == "reference";
    experiment.coast_off_time = -1.0;
    experiments_.push_back(std::move(experiment));
  }
  if (config_.identification.error == "equation") {
    if (!config_.model->traits().input_is_torque) {
      throw InputError(
          "the equation error needs model rigid_load (its input is the drive "
          "torque); model " +
          std::string(config_.model->name()) + "'s drive torque is a state of the model");
    }
    if (observe_ != std::vector<std::string>{"u"}) {
      throw InputError("the equation error compares the input: observe u (--observe u)");
    }
    for (const auto& fit_trace : traces_) {
      equation_.push_back(PrepareEquationTrace(fit_trace, config_.identification));
    }
  } else {
    for (const auto& fit_trace : traces_) {  // the runs to simulate must be feasible
      if (!fit_trace.trace.Has("t") || fit_trace.trace.rows() == 0) continue;
      const auto& t = fit_trace.trace.Column("t");
      if (const std::string error =
              RunLengthError(t.back() - t.front(), config_.simulation.dt, 0.0);
          !error.empty()) {
        throw InputError(fit_trace.path + ": " + error);
      }
    }
  }
  // A position-dependent effect sees the measured angle unless the config asks for the
  // simulated one (IdentificationSettings::effect_angle); unchanged when no trace records an
  // angle or a speed, and for the equation error, which has no simulated angle.
  if (config_.identification.effect_angle == "measured" && equation_.empty() &&
      std::any_of(config_.effects.begin(), config_.effects.end(), [](const std::string& effect) {
        return FindEffect(effect).position_dependent;
      })) {
    ForceEffectAngle();
  }
  variance_.assign(observe_.size(), 0.0);
  samples_per_column_.assign(observe_.size(), 0);
  for (std::size_t c = 0; c < observe_.size(); ++c) {
    double sum = 0.0;
    std::size_t n = 0;
    for (std::size_t k = 0; k < traces_.size(); ++k) {
      for (double v : measured(k).Column(observe_[c])) {
        sum += v;
        ++n;
      }
    }
    const double mean = n ? sum / static_cast<double>(n) : 0.0;
    double variance = 0.0;
    for (std::size_t k = 0; k < traces_.size(); ++k) {
      for (double v : measured(k).Column(observe_[c])) variance += (v - mean) * (v - mean);
    }
    variance = n ? variance / static_cast<double>(n) : 0.0;
    if (!(variance > 0.0)) {
      throw InputError(Where() + "observed column '" + observe_[c] + "' is constant" +
                       (traces_.size() > 1 ? " over all these traces" : "") +
                       ": it cannot inform the fit (observe another column with --observe)");
    }
    if (!std::isfinite(variance)) {
      throw InputError(Where() + "observed column '" + observe_[c] +
                       "' holds values too large to fit (its variance overflows a double); "
                       "rescale it with --scale " +
                       observe_[c] + "=FACTOR");
    }
    variance_[c] = variance;
    samples_per_column_[c] = n;
    num_residuals_ += n;
  }
  for (std::size_t k = 0; k < traces_.size(); ++k) {
    for (std::size_t c = 0; c < observe_.size(); ++c) {
      residual_columns_.insert(residual_columns_.end(), measured(k).rows(), static_cast<int>(c));
      residual_traces_.insert(residual_traces_.end(), measured(k).rows(), static_cast<int>(k));
    }
  }
  weight_variance_.assign(traces_.size(), variance_);
  // Noise weights when every trace knows the noise of every observed column.
  bool noise_known = !traces_.empty();
  for (const auto& fit_trace : traces_) {
    for (const auto& column : observe_) {
      const auto found = fit_trace.noise_variance.find(column);
      noise_known = noise_known && found != fit_trace.noise_variance.end() && found->second > 0.0 &&
                    std::isfinite(found->second);
    }
  }
  if (noise_known) {
    for (std::size_t k = 0; k < traces_.size(); ++k) {
      for (std::size_t c = 0; c < observe_.size(); ++c) {
        weight_variance_[k][c] = traces_[k].noise_variance.at(observe_[c]);
      }
      uniform_weights_ = uniform_weights_ && weight_variance_[k] == weight_variance_[0];
    }
    noise_weighted_ = true;
  }
}

std::string FitProblem::Where() const {
  std::string where;
  for (const auto& fit_trace : traces_) {
    if (!fit_trace.path.empty()) where += (where.empty() ? "" : ", ") + fit_trace.path;
  }
  return where.empty() ? where : where + ": ";
}

double FitProblem::DifferenceStep() const {
  const bool smooth = config_.simulation.method == SimulationMethod::kEvents && !equation_error();
  return smooth ? 1e-5 : 1e-3;
}

double FitProblem::column_weight(std::size_t c, std::size_t k) const {
  return 1.0 / std::sqrt(static_cast<double>(observe_.size()) *
                         static_cast<double>(samples_per_column_[c]) * weight_variance_[k][c]);
}

std::vector<double> FitProblem::NoiseNormalisation(const Evaluation& evaluation) const {
  const double p_per_column =
      static_cast<double>(free_.size()) / static_cast<double>(observe_.size());
  std::vector<double> factors(residual_columns_.size());
  if (uniform_weights_) {  // s_c pooled over the traces
    std::vector<double> factor_per_column(observe_.size(), 0.0);
    for (std::size_t c = 0; c < observe_.size(); ++c) {
      const double n = static_cast<double>(samples_per_column_[c]);
      const double s2 = evaluation.mse[c] * n / std::max(1.0, n - p_per_column);
      factor_per_column[c] = s2 > 0.0 ? 1.0 / (column_weight(c) * std::sqrt(s2)) : 0.0;
    }
    for (std::size_t k = 0; k < factors.size(); ++k) {
      factors[k] = factor_per_column[static_cast<std::size_t>(residual_columns_[k])];
    }
    return factors;
  }
  // Each trace's column its own noise level s_kc (its own weight).
  std::vector<std::vector<double>> factor(traces_.size(), std::vector<double>(observe_.size()));
  for (std::size_t t = 0; t < traces_.size(); ++t) {
    const double n = static_cast<double>(measured(t).rows());
    for (std::size_t c = 0; c < observe_.size(); ++c) {
      const double s2 = evaluation.mse_per_trace[t][c] * n / std::max(1.0, n - p_per_column);
      factor[t][c] = s2 > 0.0 ? 1.0 / (column_weight(c, t) * std::sqrt(s2)) : 0.0;
    }
  }
  for (std::size_t k = 0; k < factors.size(); ++k) {
    factors[k] = factor[static_cast<std::size_t>(residual_traces_[k])]
                       [static_cast<std::size_t>(residual_columns_[k])];
  }
  return factors;
}

std::vector<double> FitProblem::ToScaled(const std::vector<double>& values) const {
  std::vector<double> scaled(free_.size());
  for (std::size_t k = 0; k < free_.size(); ++k) {
    const FreeParameter& p = free_[k];
    scaled[k] = p.log_scale ? std::log(values[k] / p.lower) / std::log(p.upper / p.lower)
                            : (values[k] - p.lower) / (p.upper - p.lower);
  }
  return scaled;
}

BoundDistance DistanceToBounds(const FreeParameter& p, double value) {
  BoundDistance d;
  d.span = p.log_scale ? std::log(p.upper / p.lower) : p.upper - p.lower;
  d.below = p.log_scale ? std::log(value / p.lower) : value - p.lower;
  d.above = p.log_scale ? std::log(p.upper / value) : p.upper - value;
  return d;
}

FitProblem FitProblem::WithStart(const std::vector<double>& values) const {
  FitProblem restarted = *this;
  for (std::size_t k = 0; k < free_.size() && k < values.size(); ++k) {
    FreeParameter& p = restarted.free_[k];
    p.initial = std::clamp(values[k], p.lower, p.upper);
  }
  return restarted;
}

FitProblem FitProblem::WithFree(std::vector<FreeParameter> free) const {
  FitProblem moved = *this;
  for (std::size_t k = 0; k < moved.free_.size() && k < free.size(); ++k) {
    if (free[k].name != moved.free_[k].name) {
      throw std::logic_error("WithFree: parameter " + free[k].name + " in place of " +
                             moved.free_[k].name);
    }
  }
  if (free.size() != moved.free_.size()) throw std::logic_error("WithFree: wrong count");
  moved.free_ = std::move(free);
  return moved;
}

FitProblem FitProblem::WithStep(double dt) const {
  FitProblem stepped = *this;
  stepped.config_.simulation.dt = dt;
  return stepped;
}

std::vector<double> FitProblem::FromScaled(const std::vector<double>& scaled) const {
  std::vector<double> values(free_.size());
  for (std::size_t k = 0; k < free_.size(); ++k) {
    const FreeParameter& p = free_[k];
    values[k] = p.log_scale ? p.lower * std::pow(p.upper / p.lower, scaled[k])
                            : p.lower + scaled[k] * (p.upper - p.lower);
  }
  return values;
}

std::vector<double> FitProblem::InitialValues() const {
  std::vector<double> values;
  for (const auto& p : free_) values.push_back(p.initial);
  return values;
}

ParameterSet FitProblem::Parameters(const std::vector<double>& values) const {
  ParameterSet parameters = config_.parameters;
  for (std::size_t k = 0; k < free_.size(); ++k) parameters.Set(free_[k].name, values[k]);
  return parameters;
}

SimulationRequest FitProblem::Request(std::size_t k, const ParameterSet* parameters) const {
  SimulationRequest request;
  request.parameters = parameters;
  request.effects = &config_.effects;
  request.experiment = &experiments_[k];
  request.settings = config_.simulation;
  request.sample_times = &traces_[k].trace.Column("t");
  if (!effect_angles_.empty()) request.settings.effect_angle = &effect_angles_[k];
  return request;
}

SimStatus FitProblem::Simulate(std::size_t k, const std::vector<double>& values, Trace* out) const {
  const ParameterSet parameters = Parameters(values);
  if (!equation_.empty()) {
    PredictInput(equation_[k], parameters, config_.effects, out);
    return SimStatus::Ok();
  }
  return config_.model->Simulate(Request(k, &parameters), out);
}

bool FitProblem::ForceEffectAngle() {
  std::vector<std::vector<double>> angles;
  for (const FitTrace& trace : traces_) {
    angles.push_back(MeasuredAngle(trace));
    if (angles.back().empty()) return false;
  }
  effect_angles_ = std::move(angles);
  return true;
}

std::vector<double> MeasuredAngle(const FitTrace& fit_trace) {
  const Trace& trace = fit_trace.trace;
  if (trace.Has("theta")) return trace.Column("theta");
  if (!trace.Has("w")) return {};
  const auto& t = trace.Column("t");
  const auto& w = trace.Column("w");
  std::vector<double> theta(w.size(), fit_trace.initial.theta);
  for (std::size_t r = 1; r < w.size(); ++r) {
    theta[r] = theta[r - 1] + 0.5 * (w[r] + w[r - 1]) * (t[r] - t[r - 1]);
  }
  return theta;
}

int AngleNyquistOrder(const std::vector<FitTrace>& traces) {
  std::vector<double> limits;
  for (const FitTrace& trace : traces) {
    const std::vector<double> theta = MeasuredAngle(trace);
    if (theta.size() < 2) continue;
    std::vector<double> steps(theta.size() - 1);
    for (std::size_t r = 1; r < theta.size(); ++r) steps[r - 1] = std::abs(theta[r] - theta[r - 1]);
    // The fast steps' scale: the 99th percentile, so that a glitch or an encoder's wrap in a
    // measured angle does not set it.
    std::vector<double> sorted = steps;
    const auto high = sorted.begin() + static_cast<long>((sorted.size() - 1) * 99 / 100);
    std::nth_element(sorted.begin(), high, sorted.end());
    const double fast = *high;
    if (!(fast > 0.0) || !std::isfinite(fast)) continue;
    for (const double step : steps) {
      if (step > 0.25 * fast) limits.push_back(std::numbers::pi / step);
    }
  }
  if (limits.empty()) return 0;
  const auto middle = limits.begin() + static_cast<long>(limits.size() / 2);
  std::nth_element(limits.begin(), middle, limits.end());
  // (in double first: a slowly turning shaft resolves orders beyond any int)
  return *middle >= 1e9 ? 1000000000 : static_cast<int>(std::floor(*middle));
}

bool FitProblem::Compare(std::size_t k, const Trace& simulated, std::vector<double>* sum_sq,
                         Evaluation* evaluation, std::vector<double>* residuals) const {
  const std::size_t columns = observe_.size();
  const Trace& reference = measured(k);
  for (std::size_t c = 0; c < columns; ++c) {
    const auto& sim = simulated.Column(observe_[c]);
    const auto& meas = reference.Column(observe_[c]);
    const double weight =
        1.0 / std::sqrt(static_cast<double>(columns) * static_cast<double>(samples_per_column_[c]) *
                        weight_variance_[k][c]);
    double trace_sum = 0.0;
    for (std::size_t r = 0; r < meas.size(); ++r) {
      const double e = sim[r] - meas[r];
      trace_sum += e * e;
      if (residuals) residuals->push_back(e * weight);
    }
    if (!std::isfinite(trace_sum)) {
      evaluation->reason = "non-finite simulated '" + observe_[c] + "'";
      return false;
    }
    (*sum_sq)[c] += trace_sum;
    evaluation->mse_per_trace[k][c] = trace_sum / static_cast<double>(meas.size());
  }
  return true;
}

void FitProblem::Finish(const std::vector<double>& sum_sq, Evaluation* evaluation) const {
  const std::size_t columns = observe_.size();
  evaluation->mse.resize(columns);
  double cost = 0.0, nrmse2 = 0.0;
  for (std::size_t c = 0; c < columns; ++c) {
    evaluation->mse[c] = sum_sq[c] / static_cast<double>(samples_per_column_[c]);
    nrmse2 += evaluation->mse[c] / variance_[c];
    if (uniform_weights_) {
      cost += evaluation->mse[c] / weight_variance_[0][c];
    } else {
      for (std::size_t k = 0; k < traces_.size(); ++k) {
        cost += evaluation->mse_per_trace[k][c] * static_cast<double>(measured(k).rows()) /
                static_cast<double>(samples_per_column_[c]) / weight_variance_[k][c];
      }
    }
  }
  evaluation->cost = cost / static_cast<double>(columns);
  evaluation->nrmse2 = nrmse2 / static_cast<double>(columns);
  evaluation->ok = true;
}

namespace {

// An evaluation that has not succeeded yet: infinite cost; "" or the reason of a
// non-finite parameter value.
Evaluation Unevaluated(const std::vector<double>& values, std::size_t traces, std::size_t columns) {
  Evaluation evaluation;
  evaluation.cost = evaluation.nrmse2 = std::numeric_limits<double>::infinity();
  for (double v : values) {
    if (!std::isfinite(v)) {
      evaluation.reason = "non-finite parameter value";
      return evaluation;
    }
  }
  evaluation.mse_per_trace.assign(traces, std::vector<double>(columns, 0.0));
  return evaluation;
}

}  // namespace

Evaluation FitProblem::Evaluate(const std::vector<double>& values,
                                std::vector<double>* residuals) const {
  Evaluation evaluation = Unevaluated(values, traces_.size(), observe_.size());
  if (!evaluation.reason.empty()) return evaluation;
  if (residuals) {
    residuals->clear();
    residuals->reserve(num_residuals_);
  }
  std::vector<double> sum_sq(observe_.size(), 0.0);
  Trace simulated;
  for (std::size_t k = 0; k < traces_.size(); ++k) {
    const SimStatus status = Simulate(k, values, &simulated);
    if (!status.ok()) {
      evaluation.reason = status.message;
      return evaluation;
    }
    if (!Compare(k, simulated, &sum_sq, &evaluation, residuals)) return evaluation;
  }
  Finish(sum_sq, &evaluation);
  return evaluation;
}

std::vector<Evaluation> FitProblem::EvaluateBatch(
    const std::vector<std::vector<double>>& points,
    std::vector<std::vector<double>>* residuals) const {
  const std::size_t n = points.size();
  if (!equation_.empty()) {  // no simulation to share: point by point
    std::vector<Evaluation> evaluations;
    if (residuals) residuals->assign(n, {});
    for (std::size_t m = 0; m < n; ++m) {
      evaluations.push_back(Evaluate(points[m], residuals ? &(*residuals)[m] : nullptr));
    }
    return evaluations;
  }
  if (residuals) {
    residuals->assign(n, {});
    for (auto& r : *residuals) r.reserve(num_residuals_);
  }
  std::vector<Evaluation> evaluations;
  std::vector<std::size_t> pending;  // points still without a reason to stop
  for (std::size_t m = 0; m < n; ++m) {
    evaluations.push_back(Unevaluated(points[m], traces_.size(), observe_.size()));
    if (evaluations.back().reason.empty()) pending.push_back(m);
  }
  std::vector<std::vector<double>> sum_sq(n, std::vector<double>(observe_.size(), 0.0));
  std::vector<ParameterSet> parameters(n);
  std::vector<SimulationRequest> requests;
  std::vector<Trace> simulated;
  std::vector<SimStatus> statuses;
  for (std::size_t k = 0; k < traces_.size() && !pending.empty(); ++k) {
    requests.clear();
    for (std::size_t m : pending) {
      if (k == 0) parameters[m] = Parameters(points[m]);
      requests.push_back(Request(k, &parameters[m]));
    }
    simulated.assign(pending.size(), Trace{});
    statuses.assign(pending.size(), SimStatus{});
    config_.model->SimulateBatch(requests.data(), requests.size(), simulated.data(),
                                 statuses.data());
    std::vector<std::size_t> still;
    for (std::size_t q = 0; q < pending.size(); ++q) {
      Evaluation& evaluation = evaluations[pending[q]];
      if (!statuses[q].ok()) {
        evaluation.reason = statuses[q].message;
      } else if (Compare(k, simulated[q], &sum_sq[pending[q]], &evaluation,
                         residuals ? &(*residuals)[pending[q]] : nullptr)) {
        still.push_back(pending[q]);
      }
    }
    pending = std::move(still);
  }
  for (std::size_t m : pending) Finish(sum_sq[m], &evaluations[m]);
  return evaluations;
}

std::vector<FreeParameter> NamedFreeParameters(const std::vector<std::string>& names) {
  std::vector<FreeParameter> free;
  free.reserve(names.size());
  for (const auto& name : names) free.push_back({name, 0.0, 0.0, false, 0.0});
  return free;
}

std::vector<FreeParameter> MakeFreeParameters(const Config& config,
                                              const std::vector<std::string>& names) {
  std::vector<FreeParameter> free;
  for (const auto& name : names) {
    if (!config.parameters.Has(name)) {
      std::vector<std::string> known;
      for (const auto& [key, value] : config.parameters.entries()) known.push_back(key);
      const std::string near = NearestName(name, known);
      throw InputError("free parameter '" + name + "' is not a parameter of " +
                       (config.path.empty() ? "the config" : config.path) +
                       (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                       "; valid: " + Join(known));
    }
    for (const auto& existing : free) {
      if (existing.name == name) throw InputError("free parameter '" + name + "' listed twice");
    }
    FreeParameter p;
    p.name = name;
    std::tie(p.lower, p.upper) = config.Bounds(name);
    const ParamInfo* info = config.FindParameterInfo(name);
    p.log_scale = info && info->positive && p.lower > 0.0;
    p.initial = config.identification.initial.Has(name) ? config.identification.initial.Get(name)
                                                        : config.parameters.Get(name);
    if (!(p.lower < p.upper)) {
      throw InputError("bounds of '" + name + "' are empty: [" + FormatNumber(p.lower) + ", " +
                       FormatNumber(p.upper) + "]");
    }
    if (p.initial < p.lower || p.initial > p.upper) {
      throw InputError("initial value " + FormatNumber(p.initial) + " of '" + name +
                       "' is outside its bounds [" + FormatNumber(p.lower) + ", " +
                       FormatNumber(p.upper) + "]");
    }
    free.push_back(p);
  }
  if (free.empty()) throw InputError("no free parameters to identify (see --free)");
  return free;
}

}  // namespace blmd
