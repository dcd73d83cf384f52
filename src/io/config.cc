#include "blmd/io/config.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <unordered_map>

#include "blmd/error.h"
#include "blmd/io/csv.h"
#include "blmd/io/files.h"
#include "blmd/sim/effects.h"
#include "io/config_pid.h"
#include "io/json_reader.h"

namespace blmd {
namespace {

using nlohmann::json;
using namespace json_reader;  // NOLINT(google-build-using-namespace): the loader's own reader

InputSignal ReadInput(const Reader& reader, const json& input, const std::string& pointer,
                      const std::string& config_path) {
  reader.RequireObject(input, pointer);
  if (!input.contains("type"))
    reader.Fail(pointer, "'" + Reader::Label(pointer) +
                             "' needs a \"type\" (step, square, "
                             "steps, sweep, prbs, chirp, recorded)");
  const std::string type = reader.String(input["type"], pointer + "/type");
  InputSignal signal;
  auto number_or = [&](const char* key, double fallback) {
    return input.contains(key) ? reader.Number(input[key], pointer + "/" + key) : fallback;
  };
  // The keys every generated input shares: its amplitude, offset and start time.
  auto read_levels = [&] {
    signal.amplitude = number_or("amplitude", 1.0);
    signal.offset = number_or("offset", 0.0);
    signal.t0 = number_or("t0", 0.0);
  };
  if (type == "step") {
    reader.CheckKeys(input, pointer, {"type", "amplitude", "offset", "t0"});
    signal.kind = InputSignal::Kind::kStep;
    read_levels();
  } else if (type == "square") {
    reader.CheckKeys(input, pointer, {"type", "amplitude", "offset", "t0", "period"});
    signal.kind = InputSignal::Kind::kSquare;
    read_levels();
    if (!input.contains("period")) reader.Fail(pointer, "square input needs \"period\" (s)");
    signal.period = reader.Positive(input["period"], pointer + "/period");
  } else if (type == "prbs") {
    reader.CheckKeys(input, pointer,
                     {"type", "amplitude", "offset", "t0", "clock", "order", "seed"});
    signal.kind = InputSignal::Kind::kPrbs;
    read_levels();
    if (!input.contains("clock") || !input.contains("order")) {
      reader.Fail(pointer, "prbs input needs \"clock\" (s, one bit) and \"order\" (2 to 31)");
    }
    signal.clock = reader.Positive(input["clock"], pointer + "/clock");
    // A whole number in [low, high], or the error naming the range.
    auto whole = [&](const char* key, double low, double high, const std::string& range) {
      const std::string at = pointer + "/" + key;
      const double v = reader.Number(input[key], at);
      if (!(v >= low && v <= high && v == std::floor(v))) {
        reader.Fail(at, "'" + Reader::Label(at) + "' must be a whole number from " + range +
                            " (got " + DisplayNumber(v) + ")");
      }
      return v;
    };
    signal.order = static_cast<int>(whole("order", 2.0, 31.0, "2 to 31"));
    if (input.contains("seed")) {
      const double high = std::ldexp(1.0, signal.order) - 1.0;
      signal.seed = static_cast<std::uint32_t>(
          whole("seed", 1.0, high, "1 to 2^order - 1 = " + DisplayNumber(high)));
    }
  } else if (type == "chirp") {
    reader.CheckKeys(input, pointer,
                     {"type", "amplitude", "offset", "t0", "f0", "f1", "duration", "shape"});
    signal.kind = InputSignal::Kind::kChirp;
    read_levels();
    if (!input.contains("f0") || !input.contains("f1")) {
      reader.Fail(pointer, "chirp input needs \"f0\" and \"f1\" (Hz)");
    }
    if (input.contains("shape")) {
      const std::string shape = reader.String(input["shape"], pointer + "/shape");
      if (shape == "log") {
        signal.shape = InputSignal::ChirpShape::kLog;
      } else if (shape != "linear") {
        reader.Fail(pointer + "/shape", "unknown chirp shape '" + InputError::Excerpt(shape) +
                                            "' (valid: linear, log)");
      }
    }
    const bool log = signal.shape == InputSignal::ChirpShape::kLog;
    for (const char* key : {"f0", "f1"}) {
      const std::string at = pointer + "/" + key;
      const double f = reader.Number(input[key], at);
      if (log ? !(f > 0.0) : !(f >= 0.0)) {
        reader.Fail(at, "'" + Reader::Label(at) + "' must be " + (log ? "> 0" : ">= 0") + " Hz" +
                            (log ? " for a log chirp" : "") + " (got " + DisplayNumber(f) + ")");
      }
      (key[1] == '0' ? signal.f0 : signal.f1) = f;
    }
    if (!(signal.f0 > 0.0 || signal.f1 > 0.0)) {
      reader.Fail(pointer + "/f1", "a chirp needs f0 or f1 > 0 Hz");
    }
    // 0: the experiment's duration, set by ReadExperiment.
    if (input.contains("duration")) {
      signal.sweep = reader.Positive(input["duration"], pointer + "/duration");
    }
  } else if (type == "steps") {
    reader.CheckKeys(input, pointer, {"type", "times", "values", "offset"});
    signal.kind = InputSignal::Kind::kSteps;
    if (!input.contains("times") || !input.contains("values")) {
      reader.Fail(pointer, "steps input needs \"times\" (s) and \"values\"");
    }
    signal.times = reader.Numbers(input["times"], pointer + "/times");
    signal.values = reader.Numbers(input["values"], pointer + "/values");
    signal.offset = number_or("offset", 0.0);
    if (signal.times.size() != signal.values.size() || signal.times.empty()) {
      reader.Fail(pointer + "/values", "steps input needs as many values as times (and one)");
    }
    for (std::size_t k = 1; k < signal.times.size(); ++k) {
      if (!(signal.times[k] > signal.times[k - 1])) {
        reader.Fail(pointer + "/times/" + std::to_string(k), "step times must increase");
      }
    }
  } else if (type == "sweep") {
    // Steady-state sweep: each level held for `hold` seconds, from t = 0.
    reader.CheckKeys(input, pointer, {"type", "levels", "hold"});
    if (!input.contains("levels") || !input.contains("hold")) {
      reader.Fail(pointer, "sweep input needs \"levels\" (V) and \"hold\" (s)");
    }
    const auto levels = reader.Numbers(input["levels"], pointer + "/levels");
    const double hold = reader.Positive(input["hold"], pointer + "/hold");
    if (levels.empty()) reader.Fail(pointer + "/levels", "sweep needs at least one level");
    signal.kind = InputSignal::Kind::kSteps;
    for (std::size_t k = 0; k < levels.size(); ++k) {
      signal.times.push_back(static_cast<double>(k) * hold);
      signal.values.push_back(levels[k]);
    }
  } else if (type == "recorded") {
    reader.CheckKeys(input, pointer, {"type", "file", "column"});
    if (!input.contains("file")) reader.Fail(pointer, "recorded input needs \"file\"");
    std::string file = reader.String(input["file"], pointer + "/file");
    const std::string column =
        input.contains("column") ? reader.String(input["column"], pointer + "/column") : "u";
    if (!file.empty() && file.front() != '/') {
      const auto slash = config_path.rfind('/');
      if (slash != std::string::npos) file = config_path.substr(0, slash + 1) + file;
    }
    CsvReadOptions options;
    options.required = {"t", column};
    if (access(file.c_str(), R_OK) != 0) {
      reader.Fail(pointer + "/file",
                  "recorded input '" + file + "' cannot be read: " + std::strerror(errno));
    }
    const Trace trace = ReadTraceCsv(file, options);
    signal.kind = InputSignal::Kind::kRecorded;
    signal.times = trace.Column("t");
    signal.values = trace.Column(column);
    if (trace.Has("open")) signal.open = trace.Column("open");
  } else {
    reader.Fail(pointer + "/type",
                "unknown input type '" + InputError::Excerpt(type) +
                    "' (valid: chirp, prbs, recorded, square, step, steps, sweep)");
  }
  return signal;
}

}  // namespace

std::string RunLengthError(double span, double dt, double samples) {
  constexpr double kMaxSteps = 1e10, kMaxSamples = 1e8;
  auto short_form = [](double v) { return Short(v, 3); };
  const double steps = span / dt;
  if (!(steps <= kMaxSteps)) {
    return "a run of " + short_form(span) + " s at simulation.dt = " + short_form(dt) + " s is " +
           short_form(steps) + " steps, more than 1e10; raise dt or shorten the run";
  }
  if (!(samples <= kMaxSamples)) {
    return short_form(samples) +
           " output samples (duration x sample_rate), more than 1e8; lower the rate or "
           "shorten the run";
  }
  return {};
}

std::string Join(const std::vector<std::string>& names, const char* separator) {
  std::string out;
  for (const auto& name : names) out += (out.empty() ? "" : separator) + name;
  return out;
}

std::string NearestName(const std::string& word, const std::vector<std::string>& candidates) {
  auto lower = [](std::string s) {
    for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
  };
  const std::string a = lower(word);
  std::string best;
  std::size_t best_distance = std::string::npos;
  for (const auto& candidate : candidates) {
    const std::string b = lower(candidate);
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
      std::size_t diagonal = row[0];
      row[0] = i;
      for (std::size_t j = 1; j <= b.size(); ++j) {
        const std::size_t above = row[j];
        row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
        diagonal = above;
      }
    }
    if (row[b.size()] < best_distance) {
      best_distance = row[b.size()];
      best = candidate;
    }
  }
  const std::size_t limit = std::max<std::size_t>(1, std::min(word.size(), best.size()) / 2);
  return best_distance <= limit ? best : std::string();
}

