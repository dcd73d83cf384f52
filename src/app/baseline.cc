#include "blmd/app/baseline.h"

#include <cmath>

#include "blmd/io/stored_report.h"

namespace blmd {
namespace {

double HalfWidth(double low, double high) { return 0.5 * (high - low); }

}  // namespace

BaselineReport CompareWithBaseline(const IdentReport& report, const std::string& baseline_path) {
  const StoredReport stored = StoredReport::Load(baseline_path, "baseline report");
  stored.RequireModel(report.model, "the baseline is a report of model",
                      "this identification's model is");
  BaselineReport baseline;
  baseline.path = baseline_path;
  baseline.sha256 = stored.sha256();
  for (const StoredParameter& entry : stored.parameters()) {
    if (!entry.free) continue;  // classic estimates are not guarded
    const std::string& name = entry.name;
    BaselineParameter p;
    p.name = name;
    p.baseline = entry.value;
    const auto found = report.final_model.parameters.find(name);
    if (entry.has_ci95) {
      p.baseline_ci95_low = entry.ci95_low;
      p.baseline_ci95_high = entry.ci95_high;
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
      if (!interval || !entry.has_ci95) {
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
