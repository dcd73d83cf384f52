#include "blmd/app/identify.h"

#include <algorithm>
#include <string>
#include <thread>
#include <utility>

#include "blmd/app/baseline.h"
#include "blmd/error.h"
#include "blmd/format.h"
#include "blmd/ident/fit/cutoff_choice.h"
#include "blmd/ident/fit/progress.h"
#include "blmd/ident/optimizers/trace_jackknife.h"
#include "blmd/ident/residual/adequacy.h"
#include "blmd/io/csv.h"
#include "blmd/report/export.h"
#include "blmd/report/report.h"
#include "blmd/run.h"

namespace blmd {
namespace {

// Begins a stage of the progress (progress.h), if there is one.
void Stage(ProgressObserver* progress, std::string name, int steps = 0) {
  if (progress) progress->BeginStage(std::move(name), steps);
}

// The spread between traces in the intervals (trace_jackknife.h): K refits, K >= 3, the
// stage "<stage_prefix>leave-one-trace-out refits" of the progress.
FitResult WidenedByTraces(const FitProblem& problem, const FitResult& fit,
                          const OptimizerOptions& options, const std::string& stage_prefix) {
  FitResult copy = fit;
  if (fit.evaluation.ok && fit.summary.converged && problem.traces().size() >= 3) {
    Stage(options.progress, stage_prefix + "leave-one-trace-out refits",
          static_cast<int>(problem.traces().size()));
    WidenByTraceJackknife(problem, LeaveOneTraceOut(problem, fit.values, options), &copy);
  }
  return copy;
}

// The settings that shaped the fit, as the run applied them (the config's, then the flags'),
// into the final model's config: --write-config writes them, so that a refit from the written
// config reproduces the report (docs/export.md §1). The equation error's cut-off is written
// as used, also where it was the default.
void RecordFitSettings(const IdentRequest& request, const FitProblem& problem, Config* config) {
  IdentificationSettings& ident = config->identification;
  ident.method = request.method;
  ident.options = request.options.method_options.is_object() ? request.options.method_options
                                                             : nlohmann::json::object();
  ident.observe = request.observe;
  ident.weighting = request.noise.weighting;
  ident.noise_std = request.noise.std;
  if (problem.equation_error() && !problem.equation_traces().empty()) {
    ident.filter_hz = problem.equation_traces().front().cutoff_hz;
  }
}

// The equation error's cut-off (ident/fit/cutoff_choice.h, docs/identification.md §8a): the
// fit at each cut-off of the ladder, the plateau where the estimates hold, and the cut-off in
// use (the user's, else the plateau's highest) written into the config.
CutoffChoice ChooseEquationCutoff(IdentRequest* request, const Optimizer& optimizer) {
  CutoffChoice choice;
  Config& config = request->config;
  IdentificationSettings& ident = config.identification;
  if (ident.error != "equation" || request->traces.empty()) return choice;
  const double user_hz = ident.filter_hz;
  Config probe = config;
  probe.identification.filter_hz = 0.0;  // the record's own rate: sample rate / 10
  const FitProblem at_default(probe, request->traces, request->observe, request->free);
  if (at_default.equation_traces().empty()) return choice;
  choice.ran = true;
  choice.user_set = user_hz > 0.0;
  choice.sample_hz = 10.0 * at_default.equation_traces().front().cutoff_hz;
  choice.chosen_hz = user_hz;
  OptimizerOptions options = request->options;
  options.progress = nullptr;
  for (double hz : CutoffLadder(choice.sample_hz, user_hz)) {
    CutoffLevel level;
    level.hz = hz;
    try {
      Config at = config;
      at.identification.filter_hz = hz;
      const FitProblem problem(at, request->traces, request->observe, request->free);
      FitResult fit = optimizer.Minimize(problem, options);
      // Each level in the box the first fit will search: a default range moved past the end
      // it stops on (start_scan.h), else the ladder would compare values pinned on one end.
      RangeMove moved = MoveDefaultRanges(optimizer, problem, fit, options);
      if (moved.problem) fit = std::move(moved.fit);
      level.ok = fit.evaluation.ok;
      level.estimates = fit.estimates;
      if (!level.ok) level.reason = fit.evaluation.reason;
    } catch (const InputError& error) {
      level.reason = error.what();  // a cut-off the record is too short for
    }
    choice.levels.push_back(std::move(level));
  }
  DecideCutoff(&choice);
  ident.filter_hz = choice.chosen_hz;
  return choice;
}

}  // namespace

namespace {

// A fit from the reference whose loop reaches the drive's limit (docs/identification.md §9b):
// the measurement noise the real loop fed back is clipped there, which the simulated loop (fed
// back the model's own noise-free motion) does not reproduce, and the damping comes out
// biased. The share of samples at which the final model's simulated command sits on a limit;
// a message when it exceeds 1 %, "" otherwise.
std::string SaturatedLoop(const FitProblem& problem, const IdentOutcome& outcome) {
  const PidSettings& pid = outcome.final_config.experiment.pid;
  std::size_t at_limit = 0, total = 0;
  for (const FitTrace& part : problem.traces()) {
    Config loop = outcome.final_config;
    loop.parameters = outcome.final_parameters;
    loop.experiment.initial = part.initial;
    Trace simulated;
    if (!RunRecordedInput(loop, part.input, &simulated).ok() || !simulated.Has("u")) continue;
    for (const double u : simulated.Column("u")) {
      at_limit += u >= pid.u_max * (1.0 - 1e-9) || u <= pid.LowerLimit() * (1.0 - 1e-9);
      ++total;
    }
  }
  if (total == 0 || static_cast<double>(at_limit) <= 0.01 * static_cast<double>(total)) return "";
  return "the drive's loop sits on its limit on " +
         FormatSignificant(100.0 * static_cast<double>(at_limit) / static_cast<double>(total), 3) +
         " % of the samples: there the real loop clipped the measurement noise it fed back, which "
         "a fit from the reference does not simulate, and B comes out biased (measured: 12 "
         "standard errors on records that reach the limit); fit from the logged command "
         "(--simulate-from command) where the record has one, or from a record that stays within "
         "the "
         "limit";
}

}  // namespace

IdentOutcome Identify(IdentRequest request) {
  IdentOutcome outcome;
  const Optimizer& optimizer = FindOptimizer(request.method);
  if (!request.baseline_path.empty()) {  // a bad baseline is refused before the work
    IdentReport model_only;
    model_only.model = std::string(request.config.model->name());
    CompareWithBaseline(model_only, request.baseline_path);
  }
  // The equation error's cut-off first: every fit below (and discovery) uses it.
  if (request.config.identification.error == "equation") {
    Stage(request.options.progress, "equation error: cut-off ladder");
  }
  const CutoffChoice cutoff = ChooseEquationCutoff(&request, optimizer);
  const FitProblem given(request.config, std::move(request.traces), request.observe, request.free);
  std::unique_ptr<FitProblem> validation;
  if (!request.validation.empty()) {
    validation = std::make_unique<FitProblem>(request.config, std::move(request.validation),
                                              request.observe, request.free);
  }
  const OptimizerOptions& options = request.options;
  ProgressObserver* const progress = options.progress;
  Stage(progress, "first fit (" + request.method + ")");
  // A local fit that stopped on a bound or far above the noise is restarted from the best
  // points of a scan of the bounds box (start_scan.h).
  FitResult given_fit = MinimizeWithStartScan(optimizer, given, options, &outcome.start_scan);
  // A default range the fit stopped on is moved past that end and the fit repeated (a start
  // far from this machine's values; start_scan.h): every step below works in the moved box.
  RangeMove range = MoveDefaultRanges(optimizer, given, given_fit, options);
  if (range.problem) {
    outcome.range_shifts = range.shifts;
    outcome.start_scan = range.start_scan;
  }
  const FitProblem& unweighted = range.problem ? *range.problem : given;
  const FitResult unweighted_fit = range.problem ? std::move(range.fit) : std::move(given_fit);
  // The cost weighted by each column's noise (noise_model.h): estimated from the residual,
  // refit from the optimum until the noise settles.
  Stage(progress, "noise-weighted refit (" + request.method + ")");
  outcome.problem = FitNoiseWeighted(unweighted, unweighted_fit, optimizer, options, request.noise,
                                     &outcome.first_fit, &outcome.noise);
  const FitProblem& problem = *outcome.problem;
  OptimizerOptions refit_options = options;
  refit_options.method_options = nlohmann::json::object();
  const FitResult first_result = WidenedByTraces(problem, outcome.first_fit, refit_options, "");

  ReportInputs inputs;
  inputs.config_path = request.config_path;
  inputs.problem = &problem;
  inputs.result = &first_result;
  inputs.validation = validation.get();
  inputs.seed = options.seed;
  inputs.threads = options.threads > 0
                       ? options.threads
                       : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  Stage(progress, "report");
  IdentReport report = MakeReport(inputs);
  report.noise = outcome.noise;
  outcome.final_config = problem.config();
  outcome.final_parameters = problem.Parameters(outcome.first_fit.values);
  outcome.final_free = problem.free();
  if (request.discover) {
    DiscoveryOptions discovery_options = request.discovery;
    discovery_options.refit.threads = options.threads;
    discovery_options.refit.seed = options.seed;
    discovery_options.refit.verbose = options.verbose;
    discovery_options.refit.progress = progress;
    if (validation) discovery_options.held_out = &validation->traces();
    // Discovery decides on the variance-weighted problem, as it was calibrated (its evidence
    // rules and studies, docs/discovery.md); the noise weights of the first model's residual
    // would hold that model's misfit. The final model is then refit with its own noise.
    outcome.discovery =
        std::make_unique<DiscoveryResult>(Discover(unweighted, unweighted_fit, discovery_options));
    const DiscoveryResult& discovery = *outcome.discovery;
    // The final model is the answer: its parameters, fit, residual and
    // validation head the report; the first fit moves to discovery.before.
    std::unique_ptr<FitProblem> final_problem = FinalProblem(unweighted, discovery);
    if (final_problem) {
      // The final model fitted once more as a plain fit of the written config would fit it
      // (the user's method and options, from discovery's values): discovery's last refit
      // stops on its own tolerances, where the user's method would still move, and a refit
      // from --write-config's file would then not reproduce this report.
      Stage(progress, "final model: fitted as a plain fit (" + request.method + ")");
      // Kept only where it converged and lowered the cost (or discovery's own fit failed): a
      // fit stopped by the user's budget is no better an answer than discovery's.
      FitResult polished = optimizer.Minimize(*final_problem, options);
      const FitResult& before = outcome.discovery->final_fit;
      if (polished.evaluation.ok && polished.summary.converged &&
          (!before.evaluation.ok || polished.evaluation.cost <= before.evaluation.cost)) {
        outcome.discovery->final_fit = std::move(polished);
      }
    }
    NoiseModel final_noise = outcome.noise;
    if (final_problem && outcome.noise.weighting == "noise") {
      // The final model's own residual sets its weights: the first model's residual held the
      // misfit of what discovery added.
      Stage(progress, "final model: noise-weighted refit");
      FitResult refit;
      final_problem = FitNoiseWeighted(*final_problem, discovery.final_fit, FindOptimizer("ceres"),
                                       refit_options, request.noise, &refit, &final_noise);
      if (refit.evaluation.ok) outcome.discovery->final_fit = std::move(refit);
    }
    std::unique_ptr<FitProblem> validation_after;
    if (validation) {
      validation_after =
          std::make_unique<FitProblem>(discovery.final_config, validation->traces(),
                                       request.observe, NamedFreeParameters(discovery.final_free));
    }
    DiscoveryReport block = MakeDiscoveryReport(unweighted, unweighted_fit, discovery,
                                                validation.get(), validation_after.get());
    IdentReport headline = report;
    if (final_problem) {
      outcome.final_config = final_problem->config();
      outcome.final_parameters = final_problem->Parameters(discovery.final_fit.values);
      outcome.final_free = final_problem->free();
      const FitResult final_result =
          WidenedByTraces(*final_problem, discovery.final_fit, refit_options, "final model: ");
      ReportInputs final_inputs = inputs;
      final_inputs.problem = final_problem.get();
      final_inputs.result = &final_result;
      final_inputs.validation = validation_after.get();
      Stage(progress, "final model: report");
      headline = MakeReport(final_inputs);
      headline.noise = final_noise;
    }
    report = FinalModelReport(std::move(headline), report, std::move(block));
  }
  if (!request.discover) {
    // A plain fit's verdict on its model: what its residual still depends on.
    Stage(progress, "adequacy check");
    // Materiality for this verdict: 0.5 % of the residual's variance (a structure of about 7 %
    // of the noise's amplitude); significance, family-wise 1e-3, is what keeps it off correct
    // models. Discovery's "unexplained" keeps its 10 % (what no effect may be left to explain).
    AdequacyOptions plain;
    plain.min_share = 0.005;
    report.adequacy = CheckResidualStructure(problem, outcome.first_fit.values, plain);
  }
  std::string saturated;  // a fit from the reference whose loop sits on its limit
  if (problem.config().identification.simulate_from == "reference") {
    saturated = SaturatedLoop(problem, outcome);
    report.notes.push_back(
        "identified from the reference: the fit simulates the drive's loop (experiment.pid) "
        "from each trace's r with the model inside it (the indirect approach), so the "
        "controller must be the drive's as written: the loop sees its gain over J, and a "
        "wrong gain moves J with it; a wrong rate, delay or limit shows in the residual");
  } else if (problem.config().experiment.closed_loop) {
    report.notes.push_back(
        "the config's experiment is a closed loop (experiment.pid): the fit replays each trace's "
        "recorded u open loop, so the loop's gains play no part (this is right when u is what "
        "the drive applied; it is not the loop's reference; --simulate-from reference fits from "
        "the "
        "loop's reference r instead)");
  }
  const ResidualAnalysis* left =
      report.final_model.residual.analysis ? &*report.final_model.residual.analysis : nullptr;
  if (left && left->ok && !left->white) {
    report.notes.push_back(
        "the residual is coloured (Ljung-Box p = " + FormatSignificant(left->whiteness_p, 3) +
        "): the intervals allow for correlated noise (prewhitened HAC); a "
        "missing effect would show in the adequacy check");
  }
  if (outcome.start_scan.improved) {
    const StartScanRecord& scan = outcome.start_scan;
    std::string start;
    for (std::size_t k = 0; k < scan.start.size() && k < unweighted.num_free(); ++k) {
      start +=
          (k ? ", " : "") + unweighted.free()[k].name + " = " + FormatSignificant(scan.start[k], 4);
    }
    report.notes.push_back(
        std::string("the local fit from the ") +
        (outcome.range_shifts.empty() ? "config's start" : "moved range's start") +
        " stopped in a side valley (" + scan.reason + "); a scan of " +
        std::to_string(scan.points) + " points of the bounds box and a fit from its best (" +
        start + ") reached NRMSE " + FormatSignificant(scan.nrmse_final, 4) +
        " (docs/identification.md §2a)");
  }
  if (!outcome.range_shifts.empty()) {
    std::string moved;
    for (const RangeShift& shift : outcome.range_shifts) {
      moved += (moved.empty() ? "" : "; ") + shift.name + " from [" +
               FormatSignificant(shift.from_lower, 4) + ", " +
               FormatSignificant(shift.from_upper, 4) + "] to [" +
               FormatSignificant(shift.to_lower, 4) + ", " + FormatSignificant(shift.to_upper, 4) +
               "]";
    }
    report.notes.push_back(
        "the first fit stopped on an end of a default search range (three decades either side "
        "of the config's start, which is far from this record's values): the range was moved "
        "past that end and the fit repeated from it, " +
        moved + " (docs/identification.md §2b)");
  }
  RecordFitSettings(request, problem, &outcome.final_config);
  // A record whose u follows the residual was made in closed loop (diagnostics.h, feedback):
  // said once, with what it means for the output error and for the measured response.
  const ModelReport& first_model = report.first_fit();
  if (!first_model.fit.equation_error && first_model.residual.analysis &&
      first_model.residual.analysis->closed_loop) {
    report.notes.push_back(
        "the record looks closed loop: the first fit's residual is followed by u at the same and "
        "later samples (p = " +
        FormatSignificant(first_model.residual.analysis->feedback_p, 2) +
        ", after prewhitening), so u was computed from the measured motion; "
        "the output error from the recorded u is right only where the model is, and the "
        "measured frequency response is the loop's, not the plant's (docs/identification.md "
        "§9)");
  }
  WidenForAmbiguity(&report);
  AddLinearViews(&report, problem, outcome.final_config, outcome.final_parameters);
  if (report.frequency_response && report.frequency_response->available &&
      !ClosedLoopAdvice(report).empty()) {
    report.frequency_response->caveat =
        "the record looks closed loop (u was computed from the measured motion), so this is "
        "the response of the loop as the drive closed it, tending to the inverse of its "
        "controller where the loop is stiff, not the plant's";
  }
  if (!request.baseline_path.empty()) {
    report.baseline = CompareWithBaseline(report, request.baseline_path);
  }
  report.units_hints = CheckUnits(problem, outcome.first_fit.values);
  if (cutoff.ran) report.cutoff = cutoff;
  AddWarnings(&report);
  if (!saturated.empty()) report.warnings.push_back({"reference_saturated", saturated});
  outcome.report = std::move(report);
  return outcome;
}

}  // namespace blmd