Config LoadConfig(const std::string& path) {
  return ParseConfig(ReadFileText(path, kMaxConfigBytes, "config (a JSON file of a few KiB)"),
                     path);
}

namespace {

// The config's text as JSON, refused with line and column when it is not JSON, is nested
// absurdly deep, or holds a number beyond the double range.
json ParseJsonText(const std::string& text, const std::string& path) {
  if (const std::size_t at = TooDeep(text); at != std::string::npos) {
    const Position p = PositionOf(text, at);
    throw InputError(
        path, p.line, p.column,
        "JSON nested deeper than " + std::to_string(kMaxNesting) + " levels: not a config");
  }
  json root;
  try {
    root = json::parse(text);
  } catch (const json::parse_error& error) {
    const Position p = PositionOf(text, error.byte ? error.byte - 1 : 0);
    // "[json.exception.parse_error.101] parse error at line 3, column 30: <what>": keep
    // <what>, which may itself contain ": " ("last read: '0.04.'").
    std::string what = error.what();
    const auto column_at = what.find(", column ");
    const auto colon = what.find(": ", column_at == std::string::npos ? 0 : column_at);
    if (colon != std::string::npos) what = what.substr(colon + 2);
    throw InputError(path, p.line, p.column, "invalid JSON: " + Printable(what) + SyntaxHint(what));
  } catch (const json::exception& error) {
    // A number beyond the double range: "[json.exception.out_of_range.406] number overflow
    // parsing '1e400'".
    ErrorLocator locator;
    json::sax_parse(text, &locator);
    const Position p = PositionOf(text, locator.position ? locator.position - 1 : 0);
    std::string what = error.what();
    const auto bracket = what.find("] ");
    if (bracket != std::string::npos) what = what.substr(bracket + 2);
    throw InputError(path, p.line, p.column,
                     "invalid JSON: " + Printable(what) + " (beyond the double range)");
  }
  return root;
}

// The model's parameters: every one present (or optional), each a number in its range.
void ReadParameters(const Reader& reader, const json& root, Config* out) {
  Config& config = *out;
  const Model& model = *config.model;
  const std::string model_name(model.name());
  if (!root.contains("parameters")) reader.Fail("", "missing \"parameters\"");
  const json& parameters = root["parameters"];
  reader.RequireObject(parameters, "/parameters");
  std::vector<std::string> names;
  for (const auto& info : model.parameters()) names.push_back(info.name);
  reader.CheckKeys(parameters, "/parameters", names);
  for (const auto& info : model.parameters()) {
    const std::string pointer = "/parameters/" + info.name;
    if (!parameters.contains(info.name)) {
      if (info.optional) {
        config.parameters.Set(info.name, info.default_value);
        continue;
      }
      reader.Fail("/parameters", "missing parameter '" + info.name + "' (" + info.meaning + ", " +
                                     info.unit + ") for model " + model_name);
    }
    const double v = reader.Number(parameters[info.name], pointer);
    if (info.positive && !(v > 0.0)) {
      reader.Fail(pointer, "parameter '" + info.name + "' must be > 0 (got " + FormatNumber(v) +
                               " " + info.unit + ")");
    }
    if (info.non_negative && v < 0.0) {
      reader.Fail(pointer,
                  "parameter '" + info.name + "' must be >= 0 (got " + FormatNumber(v) + ")");
    }
    config.parameters.Set(info.name, v);
  }
}

// The declared effects: known, applying to the model, with every parameter in its range.
void ReadEffects(const Reader& reader, const json& root, Config* out) {
  Config& config = *out;
  const std::string model_name(config.model->name());
  if (root.contains("effects")) {
    const json& effects = root["effects"];
    reader.RequireObject(effects, "/effects");
    for (const auto& [effect_name, effect_values] : effects.items()) {
      const std::string pointer = "/effects/" + effect_name;
      const EffectInfo* info = nullptr;
      try {
        info = &FindEffect(effect_name);
      } catch (const InputError& error) {
        std::vector<std::string> valid;
        for (const auto& e : EffectRegistry()) valid.push_back(e.name);
        const std::string near = NearestName(effect_name, valid);
        reader.Fail(pointer, std::string(error.what()) +
                                 (near.empty() ? "" : " (did you mean '" + near + "'?)"));
      }
      if (std::find(info->models.begin(), info->models.end(), model_name) == info->models.end()) {
        reader.Fail(pointer, "effect '" + effect_name + "' does not apply to model " + model_name +
                                 " (only to " + Join(info->models) + ")");
      }
      reader.RequireObject(effect_values, pointer);
      // Keys inside the effect's object (ParamInfo::config_key: gravity's `phase` is the flat
      // parameter gravity_phase).
      std::vector<std::string> effect_params;
      for (const auto& p : info->parameters) effect_params.push_back(p.config_key());
      reader.CheckKeys(effect_values, pointer, effect_params);
      for (const auto& p : info->parameters) {
        const std::string& key = p.config_key();
        if (!effect_values.contains(key)) {
          reader.Fail(pointer, "effect '" + effect_name + "' needs parameter '" + key + "' (" +
                                   p.meaning + ", " + p.unit + ")");
        }
        const double v = reader.Number(effect_values[key], pointer + "/" + key);
        if ((p.positive && !(v > 0.0)) || (p.non_negative && v < 0.0)) {
          reader.Fail(pointer + "/" + key,
                      "effect parameter '" + key + "' must be " + (p.positive ? "> 0" : ">= 0"));
        }
        if (p.share && v > 1.0) {
          reader.Fail(pointer + "/" + key, "effect parameter '" + key +
                                               "' is a share: it must be in [0, 1] (got " +
                                               FormatNumber(v) + ")");
        }
        config.parameters.Set(p.name, v);
      }
      config.effects.push_back(effect_name);
    }
  }
}

// The simulation settings over the model's defaults, and the model's own check of them.
void ReadSimulation(const Reader& reader, const json& root, Config* out) {
  Config& config = *out;
  const Model& model = *config.model;
  config.simulation = model.default_settings();
  if (root.contains("simulation")) {
    const json& sim = root["simulation"];
    reader.RequireObject(sim, "/simulation");
    reader.CheckKeys(sim, "/simulation",
                     {"dt", "method", "max_step", "regula_falsi", "friction_smoothing_w",
                      "diagnostics", "divergence_limit"});
    if (sim.contains("dt")) config.simulation.dt = reader.Positive(sim["dt"], "/simulation/dt");
    if (sim.contains("method")) {
      const std::string name = reader.String(sim["method"], "/simulation/method");
      std::string valid;
      bool found = false;
      for (const auto& [method_name, method] : SimulationMethods()) {
        valid += (valid.empty() ? "" : ", ") + method_name;
        if (method_name == name) {
          config.simulation.method = method;
          found = true;
        }
      }
      if (!found) {
        reader.Fail("/simulation/method",
                    "unknown simulation method '" + name + "' (valid: " + valid + ")");
      }
      if (config.simulation.method == SimulationMethod::kEvents &&
          !model.traits().event_integrator) {
        reader.Fail("/simulation/method",
                    "simulation method 'events' is implemented for model "
                    "blmd only (valid for " +
                        std::string(model.name()) + ": fixed_euler)");
      }
    }
    if (sim.contains("max_step")) {
      config.simulation.max_step = reader.Positive(sim["max_step"], "/simulation/max_step");
    }
    if (sim.contains("regula_falsi")) {
      config.simulation.regula_falsi = reader.Bool(sim["regula_falsi"], "/simulation/regula_falsi");
    }
    if (sim.contains("friction_smoothing_w")) {
      config.simulation.friction_smoothing_w =
          reader.Number(sim["friction_smoothing_w"], "/simulation/friction_smoothing_w");
    }
    if (sim.contains("diagnostics")) {
      config.simulation.diagnostics = reader.Bool(sim["diagnostics"], "/simulation/diagnostics");
    }
    if (sim.contains("divergence_limit")) {
      config.simulation.divergence_limit =
          reader.Positive(sim["divergence_limit"], "/simulation/divergence_limit");
    }
  }
  if (std::string error = model.Validate(config.parameters, config.simulation); !error.empty()) {
    reader.Fail("/parameters", error);
  }
}

// What an input can only check once the experiment's duration and sample rate are known: a
// chirp's sweep defaults to the duration and stays below half the sample rate (Nyquist); a
// prbs bit lasts at least one sample.
void CheckInputAgainstSamples(const Reader& reader, Experiment* experiment) {
  InputSignal& input = experiment->input;
  const double fs = experiment->sample_rate;
  const std::string pointer = "/experiment/input";
  if (input.kind == InputSignal::Kind::kChirp) {
    if (!(input.sweep > 0.0)) input.sweep = experiment->duration;
    for (const char* key : {"f0", "f1"}) {
      const double f = key[1] == '0' ? input.f0 : input.f1;
      if (!(f < 0.5 * fs)) {
        reader.Fail(pointer + "/" + key,
                    "chirp frequency " + std::string(key) + " = " + DisplayNumber(f) +
                        " Hz is not below half the sample rate (" + DisplayNumber(0.5 * fs) +
                        " Hz): the samples would alias it; lower it or raise sample_rate");
      }
    }
  } else if (input.kind == InputSignal::Kind::kPrbs) {
    if (input.clock * fs < 1.0 - 1e-9) {
      reader.Fail(pointer + "/clock", "prbs clock " + DisplayNumber(input.clock) +
                                          " s is shorter than one sample (1/sample_rate = " +
                                          DisplayNumber(1.0 / fs) + " s)");
    }
  }
}

// The experiment (input, duration, sample rate, coast-down, PID, initial state), and whether
// it can be run at this step.
void ReadExperiment(const Reader& reader, const json& root, Config* out) {
  Config& config = *out;
  Experiment& experiment = config.experiment;
  const ModelTraits traits = config.model->traits();
  experiment.duration = traits.default_duration;
  experiment.sample_rate = traits.default_sample_rate;
  if (root.contains("experiment")) {
    const json& exp = root["experiment"];
    reader.RequireObject(exp, "/experiment");
    reader.CheckKeys(exp, "/experiment",
                     {"input", "duration", "sample_rate", "coast_off_time", "pid", "initial"});
    if (exp.contains("input")) {
      experiment.input = ReadInput(reader, exp["input"], "/experiment/input", config.path);
    }
    if (exp.contains("duration")) {
      experiment.duration = reader.Positive(exp["duration"], "/experiment/duration");
    }
    if (exp.contains("sample_rate")) {
      experiment.sample_rate = reader.Positive(exp["sample_rate"], "/experiment/sample_rate");
    }
    CheckInputAgainstSamples(reader, &experiment);
    if (exp.contains("coast_off_time")) {
      if (!traits.coast_down_and_pid) {
        reader.Fail("/experiment/coast_off_time", "coast-down applies to model dc_servo only");
      }
      experiment.coast_off_time =
          reader.Number(exp["coast_off_time"], "/experiment/coast_off_time");
      if (experiment.coast_off_time < 0.0) {
        reader.Fail("/experiment/coast_off_time", "coast_off_time must be >= 0 (s)");
      }
    }
    if (exp.contains("pid")) {
      if (!traits.coast_down_and_pid && !traits.sampled_pid) {
        reader.Fail("/experiment/pid",
                    "closed-loop PID control applies to dc_servo, rigid_load and blmd");
      }
      const json& pid = exp["pid"];
      reader.RequireObject(pid, "/experiment/pid");
      if (traits.own_current_loop) {
        // The drive's own current loops follow the demand (no current_bandwidth to give).
        reader.CheckKeys(
            pid, "/experiment/pid",
            {"loop", "Kp", "Ki", "speed_Kp", "speed_Ki", "speed_feedforward",
             "speed_difference_samples", "u_max", "u_min", "sample_rate", "delay", "notch"});
      } else if (traits.sampled_pid) {
        reader.CheckKeys(pid, "/experiment/pid",
                         {"loop", "Kp", "Ki", "speed_Kp", "speed_Ki", "speed_feedforward",
                          "speed_difference_samples", "u_max", "u_min", "sample_rate", "delay",
                          "current_bandwidth", "notch"});
      } else {
        reader.CheckKeys(pid, "/experiment/pid",
                         {"loop", "Kp", "Ki", "Kd", "tau_d", "u_max", "sample_rate", "delay"});
      }
      experiment.closed_loop = true;
      if (pid.contains("loop")) {
        const std::string loop = reader.String(pid["loop"], "/experiment/pid/loop");
        if (loop == "speed") {
          experiment.pid.loop = PidSettings::Loop::kSpeed;
        } else if (loop != "position") {
          reader.Fail("/experiment/pid/loop",
                      "unknown loop '" + InputError::Excerpt(loop) + "' (valid: position, speed)");
        }
      }
      auto get = [&](const char* key, double* field) {
        if (pid.contains(key))
          *field = reader.Number(pid[key], std::string("/experiment/pid/") + key);
      };
      get("Kp", &experiment.pid.Kp);
      get("Ki", &experiment.pid.Ki);
      get("Kd", &experiment.pid.Kd);
      get("tau_d", &experiment.pid.tau_d);
      // A drive that states its input's range (ModelTraits::input_limit) limits to it.
      if (traits.input_limit > 0.0) experiment.pid.u_max = traits.input_limit;
      get("u_max", &experiment.pid.u_max);
      if (!(experiment.pid.u_max > 0.0)) reader.Fail("/experiment/pid/u_max", "u_max must be > 0");
      if (!(experiment.pid.tau_d > 0.0)) reader.Fail("/experiment/pid/tau_d", "tau_d must be > 0");
      if (traits.sampled_pid) {
        ReadSampledPid(reader, pid, config.simulation.dt, &experiment.pid);
      } else if (pid.contains("sample_rate") || pid.contains("delay")) {
        // dc_servo's PID runs on every step without delay unless it is given a rate or a
        // delay: then it is a digital controller (a delay alone: sampled on every step).
        ReadControllerRate(reader, pid, config.simulation.dt, &experiment.pid);
      }
    }
    if (exp.contains("initial")) {
      const json& initial = exp["initial"];
      reader.RequireObject(initial, "/experiment/initial");
      reader.CheckKeys(initial, "/experiment/initial", {"i", "w", "theta"});
      if (initial.contains("i"))
        experiment.initial.i = reader.Number(initial["i"], "/experiment/initial/i");
      if (initial.contains("w"))
        experiment.initial.w = reader.Number(initial["w"], "/experiment/initial/w");
      if (initial.contains("theta")) {
        experiment.initial.theta = reader.Number(initial["theta"], "/experiment/initial/theta");
      }
    }
  }
  // The experiment's run against the step: checked only where the experiment is run
  // (blmd-sim without --input: Experiment::CheckRunnable). A trace brings its own time base,
  // and an identification never runs the config's experiment (once, a config without
  // an experiment section, dt = 5e-4, was refused for a 10 kHz trace because of the default
  // experiment's 10 kHz sample_rate).
  if (experiment.sample_rate * config.simulation.dt > 1.0 + 1e-9) {
    experiment.invalid =
        reader
            .Error("/experiment/sample_rate",
                   "sample_rate " + DisplayNumber(experiment.sample_rate) +
                       " Hz is faster than the simulation step allows (1/dt = " +
                       Short(1.0 / config.simulation.dt) + " Hz); lower it or reduce dt")
            .what();
  } else if (const std::string error =
                 RunLengthError(experiment.duration, config.simulation.dt,
                                experiment.duration * experiment.sample_rate + 1.0);
             !error.empty()) {
    const bool has_duration = root.contains("experiment") && root["experiment"].is_object() &&
                              root["experiment"].contains("duration");
    experiment.invalid =
        reader
            .Error(has_duration ? "/experiment/duration" : "/simulation/dt", "experiment: " + error)
            .what();
  }
}

// The identification set-up (free parameters, start values, bounds, observed columns,
// method, error), each name a parameter of this config, each start inside its bounds.
void ReadIdentification(const Reader& reader, const json& root, Config* out) {
  Config& config = *out;
  const std::string model_name(config.model->name());
  IdentificationSettings& ident = config.identification;
  ident.free = {"J", "B"};
  ident.observe = config.model->traits().default_observe;
  if (root.contains("identification")) {
    const json& id = root["identification"];
    reader.RequireObject(id, "/identification");
    reader.CheckKeys(
        id, "/identification",
        {"free", "initial", "bounds", "observe", "method", "options", "error", "filter_hz",
         "decimate", "weighting", "noise_std", "effect_angle", "simulate_from"});
    if (id.contains("free")) ident.free = reader.Strings(id["free"], "/identification/free");
    if (id.contains("observe")) {
      ident.observe = reader.Strings(id["observe"], "/identification/observe");
      if (ident.observe.empty()) {  // would run a fit of nothing and call it converged
        std::string valid;
        for (const auto& name : config.model->outputs())
          valid += (valid.empty() ? "" : ", ") + name;
        reader.Fail(
            "/identification/observe",
            "'identification.observe' is empty: name the columns the fit compares (valid: " +
                valid + ")");
      }
    }
    if (id.contains("method")) ident.method = reader.String(id["method"], "/identification/method");
    if (id.contains("options")) {
      reader.RequireObject(id["options"], "/identification/options");
      ident.options = id["options"];
    }
    if (id.contains("error")) {
      ident.error = reader.String(id["error"], "/identification/error");
      if (ident.error != "output" && ident.error != "equation") {
        reader.Fail("/identification/error",
                    "error '" + ident.error + "' is not one of: output, equation");
      }
      if (ident.error == "equation" && !config.model->traits().input_is_torque) {
        reader.Fail("/identification/error",
                    "the equation error needs model rigid_load (its input is the drive torque); "
                    "model " +
                        model_name + "'s drive torque is a state of the model");
      }
      if (ident.error == "equation" && !id.contains("observe")) ident.observe = {"u"};
    }
    if (id.contains("filter_hz")) {
      ident.filter_hz = reader.Positive(id["filter_hz"], "/identification/filter_hz");
    }
    if (id.contains("weighting")) {
      ident.weighting = reader.Choice(id["weighting"], "/identification/weighting", "weighting",
                                      {"noise", "variance"});
    }
    if (id.contains("effect_angle")) {
      ident.effect_angle = reader.Choice(id["effect_angle"], "/identification/effect_angle",
                                         "effect_angle", {"measured", "simulated"});
    }
    if (id.contains("simulate_from")) {
      ident.simulate_from = reader.Choice(id["simulate_from"], "/identification/simulate_from",
                                          "simulate_from", {"command", "reference"});
      if (ident.simulate_from == "reference" && !config.experiment.closed_loop) {
        reader.Fail("/identification/simulate_from",
                    "identification from the reference simulates the drive's loop: the config "
                    "needs its controller (experiment.pid)");
      }
    }
    if (id.contains("noise_std")) {
      const json& noise = id["noise_std"];
      reader.RequireObject(noise, "/identification/noise_std");
      const std::vector<std::string> outputs = config.model->OutputsWith(config.effects);
      for (const auto& [column, value] : noise.items()) {
        const std::string pointer = "/identification/noise_std/" + column;
        std::vector<std::string> valid(outputs.begin(), outputs.end());
        valid.push_back("u");
        if (std::find(valid.begin(), valid.end(), column) == valid.end()) {
          reader.Fail(pointer, "noise_std names '" + InputError::Excerpt(column) +
                                   "', not a column of model " + model_name +
                                   " (valid: " + Join(valid) + ")");
        }
        ident.noise_std[column] = reader.Positive(value, pointer);
      }
    }
    if (id.contains("decimate")) {
      const double decimate = reader.Number(id["decimate"], "/identification/decimate");
      if (!(decimate >= 1.0 && decimate <= 1000.0 && decimate == std::floor(decimate))) {
        reader.Fail("/identification/decimate", "decimate must be a whole number from 1 to 1000");
      }
      ident.decimate = static_cast<int>(decimate);
    }
    std::vector<std::string> known;
    for (const auto& [name, value] : config.parameters.entries()) known.push_back(name);
    auto check_known = [&](const std::string& name, const std::string& pointer) {
      if (config.parameters.Has(name)) return;
      // An effect parameter named by its key inside the effect's object where its flat name
      // differs (gravity's `phase` is gravity_phase outside the object).
      for (const auto& declared : config.effects) {
        for (const auto& p : FindEffect(declared).parameters) {
          if (p.config_key() == name && p.name != name) {
            reader.Fail(pointer, "parameter '" + name + "' of effect '" + declared + "' is '" +
                                     p.name + "' outside the effect's object");
          }
        }
      }
      std::string effect;
      if (IsEffectParameter(name, &effect)) {
        reader.Fail(pointer, "parameter '" + name + "' belongs to effect '" + effect +
                                 "', which the config does not declare under \"effects\"");
      }
      const std::string near = NearestName(name, known);
      reader.Fail(pointer, "unknown parameter '" + name + "'" +
                               (near.empty() ? "" : " (did you mean '" + near + "'?)"));
    };
    if (id.contains("free")) {
      for (std::size_t k = 0; k < ident.free.size(); ++k) {
        const std::string pointer = "/identification/free/" + std::to_string(k);
        check_known(ident.free[k], pointer);
        if (std::find(ident.free.begin(), ident.free.begin() + static_cast<long>(k),
                      ident.free[k]) != ident.free.begin() + static_cast<long>(k)) {
          reader.Fail(pointer, "free parameter '" + ident.free[k] + "' is listed twice");
        }
      }
    }
    if (id.contains("bounds")) {
      const json& bounds = id["bounds"];
      reader.RequireObject(bounds, "/identification/bounds");
      for (const auto& [name, pair] : bounds.items()) {
        const std::string pointer = "/identification/bounds/" + name;
        check_known(name, pointer);
        const auto values = reader.Numbers(pair, pointer);
        if (values.size() != 2)
          reader.Fail(pointer, "bounds of '" + name + "' must be [lower, upper]");
        if (!(values[0] < values[1])) {
          reader.Fail(pointer, "bounds of '" + name + "' are inverted or empty: lower " +
                                   FormatNumber(values[0]) + " >= upper " +
                                   FormatNumber(values[1]));
        }
        const ParamInfo* info = config.FindParameterInfo(name);
        if (info && info->positive && !(values[0] > 0.0)) {
          reader.Fail(pointer, "lower bound of '" + name +
                                   "' must be > 0 (it is a positive "
                                   "scale parameter)");
        }
        ident.bounds[name] = {values[0], values[1]};
      }
    }
    if (id.contains("initial")) {
      const json& initial = id["initial"];
      reader.RequireObject(initial, "/identification/initial");
      for (const auto& [name, value] : initial.items()) {
        const std::string pointer = "/identification/initial/" + name;
        check_known(name, pointer);
        ident.initial.Set(name, reader.Number(value, pointer));
      }
    }
  }
  for (const auto& name : ident.free) {
    if (!config.parameters.Has(name)) {
      reader.Fail("/identification/free", "free parameter '" + name +
                                              "' is not a parameter of "
                                              "this config");
    }
    const double initial =
        ident.initial.Has(name) ? ident.initial.Get(name) : config.parameters.Get(name);
    const auto [lower, upper] = config.Bounds(name);
    if (initial < lower || initial > upper) {
      const std::string pointer =
          ident.initial.Has(name) ? "/identification/initial/" + name : "/parameters/" + name;
      reader.Fail(pointer, "initial value " + FormatNumber(initial) + " of '" + name +
                               "' is outside its bounds [" + FormatNumber(lower) + ", " +
                               FormatNumber(upper) + "]");
    }
  }
}

}  // namespace

