#include "blmd/ident/discovery.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <thread>

#include "blmd/ident/report.h"
#include "blmd/sim/effects.h"
#include "ident/counting_cost.h"

namespace blmd {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string G(double v, int digits = 4) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*g", digits, v);
  return buffer;
}

// A candidate's search set-up: free effect parameters with bounds, fixed ones, start points.
struct CandidatePlan {
  std::string effect;
  bool applicable = true;
  std::string not_applicable;
  std::vector<FreeParameter> free;             // the effect's free parameters
  std::map<std::string, double> fixed;         // the effect's fixed parameters
  std::vector<std::vector<double>> starts;     // start values for `free`
  std::vector<std::map<std::string, double>> fixed_alternatives;  // cogging: one per period
  std::string amplitude;                       // parameter that must differ from zero
};

FreeParameter Free(const std::string& name, double lower, double upper, bool log_scale = false) {
  FreeParameter p;
  p.name = name;
  p.lower = lower;
  p.upper = upper;
  p.log_scale = log_scale;
  p.initial = log_scale ? std::sqrt(lower * upper) : 0.5 * (lower + upper);
  return p;
}

double TorqueScale(const FitProblem& problem, const ResidualAnalysis& analysis) {
  const ParameterSet& p = problem.config().parameters;
  const std::string model(problem.config().model->name());
  double per_amp = 1.0;
  if (model == "dc_servo") per_amp = p.Get("Kt");
  if (model == "blmd") per_amp = 1.5 * p.Get("Ke");
  return std::max(per_amp * analysis.i_max, 1e-12);
}

CandidatePlan Plan(const std::string& effect, const FitProblem& problem,
                   const ResidualAnalysis& analysis, const std::vector<double>& values) {
  CandidatePlan plan;
  plan.effect = effect;
  const double T = TorqueScale(problem, analysis);
  const double w_max = std::max(analysis.w_max, 1e-9);
  const auto& observe = problem.observe();
  const bool observes_i = std::find(observe.begin(), observe.end(), "i") != observe.end();
  if (effect == "coulomb_friction") {
    plan.free = {Free("Tc", 0.0, T)};
    for (double f : {0.003, 0.01, 0.03, 0.1, 0.3}) plan.starts.push_back({f * T});
    plan.amplitude = "Tc";
  } else if (effect == "load_torque") {
    plan.free = {Free("TL", -T, T)};
    for (double f : {0.01, 0.03, 0.1, 0.3}) {
      plan.starts.push_back({f * T});
      plan.starts.push_back({-f * T});
    }
    plan.amplitude = "TL";
  } else if (effect == "quadratic_drag") {
    const double scale = T / (w_max * w_max);
    plan.free = {Free("Cd", 0.0, scale)};
    for (double f : {0.01, 0.03, 0.1, 0.3}) plan.starts.push_back({f * scale});
    plan.amplitude = "Cd";
  } else if (effect == "stribeck") {
    plan.free = {Free("Ts", 0.0, T), Free("ws", 1e-3 * w_max, w_max, true)};
    for (double f : {0.01, 0.03, 0.1, 0.3}) {
      for (double g : {0.003, 0.01, 0.03, 0.1}) plan.starts.push_back({f * T, g * w_max});
    }
    plan.amplitude = "Ts";
  } else if (effect == "cogging") {
    // Periods per revolution from the residual's angle spectrum (velocity first: the
    // cogging torque's direct trace), three strongest distinct orders.
    std::vector<int> orders;
    for (const char* column : {"w", "theta", "i"}) {
      for (const auto& d : analysis.columns) {
        if (d.column != column) continue;
        for (const auto& peak : d.angle_peaks) {
          if (orders.size() < 3 && std::find(orders.begin(), orders.end(), peak.order) == orders.end()) {
            orders.push_back(peak.order);
          }
        }
      }
    }
    if (orders.empty()) {
      plan.applicable = false;
      plan.not_applicable = "the shaft turns too little for an angle spectrum";
      return plan;
    }
    plan.free = {Free("Tcog", 0.0, T), Free("phase", -2.0 * kPi, 2.0 * kPi)};
    for (int order : orders) plan.fixed_alternatives.push_back({{"periods", static_cast<double>(order)}});
    for (double f : {0.003, 0.01, 0.03, 0.1}) {
      for (double phase : {0.0, 0.5 * kPi, kPi, -0.5 * kPi}) plan.starts.push_back({f * T, phase});
    }
    plan.amplitude = "Tcog";
  } else if (effect == "dead_time") {
    const double u_max = std::max(analysis.u_max, 1e-9);
    plan.free = {Free("Vdt", 0.0, 0.5 * u_max)};
    for (double f : {0.003, 0.01, 0.03, 0.1}) plan.starts.push_back({f * u_max});
    plan.amplitude = "Vdt";
  } else if (effect == "current_offset") {
    if (!observes_i) {
      plan.applicable = false;
      plan.not_applicable = "needs the current i among the observed columns";
      return plan;
    }
    const double i_max = std::max(analysis.i_max, 1e-9);
    plan.free = {Free("i0", -i_max, i_max)};
    double mean = 0.0;
    for (const auto& d : analysis.columns) {
      if (d.column == "i") mean = d.mean;
    }
    plan.starts.push_back({std::clamp(mean, -0.9 * i_max, 0.9 * i_max)});
    plan.amplitude = "i0";
  } else {
    plan.applicable = false;
    plan.not_applicable = "no discovery plan for this effect";
  }
  (void)values;
  return plan;
}

