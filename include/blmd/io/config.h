// Config JSON (docs/config.md): the model, its parameter values, declared
// effects, numerics, the experiment and the identification set-up. Loading is strict:
// unknown keys, wrong types and impossible values are InputErrors naming file:line:column
// (and the nearest valid key for a misspelling).
#pragma once

#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "blmd/sim/experiment.h"
#include "blmd/sim/model.h"
#include "blmd/sim/parameters.h"

namespace blmd {

struct IdentificationSettings {
  std::vector<std::string> free;                            // parameters to identify
  ParameterSet initial;                                     // start values (default: parameters)
  std::map<std::string, std::pair<double, double>> bounds;  // explicit bounds
  std::vector<std::string> observe;                         // trace columns in the cost
  std::string method;                                       // empty: the tool's default
  nlohmann::json options = nlohmann::json::object();        // per-method options
  // How the model meets the trace (docs/identification.md §8): "output" simulates the model
  // from the recorded input and compares the observed columns; "equation" (rigid_load only)
  // compares the recorded input with the one the model needs along the measured motion.
  std::string error = "output";
  double filter_hz = 0.0;  // equation: Butterworth cut-off of the measured motion, Hz; 0: chosen by
                           // blmd-ident from the data (cutoff_choice.h), fs/10 elsewhere
  int decimate = 1;        // equation: keep every N-th sample, after an anti-alias filter
  // How the cost weights the observed columns (docs/identification.md §1a): "noise" (each
  // column by 1/sigma^2 of its noise, estimated from the residual unless fixed in
  // noise_std; maximum likelihood) or "variance" (by 1/its signal variance: the weights do
  // not depend on the residual, and a column with a large signal counts for less).
  std::string weighting = "noise";
  std::map<std::string, double> noise_std;  // fixed sigma per observed column, its units
  // The angle a position-dependent effect (cogging, spring, gravity) sees when the model is
  // fitted or scored (docs/discovery.md §6): "measured" (the trace's theta, else the integral
  // of its w; the effect's torque is then a known function of time, and the fit and its
  // score do not hinge on where a simulated shaft settles in a detent) or "simulated" (the
  // free-running model's own angle: the fit then follows where the simulated shaft settles).
  std::string effect_angle = "measured";
  // What drives the simulation of a fit (docs/identification.md §9b): "command" (the trace's u
  // replayed open loop: the direct approach) or "reference" (the trace's r through the drive's
  // controller, experiment.pid, closed around the model: the indirect approach).
  std::string simulate_from = "command";
};

struct Config {
  std::string path;  // file it came from ("" when parsed from text)
  std::string name;
  const Model* model = nullptr;
  ParameterSet parameters;           // model parameters and declared effects' parameters
  std::vector<std::string> effects;  // declared effects, sorted by name (then --effect's)
  SimulationSettings simulation;
  Experiment experiment;
  IdentificationSettings identification;
  nlohmann::json notes;  // free-form provenance ("notes" key), carried into reports
  // "axis": "linear" (rigid_load): a linear axis, J a mass (kg), B in N·s/m, u a force (N),
  // w and theta in m/s and m; what blmd-tune's report and text say (docs/model-rigid-load.md).
  bool linear_axis = false;
  // The JSON document as loaded (null when built in code): what blmd-ident --write-config
  // starts from, so the written config keeps the experiment and settings as written.
  nlohmann::json document;

  // Adds an effect that the config does not declare (blmd-sim --effect); throws InputError.
  // `values` holds all its parameters by their flat names or by their keys inside the
  // effect's object (gravity_phase or `phase` for gravity).
  void AddEffect(const std::string& effect, const ParameterSet& values);
  // Lower/upper bound of a parameter: explicit, else the documented default.
  std::pair<double, double> Bounds(const std::string& parameter) const;
  // Description of a model or effect parameter (nullptr when unknown).
  const ParamInfo* FindParameterInfo(const std::string& parameter) const;
};

Config LoadConfig(const std::string& path);

// A JSON file other than a config (a stored report for blmd-ident --baseline), read as
// strictly as a config (invalid JSON, absurd nesting, numbers beyond the double range are
// InputErrors with line and column), with the position of every value: Fail(pointer,
// message) throws an InputError naming the file, line and column of the value at `pointer`.
class JsonDocument {
 public:
  static JsonDocument Load(const std::string& path, std::size_t max_bytes, const std::string& what);
  // The same on JSON text in memory; `path` labels it in messages.
  static JsonDocument Parse(const std::string& text, const std::string& path);
  const nlohmann::json& root() const { return root_; }
  const std::string& path() const { return path_; }
  [[noreturn]] void Fail(const std::string& pointer, const std::string& message) const;

 private:
  std::string path_;
  nlohmann::json root_;
  std::shared_ptr<std::map<std::string, std::pair<long, long>>> positions_;
};
Config ParseConfig(const std::string& text, const std::string& path);

// A JSON input (a config, a stored report): the file `path`, or, when `text` is set, that
// text in memory, which `path` labels in messages and in reports (the Python package's dicts).
struct JsonSource {
  std::string path;
  std::optional<std::string> text;
  // The text, read when a file (ReadFileText's limit and label).
  std::string Text(std::size_t max_bytes = std::numeric_limits<std::size_t>::max(),
                   const std::string& what = "text file") const;
};
// The config of a source: ParseConfig of its text, else LoadConfig of its file.
Config LoadConfig(const JsonSource& source);

// Why a run of `span` seconds at step `dt` writing `samples` samples is refused (more
// than 1e10 steps or 1e8 samples: hours of computing or gigabytes), "" when it is fine.
std::string RunLengthError(double span, double dt, double samples);

// The names separated by ", " (for "valid: ..." in messages).
// A parameter's unit as the config's model and effects declare it, in linear units on a
// linear axis ("axis": "linear": kg for kg·m², N·s/m for N·m·s/rad, N for N·m, m for rad);
// "" when neither names it.
std::string ParameterUnit(const Config& config, const std::string& name);

std::string Join(const std::vector<std::string>& names, const char* separator = ", ");

// Closest of `candidates` to `word` by edit distance, "" when none is close.
std::string NearestName(const std::string& word, const std::vector<std::string>& candidates);

}  // namespace blmd
