// The report's "discovery" block (interface.md, docs/discovery.md §4) from a DiscoveryResult.
#include <cmath>

#include "blmd/report/report.h"

namespace blmd {

nlohmann::json DiscoveryJson(const FitProblem& problem, const FitResult& initial,
                             const DiscoveryResult& result, const FitProblem* validation_before,
                             const FitProblem* validation_after) {
  auto number = [](double v) {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
  };
  auto candidates_json = [&](const std::vector<CandidateOutcome>& outcomes) {
    nlohmann::json list = nlohmann::json::array();
    for (const auto& o : outcomes) {
      nlohmann::json c = {{"effect", o.effect}, {"fitted", o.fitted}, {"valid", o.valid}};
      if (o.fitted) {
        c["delta_bic"] = number(o.delta_bic);
        c["delta_bic_white"] = number(o.delta_bic_white);
        c["evidence_rule"] = o.evidence_rule;
        if (o.has_held_out) {
          c["held_out_nrmse"] = {{"before", number(o.held_out_before)},
                                 {"after", number(o.held_out_after)}};
        }
        if (!o.noise_model.empty()) {
          nlohmann::json noise = nlohmann::json::object();
          for (const auto& [column, model] : o.noise_model) {
            noise[column] = {{"ar_order", model.first}, {"innovation_ratio", number(model.second)}};
          }
          c["noise_model"] = noise;
        }
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
        intervals[e.name] = {{"std", number(e.std)},
                             {"ci95", {number(e.ci95_low), number(e.ci95_high)}}};
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
    // Each competing model with its parameters and error (issue 19: reported, not hidden).
    nlohmann::json models = nlohmann::json::array();
    for (const auto& effect : group) {
      for (const auto& o : result.last_round) {
        if (o.effect != effect || !o.fitted) continue;
        models.push_back({{"effect", o.effect},
                          {"nrmse", number(o.nrmse)},
                          {"delta_bic", number(o.delta_bic)},
                          {"parameters", o.model_parameters}});
      }
    }
    out["ambiguous"].push_back(
        {{"effects", group}, {"reason", result.ambiguity_reason}, {"models", models}});
  }
  out["last_round"] = candidates_json(result.last_round);
  out["conclusion"] = result.conclusion;
  const FitProblem final_problem(result.final_config, problem.traces(), problem.observe(), [&] {
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
      intervals[e.name] = {{"std", number(e.std)},
                           {"ci95", {number(e.ci95_low), number(e.ci95_high)}}};
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
