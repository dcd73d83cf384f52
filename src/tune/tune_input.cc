// LoadTuneInput: the config, and the final model and intervals of a blmd-ident report.
#include <algorithm>
#include <cmath>

#include "blmd/error.h"
#include "blmd/io/files.h"
#include "blmd/io/stored_report.h"
#include "blmd/sim/effects.h"
#include "blmd/tune/tune.h"

namespace blmd {
namespace {

using nlohmann::json;

// The model must have a closed-loop experiment (the step is simulated through it) and a
// linear part (the margins are computed on it).
void CheckModel(const Config& config) {
  const ModelTraits traits = config.model->traits();
  if (!traits.coast_down_and_pid && !traits.sampled_pid) {
    throw InputError(
        config.path + ": model " + std::string(config.model->name()) +
        " has no closed-loop experiment (experiment.pid: dc_servo, rigid_load and blmd): "
        "blmd-tune simulates the tuned loop through it (docs/tuning.md)");
  }
  const LinearModel linear = config.model->Linearise(config.parameters);
  if (!linear.available) {
    throw InputError(config.path + ": model " + std::string(config.model->name()) +
                     " has no linear part at these values: " + linear.reason);
  }
}

bool IsPair(const json& value) {
  return value.is_array() && value.size() == 2 && value[0].is_number() && value[1].is_number();
}

// One axis of the box, its low end raised to the parameter's lower bound where the
// interval reaches below it (a positive parameter's interval may reach 0 or below).
ParameterInterval Interval(const Config& config, const std::string& name, double low, double high) {
  ParameterInterval interval;
  interval.name = name;
  interval.value = config.parameters.Get(name);
  interval.low = std::min(low, high);
  interval.high = std::max(low, high);
  const ParamInfo* info = config.FindParameterInfo(name);
  const double lower = config.Bounds(name).first;
  const bool must_be_positive = info && (info->positive || info->non_negative);
  if (must_be_positive && interval.low < lower) {
    interval.low = lower;
    interval.clipped = true;
  }
  return interval;
}

// The report's final values replace the config's; its free parameters' ci95 are the box.
void ApplyReport(const JsonSource& source, TuneInput* input) {
  const std::string path = source.path;
  const StoredReport report = source.text
                                  ? StoredReport::Parse(*source.text, path, "identification report")
                                  : StoredReport::Load(path, "identification report");
  Config& config = input->config;
  ApplyFinalModel(report, &config);
  input->report_inadequacy = ReportInadequacy(report);
  input->report_ran_discovery = report.ran_discovery();
  for (const StoredParameter& entry : report.parameters()) {
    if (entry.free && entry.has_ci95) {
      input->box.push_back(Interval(config, entry.name, entry.ci95_low, entry.ci95_high));
    }
  }
  input->box_source = input->box.empty() ? "" : "report";
  input->report_path = path;
  input->report_sha256 = report.sha256();
}

// The intervals blmd-ident --write-config records in a config's notes (docs/export.md §1).
void ApplyConfigNotes(TuneInput* input) {
  const json& notes = input->config.notes;
  if (!notes.is_object() || !notes.contains("parameters") || !notes["parameters"].is_object())
    return;
  const json& by = notes.contains("identified_by") ? notes["identified_by"] : json();
  if (!by.is_string() || by.get<std::string>().rfind("blmd-ident", 0) != 0) return;
  for (const auto& [name, entry] : notes["parameters"].items()) {
    if (!entry.is_object() || !entry.contains("ci95") || !IsPair(entry["ci95"])) continue;
    if (!input->config.parameters.Has(name)) continue;
    const json& ci = entry["ci95"];
    input->box.push_back(Interval(input->config, name, ci[0].get<double>(), ci[1].get<double>()));
  }
  if (!input->box.empty()) input->box_source = "config notes";
}

// A blmd-ident report given as the config: say which flag takes it.
[[noreturn]] void RethrowForReport(const JsonSource& config, const InputError& error) {
  const std::string& config_path = config.path;
  try {
    const JsonDocument document = config.text
                                      ? JsonDocument::Parse(*config.text, config_path)
                                      : JsonDocument::Load(config_path, kMaxConfigBytes, "config");
    if (document.root().is_object() && document.root().value("tool", "") == "blmd-ident") {
      throw InputError(config_path +
                       ": a blmd-ident report, not a config: give it with --from-report and "
                       "the drive's config with --config");
    }
  } catch (const InputError& second) {
    if (std::string(second.what()).find("a blmd-ident report, not a config") != std::string::npos)
      throw;
  }
  throw error;
}

}  // namespace

TuneInput LoadTuneInput(const std::string& config_path, const std::string& report_path) {
  JsonSource report{report_path, std::nullopt};
  return LoadTuneInput(JsonSource{config_path, std::nullopt},
                       report_path.empty() ? nullptr : &report);
}

TuneInput LoadTuneInput(const JsonSource& config, const JsonSource* report) {
  TuneInput input;
  try {
    input.config = LoadConfig(config);
  } catch (const InputError& error) {
    RethrowForReport(config, error);
  }
  input.config_sha256 = Sha256Hex(config.Text(kMaxConfigBytes, "config"));
  if (!input.config.model->traits().coast_down_and_pid &&
      !input.config.model->traits().sampled_pid) {
    CheckModel(input.config);
  }
  if (!report) {
    ApplyConfigNotes(&input);
  } else {
    ApplyReport(*report, &input);
  }
  CheckModel(input.config);
  return input;
}

}  // namespace blmd