Config ParseConfig(const std::string& text, const std::string& path) {
  const json root = ParseJsonText(text, path);
  const PositionIndex index(text);
  const Reader reader(path, index);
  if (!index.duplicate().empty()) {
    const std::string& pointer = index.duplicate();
    const auto slash = pointer.rfind('/');
    const Position first = index.Find(pointer);
    throw InputError(path, index.duplicate_at().line, index.duplicate_at().column,
                     "duplicate key '" + InputError::Excerpt(Printable(pointer.substr(slash + 1))) +
                         "' in '" + InputError::Excerpt(Reader::Label(pointer.substr(0, slash))) +
                         "' (first at line " + std::to_string(first.line) +
                         "): JSON keeps only one of them; remove the other");
  }
  reader.RequireObject(root, "");
  // "$schema" (an editor's pointer to schema/config.schema.json, docs/config.md "Schema") is
  // accepted as a string and is not among the keys a misspelling is matched against.
  json keys = root;
  if (keys.is_object() && keys.contains("$schema")) {
    reader.String(root["$schema"], "/$schema");
    keys.erase("$schema");
  }
  reader.CheckKeys(keys, "",
                   {"name", "description", "notes", "model", "axis", "parameters", "effects",
                    "simulation", "experiment", "identification"});

  Config config;
  config.path = path;
  if (root.contains("name")) config.name = reader.String(root["name"], "/name");
  if (root.contains("description")) reader.String(root["description"], "/description");
  if (root.contains("notes")) config.notes = root["notes"];
  config.document = root;
  if (!root.contains("model")) {
    reader.Fail("", "missing \"model\" (one of: blmd, dc_servo, rigid_load)");
  }
  const std::string model_name = reader.String(root["model"], "/model");
  try {
    config.model = &FindModel(model_name);
  } catch (const InputError& error) {
    reader.Fail("/model", error.what());
  }
  if (root.contains("axis")) {
    const std::string axis = reader.String(root["axis"], "/axis");
    if (axis != "rotary" && axis != "linear") {
      reader.Fail("/axis",
                  "unknown axis '" + InputError::Excerpt(axis) + "' (valid: rotary, linear)");
    }
    if (!config.model->traits().input_is_torque && axis == "linear") {
      reader.Fail("/axis", "a linear axis applies to model rigid_load (a force input)");
    }
    config.linear_axis = axis == "linear";
  }
  ReadParameters(reader, root, &config);
  ReadEffects(reader, root, &config);
  ReadSimulation(reader, root, &config);
  ReadExperiment(reader, root, &config);
  ReadIdentification(reader, root, &config);
  return config;
}

