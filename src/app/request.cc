#include "app/request.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "blmd/error.h"
#include "blmd/ident/optimizers/optimizer.h"
#include "blmd/io/csv.h"
#include "blmd/io/files.h"
#include "blmd/random.h"
#include "blmd/run.h"
#include "blmd/sim/effects.h"
#include "io/flags.h"

namespace blmd {
namespace {

// The observed columns must be outputs of the model (with the output error); the message
// lists the outputs joined by `separator` (blmd-ident ",", blmd-surface ", ").
void CheckObservedOutputs(const Config& config, const std::vector<std::string>& observe,
                          const char* separator) {
  if (config.identification.error == "equation") return;
  const std::vector<std::string> outputs = config.model->OutputsWith(config.effects);
  if (config.identification.simulate_from == "reference" &&
      std::find(observe.begin(), observe.end(), "u") != observe.end()) {
    // The joint approach (the command observed beside the response) is not calibrated yet.
    throw InputError(
        "--observe u: a fit from the reference compares the response only (the command "
        "observed too, the joint approach, is not supported yet); fit from the logged command "
        "with --simulate-from command to use it");
  }
  for (const auto& name : observe) {
    if (std::find(outputs.begin(), outputs.end(), name) == outputs.end()) {
      // A column an effect adds (two_mass's load side) names the effect to declare.
      std::string hint;
      for (const EffectInfo& info : EffectRegistry()) {
        if (std::find(info.outputs.begin(), info.outputs.end(), name) != info.outputs.end())
          hint = "; it comes with the effect " + info.name;
      }
      throw InputError("--observe: '" + name + "' is not an output of model " +
                       std::string(config.model->name()) + " (valid: " + Join(outputs, separator) +
                       ")" + hint);
    }
  }
}

// Selecting settings given empty select nothing: refused with the valid choices.
void RefuseEmptySelections(const IdentSettings& settings, const Config& config) {
  if (settings.observe && settings.observe->empty()) {
    throw InputError("--observe: empty (valid: " + Join(config.model->outputs()) + ")");
  }
  if (settings.free && settings.free->empty()) {
    std::vector<std::string> names;
    for (const auto& [name, value] : config.parameters.entries()) names.push_back(name);
    throw InputError("--free: empty (valid: " + Join(names) + ")");
  }
  if (settings.candidates && settings.candidates->empty()) {
    std::vector<std::string> effects;
    for (const auto& effect : EffectRegistry()) effects.push_back(effect.name);
    throw InputError("--candidates: empty (valid: " + Join(effects) + ")");
  }
}

// The --grid axes, each a parameter of the config, positive where the parameter must be.
std::vector<GridAxis> ParseGridAxes(const Config& config, const std::vector<std::string>& grids) {
  std::vector<GridAxis> axes;
  for (const auto& text : grids) {
    GridAxis axis = ParseGridAxis(text);
    if (!config.parameters.Has(axis.name)) {
      std::vector<std::string> known;
      for (const auto& [name, value] : config.parameters.entries()) known.push_back(name);
      const std::string near = NearestName(axis.name, known);
      throw InputError("--grid: unknown parameter '" + axis.name + "'" +
                       (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                       "; valid: " + Join(known));
    }
    const ParamInfo* info = config.FindParameterInfo(axis.name);
    if (info && info->positive && !(axis.low > 0.0)) {
      throw InputError("--grid " + axis.name +
                       ": the parameter must be > 0 (LO = " + FormatNumber(axis.low) + ")");
    }
    for (const auto& other : axes) {
      if (other.name == axis.name) throw InputError("--grid: '" + axis.name + "' given twice");
    }
    axes.push_back(axis);
  }
  return axes;
}

std::string Fixed(double value, int digits = 4) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*g", digits, value);
  return buffer;
}

}  // namespace

char DialectSettings::Delimiter() const {
  return delimiter == "tab" ? '\t' : delimiter.empty() ? 0 : delimiter[0];
}

DuplicateTime DialectSettings::Duplicates() const {
  return duplicate_time == "first"  ? DuplicateTime::kFirst
         : duplicate_time == "mean" ? DuplicateTime::kMean
                                    : DuplicateTime::kError;
}

std::vector<std::string> DialectSettings::Names() const {
  return no_header.empty() ? std::vector<std::string>{} : ParseNameList(no_header, "--no-header");
}

TraceInputOptions TraceSettings::Options(const std::vector<std::string>& observe,
                                         bool equation_error, bool reference) const {
  TraceInputOptions options;
  options.delimiter = Delimiter();
  options.duplicate_time = Duplicates();
  options.names = Names();
  options.sample_rate = sample_rate;
  for (const auto& text : columns) {
    const auto [name, header] = ParseTextAssignment(text, "--column");
    options.columns[name] = header;
  }
  if (sample_rate > 0.0 && options.columns.count("t")) {
    throw InputError("--sample-rate makes the time column: not with --column t=" +
                     options.columns.at("t") + " (give one or the other)");
  }
  for (const auto& text : scales) {
    const auto [name, factor] = ParseAssignment(text, "--scale");
    options.scales[name] = factor;
  }
  for (const auto& text : derives) {
    const auto [target, source] = ParseTextAssignment(text, "--derive");
    if (target != "w" || source != "theta") {
      throw InputError("--derive '" + text + "': supported: w=theta");
    }
    options.derive.emplace_back(target, source);
  }
  if (!equation_error) options.required = observe;
  if (reference) options.input = "r";
  options.initial_from_trace = initial_state == "trace";
  for (const auto& text : selects) options.select.push_back(ParseRowSelection(text));
  options.split = split;
  if (resample == "auto") {
    options.resample_median = true;
  } else if (!resample.empty()) {
    const std::string expected =
        "--resample: expected a step in seconds > 0, or auto (the median step), not '" + resample +
        "'";
    try {
      options.resample_step = ParseNumber(resample, "--resample");
    } catch (const InputError&) {
      throw InputError(expected);
    }
    if (!(options.resample_step > 0.0)) throw InputError(expected);
  }
  return options;
}

std::string TraceSettings::RowsLine() const {
  std::string line;
  for (const auto& text : selects) line += " --select " + text;
  if (!split.empty()) line += " --split " + split;
  if (initial_state == "trace") line += " --initial-state trace";
  if (Duplicates() != DuplicateTime::kError) line += " --duplicate-time " + duplicate_time;
  if (!no_header.empty()) line += " --no-header " + no_header;
  if (sample_rate > 0.0) line += " --sample-rate " + FormatNumber(sample_rate);
  if (!resample.empty()) line += " --resample " + resample;
  return line;
}

std::vector<std::string> ErrorSettings::Apply(Config* config,
                                              const std::string& observe_text) const {
  IdentificationSettings& ident = config->identification;
  if (!kind.empty()) ident.error = kind;
  if (filter_hz > 0.0) ident.filter_hz = filter_hz;
  if (decimate > 0) ident.decimate = decimate;
  if (!simulate_from.empty()) {
    if (simulate_from != "command" && simulate_from != "reference") {
      throw InputError("--simulate-from: '" + InputError::Excerpt(simulate_from) +
                       "' is not one of: command, reference");
    }
    ident.simulate_from = simulate_from;
  }
  const bool equation = ident.error == "equation";
  if (ident.simulate_from == "reference") {
    if (!config->experiment.closed_loop) {
      throw InputError(
          "--simulate-from reference simulates the drive's loop from the trace's reference r: the "
          "config needs its controller (experiment.pid)");
    }
    if (equation) {
      throw InputError(
          "--simulate-from reference needs the output error (the equation error compares "
          "the recorded command)");
    }
  }
  if (!equation && (filter_hz > 0.0 || decimate > 0)) {
    throw InputError(std::string(filter_hz > 0.0 ? "--filter-hz" : "--decimate") +
                     " applies to the equation error only (--error equation)");
  }
  if (equation && !config->model->traits().input_is_torque) {
    throw InputError(
        "--error equation needs model rigid_load (its input is the drive torque); model " +
        std::string(config->model->name()) + "'s drive torque is a state of the model");
  }
  std::vector<std::string> observe =
      observe_text.empty() ? ident.observe : ParseNameList(observe_text, "--observe");
  if (equation && observe_text.empty()) observe = {"u"};
  if (equation && observe != std::vector<std::string>{"u"}) {
    throw InputError("--observe: the equation error compares the input: observe u");
  }
  return observe;
}

std::vector<FitTrace> LoadTraceSource(const TraceSource& source, const TraceInputOptions& options,
                                      const InitialState& default_initial) {
  if (!source.data) return LoadFitTraces(source.path, options, default_initial);
  // Columns in memory have no file: their fingerprint is the SHA-256 of the trace written as
  // the tool's own CSV (FormatTraceCsv), so equal arrays give equal hashes (docs/python.md).
  return PrepareFitTraces(*source.data, source.path, Sha256Hex(FormatTraceCsv(*source.data)),
                          options, default_initial);
}

namespace {

// A record fitted from its reference that does not log the drive's command gets, as its u,
// the command the config's loop computes around the model at the start values: what the
// analyses that read the input (the input-residual test, discovery's torque scale, the
// transient view) then see. The fit itself compares the observed columns only.
void CommandFromTheLoop(const Config& config, FitTrace* part) {
  if (part->trace.Has("u")) return;
  Config loop = config;
  loop.experiment.initial = part->initial;
  Trace simulated;
  const SimStatus status = RunRecordedInput(loop, part->input, &simulated);
  if (!status.ok() || simulated.rows() != part->trace.rows()) {
    throw InputError(part->path +
                     ": the drive's loop cannot be simulated from its reference at "
                     "the start values (" +
                     status.message + ")");
  }
  part->trace.Set("u", simulated.Column("u"));
}

}  // namespace

IdentRequest MakeIdentRequest(Config config_in, const std::string& config_path,
                              const IdentSettings& settings) {
  IdentRequest request;
  request.config_path = config_path;
  request.baseline_path = settings.baseline;
  Config& config = request.config;
  config = std::move(config_in);
  RefuseEmptySelections(settings, config);
  for (const auto& text : settings.initials) {
    const auto [name, value] = ParseAssignment(text, "--initial");
    config.identification.initial.Set(name, value);
  }
  request.observe = settings.error.Apply(&config, settings.observe.value_or(""));
  const bool equation_error = config.identification.error == "equation";
  request.method = !settings.method.empty()               ? settings.method
                   : config.identification.method.empty() ? "ceres"
                                                          : config.identification.method;
  FindOptimizer(request.method);  // an unknown method is refused before any trace is read
  CheckObservedOutputs(config, request.observe, ",");
  const std::string free_text = settings.free.value_or("");
  const std::vector<std::string> free_names =
      free_text.empty() ? config.identification.free : ParseNameList(free_text, "--free");
  for (const auto& text : settings.initials) {
    const std::string name = ParseAssignment(text, "--initial").first;
    if (std::find(free_names.begin(), free_names.end(), name) == free_names.end()) {
      throw InputError("--initial " + name + ": '" + name +
                       "' is not a free parameter, so it has no start value (free: " +
                       Join(free_names) + "; free it with --free)");
    }
  }
  request.free = MakeFreeParameters(config, free_names);
  const TraceInputOptions input_options = settings.preparation.Options(
      request.observe, equation_error, config.identification.simulate_from == "reference");

  OptimizerOptions& options = request.options;
  options.method_options = config.identification.method == request.method
                               ? config.identification.options
                               : nlohmann::json::object();
  for (const auto& text : settings.method_options) {
    const auto [key, value] = ParseTextAssignment(text, "--option");
    options.method_options[key] = value;
  }
  const std::string candidates_text = settings.candidates.value_or("");
  if (!candidates_text.empty()) {
    request.discovery.candidates = ParseNameList(candidates_text, "--candidates");
    for (const auto& name : request.discovery.candidates) FindEffect(name);
  }
  for (const auto& source : settings.traces) {
    for (auto& part : LoadTraceSource(source, input_options, config.experiment.initial)) {
      request.traces.push_back(std::move(part));
    }
  }
  for (const auto& source : settings.validation) {
    for (auto& part : LoadTraceSource(source, input_options, config.experiment.initial)) {
      request.validation.push_back(std::move(part));
    }
  }
  if (config.identification.simulate_from == "reference") {
    for (auto* traces : {&request.traces, &request.validation}) {
      for (FitTrace& part : *traces) CommandFromTheLoop(config, &part);
    }
  }
  options.seed = settings.seed;
  options.threads = settings.threads;
  options.max_evaluations = settings.max_evaluations;
  options.verbose = settings.verbose;
  request.discover = settings.discover;
  request.discovery.bic_margin = settings.bic_margin;
  request.discovery.min_explained_share = settings.min_share;
  request.discovery.max_effects = settings.max_effects;
  // The cost's weights (docs/identification.md §1a): the config's, then the flags'.
  request.noise.weighting = config.identification.weighting;
  if (!settings.weighting.empty()) {
    if (settings.weighting != "noise" && settings.weighting != "variance") {
      throw InputError("--weighting: '" + InputError::Excerpt(settings.weighting) +
                       "' is not one of: noise, variance");
    }
    request.noise.weighting = settings.weighting;
  }
  request.noise.std = config.identification.noise_std;
  for (const auto& text : settings.noise_stds) {
    const auto [name, value] = ParseAssignment(text, "--noise-std");
    if (!(value > 0.0)) {
      throw InputError("--noise-std " + name + ": sigma must be > 0 (got " + FormatNumber(value) +
                       ")");
    }
    request.noise.std[name] = value;
  }
  for (const auto& [name, value] : request.noise.std) {
    if (std::find(request.observe.begin(), request.observe.end(), name) == request.observe.end()) {
      throw InputError("--noise-std " + name + ": '" + name +
                       "' is not an observed column (observed: " + Join(request.observe) + ")");
    }
  }
  return request;
}

void CheckGridCount(const std::vector<std::string>& grids) {
  if (grids.empty() || grids.size() > 2) {
    throw InputError("--grid: give one or two axes, P=LO:HI:N (got " +
                     std::to_string(grids.size()) + ")");
  }
}

std::pair<int, int> ParseShard(const std::string& text) {
  if (text.empty()) return {1, 1};
  const auto slash = text.find('/');
  // Digits, '/', digits: std::stoi alone would take " 1" and "+1".
  if (text.find_first_not_of("0123456789/") != std::string::npos) {
    throw InputError("--shard '" + text + "': expected K/N, e.g. 3/8");
  }
  int index = 0, count = 0;
  try {
    std::size_t used = 0;
    index = std::stoi(text.substr(0, slash), &used);
    if (used != slash) throw std::invalid_argument("K");
    const std::string count_text = text.substr(slash + 1);
    count = std::stoi(count_text, &used);
    if (used != count_text.size()) throw std::invalid_argument("N");  // "1/3abc"
  } catch (const std::exception&) {
    throw InputError("--shard '" + text + "': expected K/N, e.g. 3/8");
  }
  if (slash == std::string::npos || count < 1 || index < 1 || index > count) {
    throw InputError("--shard '" + text + "': expected K/N with 1 <= K <= N");
  }
  return {index, count};
}

SweepRequest MakeSweepRequest(Config config, const SweepSettings& settings) {
  CheckGridCount(settings.grids);
  SweepRequest request;
  request.config = std::move(config);
  request.axes = ParseGridAxes(request.config, settings.grids);
  const auto [shard_index, shard_count] = ParseShard(settings.shard);
  if (settings.observe && settings.observe->empty()) {
    throw InputError("--observe: empty (valid: " + Join(request.config.model->outputs()) + ")");
  }
  request.observe = settings.error.Apply(&request.config, settings.observe.value_or(""));
  CheckObservedOutputs(request.config, request.observe, ", ");
  const bool equation_error = request.config.identification.error == "equation";
  request.rows_line = settings.preparation.RowsLine();
  request.traces = LoadTraceSource(
      settings.trace,
      settings.preparation.Options(request.observe, equation_error,
                                   request.config.identification.simulate_from == "reference"),
      request.config.experiment.initial);
  // The sweep's size before it starts: a typo in N must not ask for gigabytes.
  std::size_t points = 1;
  for (const auto& axis : request.axes) points *= static_cast<std::size_t>(axis.count);
  points =
      (points + static_cast<std::size_t>(shard_count) - 1) / static_cast<std::size_t>(shard_count);
  const double bytes =
      SweepBytes(points, request.axes.size(), request.observe.size(), request.traces.size());
  if (!settings.force && (points > kMaxSurfacePoints || bytes > kMaxSurfaceBytes)) {
    throw InputError("--grid: " + std::to_string(points) + " points" +
                     (shard_count > 1 ? " in this shard" : "") + " (about " +
                     FormatSignificant(bytes / 1e9, 3) +
                     " GB) is more than the cap of 1000000 points or 1 GB; narrow the "
                     "grid, shard it (--shard K/N), or add --force");
  }
  request.threads = settings.threads;
  request.shard_index = shard_index;
  request.shard_count = shard_count;
  return request;
}

std::vector<NoiseSpec> ParseNoise(const std::vector<std::string>& specs) {
  std::vector<NoiseSpec> noise;
  for (const auto& spec : specs) {
    NoiseSpec n;
    std::string text = spec;
    if (!text.empty() && text.back() == '%') {
      n.relative = true;
      text.pop_back();
    }
    const auto assignment = ParseAssignment(text, "--noise");
    if (assignment.second < 0.0) {
      throw InputError("--noise " + assignment.first + ": sigma must be >= 0");
    }
    if (assignment.first == "t" || assignment.first == "open") {
      // Noise on the time would make it go backwards; "open" is a switch, not a signal.
      throw InputError("--noise " + assignment.first + ": '" + assignment.first +
                       "' takes no noise (time must increase); noise an output column");
    }
    n.column = assignment.first;
    n.sigma = n.relative ? assignment.second / 100.0 : assignment.second;
    noise.push_back(n);
  }
  return noise;
}

Trace ReadInputTrace(const std::string& path, const DialectSettings& dialect) {
  CsvReadOptions options;
  options.required = {"t", "u"};
  options.strict_columns = {"t", "u", "open"};  // other columns may hold text
  options.delimiter = dialect.Delimiter();
  options.duplicate_time = dialect.Duplicates();
  options.names = dialect.Names();
  options.sample_rate = dialect.sample_rate;
  return ReadTraceCsv(path, options);
}

InputSignal RecordedInput(const Trace& input, const std::string& path, const Config& config) {
  InputSignal recorded;
  recorded.kind = InputSignal::Kind::kRecorded;
  recorded.times = input.Column("t");
  recorded.values = input.Column("u");
  if (input.Has("open")) recorded.open = input.Column("open");
  if (const std::string error =
          RunLengthError(recorded.times.back() - recorded.times.front(), config.simulation.dt, 0.0);
      !error.empty()) {
    throw InputError(path + ": " + error);
  }
  return recorded;
}

void AddNoise(std::vector<NoiseSpec>* noise, std::uint64_t seed, Trace* trace) {
  for (auto& [column, sigma, relative] : *noise) {
    if (!trace->Has(column)) {
      throw InputError("--noise: no output column '" + column +
                       "' (have: " + Join(trace->names(), ",") + ")");
    }
    if (relative) {
      double peak = 0.0;
      for (double v : trace->Column(column)) peak = std::max(peak, std::abs(v));
      sigma *= peak;
    }
  }
  Random random(seed);
  for (const auto& [column, sigma, relative] : *noise) {
    for (double& value : trace->Column(column)) {
      value += sigma * random.Normal();
      if (!std::isfinite(value)) {  // sigma near the double range: never write inf
        throw InputError("--noise " + column + "=" + FormatNumber(sigma) + ": the noisy '" +
                         column + "' is not finite (sigma too large for a double)");
      }
    }
  }
}

std::string SimulationFailureMessage(const std::string& config_path, const Config& config,
                                     const SimStatus& status) {
  std::string message =
      config_path + ": " + status.message + " at t = " + Fixed(status.at_time) + " s";
  if (status.code == SimStatus::Code::kDiverged) {
    message += "; the step simulation.dt = " + FormatNumber(config.simulation.dt) +
               " s may be too large for the model's fastest dynamics, or a parameter is "
               "unphysical: reduce dt or check the parameters";
  }
  return message;
}

}  // namespace blmd
