#include <ceres/ceres.h>
#include <ceres/covariance.h>

#include <chrono>
#include <cmath>

#include "blmd/error.h"
#include "ident/counting_cost.h"
#include "ident/methods.h"

namespace blmd::internal {
namespace {

// Residuals of the whole problem as one Ceres block. Parameters in search coordinates:
// log(value) for log-scale parameters, the value itself otherwise.
class ResidualFunctor {
 public:
  // `scale` (optional): per-residual factors applied to the residuals (noise normalisation).
  explicit ResidualFunctor(CountingCost* cost, std::vector<double> scale = {})
      : cost_(cost), scale_(std::move(scale)) {}

  bool operator()(double const* const* parameters, double* residuals) const {
    const FitProblem& problem = cost_->problem();
    std::vector<double> values(problem.num_free());
    for (std::size_t k = 0; k < values.size(); ++k) {
      values[k] = problem.free()[k].log_scale ? std::exp(parameters[0][k]) : parameters[0][k];
    }
    std::vector<double> r;
    const Evaluation evaluation = cost_->Evaluate(values, &r);
    if (!evaluation.ok) return false;  // Ceres treats the step as infeasible
    for (std::size_t k = 0; k < r.size(); ++k) residuals[k] = scale_.empty() ? r[k] : r[k] * scale_[k];
    return true;
  }

 private:
  CountingCost* cost_;
  std::vector<double> scale_;
};

}  // namespace

std::vector<std::string> CeresOptimizer::option_names() const {
  return {"max_iterations", "function_tolerance", "parameter_tolerance", "gradient_tolerance"};
}

FitResult CeresOptimizer::Minimize(const FitProblem& problem,
                                   const OptimizerOptions& options) const {
  CheckMethodOptions("ceres", options.method_options, option_names());
  const auto started = std::chrono::steady_clock::now();
  CountingCost cost(problem);
  const std::size_t p = problem.num_free();
  std::vector<double> x(p);
  const std::vector<double> initial = problem.InitialValues();
  for (std::size_t k = 0; k < p; ++k) {
    x[k] = problem.free()[k].log_scale ? std::log(initial[k]) : initial[k];
  }

  auto* functor = new ResidualFunctor(&cost);
  auto* cost_function =
      new ceres::DynamicNumericDiffCostFunction<ResidualFunctor, ceres::CENTRAL>(
          functor, ceres::TAKE_OWNERSHIP);
  cost_function->AddParameterBlock(static_cast<int>(p));
  cost_function->SetNumResiduals(static_cast<int>(problem.num_residuals()));

  ceres::Problem::Options problem_options;
  ceres::Problem ceres_problem(problem_options);
  ceres_problem.AddResidualBlock(cost_function, nullptr, x.data());
  for (std::size_t k = 0; k < p; ++k) {
    const FreeParameter& fp = problem.free()[k];
    const double lower = fp.log_scale ? std::log(fp.lower) : fp.lower;
    const double upper = fp.log_scale ? std::log(fp.upper) : fp.upper;
    ceres_problem.SetParameterLowerBound(x.data(), static_cast<int>(k), lower);
    ceres_problem.SetParameterUpperBound(x.data(), static_cast<int>(k), upper);
  }

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations =
      static_cast<int>(OptionNumber(options.method_options, "max_iterations", 100));
  solver_options.function_tolerance =
      OptionNumber(options.method_options, "function_tolerance", 1e-10);
  solver_options.parameter_tolerance =
      OptionNumber(options.method_options, "parameter_tolerance", 1e-10);
  solver_options.gradient_tolerance =
      OptionNumber(options.method_options, "gradient_tolerance", 1e-14);
  solver_options.logging_type = ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = false;
  solver_options.num_threads = 1;
  ceres::Solver::Summary ceres_summary;
  ceres::Solve(solver_options, &ceres_problem, &ceres_summary);

  FitResult result;
  result.values.resize(p);
  for (std::size_t k = 0; k < p; ++k) {
    result.values[k] = problem.free()[k].log_scale ? std::exp(x[k]) : x[k];
  }
  result.evaluation = problem.Evaluate(result.values);
  result.estimates = MakeEstimates(problem, result.values);

  OptimizerSummary& summary = result.summary;
  summary.method = "ceres";
  summary.algorithm = "LEVENBERG_MARQUARDT (numeric central differences, DENSE_QR)";
  summary.raw_code = static_cast<int>(ceres_summary.termination_type);
  summary.converged = ceres_summary.termination_type == ceres::CONVERGENCE &&
                      result.evaluation.ok;
  summary.termination = ceres::TerminationTypeToString(ceres_summary.termination_type);
  summary.message = ceres_summary.message;
  summary.iterations = static_cast<long>(ceres_summary.iterations.size());
  summary.details = {{"initial_cost", ceres_summary.initial_cost},
                     {"final_cost", ceres_summary.final_cost},
                     {"successful_steps", ceres_summary.num_successful_steps},
                     {"unsuccessful_steps", ceres_summary.num_unsuccessful_steps}};

  // Covariance of the search coordinates, scaled by the residual variance: the residuals
  // are re-weighted by each column's estimated noise level (e/s_c), so that columns with
  // different noise (current in A, speed in rad/s) each count with their own variance, and
  // ceres::Covariance of that problem is the parameter covariance directly.
  if (result.evaluation.ok && problem.num_residuals() > p) {
    std::vector<double> cov_x = x;
    auto* noise_functor = new ResidualFunctor(&cost, problem.NoiseNormalisation(result.evaluation));
    auto* noise_cost =
        new ceres::DynamicNumericDiffCostFunction<ResidualFunctor, ceres::CENTRAL>(
            noise_functor, ceres::TAKE_OWNERSHIP);
    noise_cost->AddParameterBlock(static_cast<int>(p));
    noise_cost->SetNumResiduals(static_cast<int>(problem.num_residuals()));
    ceres::Problem covariance_problem;
    covariance_problem.AddResidualBlock(noise_cost, nullptr, cov_x.data());
    ceres::Covariance::Options covariance_options;
    covariance_options.algorithm_type = ceres::DENSE_SVD;
    covariance_options.null_space_rank = -1;
    covariance_options.min_reciprocal_condition_number = 1e-14;
    ceres::Covariance covariance(covariance_options);
    std::vector<std::pair<const double*, const double*>> blocks = {{cov_x.data(), cov_x.data()}};
    if (covariance.Compute(blocks, &covariance_problem)) {
      std::vector<double> matrix(p * p);
      covariance.GetCovarianceBlock(cov_x.data(), cov_x.data(), matrix.data());
      for (std::size_t k = 0; k < p; ++k) {
        const double variance = matrix[k * p + k];
        if (variance >= 0.0 && std::isfinite(variance)) {
          SetInterval(problem.free()[k], std::sqrt(variance), "ceres_covariance",
                      &result.estimates[k]);
        }
      }
      nlohmann::json noise = nlohmann::json::object();
      for (std::size_t c = 0; c < problem.observe().size(); ++c) {
        noise[problem.observe()[c]] = std::sqrt(result.evaluation.mse[c]);
      }
      summary.details["residual_rms"] = noise;
    } else {
      summary.details["covariance"] = "rank deficient: parameters not separately identifiable";
    }
  }
  cost.FillSummary(&summary);
  summary.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return result;
}

}  // namespace blmd::internal
