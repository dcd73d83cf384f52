#include <ceres/ceres.h>
#include <glog/logging.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <mutex>

#include "blmd/error.h"
#include "ident/fit/counting_cost.h"
#include "ident/fit/jacobian.h"
#include "ident/optimizers/methods.h"

namespace blmd::internal {
namespace {

// Residuals of the whole problem as one Ceres block. Parameters in search coordinates:
// log(value) for log-scale parameters, the value itself otherwise. Derivatives are finite
// differences with a step chosen in those coordinates (fd_step: the problem's
// DifferenceStep, 1e-3 in log, i.e. 0.1 %, or 1e-3 of max(|x|, range/1000) when linear; 1e-5
// for the smooth events integration): forward differences (p + 1 simulations)
// while minimising, where the Jacobian only steers the steps, and central differences
// (2p + 1) for the intervals, whose accuracy depends on them. Ceres' own numeric
// differentiation steps relative to |x| (1e-6 |log J| ~ 1e-5), too fine for a simulator whose
// stick-slip and PWM events shift by whole steps: the cost has micro-jumps at that scale, and a
// Jacobian taken across one is wrong (and so would be the covariance). The differences are
// the one FiniteDifferenceJacobian (ident/fit/jacobian.h) every user of a Jacobian shares.
class SimulationCost final : public ceres::CostFunction {
 public:
  enum class Differences { kForward, kCentral };
  SimulationCost(CountingCost* cost, double fd_step, Differences differences)
      : cost_(cost), fd_step_(fd_step), differences_(differences) {
    const FitProblem& problem = cost_->problem();
    mutable_parameter_block_sizes()->push_back(static_cast<int>(problem.num_free()));
    set_num_residuals(static_cast<int>(problem.num_residuals()));
  }

  // Evaluates the residuals and the Jacobian at x and keeps them (RememberedResiduals,
  // RememberedJacobian); false when that fails (a simulation failed or a derivative is not
  // finite).
  bool CheckJacobian(const std::vector<double>& x) {
    remembered_residuals_.assign(cost_->problem().num_residuals(), 0.0);
    remembered_jacobian_.assign(remembered_residuals_.size() * x.size(), 0.0);
    double* jacobians[] = {remembered_jacobian_.data()};
    const double* parameters[] = {x.data()};
    return Evaluate(parameters, remembered_residuals_.data(), jacobians);
  }
  // The residuals and Jacobian CheckJacobian evaluated.
  Eigen::VectorXd RememberedResiduals() const {
    return Eigen::Map<const Eigen::VectorXd>(
        remembered_residuals_.data(), static_cast<Eigen::Index>(remembered_residuals_.size()));
  }
  Eigen::MatrixXd RememberedJacobian() const {  // Ceres's layout: row-major n x p
    const auto p = static_cast<Eigen::Index>(cost_->problem().num_free());
    const auto n = static_cast<Eigen::Index>(remembered_residuals_.size());
    return Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
        remembered_jacobian_.data(), n, p);
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const FitProblem& problem = cost_->problem();
    const std::size_t p = problem.num_free();
    const std::vector<double> x(parameters[0], parameters[0] + p);
    if (!(jacobians && jacobians[0])) {
      std::vector<std::vector<double>> one;
      const std::vector<Evaluation> evaluation =
          cost_->EvaluateBatch({FromSearchCoordinates(problem, x)}, &one);
      if (!evaluation[0].ok) return false;
      std::copy(one[0].begin(), one[0].end(), residuals);
      return true;
    }
    DifferenceRule rule;
    rule.step = fd_step_;
    rule.central = differences_ == Differences::kCentral;
    std::vector<double> r;
    Eigen::MatrixXd jacobian;
    if (!FiniteDifferenceJacobian(problem, x, rule, cost_, &r, &jacobian)) return false;
    std::copy(r.begin(), r.end(), residuals);
    // Ceres's layout: row-major n x p.
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
        jacobians[0], jacobian.rows(), jacobian.cols()) = jacobian;
    return true;
  }

 private:
  CountingCost* cost_;
  double fd_step_;
  Differences differences_;
  std::vector<double> remembered_residuals_, remembered_jacobian_;  // CheckJacobian's
};

// The intervals (uncertainty.h): the Jacobian of the cost's weighted residuals by central
// differences at the solution (checked finite; a failure is said in details.interval) and
// the prewhitened HAC sandwich of those. Ceres's own
// ceres::Covariance is not used: it is (J^T J)^-1 of the problem it is given, which describes
// this fit only if each column were weighted by its inverse noise variance; the cost weights
// by the column's variance (docs/uncertainty.md).
void SetIntervals(const FitProblem& problem, CountingCost* cost, double fd_step,
                  const std::vector<double>& x, FitResult* result) {
  OptimizerSummary& summary = result->summary;
  SimulationCost central(cost, fd_step, SimulationCost::Differences::kCentral);
  if (!central.CheckJacobian(x)) {
    summary.interval_unavailable =
        "the Jacobian at the optimum could not be evaluated (a simulation failed or a "
        "derivative is not finite)";
    summary.interval = IntervalRecord{};
    summary.interval->method = "hac_prewhitened";
    summary.interval->unavailable = summary.interval_unavailable;
    for (ParameterEstimate& e : result->estimates) e.has_interval = e.has_white_interval = false;
    return;
  }
  const Eigen::MatrixXd jacobian = central.RememberedJacobian();
  const Eigen::VectorXd residuals = central.RememberedResiduals();
  SetSandwichIntervals(problem, jacobian, residuals, result);
  auto& figures = std::get<CeresFigures>(summary.figures);
  for (std::size_t c = 0; c < problem.observe().size(); ++c) {
    figures.residual_rms[problem.observe()[c]] = std::sqrt(result->evaluation.mse[c]);
  }
}

