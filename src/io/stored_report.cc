#include "blmd/io/stored_report.h"

#include <algorithm>
#include <cmath>

#include "blmd/error.h"
#include "blmd/format.h"
#include "blmd/io/files.h"
#include "blmd/sim/effects.h"

namespace blmd {
namespace {

using nlohmann::json;

constexpr std::size_t kMaxReportBytes = std::size_t{256} << 20;

bool IsPair(const json& value) {
  return value.is_array() && value.size() == 2 && value[0].is_number() && value[1].is_number();
}

}  // namespace

StoredReport StoredReport::Load(const std::string& path, const std::string& role) {
  return Parse(ReadFileText(path, kMaxReportBytes, role + " (a blmd-ident --report JSON)"), path,
               role);
}

StoredReport StoredReport::Parse(const std::string& text, const std::string& path,
                                 const std::string& role) {
  StoredReport report(JsonDocument::Parse(text, path));
  const JsonDocument& document = report.document_;
  const json& root = document.root();
  if (!root.is_object() || root.value("tool", std::string()) != "blmd-ident") {
    document.Fail("", "not a blmd-ident report (no \"tool\": \"blmd-ident\")");
  }
  if (root.contains("model") && root["model"].is_string()) {
    report.model_ = root["model"].get<std::string>();
    report.has_model_ = true;
  }
  if (!root.contains("parameters") || !root["parameters"].is_object()) {
    document.Fail("", "the " + role + " has no \"parameters\" object");
  }
  for (const auto& [name, entry] : root["parameters"].items()) {
    const std::string pointer = "/parameters/" + name;
    if (!entry.is_object() || !entry.contains("value") || !entry["value"].is_number()) {
      document.Fail(pointer, "parameter '" + name + "' has no numeric \"value\"");
    }
    StoredParameter p;
    p.name = name;
    p.value = entry["value"].get<double>();
    p.free = entry.value("free", false);
    p.at_bound = entry.contains("at_bound") && entry["at_bound"].is_boolean() &&
                 entry["at_bound"].get<bool>();
    const json& bounds = entry.contains("bounds") ? entry["bounds"] : json();
    if (IsPair(bounds) && bounds[0].get<double>() < bounds[1].get<double>()) {
      p.has_bounds = true;
      p.bound_low = bounds[0].get<double>();
      p.bound_high = bounds[1].get<double>();
    }
    const json& ci = entry.contains("ci95") ? entry["ci95"] : json();
    if (IsPair(ci)) {
      p.has_ci95 = true;
      p.ci95_low = ci[0].get<double>();
      p.ci95_high = ci[1].get<double>();
    }
    report.parameters_.push_back(std::move(p));
  }
  if (root.contains("effects") && root["effects"].is_array()) {
    report.has_effects_ = true;
    for (std::size_t k = 0; k < root["effects"].size(); ++k) {
      const json& name = root["effects"][k];
      if (!name.is_string()) document.Fail("/effects/" + std::to_string(k), "not an effect name");
      report.effects_.push_back(name.get<std::string>());
    }
  }
  const json& discovery = root.contains("discovery") ? root["discovery"] : json();
  if (discovery.is_object() && discovery.contains("steps") && discovery["steps"].is_array()) {
    for (const json& step : discovery["steps"]) {
      if (!step.is_object() || !step.contains("effect") || !step["effect"].is_string() ||
          !step.contains("parameters") || !step["parameters"].is_object())
        continue;
      auto& values = report.step_parameters_[step["effect"].get<std::string>()];
      for (const auto& [name, value] : step["parameters"].items()) {
        if (value.is_number()) values[name] = value.get<double>();
      }
    }
  }
  if (root.contains("fit") && root["fit"].is_object() && root["fit"].contains("nrmse") &&
      root["fit"]["nrmse"].is_number()) {
    report.nrmse_ = root["fit"]["nrmse"].get<double>();
  }
  // Optional figures, taken where they are positive finite numbers and ignored otherwise
  // (reports of older versions lack them).
  const auto positive_numbers = [](const json& object, const char* key,
                                   std::map<std::string, double>* out) {
    if (!object.is_object()) return;
    for (const auto& [name, value] : object.items()) {
      const json& x =
          key ? (value.is_object() && value.contains(key) ? value[key] : json()) : value;
      if (x.is_number() && std::isfinite(x.get<double>()) && x.get<double>() > 0.0) {
        (*out)[name] = x.get<double>();
      }
    }
  };
  if (root.contains("noise") && root["noise"].is_object() && root["noise"].contains("columns")) {
    positive_numbers(root["noise"]["columns"], "std", &report.noise_std_);
  }
  const json* interval = &root;
  for (const char* key : {"method_summary", "details", "interval", "variance_ratio"}) {
    interval = interval->is_object() && interval->contains(key) ? &(*interval)[key] : nullptr;
    if (!interval) break;
  }
  if (interval) positive_numbers(*interval, nullptr, &report.variance_ratio_);
  if (root.contains("warnings") && root["warnings"].is_array()) {
    for (const json& w : root["warnings"]) {
      if (!w.is_object() || !w.contains("code") || !w["code"].is_string()) continue;
      const std::string message =
          w.contains("message") && w["message"].is_string() ? w["message"].get<std::string>() : "";
      report.warnings_.emplace_back(w["code"].get<std::string>(), message);
    }
  }
  report.sha256_ = Sha256Hex(text);
  return report;
}

const StoredParameter* StoredReport::FindParameter(const std::string& name) const {
  for (const auto& p : parameters_) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

const double* StoredReport::FindFixedParameter(const std::string& effect,
                                               const std::string& name) const {
  const auto found = step_parameters_.find(effect);
  if (found == step_parameters_.end()) return nullptr;
  const auto value = found->second.find(name);
  return value == found->second.end() ? nullptr : &value->second;
}

void StoredReport::RequireModel(const std::string& model, const std::string& theirs,
                                const std::string& ours) const {
  if (has_model_ && model_ == model) return;
  const json& root = document_.root();
  document_.Fail(root.contains("model") ? "/model" : "",
                 theirs + " " + (root.contains("model") ? root["model"].dump() : "(none)") + ", " +
                     ours + " " + model);
}

double StoredReport::input_past_frequency_hz() const {
  const nlohmann::json& root = document_.root();
  // The final model's adequacy: discovery's when it ran, else the fit's.
  const nlohmann::json* adequacy = nullptr;
  if (root.contains("discovery") && root["discovery"].is_object() &&
      root["discovery"].contains("adequacy")) {
    adequacy = &root["discovery"]["adequacy"];
  } else if (root.contains("adequacy")) {
    adequacy = &root["adequacy"];
  }
  if (!adequacy || !adequacy->is_object() || !adequacy->contains("tests") ||
      !(*adequacy)["tests"].is_array())
    return 0.0;
  double frequency = 0.0;
  for (const auto& test : (*adequacy)["tests"]) {
    if (!test.is_object() || test.value("state", std::string()) != "u (past)" ||
        !test.value("flagged", false) || !test.contains("frequency_hz") ||
        !test["frequency_hz"].is_number())
      continue;
    frequency = std::max(frequency, test["frequency_hz"].get<double>());
  }
  return std::isfinite(frequency) && frequency > 0.0 ? frequency : 0.0;
}

std::vector<std::string> ReportInadequacy(const StoredReport& report) {
  std::vector<std::string> reasons;
  if (report.nrmse() >= 1.0) {
    reasons.push_back("its NRMSE is " + FormatSignificant(report.nrmse(), 4) +
                      " (>= 1: no better than predicting each column's mean)");
  }
  for (const StoredParameter& p : report.parameters()) {
    if (p.free && p.at_bound) reasons.push_back(p.name + " is at its bound (the bound set it)");
  }
  static const char* const kModelWarnings[] = {"model_inadequate",   "unexplained_structure",
                                               "not_a_fit",          "not_converged",
                                               "nrmse_at_least_one", "decision_unstable"};
  for (const auto& [code, message] : report.warnings()) {
    if (std::find(std::begin(kModelWarnings), std::end(kModelWarnings), code) !=
        std::end(kModelWarnings)) {
      reasons.push_back("warning " + code);
    }
  }
  // Dynamics the model lacks, where they are: a loop's crossover must stay well below.
  if (const double f = report.input_past_frequency_hz(); f > 0.0) {
    reasons.push_back("its residual follows the input's past, most near " +
                      FormatSignificant(f, 3) +
                      " Hz: dynamics the model lacks (a resonance, a lag) that the gains do not "
                      "see; a crossover must stay well below it" +
                      std::string(report.ran_discovery() ? "" : ", or identify with --discover"));
  }
  return reasons;
}

void ApplyFinalModel(const StoredReport& report, Config* config) {
  const std::string model(config->model->name());
  report.RequireModel(model, "the report is of model", "the config's model is");
  if (!report.has_effects()) {
    report.Fail("", "the report has no \"effects\" list (its final model's effects)");
  }
  const std::vector<std::string>& effects = report.effects();
  for (const auto& declared : config->effects) {
    if (std::find(effects.begin(), effects.end(), declared) == effects.end()) {
      report.Fail("/effects", "the report's final model lacks the effect '" + declared + "' that " +
                                  config->path + " declares: a report of another config");
    }
  }
  for (const auto& name : effects) {
    if (std::find(config->effects.begin(), config->effects.end(), name) != config->effects.end())
      continue;
    ParameterSet values;
    try {
      for (const auto& p : FindEffect(name).parameters) {
        if (const StoredParameter* stored = report.FindParameter(p.name)) {
          values.Set(p.name, stored->value);
        } else if (const double* fixed = report.FindFixedParameter(name, p.name)) {
          values.Set(p.name, *fixed);  // e.g. a cogging's periods, fixed by discovery
        }
      }
      config->AddEffect(name, values);
    } catch (const InputError& error) {
      report.Fail("/effects", error.what());
    }
  }
  for (const StoredParameter& entry : report.parameters()) {
    const std::string pointer = "/parameters/" + entry.name;
    const ParamInfo* info = config->FindParameterInfo(entry.name);
    if (!info) {
      report.Fail(pointer, "'" + entry.name + "' is not a parameter of model " + model +
                               " or of the effects " + Join(config->effects));
    }
    if ((info->positive && !(entry.value > 0.0)) || (info->non_negative && entry.value < 0.0)) {
      report.Fail(pointer + "/value",
                  "parameter '" + entry.name + "' must be " + (info->positive ? "> 0" : ">= 0"));
    }
    config->parameters.Set(entry.name, entry.value);
  }
}

}  // namespace blmd
