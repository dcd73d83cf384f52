// The report as JSON (docs/report.md): to_json of IdentReport
// and its parts. Rendering only: every figure was computed when the report was built.
#include <cmath>
#include <variant>

#include "blmd/report/export.h"
#include "blmd/report/report.h"
#include "blmd/version.h"

namespace blmd {
namespace {

using nlohmann::json;

json Number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json Pair(double low, double high) { return json::array({Number(low), Number(high)}); }

json NumberList(const std::vector<double>& values) {
  json out = json::array();
  for (double v : values) out.push_back(Number(v));
  return out;
}

json NumberMap(const std::map<std::string, double>& values) {
  json out = json::object();
  for (const auto& [name, value] : values) out[name] = Number(value);
  return out;
}

// {name: {"std", "ci95"}} of the estimates that have an interval.
json Intervals(const std::vector<ParameterEstimate>& estimates) {
  json out = json::object();
  for (const auto& e : estimates) {
    if (e.has_interval)
      out[e.name] = {{"std", Number(e.std)}, {"ci95", Pair(e.ci95_low, e.ci95_high)}};
  }
  return out;
}

json ToJson(const ParameterReport& p) {
  const ParameterEstimate& e = p.estimate;
  json out;
  out["value"] = Number(e.value);
  out["free"] = p.free;
  if (!p.unit.empty()) out["unit"] = p.unit;
  if (!p.free) {
    out["std"] = nullptr;
    out["ci95"] = nullptr;
    return out;
  }
  out["initial"] = Number(e.initial);
  out["std"] = e.has_interval ? Number(e.std) : json(nullptr);
  out["ci95"] = e.has_interval ? Pair(e.ci95_low, e.ci95_high) : json(nullptr);
  if (e.has_interval) out["interval_method"] = e.interval_method;
  if (e.has_hac_interval) {  // widened by the spread between traces
    out["std_hac"] = Number(e.std_hac);
    out["ci95_hac"] = Pair(e.ci95_hac_low, e.ci95_hac_high);
  }
  // The white-noise interval for comparison (docs/uncertainty.md).
  if (e.has_white_interval) {
    out["std_white"] = Number(e.std_white);
    out["ci95_white"] = Pair(e.ci95_white_low, e.ci95_white_high);
    out["white_interval_method"] = e.white_method;
  }
  // The experiment's Cramer-Rao bound and how far the interval is from it.
  if (e.has_crb) {
    out["std_crb"] = Number(e.std_crb);
    if (e.has_interval && e.std_crb > 0.0) out["crb_ratio"] = Number(e.std / e.std_crb);
  }
  if (p.has_bounds) {
    out["bounds"] = {p.lower, p.upper};
    out["at_bound"] = p.at_bound;
  }
  if (p.widened_by_ambiguity) {
    out["ci95_before_ambiguity"] = Pair(p.ci95_before_ambiguity_low, p.ci95_before_ambiguity_high);
  }
  return out;
}

json ToJson(const SimulatedFit& simulated) {
  json out = simulated.errors;
  if (!simulated.column.empty()) out["observe"] = {simulated.column};
  return out;
}

json ToJson(const std::optional<SimulatedFit>& simulated) {
  return simulated ? ToJson(*simulated) : json(nullptr);
}

json ToJson(const FitReport& fit, const OptimizerSummary& s) {
  json out = fit.errors;
  out["observe"] = fit.observe;
  out["fit_percent"] = fit.errors.ok ? Number(100.0 * (1.0 - fit.errors.nrmse)) : json(nullptr);
  out["evaluations"] = s.evaluations;
  out["failed_evaluations"] = s.failed_evaluations;
  out["iterations"] = s.iterations;
  out["converged"] = s.converged;
  out["termination"] = s.termination;
  out["wall_time_s"] = Number(s.wall_time_s);
  if (fit.equation_error) {
    out["error"] = {{"type", "equation"},
                    {"filter_hz", Number(fit.filter_hz)},
                    {"decimate", fit.decimate},
                    {"samples", fit.samples}};
    out["simulated"] = ToJson(fit.simulated);
  } else {
    out["error"] = {{"type", "output"}};
  }
  return out;
}

json ToJson(const ResidualReport& residual) {
  json out = residual.analysis ? json(*residual.analysis) : json{{"whiteness_p", nullptr}};
  if (!residual.note.empty()) out["note"] = residual.note;
  return out;
}

json ToJson(const ValidationReport& validation) {
  json out = validation.errors;
  out["traces"] = validation.traces;
  if (validation.equation_error) out["simulated"] = ToJson(validation.simulated);
  return out;
}

json Numbers(const std::vector<double>& values) {
  json out = json::array();
  for (double v : values) out.push_back(Number(v));
  return out;
}

json CorrelationJson(const ParameterCorrelation& c) {
  json out = {{"available", c.available}, {"method", c.method}, {"names", c.names}};
  if (!c.available) {
    out["reason"] = c.reason;
    return out;
  }
  json matrix = json::array();
  for (Eigen::Index j = 0; j < c.correlation.rows(); ++j) {
    json row = json::array();
    for (Eigen::Index k = 0; k < c.correlation.cols(); ++k)
      row.push_back(Number(c.correlation(j, k)));
    matrix.push_back(row);
  }
  out["matrix"] = matrix;
  json pairs = json::array();
  for (const CorrelatedPair& pair : c.poorly_separable)
    pairs.push_back({{"parameters", {pair.first, pair.second}}, {"rho", Number(pair.rho)}});
  out["poorly_separable"] = pairs;
  return out;
}

json FrequencyResponseJson(const FrequencyResponseReport& r) {
  json out = {{"available", r.available}};
  if (!r.reason.empty()) out["reason"] = r.reason;
  if (!r.available) return out;
  out["method"] = "welch_h1";
  out["window"] = "hann";
  out["overlap"] = 0.5;
  out["detrend"] = "linear";
  out["model_sampling"] = "zero_order_hold";
  out["input"] = r.input;
  out["note"] = r.note;
  if (!r.caveat.empty()) out["caveat"] = r.caveat;
  out["sample_rate_hz"] = Number(r.sample_rate_hz);
  out["segment_length"] = r.segment_length;
  out["averages"] = r.averages;
  out["equivalent_averages"] = Number(r.equivalent_averages);
  out["resolution_hz"] = Number(r.resolution_hz);
  out["traces"] = r.traces;
  out["bins"] = r.bins;
  out["bins_with_content"] = r.bins_with_content;
  out["coherence_threshold"] = r.coherence_threshold;
  json outputs = json::object();
  for (const FrequencyResponseOutput& o : r.outputs) {
    outputs[o.output] = {{"f_hz", Numbers(o.f_hz)},
                         {"merged_bins", o.merged_bins},
                         {"model_mag_db", Numbers(o.model_mag_db)},
                         {"model_phase_deg", Numbers(o.model_phase_deg)},
                         {"empirical_mag_db", Numbers(o.empirical_mag_db)},
                         {"empirical_phase_deg", Numbers(o.empirical_phase_deg)},
                         {"coherence", Numbers(o.coherence)},
                         {"random_error", Numbers(o.random_error)},
                         {"low_coherence", o.low_coherence},
                         {"model_curve",
                          {{"f_hz", Numbers(o.model_curve.f_hz)},
                           {"mag_db", Numbers(o.model_curve.magnitude_db)},
                           {"phase_deg", Numbers(o.model_curve.phase_deg)}}}};
  }
  out["outputs"] = outputs;
  return out;
}

// Samples of the step response written to the JSON (the figures use every sample).
constexpr std::size_t kStepJsonPoints = 401;

json StepResponseJson(const StepResponseReport& r) {
  json out = {{"available", r.available}};
  if (!r.available) {
    out["reason"] = r.reason;
    return out;
  }
  const StepResponse& s = r.response;
  out["input"] = r.input;
  out["step"] = 1.0;
  out["settling_band"] = 0.02;
  out["duration_s"] = Number(s.duration_s);
  out["dt_s"] = Number(s.dt_s);
  std::vector<std::size_t> at;  // evenly spread sample indices, first and last included
  const std::size_t last = s.t_s.size() - 1;
  for (std::size_t k = 0; k < kStepJsonPoints; ++k) at.push_back(k * last / (kStepJsonPoints - 1));
  auto pick = [&](const std::vector<double>& v) {
    json values = json::array();
    for (std::size_t i : at) values.push_back(Number(v[i]));
    return values;
  };
  out["t_s"] = pick(s.t_s);
  json outputs = json::object();
  for (std::size_t k = 0; k < r.outputs.size(); ++k) {
    const StepFigures& f = s.figures[k];
    json o = {{"y", pick(s.y[k])}};
    if (f.ok) {
      o["final_value"] = Number(f.final_value);
      o["rise_time_s"] = Number(f.rise_time_s);
      o["overshoot_percent"] = Number(f.overshoot_percent);
      o["peak_value"] = Number(f.peak_value);
      o["peak_time_s"] = Number(f.peak_time_s);
      o["settling_time_s"] = Number(f.settling_time_s);
    } else {
      o["final_value"] = f.final_value != 0.0 ? Number(f.final_value) : json(nullptr);
      o["reason"] = f.reason;
    }
    outputs[r.outputs[k]] = o;
  }
  out["outputs"] = outputs;
  return out;
}

// The parts of a model's report: the headline's keys, or discovery.before's.
void ModelJson(const ModelReport& model, json* out) {
  (*out)["method"] = model.method;
  (*out)["effects"] = model.effects;
  json parameters = json::object();
  for (const auto& [name, p] : model.parameters) parameters[name] = ToJson(p);
  (*out)["parameters"] = parameters;
  (*out)["fit"] = ToJson(model.fit, model.summary);
  const OptimizerSummary& s = model.summary;
  (*out)["method_summary"] = {{"method", s.method},
                              {"algorithm", s.algorithm},
                              {"converged", s.converged},
                              {"termination", s.termination},
                              {"message", s.message},
                              {"raw_code", s.raw_code},
                              {"evaluations", s.evaluations},
                              {"failed_evaluations", s.failed_evaluations},
                              {"failure_reasons", s.failure_reasons},
                              {"iterations", s.iterations},
                              {"wall_time_s", Number(s.wall_time_s)},
                              {"seed", model.seed},
                              {"threads", model.threads},
                              {"details", MethodDetailsJson(s)}};
  (*out)["residual"] = ToJson(model.residual);
  (*out)["intervals_optimistic"] = model.intervals_optimistic;
  if (model.validation) (*out)["validation"] = ToJson(*model.validation);
  (*out)["correlation"] = CorrelationJson(model.correlation);
  if (!model.derived.empty()) {
    json derived = json::object();
    for (const auto& d : model.derived) {
      json entry = {{"effect", d.effect},
                    {"unit", d.unit},
                    {"meaning", d.meaning},
                    {"value", Number(d.value)}};
      if (d.has_interval) {
        entry["std"] = Number(d.std);
        entry["ci95"] = {Number(d.ci95_low), Number(d.ci95_high)};
        entry["interval_method"] = d.interval_method;
      } else {
        entry["std"] = nullptr;
        entry["ci95"] = nullptr;
        entry["reason"] = d.reason;
      }
      derived[d.name] = entry;
    }
    (*out)["derived"] = derived;
  }
}

json CandidatesJson(const std::vector<CandidateOutcome>& outcomes) {
  json list = json::array();
  for (const auto& o : outcomes) {
    json c = {{"effect", o.effect}, {"fitted", o.fitted}, {"valid", o.valid}};
    if (o.fitted) {
      c["delta_bic"] = Number(o.delta_bic);
      c["delta_bic_white"] = Number(o.delta_bic_white);
      c["evidence_rule"] = o.evidence_rule;
      if (o.deterministic) c["deterministic"] = true;
      if (o.has_held_out) {
        c["held_out_nrmse"] = {{"before", Number(o.held_out_before)},
                               {"after", Number(o.held_out_after)}};
      }
      if (!o.noise_model.empty()) {
        json noise = json::object();
        for (const auto& [column, model] : o.noise_model) {
          noise[column] = {{"ar_order", model.first}, {"innovation_ratio", Number(model.second)}};
        }
        c["noise_model"] = noise;
      }
      c["nrmse"] = Number(o.nrmse);
      if (o.explained_share >= 0.0) c["explained_share"] = Number(o.explained_share);
      if (o.cross_validated) {
        c["cross_validated_nrmse"] = {{"before", Number(o.cv_before)},
                                      {"after", Number(o.cv_after)}};
        if (!o.cv_perturbed.empty())
          c["cross_validated_nrmse"]["perturbed"] = NumberList(o.cv_perturbed);
      }
      c["parameters"] = NumberMap(o.parameters);
    }
    if (o.screening_step > 0.0) c["screening_step_s"] = Number(o.screening_step);
    if (o.cross_validated && o.cross_validation_step > 0.0)
      c["cross_validation_step_s"] = Number(o.cross_validation_step);
    if (o.stability_checked) {
      c["stability"] = {{"stable", o.stable},
                        {"delta_bic_plain", Number(o.stability_delta_bic)},
                        {"perturbed", NumberList(o.stability_perturbed)}};
    }
    if (!o.reason.empty()) c["reason"] = o.reason;
    list.push_back(c);
  }
  return list;
}

json StepJson(const DiscoveryStep& step) {
  json s;
  s["effect"] = step.effect;
  json parameters = json::object();
  for (const auto& e : step.effect_parameters) parameters[e.name] = Number(e.value);
  for (const auto& [name, value] : step.fixed_parameters) parameters[name] = Number(value);
  s["parameters"] = parameters;
  s["intervals"] = Intervals(step.effect_parameters);
  s["nrmse_before"] = Number(step.nrmse_before);
  s["nrmse_after"] = Number(step.nrmse_after);
  s["evidence"] = step.evidence;
  s["bic_before"] = Number(step.bic_before);
  s["bic_after"] = Number(step.bic_after);
  s["delta_bic"] = Number(step.bic_after - step.bic_before);
  s["candidates"] = CandidatesJson(step.candidates);
  return s;
}

}  // namespace

void SanitizeJson(json* value) {
  if (value->is_number_float() && !std::isfinite(value->get<double>())) {
    *value = nullptr;
  } else if (value->is_structured()) {
    for (auto& item : *value) SanitizeJson(&item);
  }
}

namespace {

struct FiguresJson {
  json operator()(const std::monostate&) const { return json::object(); }
  json operator()(const CeresFigures& f) const {
    json out = {{"fd_step", f.fd_step},
                {"initial_cost", f.initial_cost},
                {"final_cost", f.final_cost},
                {"successful_steps", f.successful_steps},
                {"unsuccessful_steps", f.unsuccessful_steps}};
    if (!f.residual_rms.empty()) out["residual_rms"] = f.residual_rms;
    return out;
  }
  json operator()(const PowellFigures& f) const {
    return {{"initial_step_scaled", f.initial_step_scaled},
            {"xtol_abs_scaled", f.xtol_abs_scaled},
            {"ftol_rel", f.ftol_rel},
            {"max_evaluations", f.max_evaluations}};
  }
  json operator()(const FsdFigures& f) const {
    json polished = json::array();
    for (const auto& p : f.polished)
      polished.push_back(
          {{"source", p.source}, {"start_cost", p.start_cost}, {"end_cost", p.end_cost}});
    json walkers = json::array();
    for (double best : f.walker_best_cost)
      walkers.push_back({{"best_cost", std::isfinite(best) ? json(best) : json(nullptr)}});
    return {{"seed", f.seed},
            {"polished", polished},
            {"winner", f.winner},
            {"walkers", f.walkers},
            {"bursts", f.bursts},
            {"burst_steps", f.burst_steps},
            {"quench_evaluations", f.quench_evaluations},
            {"quench_step", f.quench_step},
            {"probes", f.probes},
            {"cost_scale", f.cost_scale},
            {"t0", f.t0},
            {"schedule", f.schedule},
            {"step_a", f.step_a},
            {"initial_spread", f.initial_spread},
            {"fd_step", f.fd_step},
            {"max_step", f.max_step},
            {"polish", f.polish},
            {"polish_evaluations", f.polish_evaluations},
            {"polish_step", f.polish_step},
            {"walker_results", walkers}};
  }
  json operator()(const ClassicFigures& f) const {
    return {{"notes", f.notes}, {"tau_s", f.tau_s}, {"plateaus", f.plateaus}};
  }
};

json IntervalJson(const IntervalRecord& r) {
  json out = json::object();
  if (!r.method.empty()) out["method"] = r.method;
  if (!r.variance_ratio.empty()) out["variance_ratio"] = r.variance_ratio;
  if (r.has_bandwidth) {
    out["bandwidth"] = r.bandwidth;
    out["prewhitening_gain"] = r.prewhitening_gain;
    out["degrees_of_freedom"] = r.degrees_of_freedom;
    out["t_quantile"] = r.t_quantile;
  }
  if (!r.unavailable.empty()) out["unavailable"] = r.unavailable;
  if (r.leave_one_trace_out) {
    const JackknifeRecord& j = *r.leave_one_trace_out;
    json record = {{"traces", j.traces}};
    if (!j.ok) {
      record["unavailable"] = j.unavailable;
    } else {
      record["t_quantile"] = j.t_quantile;
      json spread = json::object();
      for (const auto& p : j.parameters) spread[p.name] = {{"std", p.std}, {"refits", p.refits}};
      record["parameters"] = spread;
    }
    out["leave_one_trace_out"] = record;
  }
  return out;
}

}  // namespace

json MethodDetailsJson(const OptimizerSummary& summary) {
  json out = std::visit(FiguresJson{}, summary.figures);
  if (summary.interval) out["interval"] = IntervalJson(*summary.interval);
  return out;
}

void to_json(json& out, const ErrorFigures& errors) {
  out = json::object();
  if (!errors.ok) {
    out["nrmse"] = nullptr;
    out["failed"] = errors.reason;
    return;
  }
  out["nrmse"] = Number(errors.nrmse);
  out["mse"] = Number(errors.mse);
  json rmse = json::object();
  for (std::size_t c = 0; c < errors.observe.size(); ++c)
    rmse[errors.observe[c]] = Number(errors.rmse[c]);
  out["rmse"] = rmse;
}

void to_json(json& out, const ResidualAnalysis& analysis) {
  out = json::object();
  if (!analysis.ok) {
    out["whiteness_p"] = nullptr;
    out["failed"] = analysis.reason;
    return;
  }
  out["whiteness_p"] = Number(analysis.whiteness_p);
  out["white"] = analysis.white;
  out["w_changes_sign"] = analysis.w_changes_sign;
  out["feedback_p"] = Number(analysis.feedback_p);
  out["closed_loop"] = analysis.closed_loop;
  json columns = json::object();
  for (const auto& d : analysis.columns) {
    json c;
    c["mean"] = Number(d.mean);
    c["rms"] = Number(d.rms);
    c["whiteness_p"] = Number(d.whiteness_p);
    c["ljung_box_q"] = Number(d.ljung_box_q);
    c["ljung_box_lags"] = d.ljung_box_lags;
    c["acf"] = d.acf;
    c["acf_band95"] = Number(d.acf_band95);
    c["input_ccf"] = {{"lags", d.input_ccf.empty() ? 0 : static_cast<int>(d.input_ccf.size() / 2)},
                      {"values", d.input_ccf},
                      {"peak", Number(d.input_ccf_peak)},
                      {"peak_lag", d.input_ccf_peak_lag},
                      {"band95", Number(d.input_ccf_band95)}};
    if (!d.future_ccf.empty()) {
      c["future_ccf"] = {{"values", d.future_ccf},
                         {"peak", Number(d.feedback_peak)},
                         {"peak_lead", d.feedback_peak_lead},
                         {"p", Number(d.feedback_p)}};
    }
    auto sign = [](const SignDependence& s) {
      if (!s.available) return json(nullptr);
      return json{{"mean_positive", Number(s.mean_positive)},
                  {"mean_negative", Number(s.mean_negative)},
                  {"count_positive", s.count_positive},
                  {"count_negative", s.count_negative},
                  {"t", Number(s.t_statistic)}};
    };
    c["by_sign_of_w"] = sign(d.sign_w);
    c["by_sign_of_i"] = sign(d.sign_i);
    json peaks = json::array();
    for (const auto& p : d.angle_peaks) {
      json peak = {{"order_per_rev", p.order},
                   {"amplitude", Number(p.amplitude)},
                   {"ratio_to_floor", Number(p.ratio)}};
      if (p.electrical_multiple > 0.0) peak["electrical_multiple"] = Number(p.electrical_multiple);
      peaks.push_back(peak);
    }
    c["angle_spectrum_peaks"] = d.shaft_turned ? peaks : json(nullptr);
    columns[d.column] = c;
  }
  out["columns"] = columns;
}

json AdequacyJson(const AdequacyReport& a) {
  json out = json::object();
  out["ok"] = a.ok;
  if (!a.ok) {
    out["failed"] = a.reason;
    return out;
  }
  out["adequate"] = a.adequate();
  out["family_level"] = Number(a.family_level);
  out["min_share"] = Number(a.min_share);
  auto test_json = [](const StructureTest& t) {
    json j = {{"state", t.state},       {"column", t.column},     {"regressors", t.regressors},
              {"f", Number(t.f)},       {"p", Number(t.p_value)}, {"share", Number(t.share)},
              {"ar_order", t.ar_order}, {"flagged", t.flagged}};
    if (t.state == "t (periodic)") {
      j["frequency_hz"] = Number(t.frequency_hz);
      if (t.input_harmonic > 0) j["input_harmonic"] = t.input_harmonic;
    }
    if (t.state == "theta (periodic)") j["order_per_rev"] = t.order;
    if (t.state == "u (past)") {
      j["lags"] = t.lags;
      if (t.frequency_hz > 0.0) j["frequency_hz"] = Number(t.frequency_hz);
      if (t.lag_s > 0.0) j["measurement_lag_s"] = Number(t.lag_s);
    }
    return j;
  };
  json tests = json::array();
  for (const auto& t : a.tests) tests.push_back(test_json(t));
  out["tests"] = tests;
  json flagged = json::array();
  for (const auto& t : a.flagged) {  // each name once (a state flagged in two columns)
    if (std::find(flagged.begin(), flagged.end(), t.Describe()) == flagged.end()) {
      flagged.push_back(t.Describe());
    }
  }
  out["depends_on"] = flagged;
  json stability = json::object();
  stability["checked"] = a.stability_checked;
  if (!a.stability_checked) {
    stability["reason"] = a.stability_reason;
  } else {
    stability["parts"] = a.parts;
    json parameters = json::array();
    for (const auto& s : a.stability) {
      parameters.push_back({{"effect", s.effect},
                            {"parameter", s.parameter},
                            {"first", Number(s.first)},
                            {"second", Number(s.second)},
                            {"first_std", Number(s.first_std)},
                            {"second_std", Number(s.second_std)},
                            {"z", Number(s.z)},
                            {"limit", Number(s.limit)},
                            {"unstable", s.unstable},
                            {"near_bound", s.near_bound}});
    }
    stability["parameters"] = parameters;
    stability["unstable"] = a.unstable;
  }
  out["stability"] = stability;
  return out;
}

void to_json(json& out, const DiscoveryReport& d) {
  out = json::object();
  out["added"] = d.added;
  out["steps"] = json::array();
  for (const auto& step : d.steps) out["steps"].push_back(StepJson(step));
  out["ambiguous"] = json::array();
  for (const auto& group : d.ambiguous) {
    json models = json::array();
    for (const auto& m : group.models) {
      models.push_back({{"effect", m.effect},
                        {"nrmse", Number(m.nrmse)},
                        {"delta_bic", Number(m.delta_bic)},
                        {"parameters", NumberMap(m.parameters)}});
    }
    out["ambiguous"].push_back(
        {{"effects", group.effects}, {"reason", group.reason}, {"models", models}});
  }
  out["last_round"] = CandidatesJson(d.last_round);
  if (!d.unstable.empty()) out["unstable"] = CandidatesJson(d.unstable);
  out["conclusion"] = d.conclusion;
  out["error_before"] = d.error_before;
  out["error_after"] = d.error_after;
  json after = json::object();
  for (const auto& e : d.parameters_after) after[e.name] = Number(e.value);
  out["parameters_after"] = after;
  out["intervals_after"] = Intervals(d.parameters_after);
  out["effects_after"] = d.effects_after;
  out["residual_after"] = d.residual_after;
  out["noise_floor"] = Number(d.noise_floor_nrmse);
  if (!d.cross_validation_parts.empty()) out["cross_validation_parts"] = d.cross_validation_parts;
  if (d.has_adequacy) out["adequacy"] = AdequacyJson(d.adequacy);
  if (d.has_validation) {
    out["validation"] = {{"before", d.validation_before}, {"after", d.validation_after}};
    if (d.equation_error)
      out["validation"]["simulated_after"] = ToJson(d.validation_simulated_after);
  }
  if (d.equation_error) out["simulated_after"] = ToJson(d.simulated_after);
  json before = json::object();
  ModelJson(d.before, &before);
  out["before"] = before;
  SanitizeJson(&out);
}

void to_json(json& out, const IdentReport& report) {
  out = json::object();
  out["tool"] = "blmd-ident";
  out["version"] = kVersion;
  out["schema_version"] = kReportSchemaVersion;
  out["model"] = report.model;
  json simulation = {{"method", SimulationMethodName(report.simulation_method)},
                     {"dt", report.simulation_dt}};
  if (report.simulation_method == SimulationMethod::kEvents)
    simulation["max_step"] = report.simulation_max_step;
  out["config"] = {{"path", report.config_path},
                   {"name", report.config_name},
                   {"effects", report.config_effects},
                   {"simulation", simulation}};
  json traces = json::array();
  for (const auto& t : report.traces) {
    json entry = {{"path", t.path}, {"samples", t.samples}, {"sha256", t.sha256}};
    if (t.has_errors) {
      entry["rmse"] = NumberMap(t.rmse);
      entry["nrmse"] = Number(t.nrmse);
    }
    traces.push_back(entry);
  }
  if (!report.traces.empty()) {
    const TraceReport& first = report.traces.front();
    out["trace"] = {{"path", first.path}, {"samples", first.samples}, {"sha256", first.sha256}};
  }
  out["traces"] = traces;
  ModelJson(report.final_model, &out);
  if (report.discovery) out["discovery"] = *report.discovery;
  if (report.linear_model.available || !report.linear_model.reason.empty()) {
    out["linear_model"] = LinearModelJson(report.linear_model);
  }
  if (report.frequency_response)
    out["frequency_response"] = FrequencyResponseJson(*report.frequency_response);
  if (report.step_response) out["step_response"] = StepResponseJson(*report.step_response);
  if (report.baseline) {
    const BaselineReport& b = *report.baseline;
    json parameters = json::object();
    for (const auto& p : b.parameters) {
      json entry = {{"verdict", p.verdict}, {"baseline", Number(p.baseline)}};
      if (!p.reason.empty()) entry["reason"] = p.reason;
      if (p.verdict != "not_compared") {
        entry["value"] = Number(p.value);
        entry["shift"] = Number(p.shift);
        entry["relative_shift"] = Number(p.baseline != 0.0 ? p.shift / p.baseline : NAN);
        entry["combined_limit"] = Number(p.combined_limit);
        entry["ci95"] = Pair(p.ci95_low, p.ci95_high);
        entry["baseline_ci95"] = Pair(p.baseline_ci95_low, p.baseline_ci95_high);
      }
      parameters[p.name] = entry;
    }
    out["baseline"] = {{"path", b.path},
                       {"sha256", b.sha256},
                       {"verdict", b.changed() ? "changed" : "unchanged"},
                       {"moved", b.moved},
                       {"parameters", parameters}};
  }
  if (!report.noise.columns.empty()) {
    json columns = json::object();
    for (const auto& c : report.noise.columns) {
      json entry = {{"std", Number(c.std)},
                    {"source", c.source},
                    {"weight", Number(c.weight)},
                    {"residual_rms", Number(c.residual_std)}};
      if (c.quantum > 0.0) entry["quantum"] = Number(c.quantum);
      if (c.std_per_trace.size() > 1) entry["std_per_trace"] = c.std_per_trace;
      columns[c.column] = entry;
    }
    out["noise"] = {{"weighting", report.noise.weighting},
                    {"fits", report.noise.fits},
                    {"evaluations", report.noise.evaluations},
                    {"converged", report.noise.converged},
                    {"columns", columns}};
  }
  if (report.cutoff && report.cutoff->ran) {
    const CutoffChoice& c = *report.cutoff;
    json levels = json::array();
    for (const CutoffLevel& level : c.levels) {
      json entry = {{"hz", Number(level.hz)}, {"ok", level.ok}};
      if (level.ok) {
        json values = json::object();
        for (const ParameterEstimate& e : level.estimates) {
          json v = {{"value", Number(e.value)}};
          if (e.has_interval) v["ci95"] = {Number(e.ci95_low), Number(e.ci95_high)};
          values[e.name] = v;
        }
        entry["parameters"] = values;
        entry["agrees_with_next_lower"] = level.agrees_below;
      } else {
        entry["reason"] = level.reason;
      }
      levels.push_back(entry);
    }
    json cutoff = {
        {"hz", Number(c.chosen_hz)}, {"user_set", c.user_set},   {"sample_hz", Number(c.sample_hz)},
        {"plateau", c.plateau},      {"sensitive", c.sensitive}, {"reason", c.reason},
        {"levels", levels}};
    if (c.plateau) cutoff["stable_hz"] = {Number(c.stable_low_hz), Number(c.stable_high_hz)};
    out["equation_cutoff"] = cutoff;
  }
  if (!report.notes.empty()) out["notes"] = report.notes;
  if (report.adequacy) out["adequacy"] = AdequacyJson(*report.adequacy);
  json warnings = json::array();
  for (const auto& w : report.warnings)
    warnings.push_back({{"code", w.code}, {"message", w.message}});
  out["warnings"] = warnings;
  SanitizeJson(&out);
}

}  // namespace blmd