struct CandidateRun {
  CandidateOutcome outcome;
  Config config;
  std::vector<FreeParameter> free;
  FitResult fit;
  std::map<std::string, double> fixed;
};

// Builds the problem with `effect` added at `effect_values` (free) and `fixed`.
FitProblem CandidateProblem(const FitProblem& base, const std::vector<double>& base_values,
                            const CandidatePlan& plan, const std::vector<double>& effect_values,
                            const std::map<std::string, double>& fixed, Config* config_out,
                            std::vector<FreeParameter>* free_out) {
  Config config = base.config();
  ParameterSet effect_parameters;
  for (std::size_t k = 0; k < plan.free.size(); ++k) effect_parameters.Set(plan.free[k].name, effect_values[k]);
  for (const auto& [name, value] : fixed) effect_parameters.Set(name, value);
  config.AddEffect(plan.effect, effect_parameters);
  std::vector<FreeParameter> free = base.free();
  for (std::size_t k = 0; k < free.size(); ++k) {
    free[k].initial = std::clamp(base_values[k], free[k].lower, free[k].upper);
    config.parameters.Set(free[k].name, free[k].initial);
  }
  for (std::size_t k = 0; k < plan.free.size(); ++k) {
    FreeParameter p = plan.free[k];
    p.initial = std::clamp(effect_values[k], p.lower, p.upper);
    free.push_back(p);
  }
  *config_out = config;
  *free_out = free;
  return FitProblem(config, base.traces(), base.observe(), free);
}

CandidateRun RunCandidate(const FitProblem& base, const std::vector<double>& base_values,
                          const CandidatePlan& plan, double bic_before,
                          const DiscoveryOptions& options) {
  CandidateRun run;
  run.outcome.effect = plan.effect;
  if (!plan.applicable) {
    run.outcome.reason = plan.not_applicable;
    return run;
  }
  // Deterministic scan of start points (and of cogging periods).
  std::vector<std::map<std::string, double>> alternatives = plan.fixed_alternatives;
  if (alternatives.empty()) alternatives.push_back({});
  double best_cost = std::numeric_limits<double>::infinity();
  std::vector<double> best_start;
  std::map<std::string, double> best_fixed;
  for (const auto& fixed : alternatives) {
    for (const auto& start : plan.starts) {
      Config config;
      std::vector<FreeParameter> free;
      const FitProblem problem = CandidateProblem(base, base_values, plan, start, fixed, &config, &free);
      const Evaluation evaluation = problem.Evaluate(problem.InitialValues());
      if (evaluation.ok && evaluation.cost < best_cost) {
        best_cost = evaluation.cost;
        best_start = start;
        best_fixed = fixed;
      }
    }
  }
  if (best_start.empty()) {
    run.outcome.reason = "every start point failed to simulate";
    return run;
  }
  const FitProblem problem =
      CandidateProblem(base, base_values, plan, best_start, best_fixed, &run.config, &run.free);
  OptimizerOptions refit = options.refit;
  if (!refit.method_options.contains("max_iterations")) refit.method_options["max_iterations"] = 60;
  run.fit = FindOptimizer("ceres").Minimize(problem, refit);
  run.fixed = best_fixed;
  run.outcome.fitted = run.fit.evaluation.ok;
  if (!run.outcome.fitted) {
    run.outcome.reason = "refit failed: " + run.fit.evaluation.reason;
    return run;
  }
  run.outcome.bic = Bic(problem, run.fit.evaluation, problem.num_free());
  run.outcome.delta_bic = run.outcome.bic - bic_before;
  run.outcome.nrmse = std::sqrt(run.fit.evaluation.cost);
  const std::size_t offset = base.num_free();
  for (std::size_t k = 0; k < plan.free.size(); ++k) {
    run.outcome.parameters[plan.free[k].name] = run.fit.values[offset + k];
  }
  for (const auto& [name, value] : best_fixed) run.outcome.parameters[name] = value;
  // Physical validity: off the search bounds, and the amplitude distinguishable from zero.
  run.outcome.valid = true;
  for (std::size_t k = 0; k < plan.free.size(); ++k) {
    const FreeParameter& p = plan.free[k];
    if (p.name == "phase") continue;  // periodic
    const double v = run.fit.values[offset + k];
    const double margin = 1e-3 * (p.log_scale ? std::log(p.upper / p.lower) : (p.upper - p.lower));
    const double below = p.log_scale ? std::log(v / p.lower) : v - p.lower;
    const double above = p.log_scale ? std::log(p.upper / v) : p.upper - v;
    if (below < margin || above < margin) {
      run.outcome.valid = false;
      run.outcome.reason = p.name + " = " + G(v) + " sits on its search bound [" + G(p.lower) +
                           ", " + G(p.upper) + "]";
      break;
    }
    if (p.name == plan.amplitude) {
      const ParameterEstimate& e = run.fit.estimates[offset + k];
      if (e.has_interval && std::abs(v) < 2.0 * e.std) {
        run.outcome.valid = false;
        run.outcome.reason = p.name + " = " + G(v) + " is within two standard deviations (" +
                             G(e.std) + ") of zero";
        break;
      }
    }
  }
  if (run.outcome.valid && !(run.outcome.delta_bic < -options.bic_margin)) {
    run.outcome.reason = "BIC does not fall by more than " + G(options.bic_margin);
  }
  return run;
}