std::string JsonSource::Text(std::size_t max_bytes, const std::string& what) const {
  return text ? *text : ReadFileText(path, max_bytes, what);
}

Config LoadConfig(const JsonSource& source) {
  return source.text ? ParseConfig(*source.text, source.path) : LoadConfig(source.path);
}

JsonDocument JsonDocument::Load(const std::string& path, std::size_t max_bytes,
                                const std::string& what) {
  return Parse(ReadFileText(path, max_bytes, what), path);
}

JsonDocument JsonDocument::Parse(const std::string& text, const std::string& path) {
  JsonDocument document;
  document.path_ = path;
  document.root_ = ParseJsonText(text, path);
  const PositionIndex index(text);
  document.positions_ = std::make_shared<std::map<std::string, std::pair<long, long>>>();
  // Every pointer's position, for Fail (PositionIndex is private to this file).
  std::vector<std::string> pointers = {""};
  for (std::size_t k = 0; k < pointers.size(); ++k) {
    const std::string pointer = pointers[k];
    const Position p = index.Find(pointer);
    (*document.positions_)[pointer] = {p.line, p.column};
    const json& value = document.root_.at(json::json_pointer(pointer));
    if (value.is_object()) {
      for (const auto& [key, item] : value.items()) {
        std::string escaped;
        for (char c : key) escaped += c == '~' ? "~0" : c == '/' ? "~1" : std::string(1, c);
        pointers.push_back(pointer + "/" + escaped);
      }
    } else if (value.is_array()) {
      for (std::size_t i = 0; i < value.size(); ++i)
        pointers.push_back(pointer + "/" + std::to_string(i));
    }
  }
  return document;
}

