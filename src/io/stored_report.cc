#include "blmd/io/stored_report.h"

#include "blmd/io/files.h"

namespace blmd {
namespace {

using nlohmann::json;

constexpr std::size_t kMaxReportBytes = std::size_t{256} << 20;

bool IsPair(const json& value) {
  return value.is_array() && value.size() == 2 && value[0].is_number() && value[1].is_number();
}

}  // namespace

StoredReport StoredReport::Load(const std::string& path, const std::string& role) {
  StoredReport report(
      JsonDocument::Load(path, kMaxReportBytes, role + " (a blmd-ident --report JSON)"));
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
  report.sha256_ = Sha256Hex(ReadFileText(path, kMaxReportBytes, role));
  return report;
}

const StoredParameter* StoredReport::FindParameter(const std::string& name) const {
  for (const auto& p : parameters_) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

void StoredReport::RequireModel(const std::string& model, const std::string& theirs,
                                const std::string& ours) const {
  if (has_model_ && model_ == model) return;
  const json& root = document_.root();
  document_.Fail(root.contains("model") ? "/model" : "",
                 theirs + " " + (root.contains("model") ? root["model"].dump() : "(none)") + ", " +
                     ours + " " + model);
}

}  // namespace blmd