std::string Evidence(const std::string& effect, const ResidualAnalysis& analysis,
                     const CandidateOutcome& outcome, double nrmse_before) {
  std::string text = "BIC " + G(outcome.delta_bic, 5) + ", NRMSE " + G(nrmse_before) + " -> " +
                     G(outcome.nrmse);
  for (const auto& d : analysis.columns) {
    if ((effect == "coulomb_friction" || effect == "stribeck") && d.sign_w.available) {
      text += "; " + d.column + " residual mean differs by sign of w (t = " + G(d.sign_w.t_statistic, 3) + ")";
      break;
    }
    if (effect == "dead_time" && d.sign_i.available) {
      text += "; " + d.column + " residual mean differs by sign of i (t = " + G(d.sign_i.t_statistic, 3) + ")";
      break;
    }
    if (effect == "cogging" && !d.angle_peaks.empty()) {
      text += "; " + d.column + " residual peaks at " + std::to_string(d.angle_peaks.front().order) +
              " periods/rev (" + G(d.angle_peaks.front().ratio, 3) + " x floor)";
      break;
    }
    if ((effect == "load_torque" || effect == "current_offset") && d.rms > 0.0) {
      text += "; " + d.column + " residual mean " + G(d.mean) + " (rms " + G(d.rms) + ")";
      break;
    }
  }
  return text;
}

}  // namespace

double Bic(const FitProblem& problem, const Evaluation& evaluation, std::size_t k) {
  double bic = 0.0;
  std::size_t total = 0;
  for (std::size_t c = 0; c < problem.observe().size(); ++c) {
    std::size_t n = 0;
    for (const auto& t : problem.traces()) n += t.trace.rows();
    total += n;
    bic += static_cast<double>(n) * std::log(std::max(evaluation.mse[c], 1e-300));
  }
  return bic + static_cast<double>(k) * std::log(static_cast<double>(total));
}