// Ceres logs through glog, whose default writes WARNING and above to stderr (with a "Logging
// before InitGoogleLogging()" line first). Not verbose: nothing below FATAL is logged at all,
// so Ceres's lines never precede a command's own one-line error. The flag is process-wide, as
// glog's is; it is set on every call, so the last call's choice holds.
void SetCeresLogging(bool verbose) {
  static std::mutex mutex;  // discovery runs Ceres fits on several threads
  const std::lock_guard<std::mutex> lock(mutex);
  const int level = verbose ? google::GLOG_INFO : google::GLOG_FATAL;
  if (FLAGS_minloglevel != level) FLAGS_minloglevel = level;
}

}  // namespace

std::vector<std::string> CeresOptimizer::option_names() const {
  return {"max_iterations", "function_tolerance", "parameter_tolerance", "gradient_tolerance",
          "fd_step"};
}

FitResult CeresOptimizer::Minimize(const FitProblem& problem,
                                   const OptimizerOptions& options) const {
  CheckMethodOptions("ceres", options.method_options, option_names());
  SetCeresLogging(options.verbose);
  const auto started = std::chrono::steady_clock::now();
  CountingCost cost(problem, options.progress);
  const std::size_t p = problem.num_free();
  std::vector<double> x(p);
  const std::vector<double> initial = problem.InitialValues();
  for (std::size_t k = 0; k < p; ++k) {
    x[k] = problem.free()[k].log_scale ? std::log(initial[k]) : initial[k];
  }

  const nlohmann::json& o = options.method_options;
  const double fd_step =
      OptionNumber("ceres", o, "fd_step", problem.DifferenceStep(), {0.0, 0.5, true});
  auto* cost_function = new SimulationCost(&cost, fd_step, SimulationCost::Differences::kForward);

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
  solver_options.max_num_iterations = OptionWholeNumber(
      "ceres", o, "max_iterations",
      options.default_max_iterations > 0 ? options.default_max_iterations : 100, 1, 1000000);
  if (options.max_evaluations > 0) {
    // Each iteration costs about p + 2 evaluations (forward differences and the step).
    solver_options.max_num_iterations =
        std::max(1, std::min(solver_options.max_num_iterations,
                             options.max_evaluations / static_cast<int>(p + 2)));
  }
  solver_options.function_tolerance =
      OptionNumber("ceres", o, "function_tolerance", 1e-10, {0.0, 1.0, true});
  solver_options.parameter_tolerance =
      OptionNumber("ceres", o, "parameter_tolerance", 1e-10, {0.0, 1.0, true});
  solver_options.gradient_tolerance =
      OptionNumber("ceres", o, "gradient_tolerance", 1e-14, {0.0, 1.0, true});
  // No projected line search after a successful step: with bounds, Ceres would otherwise
  // evaluate the Jacobian again along the step (2p + 1 more simulations per iteration, half
  // of a fit's evaluations) before the next iteration evaluates it anyway; a step that
  // leaves the box is projected back onto it instead.
  solver_options.max_num_line_search_step_size_iterations = 0;
  solver_options.logging_type = ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = false;
  solver_options.num_threads = 1;
  ceres::Solver::Summary ceres_summary;
  ceres::Solve(solver_options, &ceres_problem, &ceres_summary);
  FitResult result;
  // Clamped: Ceres keeps ln x inside [ln lower, ln upper], and exp(ln 1e-8) is a rounding
  // below 1e-8; a value outside its bounds would not load back from --write-config.
  result.values = FromSearchCoordinates(problem, x, /*clamp=*/true);
  result.evaluation = problem.Evaluate(result.values);
  result.estimates = MakeEstimates(problem, result.values);

  OptimizerSummary& summary = result.summary;
  summary.method = "ceres";
  summary.algorithm =
      "LEVENBERG_MARQUARDT (forward differences, central for the covariance; DENSE_QR)";
  summary.raw_code = static_cast<int>(ceres_summary.termination_type);
  summary.converged = ceres_summary.termination_type == ceres::CONVERGENCE && result.evaluation.ok;
  summary.termination = ceres::TerminationTypeToString(ceres_summary.termination_type);
  summary.message = ceres_summary.message;
  summary.iterations = static_cast<long>(ceres_summary.iterations.size());
  summary.fd_step = fd_step;
  CeresFigures figures;
  figures.fd_step = fd_step;
  figures.initial_cost = ceres_summary.initial_cost;
  figures.final_cost = ceres_summary.final_cost;
  figures.successful_steps = ceres_summary.num_successful_steps;
  figures.unsuccessful_steps = ceres_summary.num_unsuccessful_steps;
  summary.figures = figures;

  CheckProgress(problem, &result);
  if (result.evaluation.ok && problem.num_residuals() > p) {
    SetIntervals(problem, &cost, fd_step, x, &result);
  }
  CloseSummary(cost, started, &summary);
  return result;
}

}  // namespace blmd::internal
