#include "blmd/io/starting_config.h"

#include <algorithm>
#include <vector>

#include "blmd/error.h"
#include "blmd/sim/effects.h"
#include "blmd/version.h"

namespace blmd {
namespace {

using nlohmann::ordered_json;

// What a model's starting config runs and fits besides its parameters: an experiment that
// excites the shaft enough to tell J from B, the observed columns, the method. Every model
// of the registry should have one (tests/unit/starting_config_test.cc simulates and fits each);
// a model without one gets a 1 s unit step and the loader's defaults.
struct StartingSetup {
  std::string_view model;
  const char* origin;  // where the typical values come from
  ordered_json experiment;
  std::vector<std::string> observe;
  const char* method;
};

const std::vector<StartingSetup>& Setups() {
  static const std::vector<StartingSetup> setups = {
      {"blmd",
       "the 1.5 kW D31x-class brushless drive of configs/blmd-d31x.json (Guinee & Lyden 1999; "
       "the values the paper does not give are plausible ones): a +-1 V torque-demand square "
       "wave of 0.2 s, the speed observed (the phase current's cost has side lobes in J that "
       "trap a local method started far off: docs/surfaces.md)",
       {{"input", {{"type", "square"}, {"amplitude", 1.0}, {"period", 0.2}}},
        {"duration", 0.2},
        {"sample_rate", 50000.0}},
       {"w"},
       "ceres"},
      {"dc_servo",
       "the no-load DC servo of Ganesh et al. (2012), configs/ganesh-square.json: a +-12 V "
       "square wave of 1 s, current and speed observed",
       {{"input", {{"type", "square"}, {"amplitude", 12.0}, {"period", 1.0}}},
        {"duration", 2.0},
        {"sample_rate", 2000.0}},
       {"i", "w"},
       "ceres"},
      {"rigid_load",
       "a shaft of 0.02 kg·m² with 0.05 N·m·s/rad of damping driven by its torque "
       "(tests/schema/rigid-truth.json): a +-0.5 N·m square wave of 2 s, speed observed",
       {{"input", {{"type", "square"}, {"amplitude", 0.5}, {"period", 2.0}}},
        {"duration", 6.0},
        {"sample_rate", 1000.0}},
       {"w"},
       "ceres"},
  };
  return setups;
}

std::string SignRule(const ParamInfo& info) {
  if (info.positive) return "> 0";
  if (info.non_negative) return ">= 0";
  return "any";
}

// Units, meaning, typical value, sign rule and default range of one parameter.
ordered_json ParameterNote(const ParamInfo& info) {
  ordered_json note;
  note["unit"] = info.unit;
  note["description"] = info.meaning;
  note["typical"] = info.typical;
  note["sign"] = SignRule(info);
  note["bounds"] = {info.default_lower, info.default_upper};
  if (info.optional)
    note["optional"] = "may be left out: then " + ordered_json(info.default_value).dump();
  return note;
}

// The effects the model can carry, each with its parameters' unit and meaning.
ordered_json EffectNotes(const Model& model) {
  ordered_json effects = ordered_json::object();
  const std::string name(model.name());
  for (const EffectInfo& effect : EffectRegistry()) {
    if (std::find(effect.models.begin(), effect.models.end(), name) == effect.models.end())
      continue;
    ordered_json parameters = ordered_json::object();
    for (const ParamInfo& info : effect.parameters) {
      parameters[info.config_key()] = info.unit + ", " + info.meaning;
    }
    effects[effect.name] = parameters;
  }
  return effects;
}

// `value` as JSON text the way the bundled configs are written: an object or array that fits
// in the line (kWidth characters from its key's indentation) on one line, with spaces after
// ':' and ',' ({ "R": 12.6, "L": 0.283 }), a longer one over several lines, two spaces a level.
constexpr std::size_t kWidth = 100;

std::string OneLine(const ordered_json& value) {
  if (value.is_object() && !value.empty()) {
    std::string text = "{ ";
    for (auto item = value.begin(); item != value.end(); ++item) {
      text += (item == value.begin() ? "" : ", ") + ordered_json(item.key()).dump() + ": " +
              OneLine(item.value());
    }
    return text + " }";
  }
  if (value.is_array() && !value.empty()) {
    std::string text = "[";
    for (auto item = value.begin(); item != value.end(); ++item)
      text += (item == value.begin() ? "" : ", ") + OneLine(*item);
    return text + "]";
  }
  return value.dump();
}

std::string Layout(const ordered_json& value, std::size_t indent, std::size_t used) {
  const std::string line = OneLine(value);
  if ((!value.is_object() && !value.is_array()) || value.empty() ||
      indent + used + line.size() <= kWidth) {
    return line;
  }
  const std::string inner(indent + 2, ' ');
  const bool object = value.is_object();
  std::string text = object ? "{\n" : "[\n";
  for (auto item = value.begin(); item != value.end(); ++item) {
    const std::string key = object ? ordered_json(item.key()).dump() + ": " : "";
    text += (item == value.begin() ? "" : ",\n") + inner + key +
            Layout(item.value(), indent + 2, key.size());
  }
  return text + "\n" + std::string(indent, ' ') + (object ? "}" : "]");
}

}  // namespace

ordered_json StartingConfig(const Model& model) {
  const std::string name(model.name());
  const std::vector<StartingSetup>& setups = Setups();
  const auto setup = std::find_if(setups.begin(), setups.end(),
                                  [&](const StartingSetup& s) { return s.model == name; });
  const bool known = setup != setups.end();
  std::string page = name;
  std::replace(page.begin(), page.end(), '_', '-');
  page = "docs/model-" + page + ".md";

  ordered_json config;
  config["name"] = "my-" + name;
  config["description"] = "Starting config of model " + name + " (blmd-sim --init-config " + name +
                          "): replace the parameters with " +
                          "your drive's and the experiment with the one you recorded.";
  ordered_json notes;
  notes["about"] = std::string("Written by blmd-sim ") + kVersion + " --init-config " + name +
                   ". Typical values: " + (known ? setup->origin : "the model's") +
                   ". The commands do not read these notes. Per parameter: unit, description, "
                   "typical value, sign rule and the model's default range (bounds): a free "
                   "parameter > 0 is searched three decades either side of its start within "
                   "that range, any other within the range, unless identification.bounds "
                   "gives its own. docs/config.md, " +
                   page + ".";
  ordered_json parameter_notes = ordered_json::object();
  ordered_json parameters = ordered_json::object();
  for (const ParamInfo& info : model.parameters()) {
    parameter_notes[info.name] = ParameterNote(info);
    parameters[info.name] = info.typical;
  }
  notes["parameters"] = parameter_notes;
  notes["effects"] = EffectNotes(model);
  notes["effects_how"] =
      "declare one under \"effects\" with all its parameters, e.g. {\"coulomb_friction\": "
      "{\"Tc\": 0.01}}, or let blmd-ident --discover find the ones the data shows "
      "(docs/effects.md, docs/discovery.md)";
  config["notes"] = notes;
  config["model"] = name;
  config["parameters"] = parameters;
  config["effects"] = ordered_json::object();
  config["simulation"] = {{"dt", model.default_settings().dt}};
  config["experiment"] = known ? setup->experiment
                               : ordered_json{{"input", {{"type", "step"}, {"amplitude", 1.0}}},
                                              {"duration", 1.0},
                                              {"sample_rate", 1000.0}};
  ordered_json identification;
  identification["free"] = {"J", "B"};
  if (known) {
    identification["observe"] = setup->observe;
    identification["method"] = setup->method;
  }
  config["identification"] = identification;
  return config;
}

std::string StartingConfigText(std::string_view model) {
  return Layout(StartingConfig(FindModel(model)), 0, 0) + "\n";
}

}  // namespace blmd
