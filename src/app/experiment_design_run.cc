#include "app/experiment_design_run.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "blmd/error.h"
#include "blmd/io/csv.h"
#include "blmd/io/files.h"
#include "blmd/io/stored_report.h"
#include "blmd/report/report.h"
#include "blmd/run.h"
#include "blmd/sim/effects.h"
#include "blmd/version.h"
#include "io/flags.h"

namespace blmd {
namespace {

using json = nlohmann::json;

// --limit NAME=VALUE: u (the input) or an output column of the model, VALUE > 0.
void ParseLimits(const Config& config, const std::vector<std::string>& texts,
                 ExperimentDesignOptions* options, bool* has_input_limit) {
  const std::vector<std::string> outputs = config.model->OutputsWith(config.effects);
  std::vector<std::string> valid = {"u"};
  valid.insert(valid.end(), outputs.begin(), outputs.end());
  for (const auto& text : texts) {
    const auto [name, value] = ParseAssignment(text, "--limit");
    if (std::find(valid.begin(), valid.end(), name) == valid.end()) {
      throw InputError("--limit " + name + ": not the input or an output of " +
                       std::string(config.model->name()) + " (valid: " + Join(valid) + ")");
    }
    if (!(value > 0.0))
      throw InputError("--limit " + name + ": must be > 0, not " + DisplayNumber(value));
    if (name == "u") {
      options->input_limit = value;
      *has_input_limit = true;
    } else {
      options->output_limits[name] = value;
    }
  }
}

// Each observed column's peak |value| in the noise-free simulation of the config's own
// experiment (what --noise NAME=P% is a percentage of, as in blmd-sim).
std::map<std::string, double> ConfigPeaks(const Config& config, const std::string& config_path) {
  Trace trace;
  const SimStatus status = RunExperiment(config, &trace);
  if (!status.ok()) {
    throw InputError("--noise with %: the config's own experiment does not run: " +
                     SimulationFailureMessage(config_path, config, status));
  }
  std::map<std::string, double> peaks;
  for (const auto& name : trace.names()) {
    double peak = 0.0;
    for (double v : trace.Column(name)) peak = std::max(peak, std::abs(v));
    peaks[name] = peak;
  }
  return peaks;
}

// --noise for the observed columns; a column without one is estimated from --trace, else an
// error.
void SetNoise(const Config& config, const std::string& config_path, const DesignSettings& s,
              DesignRequest* request) {
  DesignProblem& problem = request->problem;
  const std::vector<NoiseSpec> noise = ParseNoise(s.noises);
  request->noise_source.assign(problem.observe.size(), "");
  std::map<std::string, double> peaks;
  for (const auto& n : noise) {
    const auto at = std::find(problem.observe.begin(), problem.observe.end(), n.column);
    if (at == problem.observe.end()) {
      throw InputError("--noise " + n.column +
                       ": not an observed column (observed: " + Join(problem.observe) + ")");
    }
    if (!(n.sigma > 0.0)) throw InputError("--noise " + n.column + ": sigma must be > 0");
    const auto c = static_cast<std::size_t>(at - problem.observe.begin());
    double sigma = n.sigma;
    if (n.relative) {
      if (peaks.empty()) {
        if (!s.trace_path.empty()) {
          for (const auto& name : request->trace.names()) {
            double peak = 0.0;
            for (double v : request->trace.Column(name)) peak = std::max(peak, std::abs(v));
            peaks[name] = peak;
          }
        } else {
          peaks = ConfigPeaks(config, config_path);
        }
      }
      sigma *= peaks[n.column];
      if (!(sigma > 0.0)) {
        throw InputError("--noise " + n.column + "=" + DisplayNumber(100 * n.sigma) + "%: the '" +
                         n.column + "' column's peak is 0: give an absolute sigma");
      }
    }
    problem.sigma[c] = sigma;
    request->noise_source[c] = n.relative ? "flag_percent" : "flag";
  }
  for (std::size_t c = 0; c < problem.observe.size(); ++c) {
    const std::string& column = problem.observe[c];
    if (!request->noise_source[c].empty()) continue;
    if (const auto at = request->report_noise.find(column);
        s.trace_path.empty() && at != request->report_noise.end()) {
      problem.sigma[c] = at->second;  // the report's residual: its noise and model error
      request->noise_source[c] = "report";
      continue;
    }
    if (s.trace_path.empty()) {
      throw InputError("--noise: no noise level for the observed column '" + column +
                       "' (give --noise " + column +
                       "=SIGMA, or --trace to estimate it from a recording)");
    }
    if (!request->trace.Has(column)) {
      throw InputError(s.trace_path + ": no column '" + column +
                       "' to estimate its noise from (give --noise " + column + "=SIGMA)");
    }
  }
}

// --trace: t, u (and open) and the observed columns whose noise it estimates, read and
// prepared by blmd-ident's own trace flags (--column, --scale, --derive, --select, ...).
void ReadTrace(const Config& config, const DesignSettings& s, DesignRequest* request) {
  const std::vector<FitTrace> traces = LoadTraceSource(
      {s.trace_path, s.trace_data}, s.trace.Options({}, false), config.experiment.initial);
  if (traces.size() != 1) {
    throw InputError(
        s.trace_path + ": " +
        (s.trace.split.empty() ? "--resample cut it at its gaps into " : "--split made ") +
        std::to_string(traces.size()) +
        " experiments: blmd-design evaluates one recorded input (--select one)");
  }
  request->trace = traces.front().trace;
  request->trace_sha256 = traces.front().sha256;
  // --initial-state trace: the replay starts where the record does (a coast-down from speed).
  request->problem.config.experiment.initial = traces.front().initial;
  if (request->trace.rows() < 3) {
    throw InputError(s.trace_path + ": " + std::to_string(request->trace.rows()) +
                     " rows: a recorded experiment needs at least 3");
  }
  request->recorded = RecordedInput(request->trace, s.trace_path, config);
  request->trace_path = s.trace_path;
  request->evaluate_trace = true;
}

// --from-report: the report's final model on the config; the effects' parameters the report
// fitted become free, so that the design predicts their precision too. A report whose model
// is not to be trusted is a warning (the design rests on that model).
void ApplyDesignReport(const DesignSettings& s, Config* config, DesignRequest* request) {
  const std::string& path = s.from_report;
  const StoredReport report =
      s.from_report_text ? StoredReport::Parse(*s.from_report_text, path, "identification report")
                         : StoredReport::Load(path, "identification report");
  ApplyFinalModel(report, config);
  std::vector<std::string>& free = config->identification.free;
  for (const StoredParameter& p : report.parameters()) {
    if (p.free && std::find(free.begin(), free.end(), p.name) == free.end()) free.push_back(p.name);
    // The bounds the report's fit searched in (discovery scales an effect's bounds to the
    // data; the effect's defaults may not hold the fitted value).
    if (p.free && p.has_bounds && p.bound_low <= p.value && p.value <= p.bound_high) {
      config->identification.bounds[p.name] = {p.bound_low, p.bound_high};
    }
  }
  request->report_path = path;
  request->report_sha256 = report.sha256();
  request->report_noise = report.noise_std();
  request->report_variance_ratio = report.variance_ratio();
  const std::vector<std::string> reasons = ReportInadequacy(report);
  if (!reasons.empty()) {
    request->warnings.emplace_back(
        "report_inadequate", "the identified model is not to be trusted (" + Join(reasons, "; ") +
                                 "): the design rests on it; identify again (--discover, a "
                                 "better record) before relying on the predicted intervals");
  }
}

// The margin over the breakaway torque a designed input must reach (docs/design.md §7): the
// static friction is known to about ±20 % from one record (the real rigs' Coulomb friction
// moved by 10-20 % between records and directions).
constexpr double kBreakawayMargin = 1.2;

// The friction warning and the breakaway: the torque that holds a shaft at rest, the |u|
// that overcomes it with the margin; the search rejects inputs below it.
void SetBreakaway(const Config& config, DesignRequest* request) {
  const ParameterSet& p = config.parameters;
  bool friction = false;
  const double torque = TorqueAtRest(p, config.effects, &friction);
  if (!friction) {
    request->warnings.emplace_back(
        "no_friction", "the model declares no friction (" + Join(FrictionAtRestEffects()) +
                           "): a real drive's breakaway friction can hold the shaft still under "
                           "a designed input of small amplitude; identify with --discover and "
                           "design from that report (--from-report)");
  }
  const double per_input = config.model->StallTorquePerInput(p);
  if (!(torque > 0.0) || !(per_input > 0.0)) return;
  request->breakaway_torque = torque;
  request->breakaway_u = kBreakawayMargin * torque / per_input;
  request->options.breakaway_input = request->breakaway_u;
}

std::vector<std::string> Families(const std::string& text) {
  if (text == "all") return DesignFamilies();
  const auto& valid = DesignFamilies();
  if (std::find(valid.begin(), valid.end(), text) == valid.end()) {
    throw InputError("--family: unknown family '" + text + "' (valid: " + Join(valid) + ", all)");
  }
  return {text};
}

}  // namespace

namespace {

// Without --trace: the run's length checked, the families.
void SetSearchRun(const Config& config, const std::string& config_path, const DesignSettings& s,
                  bool has_input_limit, DesignRequest* request) {
  if (!has_input_limit) {
    throw InputError("--limit u=V is required: the largest |u| the drive may apply");
  }
  if (!s.duration) throw InputError("--duration is required (the experiment's length, s)");
  const double duration = *s.duration;
  if (!(duration > 0.0) || !std::isfinite(duration)) {
    throw InputError("--duration: must be a number > 0, not " + DisplayNumber(duration));
  }
  request->options.duration = duration;
  const double samples = duration * request->options.sample_rate;
  if (const std::string error = RunLengthError(duration, config.simulation.dt, samples);
      !error.empty()) {
    throw InputError("--duration " + DisplayNumber(duration) + ": " + error);
  }
  if (samples < 10.0) {
    throw InputError("--duration " + DisplayNumber(duration) + ": fewer than 10 samples at " +
                     "the config's sample_rate " + DisplayNumber(request->options.sample_rate) +
                     " Hz");
  }
  if (1.0 / request->options.sample_rate < config.simulation.dt * (1 - 1e-9)) {
    throw InputError(config_path + ": experiment.sample_rate is above 1/simulation.dt");
  }
  request->options.families = Families(s.family);
}

// With --trace: its span and mean sample rate.
void SetTraceRun(const Config& config, const DesignSettings& s, DesignRequest* request) {
  if (s.duration) {
    throw InputError("--duration: not with --trace (the trace's span is the experiment)");
  }
  if (s.family != "all") {
    throw InputError("--family: not with --trace (its recorded input is evaluated)");
  }
  ReadTrace(config, s, request);
  const auto& t = request->trace.Column("t");
  request->options.duration = t.back() - t.front();
  request->options.sample_rate = static_cast<double>(t.size() - 1) / request->options.duration;
}

}  // namespace

DesignRequest MakeDesignRequest(Config config, const std::string& config_path,
                                const DesignSettings& s) {
  return MakeDesignRequest(std::move(config), JsonSource{config_path, std::nullopt}, s);
}

DesignRequest MakeDesignRequest(Config config, const JsonSource& config_source,
                                const DesignSettings& s) {
  const std::string& config_path = config_source.path;
  DesignRequest request;
  if (!s.from_report.empty()) ApplyDesignReport(s, &config, &request);
  SetBreakaway(config, &request);
  request.config_path = config_path;
  request.config_sha256 = Sha256Hex(config_source.Text(kMaxConfigBytes, "config"));
  request.problem = MakeDesignProblem(config);
  if (!s.from_report.empty()) {
    // What the report's record achieved beyond white noise (its residual's colour and the
    // model's error): each parameter's variance widened by the report's ratio.
    for (const FreeParameter& p : request.problem.free) {
      const auto at = request.report_variance_ratio.find(p.name);
      request.problem.variance_factor.push_back(
          at == request.report_variance_ratio.end() ? 1.0 : at->second);
    }
  }
  request.options.threads = s.threads;
  request.options.sample_rate = config.experiment.sample_rate;
  bool has_input_limit = false;
  ParseLimits(config, s.limits, &request.options, &has_input_limit);
  if (s.trace_path.empty()) {
    SetSearchRun(config, config_path, s, has_input_limit, &request);
  } else {
    SetTraceRun(config, s, &request);
  }
  if (!s.target.empty()) request.options.target = ParseNameList(s.target, "--target");
  std::vector<std::string> free;
  for (const auto& p : request.problem.free) free.push_back(p.name);
  for (const auto& name : request.options.target) {
    if (std::find(free.begin(), free.end(), name) == free.end()) {
      throw InputError("--target " + name + ": not a free parameter (free: " + Join(free) + ")");
    }
  }
  SetNoise(config, config_path, s, &request);
  return request;
}

namespace {

// The config's own input, when it is one the families can write (and not a closed loop's).
std::optional<DesignCandidate> ReferenceCandidate(const Config& config) {
  const InputSignal& input = config.experiment.input;
  using Kind = InputSignal::Kind;
  if (config.experiment.closed_loop || config.experiment.coast_off_time >= 0.0) return std::nullopt;
  if (input.kind == Kind::kRecorded) return std::nullopt;
  DesignCandidate c;
  c.family = "config";
  c.input = input;
  return c;
}

bool WithinLimits(const ExperimentDesignOptions& options, const PrecisionPrediction& prediction) {
  const auto peak = [&](const std::string& name) {
    const auto at = prediction.peaks.find(name);
    return at == prediction.peaks.end() ? 0.0 : at->second;
  };
  if (options.input_limit > 0.0 && peak("u") > options.input_limit * (1 + 1e-12)) return false;
  for (const auto& [column, limit] : options.output_limits) {
    if (peak(column) > limit) return false;
  }
  return true;
}

// `candidate`'s input played at `times`, predicted with the problem's noise as it stands.
DesignCandidate PredictOn(const DesignProblem& problem, DesignCandidate c,
                          const std::vector<double>& times, const std::vector<std::string>& target,
                          Trace* response) {
  const SimStatus status = SimulateSampledInput(problem, c.input, times, response);
  if (!status.ok()) {
    c.rejected = "the simulation failed: " + status.message;
    return c;
  }
  c.prediction = PredictPrecision(problem, *response);
  c.rejected = c.prediction.reason;
  c.feasible = c.prediction.ok;
  c.criterion = DesignCriterion(c.prediction, target);
  return c;
}

// The trace's recorded input evaluated (no amplitude change), each observed column's noise
// without a --noise estimated from the trace's residual against the model's response.
DesignCandidate EvaluateRecorded(const DesignRequest& request, DesignProblem* problem,
                                 DesignReport* report) {
  DesignCandidate c;
  c.family = "recorded";
  c.input = request.recorded;
  const std::vector<double>& times = request.trace.Column("t");
  Trace response;
  const SimStatus status = SimulateSampledInput(*problem, c.input, times, &response);
  if (!status.ok()) {
    c.rejected = "the simulation of the recorded input failed: " + status.message;
    return c;
  }
  for (std::size_t k = 0; k < problem->observe.size(); ++k) {
    if (!request.noise_source[k].empty()) continue;
    const std::string& column = problem->observe[k];
    problem->sigma[k] = ResidualNoise(request.trace.Column(column), response.Column(column));
    report->noise_source[k] = "trace";
    if (!(problem->sigma[k] > 0.0)) {
      c.rejected = "the trace's '" + column +
                   "' equals the model's response exactly: no noise to estimate (give --noise " +
                   column + "=SIGMA)";
      return c;
    }
  }
  return PredictOn(*problem, c, times, request.options.target, &response);
}

// The config's own input over the same span and samples: searching, with its amplitude
// lowered as a candidate's to keep within the limits; with --trace, as configured.
void AddReference(const DesignRequest& request, const DesignProblem& problem,
                  DesignReport* report) {
  const auto reference = ReferenceCandidate(request.problem.config);
  if (!reference) return;
  DesignCandidate evaluated;
  if (request.evaluate_trace) {
    Trace response;
    evaluated = PredictOn(problem, *reference, request.trace.Column("t"), request.options.target,
                          &response);
  } else {
    evaluated = EvaluateCandidate(problem, request.options, *reference);
  }
  if (evaluated.feasible) {
    report->reference_within_limits = WithinLimits(request.options, evaluated.prediction);
    report->reference = evaluated;
  }
}

}  // namespace

DesignReport RunDesign(const DesignRequest& request) {
  DesignReport report;
  report.config_path = request.config_path;
  report.config_sha256 = request.config_sha256;
  report.model = std::string(request.problem.config.model->name());
  report.evaluate_trace = request.evaluate_trace;
  report.trace_path = request.trace_path;
  report.trace_sha256 = request.trace_sha256;
  report.target = request.options.target;
  report.criterion = request.options.target.empty() ? "D-optimal" : "A-optimal";
  report.options = request.options;
  report.observe = request.problem.observe;
  report.sigma = request.problem.sigma;
  report.noise_source = request.noise_source;
  for (const auto& p : request.problem.free) {
    report.units.push_back(ParameterUnit(request.problem.config, p.name));
  }
  DesignProblem problem = request.problem;
  if (request.evaluate_trace) {
    report.chosen = EvaluateRecorded(request, &problem, &report);
    report.sigma = problem.sigma;
    report.ok = report.chosen.feasible;
    report.reason = report.chosen.rejected;
    if (report.ok) {
      report.chosen_within_limits = WithinLimits(request.options, report.chosen.prediction);
    }
  } else {
    const ExperimentDesignResult result = SearchDesign(problem, request.options);
    report.ok = result.ok;
    report.reason = result.reason;
    report.chosen = result.best;
    report.family_best = result.family_best;
    report.evaluated = result.evaluated;
    report.rejected = result.rejected;
  }
  if (report.ok) AddReference(request, problem, &report);
  report.report_path = request.report_path;
  report.report_sha256 = request.report_sha256;
  for (std::size_t k = 0; k < request.problem.variance_factor.size(); ++k) {
    report.variance_factor[request.problem.free[k].name] = request.problem.variance_factor[k];
  }
  report.breakaway_torque = request.breakaway_torque;
  report.breakaway_u = request.breakaway_u;
  report.warnings = request.warnings;
  if (report.ok && request.evaluate_trace && request.breakaway_u > 0.0) {
    double peak = 0.0;
    for (double v : request.trace.Column("u")) peak = std::max(peak, std::abs(v));
    if (peak < request.breakaway_u) {
      report.warnings.emplace_back(
          "below_breakaway", "the recorded input's peak |u| " + FormatSignificant(peak, 4) +
                                 " stays below the breakaway " +
                                 FormatSignificant(request.breakaway_u, 4) +
                                 " (friction, cogging and load with a 20 % margin): the shaft "
                                 "may not move; raise the amplitude");
    }
  }
  return report;
}

}  // namespace blmd