DiscoveryResult Discover(const FitProblem& problem, const FitResult& initial,
                         const DiscoveryOptions& options) {
  DiscoveryResult result;
  std::vector<std::string> candidates = options.candidates;
  const std::string model(problem.config().model->name());
  if (candidates.empty()) {
    for (const auto& effect : EffectRegistry()) {
      if (std::find(effect.models.begin(), effect.models.end(), model) != effect.models.end()) {
        candidates.push_back(effect.name);
      }
    }
  }
  // The current model: problem + fit.
  auto current_problem = std::make_unique<FitProblem>(problem);
  FitResult current_fit = initial;
  double current_bic = initial.evaluation.ok ? Bic(problem, initial.evaluation, problem.num_free())
                                             : std::numeric_limits<double>::infinity();
  result.bic_initial = current_bic;
  if (!initial.evaluation.ok) {
    result.conclusion = "the initial fit failed: nothing to examine";
    result.final_config = problem.config();
    result.final_fit = initial;
    return result;
  }
  for (int round = 0; round < options.max_effects; ++round) {
    const ResidualAnalysis analysis = AnalyseResidual(*current_problem, current_fit.values);
    std::vector<CandidatePlan> plans;
    for (const auto& effect : candidates) {
      const auto& declared = current_problem->config().effects;
      if (std::find(declared.begin(), declared.end(), effect) != declared.end()) continue;
      plans.push_back(Plan(effect, *current_problem, analysis, current_fit.values));
    }
    if (plans.empty()) break;
    std::vector<CandidateRun> runs(plans.size());
    const int threads = std::max(1, internal::ThreadCount(options.refit.threads));
    {
      std::vector<std::thread> pool;
      for (int t = 0; t < threads; ++t) {
        pool.emplace_back([&, t] {
          for (std::size_t k = static_cast<std::size_t>(t); k < plans.size(); k += static_cast<std::size_t>(threads)) {
            runs[k] = RunCandidate(*current_problem, current_fit.values, plans[k], current_bic, options);
          }
        });
      }
      for (auto& thread : pool) thread.join();
    }
    // Best first: fitted before not, then by BIC; ties by name (deterministic).
    std::vector<std::size_t> order(runs.size());
    for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
    std::stable_sort(order.begin(), order.end(), [&](std::size_t l, std::size_t r) {
      const auto& a = runs[l].outcome;
      const auto& b = runs[r].outcome;
      if (a.fitted != b.fitted) return a.fitted;
      if (a.fitted && a.bic != b.bic) return a.bic < b.bic;
      return a.effect < b.effect;
    });
    std::vector<CandidateOutcome> outcomes;
    for (std::size_t k : order) outcomes.push_back(runs[k].outcome);
    std::vector<std::size_t> qualifying;
    for (std::size_t k : order) {
      const auto& o = runs[k].outcome;
      if (o.fitted && o.valid && o.delta_bic < -options.bic_margin) qualifying.push_back(k);
    }
    if (qualifying.empty()) {
      result.last_round = outcomes;
      break;
    }
    const CandidateRun& best = runs[qualifying.front()];
    std::vector<std::string> tied = {best.outcome.effect};
    for (std::size_t q = 1; q < qualifying.size(); ++q) {
      if (runs[qualifying[q]].outcome.bic - best.outcome.bic < options.ambiguity_margin) {
        tied.push_back(runs[qualifying[q]].outcome.effect);
      }
    }
    if (tied.size() > 1) {
      result.ambiguous.push_back(tied);
      std::string names;
      for (const auto& n : tied) names += (names.empty() ? "" : " and ") + n;
      result.ambiguity_reason = names + " explain the residual equally well (BIC within " +
                                G(options.ambiguity_margin) + ")" +
                                (analysis.w_changes_sign ? "" : "; w never changes sign on this data, "
                                                                "so friction and a constant load look alike") +
                                ": record motion in both directions to tell them apart";
      result.last_round = outcomes;
      break;
    }
    DiscoveryStep step;
    step.effect = best.outcome.effect;
    step.nrmse_before = std::sqrt(current_fit.evaluation.cost);
    step.nrmse_after = best.outcome.nrmse;
    step.bic_before = current_bic;
    step.bic_after = best.outcome.bic;
    step.candidates = outcomes;
    step.fixed_parameters = best.fixed;
    const std::size_t offset = current_problem->num_free();
    for (std::size_t k = offset; k < best.fit.estimates.size(); ++k) {
      step.effect_parameters.push_back(best.fit.estimates[k]);
    }
    step.evidence = Evidence(step.effect, analysis, best.outcome, step.nrmse_before);
    result.steps.push_back(step);
    result.added.push_back(step.effect);
    // The winner becomes the current model, its fitted values its parameters.
    Config config = best.config;
    for (std::size_t k = 0; k < best.free.size(); ++k) config.parameters.Set(best.free[k].name, best.fit.values[k]);
    std::vector<FreeParameter> free = best.free;
    for (std::size_t k = 0; k < free.size(); ++k) free[k].initial = best.fit.values[k];
    current_problem = std::make_unique<FitProblem>(config, problem.traces(), problem.observe(), free);
    current_fit = best.fit;
    current_bic = best.outcome.bic;
  }
  result.final_config = current_problem->config();
  for (const auto& p : current_problem->free()) result.final_free.push_back(p.name);
  result.final_fit = current_fit;
  if (!result.ambiguous.empty() && result.added.empty()) {
    result.conclusion = "ambiguous: " + result.ambiguity_reason;
  } else if (result.added.empty()) {
    std::string best;
    if (!result.last_round.empty() && result.last_round.front().fitted) {
      best = " (best candidate " + result.last_round.front().effect + ": BIC " +
             G(result.last_round.front().delta_bic, 4) + ")";
    }
    result.conclusion = "nothing missing: no effect lowers BIC by more than " +
                        G(options.bic_margin) + " with valid parameters" + best;
  } else {
    std::string names;
    for (const auto& n : result.added) names += (names.empty() ? "" : ", ") + n;
    result.conclusion = "added " + names;
    if (!result.ambiguous.empty()) result.conclusion += "; then ambiguous: " + result.ambiguity_reason;
  }
  return result;
}

