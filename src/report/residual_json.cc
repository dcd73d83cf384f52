// The report's "residual" block (docs/report.md) from the residual diagnostics.
#include <cmath>

#include "blmd/report/report.h"

namespace blmd {
namespace {

nlohmann::json Number(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

}  // namespace

nlohmann::json ResidualJson(const ResidualAnalysis& analysis) {
  nlohmann::json out = nlohmann::json::object();
  if (!analysis.ok) {
    out["whiteness_p"] = nullptr;
    out["failed"] = analysis.reason;
    return out;
  }
  out["whiteness_p"] = Number(analysis.whiteness_p);
  out["white"] = analysis.white;
  out["w_changes_sign"] = analysis.w_changes_sign;
  nlohmann::json columns = nlohmann::json::object();
  for (const auto& d : analysis.columns) {
    nlohmann::json c;
    c["mean"] = Number(d.mean);
    c["rms"] = Number(d.rms);
    c["whiteness_p"] = Number(d.whiteness_p);
    c["ljung_box_q"] = Number(d.ljung_box_q);
    c["ljung_box_lags"] = d.ljung_box_lags;
    c["acf"] = d.acf;
    c["acf_band95"] = Number(d.acf_band95);
    c["input_ccf"] = {{"lags", d.input_ccf.empty() ? 0 : static_cast<int>(d.input_ccf.size() / 2)},
                      {"values", d.input_ccf},
                      {"peak", Number(d.input_ccf_peak)},
                      {"peak_lag", d.input_ccf_peak_lag},
                      {"band95", Number(d.input_ccf_band95)}};
    auto sign = [](const SignDependence& s) {
      if (!s.available) return nlohmann::json(nullptr);
      return nlohmann::json{{"mean_positive", Number(s.mean_positive)},
                            {"mean_negative", Number(s.mean_negative)},
                            {"count_positive", s.count_positive},
                            {"count_negative", s.count_negative},
                            {"t", Number(s.t_statistic)}};
    };
    c["by_sign_of_w"] = sign(d.sign_w);
    c["by_sign_of_i"] = sign(d.sign_i);
    nlohmann::json peaks = nlohmann::json::array();
    for (const auto& p : d.angle_peaks) {
      nlohmann::json peak = {{"order_per_rev", p.order},
                             {"amplitude", Number(p.amplitude)},
                             {"ratio_to_floor", Number(p.ratio)}};
      if (p.electrical_multiple > 0.0) peak["electrical_multiple"] = Number(p.electrical_multiple);
      peaks.push_back(peak);
    }
    c["angle_spectrum_peaks"] = d.shaft_turned ? peaks : nlohmann::json(nullptr);
    columns[d.column] = c;
  }
  out["columns"] = columns;
  return out;
}

}  // namespace blmd
