#include "blmd/report/design_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "blmd/error.h"
#include "blmd/io/csv.h"
#include "blmd/io/files.h"
#include "blmd/io/flags.h"
#include "blmd/report/report.h"
#include "blmd/run.h"
#include "blmd/version.h"

namespace blmd {
namespace {

using json = nlohmann::json;

std::string Sig(double value, int digits = 4) { return FormatSignificant(value, digits); }

// --limit NAME=VALUE: u (the input) or an output column of the model, VALUE > 0.
void ParseLimits(const Config& config, const std::vector<std::string>& texts,
                 DesignOptions* options, bool* has_input_limit) {
  const std::vector<std::string> outputs = config.model->outputs();
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

// --trace: t, u (and open) and the observed columns whose noise it estimates.
void ReadTrace(const Config& config, const DesignSettings& s, DesignRequest* request) {
  CsvReadOptions options;
  options.required = {"t", "u"};
  options.strict_columns = {"t", "u", "open"};
  for (const auto& column : request->problem.observe) options.strict_columns.push_back(column);
  options.delimiter = s.dialect.Delimiter();
  options.duplicate_time = s.dialect.Duplicates();
  request->trace = ReadTraceCsv(s.trace_path, options, &request->trace_sha256);
  if (request->trace.rows() < 3) {
    throw InputError(s.trace_path + ": " + std::to_string(request->trace.rows()) +
                     " rows: a recorded experiment needs at least 3");
  }
  request->recorded = RecordedInput(request->trace, s.trace_path, config);
  request->trace_path = s.trace_path;
  request->evaluate_trace = true;
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

DesignRequest MakeDesignRequest(const Config& config, const std::string& config_path,
                                const DesignSettings& s) {
  DesignRequest request;
  request.config_path = config_path;
  request.config_sha256 = Sha256Hex(ReadFileText(config_path, kMaxConfigBytes, "config"));
  request.problem = MakeDesignProblem(config);
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

bool WithinLimits(const DesignOptions& options, const PrecisionPrediction& prediction) {
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
    const ParamInfo* info = request.problem.config.FindParameterInfo(p.name);
    report.units.push_back(info ? info->unit : "");
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
    const DesignResult result = SearchDesign(problem, request.options);
    report.ok = result.ok;
    report.reason = result.reason;
    report.chosen = result.best;
    report.family_best = result.family_best;
    report.evaluated = result.evaluated;
    report.rejected = result.rejected;
  }
  if (report.ok) AddReference(request, problem, &report);
  return report;
}

nlohmann::json InputJson(const InputSignal& input) {
  using Kind = InputSignal::Kind;
  json out = json::object();
  const auto levels = [&] {
    if (input.offset != 0.0) out["offset"] = input.offset;
    if (input.t0 != 0.0) out["t0"] = input.t0;
  };
  switch (input.kind) {
    case Kind::kStep:
      out = {{"type", "step"}, {"amplitude", input.amplitude}};
      levels();
      break;
    case Kind::kSquare:
      out = {{"type", "square"}, {"amplitude", input.amplitude}, {"period", input.period}};
      levels();
      break;
    case Kind::kSteps:
      out = {{"type", "steps"}, {"times", input.times}, {"values", input.values}};
      if (input.offset != 0.0) out["offset"] = input.offset;
      break;
    case Kind::kPrbs:
      out = {{"type", "prbs"},
             {"amplitude", input.amplitude},
             {"clock", input.clock},
             {"order", input.order},
             {"seed", input.seed}};
      levels();
      break;
    case Kind::kChirp:
      out = {{"type", "chirp"},
             {"amplitude", input.amplitude},
             {"f0", input.f0},
             {"f1", input.f1},
             {"duration", input.sweep},
             {"shape", input.shape == InputSignal::ChirpShape::kLog ? "log" : "linear"}};
      levels();
      break;
    case Kind::kRecorded:
      out = {{"type", "recorded"}};
      break;
  }
  return out;
}

namespace {

// The settings of an input, by name (the report's design.settings): its amplitude (the largest
// |u - offset| of a table) and what its family searches.
json Settings(const DesignCandidate& c) {
  using Kind = InputSignal::Kind;
  double amplitude = c.input.amplitude;
  if (c.input.kind == Kind::kSteps || c.input.kind == Kind::kRecorded) {
    amplitude = 0.0;
    for (double v : c.input.values) amplitude = std::max(amplitude, std::abs(v));
  }
  json s = {{"amplitude", amplitude}};
  if (c.input.kind == Kind::kSquare) {
    s["period_s"] = c.input.period;
  } else if (c.family == "steps") {
    s["dwell_s"] = c.dwell;
    s["levels_per_direction"] = c.levels;
  } else if (c.input.kind == Kind::kPrbs) {
    s["clock_s"] = c.input.clock;
    s["order"] = c.input.order;
    s["seed"] = c.input.seed;
    s["sequence_period_s"] = (std::exp2(c.input.order) - 1.0) * c.input.clock;
  } else if (c.input.kind == Kind::kChirp) {
    s["f0_hz"] = c.input.f0;
    s["f1_hz"] = c.input.f1;
    s["shape"] = c.input.shape == InputSignal::ChirpShape::kLog ? "log" : "linear";
    s["sweep_s"] = c.input.sweep;
  }
  return s;
}

json Predicted(const DesignReport& report, const PrecisionPrediction& p) {
  json out = json::object();
  for (std::size_t k = 0; k < p.names.size(); ++k) {
    const auto i = static_cast<Eigen::Index>(k);
    json entry = {{"prior", p.values[k]},
                  {"ci95_halfwidth", p.ci95_halfwidth[k]},
                  {"ci95_relative_halfwidth", p.ci95_halfwidth[k] / std::abs(p.values[k])},
                  {"std_search", std::sqrt(p.covariance(i, i))},
                  {"search_scale", p.log_scale[k] ? "log" : "linear"},
                  {"cramer_rao_ci95_halfwidth", p.cramer_rao_ci95_halfwidth[k]}};
    if (!report.units[k].empty()) entry["unit"] = report.units[k];
    out[p.names[k]] = entry;
  }
  return out;
}

json Correlation(const PrecisionPrediction& p) {
  json rows = json::array();
  for (Eigen::Index i = 0; i < p.covariance.rows(); ++i) {
    json row = json::array();
    for (Eigen::Index j = 0; j < p.covariance.cols(); ++j) {
      row.push_back(p.covariance(i, j) / std::sqrt(p.covariance(i, i) * p.covariance(j, j)));
    }
    rows.push_back(row);
  }
  return {{"names", p.names}, {"matrix", rows}};
}

json CandidateJson(const DesignReport& report, const DesignCandidate& c) {
  json out = {{"family", c.family},
              {"input", InputJson(c.input)},
              {"settings", Settings(c)},
              {"criterion", c.criterion},
              {"log_det_covariance", c.prediction.log_det},
              {"peaks", c.prediction.peaks},
              {"predicted", Predicted(report, c.prediction)}};
  if (c.family == "recorded") out.erase("input");
  return out;
}

}  // namespace

nlohmann::json DesignReportJson(const DesignReport& report) {
  json noise = json::object();
  for (std::size_t c = 0; c < report.observe.size(); ++c) {
    noise[report.observe[c]] = {{"sigma", report.sigma[c]}, {"source", report.noise_source[c]}};
  }
  json limits = json::object();
  if (report.options.input_limit > 0.0) limits["u"] = report.options.input_limit;
  for (const auto& [column, value] : report.options.output_limits) limits[column] = value;
  json out = {{"tool", "blmd-design"},
              {"version", kVersion},
              {"config", {{"path", report.config_path}, {"sha256", report.config_sha256}}},
              {"model", report.model},
              {"mode", report.evaluate_trace ? "trace" : "search"},
              {"criterion", report.criterion},
              {"target", report.target},
              {"duration_s", report.options.duration},
              {"sample_rate_hz", report.options.sample_rate},
              {"limits", limits},
              {"observe", report.observe},
              {"noise", noise},
              {"ok", report.ok}};
  if (report.evaluate_trace) {
    out["trace"] = {{"path", report.trace_path}, {"sha256", report.trace_sha256}};
  }
  if (!report.ok) {
    out["failure"] = report.reason;
  } else {
    const DesignCandidate& c = report.chosen;
    json design = CandidateJson(report, c);
    design["within_limits"] = report.chosen_within_limits;
    out["design"] = design;
    out["predicted"] = Predicted(report, c.prediction);
    out["correlation"] = Correlation(c.prediction);
  }
  if (report.reference) {
    json reference = CandidateJson(report, *report.reference);
    reference["within_limits"] = report.reference_within_limits;
    if (report.ok) {
      json ratio = json::object();
      for (std::size_t k = 0; k < report.chosen.prediction.names.size(); ++k) {
        ratio[report.chosen.prediction.names[k]] = report.reference->prediction.ci95_halfwidth[k] /
                                                   report.chosen.prediction.ci95_halfwidth[k];
      }
      reference["halfwidth_over_design"] = ratio;
    }
    out["reference"] = reference;
  }
  if (!report.evaluate_trace) {
    json families = json::array();
    for (const auto& c : report.family_best) families.push_back(CandidateJson(report, c));
    out["families"] = families;
    out["search"] = {{"evaluated", report.evaluated}, {"rejected", report.rejected}};
  }
  SanitizeJson(&out);
  return out;
}

namespace {

std::string Describe(const DesignCandidate& c) {
  const json s = Settings(c);
  std::string text = c.family;
  if (c.family == "recorded") return "the recorded input";
  text += ", amplitude " + Sig(c.input.amplitude);
  if (s.contains("period_s")) text += ", period " + Sig(s["period_s"]) + " s";
  if (s.contains("dwell_s")) {
    text += c.levels == 1 ? std::string(" (+a, 0, -a, 0)")
                          : ", a staircase of " + std::to_string(c.levels) + " levels each way";
    text += ", " + Sig(s["dwell_s"]) + " s per level";
  }
  if (s.contains("clock_s")) {
    text += ", clock " + Sig(s["clock_s"]) + " s, order " + std::to_string(c.input.order);
  }
  if (s.contains("f0_hz")) {
    text +=
        ", " + Sig(c.input.f0) + " -> " + Sig(c.input.f1) + " Hz " + s["shape"].get<std::string>();
  }
  return text;
}

}  // namespace

std::string DesignSummary(const DesignReport& report) {
  std::ostringstream out;
  out << "blmd-design: " << report.model << " '" << report.config_path << "', "
      << (report.evaluate_trace ? "the recorded input of " + report.trace_path
                                : report.criterion + " design")
      << " over " << Sig(report.options.duration) << " s\n";
  if (!report.ok) {
    out << "  no design: " << report.reason << "\n";
    return out.str();
  }
  out << "  experiment: " << Describe(report.chosen);
  if (!report.evaluate_trace) out << " (best of " << report.evaluated << " candidates)";
  out << "\n";
  const PrecisionPrediction& p = report.chosen.prediction;
  for (std::size_t k = 0; k < p.names.size(); ++k) {
    char line[256];
    std::snprintf(line, sizeof line, "  %-4s %-12s +- %-10s (%.3g %%)", p.names[k].c_str(),
                  Sig(p.values[k], 5).c_str(), Sig(p.ci95_halfwidth[k], 3).c_str(),
                  100.0 * p.ci95_halfwidth[k] / std::abs(p.values[k]));
    out << line << " predicted 95 % half-width " << report.units[k];
    if (report.reference) {
      out << "; the config's input: +- " << Sig(report.reference->prediction.ci95_halfwidth[k], 3)
          << " (" << Sig(report.reference->prediction.ci95_halfwidth[k] / p.ci95_halfwidth[k], 3)
          << "x)";
    }
    out << "\n";
  }
  if (!report.chosen_within_limits) out << "  note: the recorded response exceeds a --limit\n";
  return out.str();
}

nlohmann::json DesignConfigJson(const Config& config, const DesignReport& report) {
  json doc = config.document.is_object() ? config.document : json::object();
  doc["model"] = std::string(config.model->name());
  doc["name"] = config.name + "-design";
  doc["description"] =
      "blmd-design: " + Describe(report.chosen) + ", " + report.criterion + " for " +
      (report.target.empty() ? std::string("all free parameters") : Join(report.target));
  json experiment = doc.contains("experiment") && doc["experiment"].is_object() ? doc["experiment"]
                                                                                : json::object();
  experiment.erase("pid");
  experiment.erase("coast_off_time");
  experiment["input"] = InputJson(report.chosen.input);
  experiment["duration"] = report.options.duration;
  experiment["sample_rate"] = report.options.sample_rate;
  doc["experiment"] = experiment;
  json predicted = json::object();
  const PrecisionPrediction& p = report.chosen.prediction;
  for (std::size_t k = 0; k < p.names.size(); ++k) predicted[p.names[k]] = p.ci95_halfwidth[k];
  json notes = {{"designed_by", std::string("blmd-design ") + kVersion},
                {"from_config", report.config_path},
                {"criterion", report.criterion},
                {"predicted_ci95_halfwidth", predicted}};
  if (!config.notes.is_null()) notes["config_notes"] = config.notes;
  doc["notes"] = notes;
  SanitizeJson(&doc);
  return doc;
}

Trace DesignInputTable(const DesignReport& report) {
  Experiment experiment;
  experiment.duration = report.options.duration;
  experiment.sample_rate = report.options.sample_rate;
  std::vector<double> times = experiment.SampleTimes();
  std::vector<double> u;
  u.reserve(times.size());
  InputCursor cursor(report.chosen.input);
  for (double t : times) u.push_back(cursor.At(t));
  Trace table;
  table.Append("t", std::move(times));
  table.Append("u", std::move(u));
  table.comments.push_back("blmd-design " + std::string(kVersion) + " " + Describe(report.chosen) +
                           " (zero-order hold: u holds from each row to the next)");
  return table;
}

}  // namespace blmd
