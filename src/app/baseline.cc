#include "blmd/app/baseline.h"

#include <cmath>

#include "blmd/io/files.h"

namespace blmd {
namespace {

using nlohmann::json;

double HalfWidth(double low, double high) { return 0.5 * (high - low); }

}  // namespace

BaselineReport CompareWithBaseline(const IdentReport& report, const std::string& baseline_path) {
  const JsonDocument document =
      JsonDocument::Load(baseline_path, 256u << 20, "baseline report (a blmd-ident --report JSON)");
  const json& root = document.root();
  if (!root.is_object() || root.value("tool", std::string()) != "blmd-ident") {
    document.Fail("", "not a blmd-ident report (no \"tool\": \"blmd-ident\")");
  }
  if (!root.contains("parameters") || !root["parameters"].is_object()) {
    document.Fail("", "the baseline report has no \"parameters\" object");
  }
  if (!root.contains("model") || !root["model"].is_string() || root["model"] != report.model) {
    document.Fail(root.contains("model") ? "/model" : "",
                  "the baseline is a report of model " +
                      (root.contains("model") ? root["model"].dump() : std::string("(none)")) +
                      ", this identification's model is " + report.model);
  }
  BaselineReport baseline;
  baseline.path = baseline_path;
  baseline.sha256 = Sha256Hex(ReadFileText(baseline_path, 256u << 20, "baseline report"));
  for (const auto& [name, stored] : root["parameters"].items()) {
    const std::string pointer = "/parameters/" + name;
    if (!stored.is_object()) document.Fail(pointer, "parameter '" + name + "' is not an object");
    if (!stored.value("free", false)) continue;  // classic estimates are not guarded
    BaselineParameter p;
    p.name = name;
    const json& value = stored.contains("value") ? stored["value"] : json();
    if (!value.is_number()) document.Fail(pointer, "parameter '" + name + "' has no numeric value");
    p.baseline = value.get<double>();
    const auto found = report.final_model.parameters.find(name);
    const json& ci = stored.contains("ci95") ? stored["ci95"] : json();
    const bool baseline_interval =
        ci.is_array() && ci.size() == 2 && ci[0].is_number() && ci[1].is_number();
    if (baseline_interval) {
      p.baseline_ci95_low = ci[0].get<double>();
      p.baseline_ci95_high = ci[1].get<double>();
    }
    if (found == report.final_model.parameters.end() || !found->second.free) {
      p.verdict = "not_compared";
      p.reason = "not a fitted parameter of this identification";
    } else {
      const ParameterEstimate& e = found->second.estimate;
      p.value = e.value;
      p.shift = e.value - p.baseline;
      p.ci95_low = e.ci95_low;
      p.ci95_high = e.ci95_high;
      const bool interval =
          e.has_interval && std::isfinite(e.ci95_low) && std::isfinite(e.ci95_high);
      if (!interval || !baseline_interval) {
        p.verdict = "not_compared";
        p.reason = !interval ? "no 95 % interval in this identification"
                             : "no 95 % interval in the baseline";
      } else {
        // The difference of two independent estimates has the half-width sqrt(h1^2 + h2^2)
        // (Schenker & Gentleman 2001; docs/export.md).
        p.combined_limit = std::hypot(HalfWidth(e.ci95_low, e.ci95_high),
                                      HalfWidth(p.baseline_ci95_low, p.baseline_ci95_high));
        p.verdict = std::abs(p.shift) > p.combined_limit ? "moved" : "same";
        if (p.verdict == "moved") baseline.moved.push_back(name);
      }
    }
    baseline.parameters.push_back(p);
  }
  return baseline;
}

}  // namespace blmd