void JsonDocument::Fail(const std::string& pointer, const std::string& message) const {
  std::pair<long, long> at = {1, 1};
  if (positions_) {
    const auto found = positions_->find(pointer);
    if (found != positions_->end() && found->second.first > 0) at = found->second;
  }
  throw InputError(path_, at.first, at.second, message);
}

const ParamInfo* Config::FindParameterInfo(const std::string& parameter) const {
  if (model) {
    if (const ParamInfo* info = model->FindParameter(parameter)) return info;
  }
  for (const auto& effect : EffectRegistry()) {
    for (const auto& info : effect.parameters) {
      if (info.name == parameter) return &info;
    }
  }
  return nullptr;
}

std::pair<double, double> Config::Bounds(const std::string& parameter) const {
  const auto it = identification.bounds.find(parameter);
  if (it != identification.bounds.end()) return it->second;
  if (const ParamInfo* info = FindParameterInfo(parameter)) {
    // A positive scale parameter without explicit bounds is searched over three decades
    // either side of its start value (within the model's wide default range): the defaults
    // must serve a 20 g rotor and a 100 kg axis alike, and a search box of 20 decades would
    // make every step of a scaled-coordinate search a leap of decades.
    if (info->positive) {
      const double start = identification.initial.Has(parameter)
                               ? identification.initial.Get(parameter)
                               : parameters.GetOr(parameter, 0.0);
      if (start > 0.0) {
        return {std::max(info->default_lower, start * 1e-3),
                std::min(info->default_upper, start * 1e3)};
      }
    }
    return {info->default_lower, info->default_upper};
  }
  return {-1e300, 1e300};
}

