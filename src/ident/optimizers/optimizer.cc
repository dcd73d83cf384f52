#include "blmd/ident/optimizers/optimizer.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "blmd/error.h"
#include "blmd/io/csv.h"
#include "ident/fit/counting_cost.h"
#include "ident/fit/jacobian.h"
#include "ident/optimizers/methods.h"

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
  throw InputError("unknown method '" + InputError::Excerpt(std::string(name)) +
                   "' (valid: " + valid + ")");
}

namespace internal {

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

void CloseSummary(const CountingCost& cost, std::chrono::steady_clock::time_point started,
                  OptimizerSummary* summary) {
  cost.FillSummary(summary);
  summary->wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
}

void FinishFit(const FitProblem& problem, const CountingCost& cost,
               std::chrono::steady_clock::time_point started, FitResult* result) {
  CloseSummary(cost, started, &result->summary);
  if (result->evaluation.ok) EstimateUncertainty(problem, result->values, &result->estimates);
}

void CheckProgress(const FitProblem& problem, FitResult* result) {
  OptimizerSummary& summary = result->summary;
  if (!summary.converged) return;
  const std::vector<double> start = problem.InitialValues();
  const Evaluation at_start = problem.Evaluate(start);
  if (!at_start.ok) {
    summary.converged = false;
    summary.termination = "cost not finite at the start values";
    summary.message = "the start values give no finite cost (" + at_start.reason +
                      "); start from values of the right magnitude (--initial, or the "
                      "config's identification.initial)";
    return;
  }
  const double final_cost = result->evaluation.cost;
  if (final_cost < at_start.cost * (1.0 - 1e-9)) return;  // the fit made progress
  const double tolerance = 1e-9 * std::max(final_cost, std::numeric_limits<double>::min());
  for (std::size_t k = 0; k < problem.num_free(); ++k) {
    const FreeParameter& fp = problem.free()[k];
    for (const double direction : {-1.0, 1.0}) {
      std::vector<double> probe = result->values;
      const double x = probe[k];
      probe[k] = fp.log_scale
                     ? x * std::exp(0.05 * direction)
                     : x + 0.05 * direction * std::max(std::abs(x), 1e-3 * (fp.upper - fp.lower));
      probe[k] = std::clamp(probe[k], fp.lower, fp.upper);
      if (probe[k] == x) continue;
      const Evaluation moved = problem.Evaluate(probe);
      if (!moved.ok || std::abs(moved.cost - final_cost) > tolerance) return;  // not flat
    }
  }
  summary.converged = false;
  summary.termination = "flat cost";
  summary.message =
      "no progress from the start values and the cost does not change when any free parameter "
      "moves 5 % around them: the parameters are not determined there (start values far from "
      "the data's, e.g. a J so large that the shaft does not move); start from values of the "
      "right magnitude (--initial, or the config's identification.initial)";
}

void CheckMethodOptions(const std::string& method, const nlohmann::json& options,
                        const std::vector<std::string>& valid) {
  for (const auto& [key, value] : options.items()) {
    bool known = false;
    for (const auto& name : valid) known = known || name == key;
    if (!known) {
      std::string list;
      for (const auto& name : valid) list += (list.empty() ? "" : ", ") + name;
      throw InputError("unknown option '" + InputError::Excerpt(key) + "' for method " + method +
                       " (valid: " + list + ")");
    }
  }
}

namespace {

std::string OptionText(const nlohmann::json& value) {
  return InputError::Excerpt(value.is_string() ? value.get<std::string>() : value.dump(), 40);
}

// The option's value as a finite number, or nullopt when it is not one.
std::optional<double> OptionAsNumber(const nlohmann::json& value) {
  if (value.is_number()) return value.get<double>();
  if (!value.is_string()) return std::nullopt;
  const std::string text = value.get<std::string>();
  try {
    std::size_t used = 0;
    const double v = std::stod(text, &used);
    if (used == text.size() && !text.empty()) return v;
  } catch (const std::exception&) {
  }
  return std::nullopt;
}

std::string RangeText(OptionRange range) {
  return std::string(range.low_open ? "> " : ">= ") + FormatSignificant(range.low, 6) +
         " and <= " + FormatSignificant(range.high, 6);
}

}  // namespace

double OptionNumber(const std::string& method, const nlohmann::json& options, const char* key,
                    double fallback, OptionRange range) {
  if (!options.contains(key)) return fallback;
  const std::optional<double> value = OptionAsNumber(options[key]);
  const bool in_range = value && std::isfinite(*value) &&
                        (range.low_open ? *value > range.low : *value >= range.low) &&
                        *value <= range.high;
  if (!in_range) {
    throw InputError("method " + method + ": option " + key + "=" + OptionText(options[key]) +
                     " must be a number " + RangeText(range));
  }
  return *value;
}

int OptionWholeNumber(const std::string& method, const nlohmann::json& options, const char* key,
                      int fallback, int low, int high) {
  if (!options.contains(key)) return fallback;
  const std::optional<double> value = OptionAsNumber(options[key]);
  if (!value || !(*value >= low && *value <= high) || std::floor(*value) != *value) {
    throw InputError("method " + method + ": option " + key + "=" + OptionText(options[key]) +
                     " must be a whole number from " + std::to_string(low) + " to " +
                     std::to_string(high));
  }
  return static_cast<int>(*value);
}

std::string OptionChoice(const std::string& method, const nlohmann::json& options, const char* key,
                         const std::string& fallback, const std::vector<std::string>& choices) {
  if (!options.contains(key)) return fallback;
  const nlohmann::json& value = options[key];
  if (value.is_string() &&
      std::find(choices.begin(), choices.end(), value.get<std::string>()) != choices.end()) {
    return value.get<std::string>();
  }
  std::string list;
  for (const auto& choice : choices) list += (list.empty() ? "" : ", ") + choice;
  throw InputError(method + " option " + key + "='" + OptionText(value) + "' (valid: " + list +
                   ")");
}

}  // namespace internal
}  // namespace blmd