nlohmann::json DiscoveryJson(const FitProblem& problem, const FitResult& initial,
                             const DiscoveryResult& result, const FitProblem* validation_before,
                             const FitProblem* validation_after) {
  auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  auto candidates_json = [&](const std::vector<CandidateOutcome>& outcomes) {
    nlohmann::json list = nlohmann::json::array();
    for (const auto& o : outcomes) {
      nlohmann::json c = {{"effect", o.effect}, {"fitted", o.fitted}, {"valid", o.valid}};
      if (o.fitted) {
        c["delta_bic"] = number(o.delta_bic);
        c["nrmse"] = number(o.nrmse);
        c["parameters"] = o.parameters;
      }
      if (!o.reason.empty()) c["reason"] = o.reason;
      list.push_back(c);
    }
    return list;
  };
  nlohmann::json out;
  out["added"] = result.added;
  out["steps"] = nlohmann::json::array();
  for (const auto& step : result.steps) {
    nlohmann::json s;
    s["effect"] = step.effect;
    nlohmann::json parameters = nlohmann::json::object(), intervals = nlohmann::json::object();
    for (const auto& e : step.effect_parameters) {
      parameters[e.name] = number(e.value);
      if (e.has_interval) {
        intervals[e.name] = {{"std", number(e.std)}, {"ci95", {number(e.ci95_low), number(e.ci95_high)}}};
      }
    }
    for (const auto& [name, value] : step.fixed_parameters) parameters[name] = number(value);
    s["parameters"] = parameters;
    s["intervals"] = intervals;
    s["nrmse_before"] = number(step.nrmse_before);
    s["nrmse_after"] = number(step.nrmse_after);
    s["evidence"] = step.evidence;
    s["bic_before"] = number(step.bic_before);
    s["bic_after"] = number(step.bic_after);
    s["delta_bic"] = number(step.bic_after - step.bic_before);
    s["candidates"] = candidates_json(step.candidates);
    out["steps"].push_back(s);
  }
  out["ambiguous"] = nlohmann::json::array();
  for (const auto& group : result.ambiguous) {
    out["ambiguous"].push_back({{"effects", group}, {"reason", result.ambiguity_reason}});
  }
  out["last_round"] = candidates_json(result.last_round);
  out["conclusion"] = result.conclusion;
  const FitProblem final_problem(result.final_config, problem.traces(), problem.observe(),
                                 [&] {
                                   std::vector<FreeParameter> free;
                                   for (const auto& name : result.final_free) {
                                     FreeParameter p;
                                     p.name = name;
                                     free.push_back(p);
                                   }
                                   return free;
                                 }());
  out["error_before"] = ErrorsJson(ComputeErrors(problem, initial.values));
  out["error_after"] = ErrorsJson(ComputeErrors(final_problem, result.final_fit.values));
  nlohmann::json after = nlohmann::json::object(), intervals = nlohmann::json::object();
  for (const auto& e : result.final_fit.estimates) {
    after[e.name] = number(e.value);
    if (e.has_interval) {
      intervals[e.name] = {{"std", number(e.std)}, {"ci95", {number(e.ci95_low), number(e.ci95_high)}}};
    }
  }
  out["parameters_after"] = after;
  out["intervals_after"] = intervals;
  out["effects_after"] = result.final_config.effects;
  out["residual_after"] = ResidualJson(AnalyseResidual(final_problem, result.final_fit.values));
  if (validation_before && validation_after) {
    out["validation"] = {
        {"before", ErrorsJson(ComputeErrors(*validation_before, initial.values))},
        {"after", ErrorsJson(ComputeErrors(*validation_after, result.final_fit.values))}};
  }
  SanitizeJson(&out);
  return out;
}

}  // namespace blmd