void Config::AddEffect(const std::string& effect, const ParameterSet& values) {
  const EffectInfo& info = FindEffect(effect);
  const std::string model_name(model->name());
  if (std::find(info.models.begin(), info.models.end(), model_name) == info.models.end()) {
    throw InputError("effect '" + effect + "' does not apply to model " + model_name +
                     " (only to " + Join(info.models) + ")");
  }
  for (const auto& [key, value] : values.entries()) {
    bool known = false;
    // By its flat name (the library's ParameterSet) or its key inside the effect's object.
    for (const auto& p : info.parameters) known = known || p.name == key || p.config_key() == key;
    if (!known) {
      std::vector<std::string> valid;
      for (const auto& p : info.parameters) valid.push_back(p.config_key());
      const std::string near = NearestName(key, valid);
      throw InputError("effect '" + effect + "' has no parameter '" + key + "'" +
                       (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                       "; valid: " + Join(valid));
    }
  }
  for (const auto& p : info.parameters) {
    const std::string& key = p.config_key();  // the name users give it (--effect)
    if (!values.Has(p.name) && !values.Has(key)) {
      throw InputError("effect '" + effect + "' needs parameter '" + key + "' (" + p.meaning +
                       ", " + p.unit + ")");
    }
    const double v = values.Has(p.name) ? values.Get(p.name) : values.Get(key);
    if ((p.positive && !(v > 0.0)) || (p.non_negative && v < 0.0) || !std::isfinite(v)) {
      throw InputError("effect parameter '" + key + "' must be " + (p.positive ? "> 0" : ">= 0"));
    }
    if (p.share && v > 1.0) {
      throw InputError("effect parameter '" + key + "' is a share: it must be in [0, 1] (got " +
                       FormatNumber(v) + ")");
    }
    parameters.Set(p.name, v);
  }
  if (std::find(effects.begin(), effects.end(), effect) == effects.end()) effects.push_back(effect);
}

std::string ParameterUnit(const Config& config, const std::string& name) {
  const ParamInfo* info = config.FindParameterInfo(name);
  if (!info) return "";
  std::string unit = info->unit;
  if (!config.linear_axis) return unit;
  // A rotary unit read on a linear axis: the angle is a position (m), a torque a force (N).
  static const std::pair<const char*, const char*> kLinear[] = {{"kg·m²", "kg"},
                                                                {"N·m·s²/rad²", "N·s²/m²"},
                                                                {"N·m·s/rad", "N·s/m"},
                                                                {"N·m/rad", "N/m"},
                                                                {"N·m", "N"},
                                                                {"rad/s", "m/s"},
                                                                {"rad", "m"}};
  for (const auto& [rotary, linear] : kLinear) {
    for (std::size_t at = unit.find(rotary); at != std::string::npos;
         at = unit.find(rotary, at + std::string(linear).size())) {
      unit.replace(at, std::string(rotary).size(), linear);
    }
  }
  return unit;
}

}  // namespace blmd
