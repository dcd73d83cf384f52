// Building the typed report (report.h) from a fit, discovery's result and the traces; the
// warnings and the widening for ambiguity work on the typed value.
#include "blmd/report/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "blmd/error.h"
#include "blmd/sim/effects.h"
#include "blmd/sim/model.h"
#include "report/text.h"

namespace blmd {
namespace {

using internal::Figure;

// An estimate on a bound is the bound's answer, not the data's: its interval means little,
// and a wider bound (or another model) is needed. Within 1e-6 of the range, and (linear
// scale) closer to the bound than a hundredth of its standard deviation: Cd = 4.3e-7 +-
// 2.8e-8 on [0, 1] is within 1e-6 of the range but forty deviations from 0, a value the
// data set, not the bound.
bool AtBound(const FreeParameter& fp, const ParameterEstimate& e) {
  const BoundDistance d = DistanceToBounds(fp, e.value);
  const double std_search = e.has_interval && !fp.log_scale ? e.std : 0.0;
  auto near = [&](double distance) {
    return distance <= 1e-6 * d.span && (std_search <= 0.0 || distance <= 0.01 * std_search);
  };
  return near(d.below) || near(d.above);
}

std::map<std::string, ParameterReport> Parameters(const FitProblem& problem,
                                                  const FitResult& result) {
  const Config& config = problem.config();
  std::map<std::string, ParameterReport> parameters;
  for (const auto& e : result.estimates) {
    ParameterReport p;
    p.estimate = e;
    p.unit = ParameterUnit(config, e.name);
    for (const auto& fp : problem.free()) {
      if (fp.name != e.name) continue;
      p.has_bounds = true;
      p.lower = fp.lower;
      p.upper = fp.upper;
      // A share's ends are its physical domain's (all of the damping on one side): a finding,
      // not the search box deciding (ParamInfo::share).
      const bool domain_end =
          IsShareParameter(e.name) && (e.value <= 1e-6 || e.value >= 1.0 - 1e-6);
      p.at_bound = AtBound(fp, e) && !domain_end;
    }
    parameters[e.name] = p;
  }
  for (const auto& [name, value] : result.extra_estimates) {
    if (parameters.count(name) != 0) continue;
    ParameterReport p;
    p.estimate.name = name;
    p.estimate.value = value;
    p.free = false;
    p.unit = ParameterUnit(config, name);
    parameters[name] = p;
  }
  return parameters;
}

std::vector<TraceReport> Traces(const FitProblem& problem, const Evaluation& evaluation) {
  std::vector<TraceReport> traces;
  for (std::size_t k = 0; k < problem.traces().size(); ++k) {
    const FitTrace& t = problem.traces()[k];
    TraceReport entry;
    entry.path = t.path;
    entry.samples = t.trace.rows();
    entry.sha256 = t.sha256;
    entry.has_errors = evaluation.ok;
    if (evaluation.ok) {
      double normalised = 0.0;
      for (std::size_t c = 0; c < problem.observe().size(); ++c) {
        entry.rmse[problem.observe()[c]] = std::sqrt(evaluation.mse_per_trace[k][c]);
        normalised += evaluation.mse_per_trace[k][c] / problem.variance()[c];
      }
      entry.nrmse = std::sqrt(normalised / static_cast<double>(problem.observe().size()));
    }
    traces.push_back(std::move(entry));
  }
  return traces;
}

std::vector<std::string> FreeNames(const FitProblem& problem) {
  std::vector<std::string> names;
  for (const auto& p : problem.free()) names.push_back(p.name);
  return names;
}

ModelReport MakeModelReport(const ReportInputs& inputs) {
  const FitProblem& problem = *inputs.problem;
  const FitResult& result = *inputs.result;
  const Config& config = problem.config();
  ModelReport model;
  model.method = result.summary.method;
  model.effects = config.effects;
  model.parameters = Parameters(problem, result);
  model.summary = result.summary;
  model.seed = inputs.seed;
  model.threads = inputs.threads;

  FitReport& fit = model.fit;
  fit.errors = ComputeErrors(problem, result.values);
  fit.observe = problem.observe();
  if (problem.equation_error()) {
    fit.equation_error = true;
    fit.filter_hz = problem.equation_traces().front().cutoff_hz;
    fit.decimate = problem.equation_traces().front().decimate;
    for (std::size_t k = 0; k < problem.traces().size(); ++k)
      fit.samples += problem.measured(k).rows();
    fit.simulated = SimulatedErrors(problem, config, FreeNames(problem), result.values);
  }

  if (fit.errors.ok) model.residual.analysis = AnalyseResidual(problem, result.values);
  model.correlation = EstimateParameterCorrelation(problem, result);
  model.derived = EstimateDerived(problem, result, model.correlation);
  // Intervals that take the residuals as white are optimistic when they are not; the HAC
  // sandwich's account for the correlation (docs/uncertainty.md).
  bool any_white_interval = false;
  for (const auto& e : result.estimates) {
    any_white_interval =
        any_white_interval || (e.has_interval && e.interval_method != "hac_prewhitened" &&
                               e.interval_method != "leave_one_trace_out");
  }
  const ResidualAnalysis* analysis = model.residual.analysis ? &*model.residual.analysis : nullptr;
  if (any_white_interval && analysis && analysis->ok && !analysis->white) {
    model.residual.note =
        "the residual is not white: the intervals assume white noise and are optimistic";
    model.intervals_optimistic = true;
  }

  if (inputs.validation) {
    ValidationReport validation;
    validation.errors = ComputeErrors(*inputs.validation, result.values);
    for (const auto& t : inputs.validation->traces()) validation.traces.push_back(t.path);
    if (inputs.validation->equation_error()) {
      validation.equation_error = true;
      validation.simulated = SimulatedErrors(*inputs.validation, inputs.validation->config(),
                                             FreeNames(problem), result.values);
    }
    model.validation = std::move(validation);
  }
  return model;
}

// The competing models of an ambiguous group: the last round's fitted candidates.
std::vector<AmbiguousGroup> AmbiguousGroups(const DiscoveryResult& result) {
  std::vector<AmbiguousGroup> groups;
  for (std::size_t g = 0; g < result.ambiguous.size(); ++g) {
    AmbiguousGroup group;
    group.effects = result.ambiguous[g];
    group.reason = result.ambiguity_reason;
    const std::vector<CandidateOutcome>& round =
        g < result.ambiguous_models.size() ? result.ambiguous_models[g] : result.last_round;
    for (const auto& effect : group.effects) {
      for (const auto& o : round) {
        if (o.effect != effect || !o.fitted) continue;
        group.models.push_back({o.effect, o.nrmse, o.delta_bic, o.model_parameters});
      }
    }
    groups.push_back(std::move(group));
  }
  return groups;
}

}  // namespace

std::optional<SimulatedFit> SimulatedErrors(const FitProblem& problem, const Config& config,
                                            const std::vector<std::string>& free,
                                            const std::vector<double>& values) {
  if (!problem.equation_error()) return std::nullopt;
  Config output = config;
  output.identification.error = "output";
  const std::string column = problem.traces().front().trace.Has("w") ? "w" : "theta";
  for (const auto& t : problem.traces()) {
    if (!t.trace.Has(column)) return std::nullopt;
  }
  SimulatedFit simulated;
  try {
    const FitProblem problem_as_simulation(output, problem.traces(), {column},
                                           NamedFreeParameters(free));
    simulated.column = column;
    simulated.errors = ComputeErrors(problem_as_simulation, values);
  } catch (const InputError& error) {
    simulated.errors.ok = false;
    simulated.errors.reason = error.what();
  }
  return simulated;
}

IdentReport MakeReport(const ReportInputs& inputs) {
  const Config& config = inputs.problem->config();
  IdentReport report;
  report.model = std::string(config.model->name());
  report.config_path = inputs.config_path;
  report.config_name = config.name;
  report.config_effects = config.effects;
  report.simulation_method = config.simulation.method;
  report.simulation_dt = config.simulation.dt;
  report.simulation_max_step = config.simulation.max_step;
  report.traces = Traces(*inputs.problem, inputs.result->evaluation);
  report.final_model = MakeModelReport(inputs);
  return report;
}

DiscoveryReport MakeDiscoveryReport(const FitProblem& problem, const FitResult& initial,
                                    const DiscoveryResult& result,
                                    const FitProblem* validation_before,
                                    const FitProblem* validation_after) {
  DiscoveryReport report;
  report.added = result.added;
  report.steps = result.steps;
  report.ambiguous = AmbiguousGroups(result);
  report.last_round = result.last_round;
  report.unstable = result.unstable;
  report.conclusion = result.conclusion;
  report.noise_floor_nrmse = result.noise_floor_nrmse;
  report.cross_validation_parts = result.cross_validation_parts;
  report.has_adequacy = result.adequacy.ok || !result.adequacy.reason.empty();
  report.adequacy = result.adequacy;
  const FitProblem final_problem(result.final_config, problem.traces(), problem.observe(),
                                 NamedFreeParameters(result.final_free));
  const std::vector<double>& values = result.final_fit.values;
  report.error_before = ComputeErrors(problem, initial.values);
  report.error_after = ComputeErrors(final_problem, values);
  report.parameters_after = result.final_fit.estimates;
  report.effects_after = result.final_config.effects;
  report.residual_after = AnalyseResidual(final_problem, values);
  if (validation_before && validation_after) {
    report.has_validation = true;
    report.validation_before = ComputeErrors(*validation_before, initial.values);
    report.validation_after = ComputeErrors(*validation_after, values);
  }
  if (problem.equation_error()) {
    report.equation_error = true;
    report.simulated_after =
        SimulatedErrors(problem, result.final_config, result.final_free, values);
    if (report.has_validation) {
      report.validation_simulated_after =
          SimulatedErrors(*validation_after, result.final_config, result.final_free, values);
    }
  }
  return report;
}

IdentReport FinalModelReport(IdentReport final_report, const IdentReport& first_report,
                             DiscoveryReport discovery) {
  discovery.before = first_report.final_model;
  final_report.discovery = std::move(discovery);
  final_report.config_effects = first_report.config_effects;
  return final_report;
}

std::vector<StepParameter> StepParameters(const DiscoveryStep& step) {
  std::map<std::string, StepParameter> by_name;
  for (const auto& e : step.effect_parameters) by_name[e.name] = {e.name, e.value, &e};
  for (const auto& [name, value] : step.fixed_parameters) by_name[name] = {name, value, nullptr};
  std::vector<StepParameter> parameters;
  for (auto& [name, parameter] : by_name) parameters.push_back(parameter);
  return parameters;
}

void AddLinearViews(IdentReport* report, const FitProblem& problem, const Config& final_config,
                    const ParameterSet& final_parameters) {
  report->linear_model = final_config.model->Linearise(final_parameters);
  report->frequency_response = MakeFrequencyResponseReport(problem, report->linear_model);
  report->step_response = MakeStepResponseReport(report->linear_model);
}

void WidenForAmbiguity(IdentReport* report) {
  if (!report->discovery) return;
  auto& parameters = report->final_model.parameters;
  for (const auto& group : report->discovery->ambiguous) {
    for (const auto& model : group.models) {
      for (const auto& [name, v] : model.parameters) {
        const auto found = parameters.find(name);
        if (found == parameters.end() || !std::isfinite(v)) continue;
        ParameterReport& p = found->second;
        ParameterEstimate& e = p.estimate;
        if (!p.free || !e.has_interval || !std::isfinite(e.ci95_low) || !std::isfinite(e.ci95_high))
          continue;
        if (v >= e.ci95_low && v <= e.ci95_high) continue;
        if (!p.widened_by_ambiguity) {
          p.widened_by_ambiguity = true;
          p.ci95_before_ambiguity_low = e.ci95_low;
          p.ci95_before_ambiguity_high = e.ci95_high;
          e.interval_method += "+ambiguity";
        }
        e.ci95_low = std::min(e.ci95_low, v);
        e.ci95_high = std::max(e.ci95_high, v);
      }
    }
  }
}

namespace {

// The warning of a cut-off off the plateau (cutoff_choice.h): how the estimates move, where
// they hold, and the flag that uses it.
std::string CutoffWarning(const CutoffChoice& choice) {
  const auto hz = [](double v) { return Figure(v, 3) + " Hz"; };
  std::string moves;
  const CutoffLevel* used = nullptr;
  for (const CutoffLevel& level : choice.levels) {
    if (level.ok && level.hz == choice.chosen_hz) used = &level;
  }
  if (used && !used->estimates.empty()) {
    const ParameterEstimate& first = used->estimates.front();
    moves = first.name + " is " + Figure(first.value, 4) + " at " + hz(used->hz);
    for (const CutoffLevel& level : choice.levels) {
      if (!level.ok || &level == used || level.estimates.empty()) continue;
      moves += ", " + Figure(level.estimates.front().value, 4) + " at " + hz(level.hz);
    }
    moves += ": ";
  }
  const std::string start = "the equation error's estimates move with its low-pass cut-off (" +
                            moves +
                            "beyond their 95 % intervals): the differentiated motion's "
                            "noise biases J towards zero at high cut-offs";
  if (choice.plateau) {
    return start + "; they hold from " + hz(choice.stable_low_hz) + " to " +
           hz(choice.stable_high_hz) + "; next: --filter-hz " + Figure(choice.stable_high_hz, 3);
  }
  return start +
         "; no two neighbouring cut-offs agree; next: a record with more acceleration "
         "or a finer encoder, or the output error (--error output) where the motion "
         "can be simulated";
}

}  // namespace

std::string ClosedLoopAdvice(const IdentReport& report) {
  const ModelReport& first = report.first_fit();
  if (first.fit.equation_error || !first.residual.analysis ||
      !first.residual.analysis->closed_loop) {
    return "";
  }
  std::string text =
      "the record is closed loop (u was computed from the measured motion: u at the "
      "same and later samples follows the residual, p = " +
      Figure(first.residual.analysis->feedback_p, 2) +
      "), and a simulation from the recorded u drifts wherever the model errs, "
      "since the loop that held the real shaft is not simulated";
  if (FindModel(report.model).traits().input_is_torque) {
    return text +
           "; fit the equation error (--error equation, the input the model needs along "
           "the measured motion), then --discover";
  }
  return text +
         "; fit a record of the drive in open loop (a torque or voltage command it "
         "applies as given)";
}

// What a residual that follows the input's past means (the input-residual test, docs/
// discovery.md §7b), when one of `adequacy`'s flagged tests is that test: "" otherwise. The
// vocabulary's effects but the two-mass coupling are static torques of the state; none of
// them makes a response to the input's history, so the warning names the kinds of dynamics
// that do and what the values still mean.
std::string DynamicsMeaning(const AdequacyReport& adequacy) {
  const auto past = std::find_if(adequacy.flagged.begin(), adequacy.flagged.end(),
                                 [](const StructureTest& t) { return t.state == "u (past)"; });
  if (past == adequacy.flagged.end()) return "";
  if (past->lag_s > 0.0) {
    return "; the measured " + past->column + " lags the model by about " +
           Figure(1e3 * past->lag_s, 2) +
           " ms, as a sensor, a filter or a logger makes (the model has no measurement delay); "
           "where the speed column has a sensor or estimator of its own (a tachometer, a "
           "filtered estimate) and the trace has the angle, fit the speed derived from the "
           "angle (--derive w=theta)";
  }
  const bool where = past->frequency_hz > 0.0;
  return "; the residual follows the input's past" +
         (where ? " (most near " + Figure(past->frequency_hz, 3) + " Hz)" : std::string()) +
         ": dynamics the model lacks, such as a flexible coupling's resonance (the two-mass "
         "effect, which --discover tries), a lag in the current loop, or a filter, which no "
         "other effect of the vocabulary makes. J is then the "
         "rigid part's (the total inertia below " +
         (where ? "that frequency" : std::string("those dynamics")) +
         "), and a loop tuned on it must keep its crossover well below " +
         (where ? "it" : std::string("them"));
}

void AddWarnings(IdentReport* report) {
  std::vector<Warning>& warnings = report->warnings;
  warnings.clear();
  auto add = [&](const std::string& code, const std::string& message) {
    warnings.push_back({code, message});
  };
  const ModelReport& model = report->final_model;
  if (!model.summary.converged) {
    add("not_converged", "the fit did not converge (" +
                             nlohmann::json(model.summary.termination).dump() +
                             "): the values are where the method stopped, not a minimum");
  }
  const ErrorFigures& fit = model.fit.errors;
  if (fit.ok && std::isfinite(fit.nrmse) && fit.nrmse >= 1.0) {
    add("nrmse_at_least_one",
        "NRMSE " + Figure(fit.nrmse, 4) +
            " >= 1: the model explains the measured columns no better than their means");
  }
  if (model.validation) {
    const ErrorFigures& v = model.validation->errors;
    if (v.ok && std::isfinite(v.nrmse) && v.nrmse >= 1.0) {
      add("nrmse_at_least_one",
          "validation NRMSE " + Figure(v.nrmse, 4) +
              " >= 1: on the held-out traces the model is no better than the columns' means");
    }
  }
  // A residual that is merely coloured is no verdict on the model (the intervals allow for
  // correlated noise; notes). The model is inadequate when its residual depends on the input,
  // the states, the angle or the time beyond what a noise model explains: the adequacy check.
  const ResidualAnalysis* residual = model.residual.analysis ? &*model.residual.analysis : nullptr;
  const bool one_direction =
      residual && residual->ok && !residual->w_changes_sign && residual->w_max > 0.0;
  if (report->adequacy && report->adequacy->ok && !report->adequacy->flagged.empty()) {
    add("model_inadequate",
        report->adequacy->StructureMessage() +
            ": the model misses something that biases its values" +
            DynamicsMeaning(*report->adequacy) + "; next: " +
            (ClosedLoopAdvice(*report).empty() ? "run --discover to find the effect"
                                               : ClosedLoopAdvice(*report)) +
            (one_direction
                 ? "; the shaft turned one way only, so J and a constant torque (friction, a "
                   "load) are confounded: record motion in both directions"
                 : ""));
  }
  if (report->cutoff && report->cutoff->sensitive)
    add("cutoff_sensitive", CutoffWarning(*report->cutoff));
  bool any_at_bound = false;
  for (const auto& [name, p] : model.parameters)
    any_at_bound = any_at_bound || (p.free && p.at_bound);
  if (fit.ok && std::isfinite(fit.nrmse) && fit.nrmse >= 1.0 && any_at_bound) {
    add("not_a_fit",
        "NRMSE " + Figure(fit.nrmse, 4) +
            " >= 1 with parameters at their bounds: the model does not describe this trace at "
            "any value; check the column mapping (is u the drive's input, not the loop's "
            "reference or a command?), the columns' units and the model");
  }
  std::string no_interval;
  for (const auto& [name, p] : model.parameters) {
    if (!p.free) continue;
    const ParameterEstimate& e = p.estimate;
    if (p.has_bounds && p.at_bound) {
      // A positive parameter's default range spans three decades either side of its start
      // (docs/identification.md §2): a start a decade beyond the bound moves the range with it.
      const bool at_lower = std::abs(e.value - p.lower) <= std::abs(e.value - p.upper);
      const double beyond = at_lower ? 0.1 * p.lower : 10.0 * p.upper;
      const std::string next =
          p.lower > 0.0
              ? "next: start the search beyond it (--initial " + name + "=" + Figure(beyond, 3) +
                    ": the default range spans three decades either side of the start), or "
                    "widen identification.bounds; else change the model"
              : "next: widen identification.bounds, or change the model";
      add("parameter_at_bound", name + " = " + Figure(e.value, 6) + " is at its bound [" +
                                    Figure(p.lower, 4) + ", " + Figure(p.upper, 4) +
                                    "]: the bound, not the data, set it; " + next);
    }
    if (!e.has_interval) {
      no_interval += (no_interval.empty() ? "" : ", ") + name;
    } else if (std::isfinite(e.value) && std::isfinite(e.ci95_low) && std::isfinite(e.ci95_high) &&
               !IsPeriodicParameter(name)) {  // a phase has no scale to be ±50 % of
      // A share in [0, 1] is judged against its domain: poorly determined when its interval
      // is wider than the whole of it (more than ±0.5), whatever its value.
      const bool share = IsShareParameter(name);
      const double half = 0.5 * (e.ci95_high - e.ci95_low);
      if (!(half <= 0.5 * (share ? 1.0 : std::abs(e.value)))) {
        add("parameter_poorly_determined",
            name + " = " + Figure(e.value, 4) + " with a 95 % interval of [" +
                Figure(e.ci95_low, 4) + ", " + Figure(e.ci95_high, 4) +
                (share ? "] (wider than its range [0, 1])" : "] (more than ±50 %)") +
                ": these traces hardly determine it");
      }
    }
  }
  if (!no_interval.empty()) {
    const std::string& unavailable = model.summary.interval_unavailable;
    const std::string reason = unavailable.empty() ? "" : ": " + unavailable;
    add("interval_unavailable", "no interval for " + no_interval + reason);
  }
  for (const UnitsHint& hint : report->units_hints) {
    add("units_suspect", hint.evidence + ": is '" + hint.column + "' in " + hint.unit +
                             "? The model works in " + hint.model_unit +
                             "; if so, convert it with " + hint.ScaleFlag());
  }
  if (report->baseline) {
    std::string names;
    for (const auto& p : report->baseline->parameters) {
      if (p.verdict == "not_compared")
        names += (names.empty() ? "" : ", ") + p.name + " (" + p.reason + ")";
    }
    if (!names.empty()) {
      add("baseline_not_compared",
          "the drift guard could not judge " + names + ": a change there would go unnoticed");
    }
  }
  if (!report->discovery) {
    return;
  }
  const DiscoveryReport& discovery = *report->discovery;
  for (const auto& group : discovery.ambiguous) {
    std::string effects;
    for (const auto& e : group.effects) effects += (effects.empty() ? "" : ", ") + e;
    std::string models;
    for (const auto& m : group.models) {
      models += (models.empty() ? "" : "; ") + m.effect + ":";
      for (const char* name : {"J", "B"}) {
        const auto found = m.parameters.find(name);
        if (found != m.parameters.end())
          models += std::string(" ") + name + " = " + Figure(found->second, 4);
      }
      models += " (NRMSE " + Figure(m.nrmse, 4) + ")";
    }
    // Which headline parameters the choice moves: a model's value outside the final model's
    // own 95 % interval (before the widening).
    std::string agree, depend;
    for (const auto& [name, p] : report->final_model.parameters) {
      if (!p.free || !p.estimate.has_interval) continue;
      const double low = p.widened_by_ambiguity ? p.ci95_before_ambiguity_low : p.estimate.ci95_low;
      const double high =
          p.widened_by_ambiguity ? p.ci95_before_ambiguity_high : p.estimate.ci95_high;
      bool shared = false, inside = true;
      for (const auto& m : group.models) {
        const auto found = m.parameters.find(name);
        if (found == m.parameters.end()) continue;
        shared = true;
        inside = inside && found->second >= low && found->second <= high;
      }
      if (!shared) continue;
      std::string& list = inside ? agree : depend;
      list += (list.empty() ? "" : ", ") + name;
    }
    std::string added;
    for (const auto& step : discovery.steps) {
      if (!step.ambiguous_with.empty()) added = step.effect;
    }
    add("discovery_ambiguous",
        "discovery could not tell " + effects + " apart (" + group.reason + "); " +
            (added.empty() ? std::string("it added neither")
                           : "it added " + added + ", the best by BIC") +
            "; the competing models: " + (models.empty() ? "see discovery.ambiguous" : models) +
            (agree.empty() ? std::string() : "; " + agree + " agree across them") +
            (depend.empty() ? std::string()
                            : "; " + depend +
                                  " depend on the choice (the intervals cover every "
                                  "model's value)"));
  }
  if (!discovery.unstable.empty()) {
    std::string names;
    for (const auto& o : discovery.unstable) names += (names.empty() ? "" : ", ") + o.effect;
    add("decision_unstable",
        "whether to add " + names +
            " hinges on the data's last bits or is too close to call: a change far below "
            "their noise moves, or could move, its evidence, its cross-validated verdict or "
            "whether the record's parts can judge it (discovery.unstable, each with its "
            "reason), so it was not added (a chaotic record, e.g. a simulated shaft settling in "
            "one detent or the next, or parts that predict each other about as well as the "
            "limit for judging a candidate). Next: a record that keeps the shaft moving "
            "through the effect's field (a higher or steadier speed), or a held-out record "
            "(--validate) to judge it");
  }
  if (discovery.has_adequacy && discovery.adequacy.ok && !discovery.adequacy.flagged.empty()) {
    add("unexplained_structure",
        discovery.adequacy.StructureMessage() +
            ": the final model misses something that no effect of the vocabulary explains; the "
            "values may be biased by it (discovery.adequacy)" +
            DynamicsMeaning(discovery.adequacy) +
            (ClosedLoopAdvice(*report).empty() ? std::string()
                                               : "; next: " + ClosedLoopAdvice(*report)));
  }
  for (const std::string& effect : discovery.adequacy.unstable) {
    std::string detail;
    for (const auto& s : discovery.adequacy.stability) {
      if (s.effect != effect || !s.unstable) continue;
      detail += (detail.empty() ? "" : "; ") + s.parameter + " " + Figure(s.first, 4) +
                " against " + Figure(s.second, 4) + " (z = " + Figure(s.z, 3) + ")";
    }
    add("effect_unstable", effect + "'s parameters differ between " + discovery.adequacy.parts +
                               " beyond their intervals (" + detail +
                               "): it may stand in for something that changes over the record");
  }
  const ErrorFigures& before = discovery.validation_before;
  const ErrorFigures& after = discovery.validation_after;
  if (discovery.has_validation && before.ok && after.ok && std::isfinite(before.nrmse) &&
      std::isfinite(after.nrmse) && after.nrmse > before.nrmse) {
    add("validation_worse_after_discovery",
        "the validation NRMSE rose from " + Figure(before.nrmse, 4) + " to " +
            Figure(after.nrmse, 4) +
            " when discovery added effects: they may fit the fit traces' noise, not the "
            "motor; compare with discovery.before");
  }
}

}  // namespace blmd
