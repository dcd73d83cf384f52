#include "blmd/ident/optimizer.h"

#include <Eigen/Dense>
#include <cmath>
#include <thread>

#include "blmd/error.h"
#include "ident/counting_cost.h"
#include "ident/methods.h"

namespace blmd {

const std::vector<const Optimizer*>& OptimizerRegistry() {
  static const internal::CeresOptimizer ceres;
  static const internal::ClassicOptimizer classic;
  static const internal::FsdOptimizer fsd;
  static const internal::PowellOptimizer powell;
  static const std::vector<const Optimizer*> registry = {&ceres, &classic, &fsd, &powell};
  return registry;
}

const Optimizer& FindOptimizer(std::string_view name) {
  for (const Optimizer* optimizer : OptimizerRegistry()) {
    if (optimizer->name() == name) return *optimizer;
  }
  std::string valid;
  for (const Optimizer* optimizer : OptimizerRegistry()) {
    valid += (valid.empty() ? "" : ", ") + std::string(optimizer->name());
  }
  throw InputError("unknown method '" + std::string(name) + "' (valid: " + valid + ")");
}

void EstimateUncertainty(const FitProblem& problem, const std::vector<double>& values,
                         std::vector<ParameterEstimate>* estimates) {
  const std::size_t p = problem.num_free();
  std::vector<double> r0;
  const Evaluation base = problem.Evaluate(values, &r0);
  if (!base.ok) return;
  const std::size_t n = r0.size();
  if (n <= p) return;
  // Noise-normalised residuals e/s_c: unit variance in every column, so cov = (J^T J)^-1.
  const std::vector<double> normalise = problem.NoiseNormalisation(base);
  // Search coordinates: log(value) for log-scale parameters, value otherwise.
  Eigen::MatrixXd jacobian(n, p);
  for (std::size_t k = 0; k < p; ++k) {
    const FreeParameter& fp = problem.free()[k];
    // The same step as the ceres method (see ceres_fit.cc): coarse enough to step over the
    // simulator's whole-step event jitter.
    const double h = fp.log_scale ? 1e-3 : 1e-3 * std::max(std::abs(values[k]),
                                                           1e-3 * (fp.upper - fp.lower));
    std::vector<double> plus = values, minus = values;
    if (fp.log_scale) {
      plus[k] = values[k] * std::exp(h);
      minus[k] = values[k] * std::exp(-h);
    } else {
      plus[k] = values[k] + h;
      minus[k] = values[k] - h;
    }
    std::vector<double> rp, rm;
    if (!problem.Evaluate(plus, &rp).ok || !problem.Evaluate(minus, &rm).ok) return;
    for (std::size_t r = 0; r < n; ++r) {
      jacobian(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(k)) =
          normalise[r] * (rp[r] - rm[r]) / (2.0 * h);
    }
  }
  const double s2 = 1.0;  // already in units of each column's residual noise
  const Eigen::MatrixXd information = jacobian.transpose() * jacobian;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(information, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const auto& singular = svd.singularValues();
  if (singular(0) <= 0.0 || singular(static_cast<Eigen::Index>(p) - 1) < 1e-12 * singular(0)) return;
  const Eigen::MatrixXd covariance = s2 * information.inverse();
  for (std::size_t k = 0; k < p; ++k) {
    const double variance = covariance(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(k));
    if (!(variance >= 0.0) || !std::isfinite(variance)) continue;
    const double sd = std::sqrt(variance);
    ParameterEstimate& e = (*estimates)[k];
    internal::SetInterval(problem.free()[k], sd, "gauss_newton", &e);
  }
}

namespace internal {

void SetInterval(const FreeParameter& parameter, double std_search, const std::string& method,
                 ParameterEstimate* estimate) {
  if (parameter.log_scale) {
    estimate->std = estimate->value * std_search;  // delta method
    estimate->ci95_low = estimate->value * std::exp(-1.959963984540054 * std_search);
    estimate->ci95_high = estimate->value * std::exp(1.959963984540054 * std_search);
  } else {
    estimate->std = std_search;
    estimate->ci95_low = estimate->value - 1.959963984540054 * std_search;
    estimate->ci95_high = estimate->value + 1.959963984540054 * std_search;
  }
  estimate->has_interval = std::isfinite(estimate->std) && std::isfinite(estimate->ci95_low) &&
                           std::isfinite(estimate->ci95_high);
  estimate->interval_method = method;
}

std::vector<ParameterEstimate> MakeEstimates(const FitProblem& problem,
                                             const std::vector<double>& values) {
  std::vector<ParameterEstimate> estimates;
  for (std::size_t k = 0; k < problem.num_free(); ++k) {
    ParameterEstimate e;
    e.name = problem.free()[k].name;
    e.value = values[k];
    e.initial = problem.free()[k].initial;
    estimates.push_back(e);
  }
  return estimates;
}

void CheckMethodOptions(const std::string& method, const nlohmann::json& options,
                        const std::vector<std::string>& valid) {
  for (const auto& [key, value] : options.items()) {
    bool known = false;
    for (const auto& name : valid) known = known || name == key;
    if (!known) {
      std::string list;
      for (const auto& name : valid) list += (list.empty() ? "" : ", ") + name;
      throw InputError("unknown option '" + key + "' for method " + method + " (valid: " + list +
                       ")");
    }
  }
}

double OptionNumber(const nlohmann::json& options, const char* key, double fallback) {
  if (!options.contains(key)) return fallback;
  const auto& value = options[key];
  if (value.is_number()) return value.get<double>();
  if (value.is_string()) {
    try {
      std::size_t used = 0;
      const std::string text = value.get<std::string>();
      const double v = std::stod(text, &used);
      if (used == text.size() && std::isfinite(v)) return v;
    } catch (const std::exception&) {
    }
  }
  throw InputError(std::string("option '") + key + "' must be a number");
}

std::string OptionString(const nlohmann::json& options, const char* key,
                         const std::string& fallback) {
  if (!options.contains(key)) return fallback;
  if (!options[key].is_string()) throw InputError(std::string("option '") + key + "' must be text");
  return options[key].get<std::string>();
}

int ThreadCount(int requested) {
  if (requested > 0) return requested;
  const unsigned hardware = std::thread::hardware_concurrency();
  return hardware ? static_cast<int>(hardware) : 1;
}

}  // namespace internal
}  // namespace blmd
