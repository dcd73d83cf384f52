#include "blmd/ident/experiment_design/experiment_design.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <set>

#include "blmd/error.h"
#include "blmd/ident/fit/trace_input.h"
#include "ident/fit/jacobian.h"
#include "parallel.h"

namespace blmd {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;

constexpr double kZ95 = 1.959963984540054;  // the standard normal's 97.5 % quantile
// A scaled information matrix whose smallest singular value is below this fraction of its
// largest is singular: the experiment does not tell the parameters apart.
constexpr double kSingular = 1e-10;

// (A)^-1 of a symmetric positive semi-definite A, inverted with its rows and columns scaled
// to unit diagonal; false when singular.
bool InvertScaled(const MatrixXd& a, MatrixXd* inverse) {
  const Index p = a.rows();
  Eigen::VectorXd scale(p);
  for (Index j = 0; j < p; ++j) {
    if (!(a(j, j) > 0.0) || !std::isfinite(a(j, j))) return false;
    scale(j) = 1.0 / std::sqrt(a(j, j));
  }
  const MatrixXd scaled = scale.asDiagonal() * a * scale.asDiagonal();
  Eigen::JacobiSVD<MatrixXd> svd(scaled, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::VectorXd& s = svd.singularValues();
  if (!(s(p - 1) >= kSingular * s(0))) return false;
  *inverse = scale.asDiagonal() * svd.solve(MatrixXd::Identity(p, p)) * scale.asDiagonal();
  return inverse->allFinite();
}

std::vector<double> Times(double duration, double sample_rate) {
  Experiment experiment;
  experiment.duration = duration;
  experiment.sample_rate = sample_rate;
  return experiment.SampleTimes();
}

// n values from lo to hi, equally spaced in log.
std::vector<double> LogGrid(double lo, double hi, int n) {
  std::vector<double> grid;
  grid.reserve(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    grid.push_back(n == 1 ? lo : lo * std::pow(hi / lo, static_cast<double>(k) / (n - 1)));
  }
  return grid;
}

// `value` as a whole number n >= `least` of quanta of `samples` sample intervals, written
// (n·samples)/fs so that the time prints as it reads (0.1075, not 0.10750000000000001).
double Quantise(double value, int samples, double fs, double least) {
  const double n = std::max(least, std::round(value * fs / samples));
  return n * samples / fs;
}

// `value` rounded to three significant digits by `round` (std::floor or std::round), the
// result the double nearest to the decimal (10.6, not 10.600000000000001).
double Round3(double value, double (*round)(double)) {
  if (!(value > 0.0)) return value;
  const int exponent = static_cast<int>(std::floor(std::log10(value))) - 2;
  const double scale = std::pow(10.0, std::abs(exponent));  // exact for |exponent| <= 22
  return exponent < 0 ? round(value * scale * (1.0 + 1e-12)) / scale
                      : round(value / scale * (1.0 + 1e-12)) * scale;
}
// A frequency to three digits (0.907 Hz); a lowered amplitude down to three digits (11.5 V).
double RoundNearest3(double value) { return Round3(value, std::round); }
double RoundDown3(double value) { return Round3(value, std::floor); }

// The order of the shortest maximum-length register whose period covers the run.
int PrbsOrderCovering(double clock, double duration) {
  int order = 2;
  while (order < 31 && (std::exp2(order) - 1.0) * clock < duration) ++order;
  return order;
}

DesignCandidate Square(double amplitude, double period) {
  DesignCandidate c;
  c.family = "square";
  c.input.kind = InputSignal::Kind::kSquare;
  c.input.amplitude = amplitude;
  c.input.period = period;
  return c;
}

// A staircase triangle: levels a·s/n with s = 1, 2, ..., n, n-1, ..., 0, -1, ..., -n, ..., 0,
// 1, ... (steps of a/n, period 4n dwells), each held `dwell` seconds; n = 1 is +a, 0, -a, 0.
DesignCandidate Steps(double amplitude, double dwell, int levels, double duration, double fs) {
  DesignCandidate c;
  c.family = "steps";
  c.dwell = dwell;
  c.levels = levels;
  c.input.kind = InputSignal::Kind::kSteps;
  const long n = levels;
  const long period = 4L * n;
  for (long k = 0; static_cast<double>(k) * dwell < duration - 1e-12; ++k) {
    const long phase = (k + 1) % period;
    const long s = phase <= n ? phase : (phase <= 3 * n ? 2 * n - phase : phase - period);
    c.input.times.push_back(std::round(static_cast<double>(k) * dwell * fs) / fs);
    c.input.values.push_back(amplitude * static_cast<double>(s) / levels);
  }
  c.input.amplitude = amplitude;
  return c;
}

DesignCandidate Prbs(double amplitude, double clock, int order) {
  DesignCandidate c;
  c.family = "prbs";
  c.input.kind = InputSignal::Kind::kPrbs;
  c.input.amplitude = amplitude;
  c.input.clock = clock;
  c.input.order = order;
  c.input.seed = 1;
  return c;
}

DesignCandidate Chirp(double amplitude, double f0, double f1, InputSignal::ChirpShape shape,
                      double duration) {
  DesignCandidate c;
  c.family = "chirp";
  c.input.kind = InputSignal::Kind::kChirp;
  c.input.amplitude = amplitude;
  c.input.f0 = RoundNearest3(f0);
  c.input.f1 = RoundNearest3(f1);
  c.input.shape = shape;
  c.input.sweep = duration;
  return c;
}

// Lowers the amplitude by `factor` (rounded down to three digits), the steps' levels with it.
void ScaleAmplitude(DesignCandidate* c, double factor, const ExperimentDesignOptions& o) {
  const double amplitude = RoundDown3(c->input.amplitude * factor);
  if (c->family == "steps") {  // the levels anew, as exact as the amplitude
    *c = Steps(amplitude, c->dwell, c->levels, o.duration, o.sample_rate);
    return;
  }
  const double applied = c->input.amplitude > 0.0 ? amplitude / c->input.amplitude : factor;
  c->input.amplitude = amplitude;
  for (double& v : c->input.values) v *= applied;
}

// A key that tells candidates apart (the same settings are evaluated once).
std::string Key(const DesignCandidate& c) {
  char text[160];
  std::snprintf(text, sizeof text, "%s %.9g %.9g %d %.9g %d %.9g %.9g %d", c.family.c_str(),
                c.input.period, c.dwell, c.levels, c.input.clock, c.input.order, c.input.f0,
                c.input.f1, static_cast<int>(c.input.shape));
  return text;
}

// The grid of settings (docs/design.md §3): square periods from 4 samples to twice the run,
// steps dwells from 2 samples to half the run with 2-4 levels per direction, PRBS clocks from
// one sample to a quarter of the run (the register that covers the run, and one shorter),
// chirps between frequency pairs from 0.5/duration to fs/5, log and linear.
constexpr int kSquarePoints = 20, kStepsPoints = 12, kPrbsPoints = 14, kChirpPoints = 8;

double Ratio(double lo, double hi, int n) { return std::pow(hi / lo, 1.0 / (n - 1)); }

std::vector<DesignCandidate> CoarseGrid(const ExperimentDesignOptions& o,
                                        const std::string& family) {
  const double ts = 1.0 / o.sample_rate, d = o.duration, a = o.input_limit;
  std::vector<DesignCandidate> out;
  if (family == "square") {
    for (double p : LogGrid(4 * ts, 2 * d, kSquarePoints))
      out.push_back(Square(a, Quantise(p, 2, o.sample_rate, 2)));
  } else if (family == "steps") {
    for (int levels : {1, 2, 3, 4, 6, 8}) {
      for (double w : LogGrid(2 * ts, d / 2, kStepsPoints))
        out.push_back(Steps(a, Quantise(w, 1, o.sample_rate, 1), levels, d, o.sample_rate));
    }
  } else if (family == "prbs") {
    for (double c : LogGrid(ts, d / 4, kPrbsPoints)) {
      const double clock = Quantise(c, 1, o.sample_rate, 1);
      const int order = PrbsOrderCovering(clock, d);
      out.push_back(Prbs(a, clock, order));
      if (order > 2) out.push_back(Prbs(a, clock, order - 1));
    }
  } else if (family == "chirp") {
    const std::vector<double> f = LogGrid(0.5 / d, 0.2 * o.sample_rate, kChirpPoints);
    for (std::size_t i = 0; i < f.size(); ++i) {
      for (std::size_t j = i + 1; j < f.size(); ++j) {
        out.push_back(Chirp(a, f[i], f[j], InputSignal::ChirpShape::kLog, d));
        out.push_back(Chirp(a, f[i], f[j], InputSignal::ChirpShape::kLinear, d));
      }
    }
  }
  return out;
}

// Neighbours of a family's best: each continuous setting times ratio^(±k/3), k = 1, 2, with
// `shrink` dividing the exponents (1 in the first round, 3 in the second).
std::vector<DesignCandidate> Neighbours(const ExperimentDesignOptions& o,
                                        const DesignCandidate& best, double shrink) {
  const double ts = 1.0 / o.sample_rate, d = o.duration, a = o.input_limit;
  const double ratio_square = Ratio(4 * ts, 2 * d, kSquarePoints);
  const double ratio_steps = Ratio(2 * ts, d / 2, kStepsPoints);
  const double ratio_prbs = Ratio(ts, d / 4, kPrbsPoints);
  const double ratio_chirp = Ratio(0.5 / d, 0.2 * o.sample_rate, kChirpPoints);
  std::vector<DesignCandidate> out;
  for (double k : {-2.0, -1.0, 1.0, 2.0}) {
    const double e = k / (3.0 * shrink);
    if (best.family == "square") {
      out.push_back(
          Square(a, Quantise(best.input.period * std::pow(ratio_square, e), 2, o.sample_rate, 2)));
    } else if (best.family == "steps") {
      out.push_back(Steps(a, Quantise(best.dwell * std::pow(ratio_steps, e), 1, o.sample_rate, 1),
                          best.levels, d, o.sample_rate));
    } else if (best.family == "prbs") {
      const double clock =
          Quantise(best.input.clock * std::pow(ratio_prbs, e), 1, o.sample_rate, 1);
      const int covering = PrbsOrderCovering(clock, d);
      out.push_back(Prbs(a, clock, covering));
      if (covering > 2) out.push_back(Prbs(a, clock, covering - 1));
    } else if (best.family == "chirp") {
      const double g = std::pow(ratio_chirp, e);
      const double nyquist_margin = 0.45 * o.sample_rate;
      if (best.input.f0 * g < best.input.f1)
        out.push_back(Chirp(a, best.input.f0 * g, best.input.f1, best.input.shape, d));
      if (best.input.f1 * g > best.input.f0 && best.input.f1 * g < nyquist_margin)
        out.push_back(Chirp(a, best.input.f0, best.input.f1 * g, best.input.shape, d));
    }
  }
  return out;
}

// Evaluates the candidates not seen before (in parallel), adding them to *seen.
void EvaluateAll(const DesignProblem& problem, const ExperimentDesignOptions& options,
                 std::vector<DesignCandidate> candidates, std::set<std::string>* seen,
                 std::vector<DesignCandidate>* evaluated) {
  std::vector<DesignCandidate> fresh;
  for (auto& c : candidates) {
    if (seen->insert(Key(c)).second) fresh.push_back(std::move(c));
  }
  internal::ParallelFor(fresh.size(), options.threads, [&](std::size_t k) {
    fresh[k] = EvaluateCandidate(problem, options, std::move(fresh[k]));
  });
  for (auto& c : fresh) evaluated->push_back(std::move(c));
}

// The best feasible candidate of `family` among `evaluated` (nullptr when none).
const DesignCandidate* BestOf(const std::vector<DesignCandidate>& evaluated,
                              const std::string& family) {
  const DesignCandidate* best = nullptr;
  for (const auto& c : evaluated) {
    if (c.family == family && c.feasible && (!best || c.criterion < best->criterion)) best = &c;
  }
  return best;
}

void CheckOptions(const DesignProblem& problem, const ExperimentDesignOptions& options) {
  for (const auto& family : options.families) {
    const auto& valid = DesignFamilies();
    if (std::find(valid.begin(), valid.end(), family) == valid.end()) {
      throw InputError("unknown input family '" + family + "' (valid: " + Join(valid) + ", all)");
    }
  }
  std::vector<std::string> free;
  for (const auto& p : problem.free) free.push_back(p.name);
  for (const auto& name : options.target) {
    if (std::find(free.begin(), free.end(), name) == free.end()) {
      throw InputError("--target " + name + ": not a free parameter (free: " + Join(free) + ")");
    }
  }
}

}  // namespace

const std::vector<std::string>& DesignFamilies() {
  static const std::vector<std::string> families = {"square", "steps", "prbs", "chirp"};
  return families;
}

double Ci95HalfWidth(double value, double sd, bool log_scale) {
  if (!log_scale) return kZ95 * sd;
  return std::abs(value) * 0.5 * (std::exp(kZ95 * sd) - std::exp(-kZ95 * sd));
}

DesignProblem MakeDesignProblem(const Config& config) {
  if (config.identification.error == "equation") {
    throw InputError(config.path +
                     ": the equation error (identification.error) is not designed "
                     "for: blmd-design predicts the output error's precision; next: design with "
                     "\"error\": \"output\" and the motion observed (\"observe\": [\"w\"] or "
                     "[\"theta\"]) in a copy of this config: an experiment that determines J and "
                     "B by the output error drives the motion the equation error differentiates");
  }
  DesignProblem problem;
  problem.config = config;
  problem.config.experiment.closed_loop = false;
  problem.config.experiment.coast_off_time = -1.0;
  problem.observe = config.identification.observe.empty() ? config.model->traits().default_observe
                                                          : config.identification.observe;
  const auto outputs = config.model->OutputsWith(config.effects);
  for (const auto& column : problem.observe) {
    if (std::find(outputs.begin(), outputs.end(), column) == outputs.end()) {
      throw InputError(config.path + ": observed column '" + column + "' is not an output of " +
                       std::string(config.model->name()) + " (outputs: " + Join(outputs) + ")");
    }
  }
  if (config.identification.free.empty()) {
    throw InputError(config.path + ": no free parameters (identification.free)");
  }
  problem.free = MakeFreeParameters(config, config.identification.free);
  problem.sigma.assign(problem.observe.size(), 0.0);
  return problem;
}

SimStatus SimulateSampledInput(const DesignProblem& problem, const InputSignal& input,
                               const std::vector<double>& times, Trace* response) {
  Experiment experiment = problem.config.experiment;
  if (input.kind == InputSignal::Kind::kRecorded && input.times == times) {
    experiment.input = input;
  } else {
    experiment.input = InputSignal{};
    experiment.input.kind = InputSignal::Kind::kRecorded;
    experiment.input.times = times;
    experiment.input.values.reserve(times.size());
    InputCursor cursor(input);
    for (double t : times) experiment.input.values.push_back(cursor.At(t));
  }
  experiment.duration = times.back() - times.front();
  SimulationRequest request;
  request.parameters = &problem.config.parameters;
  request.effects = &problem.config.effects;
  request.experiment = &experiment;
  request.settings = problem.config.simulation;
  request.sample_times = &times;
  return problem.config.model->Simulate(request, response);
}

namespace {

// Per observed column: S_c^T S_c of its sensitivities (search coordinates), the noise-free
// column's variance and its sample count.
struct ColumnSensitivity {
  MatrixXd product;
  double variance = 0.0;
  double samples = 0.0;
};

// The sensitivities of `response`'s observed columns at the prior values: a FitProblem on the
// noise-free response (its residuals zero there) differentiated by FiniteDifferenceJacobian,
// each row divided by its column's cost weight. Empty, with the reason, when it cannot be.
std::vector<ColumnSensitivity> Sensitivities(const DesignProblem& dp, const Trace& response,
                                             const std::vector<double>& values,
                                             std::string* reason) {
  std::vector<FitTrace> traces;
  traces.push_back(RecordedFitTrace(response, dp.config.experiment.initial, "design"));
  std::optional<FitProblem> problem;
  try {
    problem.emplace(dp.config, std::move(traces), dp.observe, dp.free);
  } catch (const InputError& error) {
    *reason = error.what();  // a constant observed column: nothing to learn from it
    return {};
  }
  const std::vector<double> x = internal::ToSearchCoordinates(*problem, values);
  std::vector<double> residuals;
  MatrixXd jacobian;
  if (!internal::FiniteDifferenceJacobian(*problem, x, internal::DifferenceRule{}, nullptr,
                                          &residuals, &jacobian)) {
    *reason = "a simulation beside the prior values failed (no sensitivities)";
    return {};
  }
  const Index p = jacobian.cols();
  std::vector<ColumnSensitivity> columns(dp.observe.size());
  for (std::size_t c = 0; c < columns.size(); ++c) {
    columns[c].product = MatrixXd::Zero(p, p);
    columns[c].variance = problem->variance()[c];
  }
  for (Index i = 0; i < jacobian.rows(); ++i) {
    const auto c =
        static_cast<std::size_t>(problem->residual_columns()[static_cast<std::size_t>(i)]);
    const auto row = jacobian.row(i) / problem->column_weight(c);
    columns[c].product += row.transpose() * row;
    columns[c].samples += 1.0;
  }
  return columns;
}

// The covariance of the cost's estimate and the inverse Fisher information; false when either
// is singular. The fit's weights (identification.weighting): "noise", a_c = 1/(C N_c
// sigma_c^2), the maximum-likelihood estimate, whose covariance is the inverse Fisher
// information itself; "variance", a_c = 1/(C N_c (Var_c + sigma_c^2)), the sandwich.
bool Covariances(const std::vector<ColumnSensitivity>& columns, const std::vector<double>& sigma,
                 bool noise_weighted, PrecisionPrediction* out) {
  const Index p = columns.front().product.rows();
  MatrixXd bread = MatrixXd::Zero(p, p), meat = MatrixXd::Zero(p, p), fisher = MatrixXd::Zero(p, p);
  for (std::size_t c = 0; c < columns.size(); ++c) {
    const double sigma2 = sigma[c] * sigma[c];
    const double scale = noise_weighted ? sigma2 : columns[c].variance + sigma2;
    const double weight =
        1.0 / (static_cast<double>(columns.size()) * columns[c].samples * scale);  // a_c
    bread += weight * columns[c].product;
    meat += weight * weight * sigma2 * columns[c].product;
    fisher += columns[c].product / sigma2;
  }
  MatrixXd bread_inverse;
  if (!InvertScaled(bread, &bread_inverse) || !InvertScaled(fisher, &out->cramer_rao)) {
    out->reason = "the experiment does not tell the free parameters apart (singular information)";
    return false;
  }
  out->covariance = bread_inverse * meat * bread_inverse;
  return true;
}

}  // namespace

PrecisionPrediction PredictPrecision(const DesignProblem& dp, const Trace& response) {
  PrecisionPrediction out;
  for (const auto& p : dp.free) {
    out.names.push_back(p.name);
    out.values.push_back(dp.config.parameters.Get(p.name));
    out.log_scale.push_back(p.log_scale);
  }
  for (const auto& name : response.names()) {
    if (name == "t") continue;
    double peak = 0.0;
    for (double v : response.Column(name)) peak = std::max(peak, std::abs(v));
    out.peaks[name] = peak;
  }
  const std::vector<ColumnSensitivity> columns =
      Sensitivities(dp, response, out.values, &out.reason);
  if (columns.empty() ||
      !Covariances(columns, dp.sigma, dp.config.identification.weighting == "noise", &out))
    return out;
  if (dp.variance_factor.size() == out.names.size()) {
    const Eigen::VectorXd root =
        Eigen::Map<const Eigen::VectorXd>(dp.variance_factor.data(),
                                          static_cast<Index>(dp.variance_factor.size()))
            .cwiseSqrt();
    out.covariance = root.asDiagonal() * out.covariance * root.asDiagonal();
  }
  const Eigen::LDLT<MatrixXd> ldlt(out.covariance);
  if (!out.covariance.allFinite() || ldlt.info() != Eigen::Success ||
      !(ldlt.vectorD().minCoeff() > 0.0)) {
    out.reason = "the predicted covariance is not positive definite";
    return out;
  }
  out.log_det = ldlt.vectorD().array().log().sum();
  for (std::size_t k = 0; k < out.names.size(); ++k) {
    const auto i = static_cast<Index>(k);
    out.ci95_halfwidth.push_back(
        Ci95HalfWidth(out.values[k], std::sqrt(out.covariance(i, i)), out.log_scale[k]));
    out.cramer_rao_ci95_halfwidth.push_back(
        Ci95HalfWidth(out.values[k], std::sqrt(out.cramer_rao(i, i)), out.log_scale[k]));
  }
  out.ok = true;
  return out;
}

double DesignCriterion(const PrecisionPrediction& prediction,
                       const std::vector<std::string>& target) {
  if (!prediction.ok) return std::numeric_limits<double>::infinity();
  if (target.empty()) return prediction.log_det;
  double sum = 0.0;
  for (const auto& name : target) {
    const auto at = std::find(prediction.names.begin(), prediction.names.end(), name);
    const auto k = static_cast<Index>(at - prediction.names.begin());
    sum += prediction.covariance(k, k);
  }
  return sum;
}

DesignCandidate EvaluateCandidate(const DesignProblem& problem,
                                  const ExperimentDesignOptions& options,
                                  DesignCandidate candidate) {
  const std::vector<double> times = Times(options.duration, options.sample_rate);
  Trace response;
  for (int attempt = 0;; ++attempt) {
    response = Trace();
    const SimStatus status = SimulateSampledInput(problem, candidate.input, times, &response);
    if (!status.ok()) {
      candidate.rejected = "the simulation failed: " + status.message;
      return candidate;
    }
    double factor = 1.0;
    std::string over;
    if (options.input_limit > 0.0) {
      double peak = 0.0;
      for (double v : response.Column("u")) peak = std::max(peak, std::abs(v));
      if (peak > options.input_limit * (1.0 + 1e-12)) {
        factor = options.input_limit / peak;
        over = "u";
      }
    }
    for (const auto& [column, limit] : options.output_limits) {
      double peak = 0.0;
      for (double v : response.Column(column)) peak = std::max(peak, std::abs(v));
      if (peak > limit && limit / peak < factor) {
        factor = limit / peak;
        over = column;
      }
    }
    if (factor >= 1.0) {
      if (options.breakaway_input > 0.0) {
        double peak = 0.0;
        for (double v : response.Column("u")) peak = std::max(peak, std::abs(v));
        if (peak < options.breakaway_input) {
          candidate.rejected = "its peak |u| stays below the breakaway (the shaft would not move)";
          return candidate;
        }
      }
      break;
    }
    if (attempt == 4) {
      candidate.rejected = "the response exceeds the limit on " + over;
      return candidate;
    }
    ScaleAmplitude(&candidate, factor, options);  // the response is about linear in u
  }
  candidate.prediction = PredictPrecision(problem, response);
  if (!candidate.prediction.ok) {
    candidate.rejected = candidate.prediction.reason;
    return candidate;
  }
  candidate.criterion = DesignCriterion(candidate.prediction, options.target);
  candidate.feasible = true;
  return candidate;
}

ExperimentDesignResult SearchDesign(const DesignProblem& problem,
                                    const ExperimentDesignOptions& options) {
  CheckOptions(problem, options);
  ExperimentDesignResult result;
  result.criterion = options.target.empty() ? "D-optimal" : "A-optimal";
  const std::vector<std::string> families =
      options.families.empty() ? DesignFamilies() : options.families;
  std::vector<DesignCandidate> evaluated;
  std::set<std::string> seen;
  std::vector<DesignCandidate> grid;
  for (const auto& family : families) {
    for (auto& c : CoarseGrid(options, family)) grid.push_back(std::move(c));
  }
  EvaluateAll(problem, options, std::move(grid), &seen, &evaluated);
  for (double shrink : {1.0, 3.0}) {  // two finer rounds around each family's best
    std::vector<DesignCandidate> around;
    for (const auto& family : families) {
      if (const DesignCandidate* best = BestOf(evaluated, family)) {
        for (auto& c : Neighbours(options, *best, shrink)) around.push_back(std::move(c));
      }
    }
    EvaluateAll(problem, options, std::move(around), &seen, &evaluated);
  }
  result.evaluated = static_cast<long>(evaluated.size());
  for (const auto& c : evaluated) {
    if (!c.feasible) ++result.rejected[c.rejected];
  }
  for (const auto& family : families) {
    if (const DesignCandidate* best = BestOf(evaluated, family))
      result.family_best.push_back(*best);
  }
  if (result.family_best.empty()) {
    result.reason = "no candidate input is feasible within the limits";
    if (!result.rejected.empty()) {
      const auto most =
          std::max_element(result.rejected.begin(), result.rejected.end(),
                           [](const auto& a, const auto& b) { return a.second < b.second; });
      result.reason += " (most often: " + most->first + ")";
    }
    return result;
  }
  result.best = *std::min_element(
      result.family_best.begin(), result.family_best.end(),
      [](const DesignCandidate& a, const DesignCandidate& b) { return a.criterion < b.criterion; });
  result.ok = true;
  return result;
}

double ResidualNoise(const std::vector<double>& measured, const std::vector<double>& response) {
  double sum = 0.0;
  for (std::size_t k = 0; k < measured.size(); ++k) {
    sum += (measured[k] - response[k]) * (measured[k] - response[k]);
  }
  return measured.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(measured.size()));
}

}  // namespace blmd
