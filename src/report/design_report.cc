#include "blmd/report/design_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "blmd/error.h"
#include "blmd/io/csv.h"
#include "blmd/io/files.h"
#include "blmd/report/report.h"
#include "blmd/run.h"
#include "blmd/version.h"
#include "io/flags.h"
#include "report/config_document.h"

namespace blmd {

using json = nlohmann::json;
namespace {
std::string Sig(double value, int digits = 4) { return FormatSignificant(value, digits); }
}  // namespace

nlohmann::json InputJson(const InputSignal& input) {
  using Kind = InputSignal::Kind;
  json out = json::object();
  const auto levels = [&] {
    if (input.offset != 0.0) out["offset"] = input.offset;
    if (input.t0 != 0.0) out["t0"] = input.t0;
  };
  switch (input.kind) {
    case Kind::kStep:
      out = {{"type", "step"}, {"amplitude", input.amplitude}};
      levels();
      break;
    case Kind::kSquare:
      out = {{"type", "square"}, {"amplitude", input.amplitude}, {"period", input.period}};
      levels();
      break;
    case Kind::kSteps:
      out = {{"type", "steps"}, {"times", input.times}, {"values", input.values}};
      if (input.offset != 0.0) out["offset"] = input.offset;
      break;
    case Kind::kPrbs:
      out = {{"type", "prbs"},
             {"amplitude", input.amplitude},
             {"clock", input.clock},
             {"order", input.order},
             {"seed", input.seed}};
      levels();
      break;
    case Kind::kChirp:
      out = {{"type", "chirp"},
             {"amplitude", input.amplitude},
             {"f0", input.f0},
             {"f1", input.f1},
             {"duration", input.sweep},
             {"shape", input.shape == InputSignal::ChirpShape::kLog ? "log" : "linear"}};
      levels();
      break;
    case Kind::kRecorded:
      out = {{"type", "recorded"}};
      break;
  }
  return out;
}

namespace {

// The settings of an input, by name (the report's design.settings): its amplitude (the largest
// |u - offset| of a table) and what its family searches.
json Settings(const DesignCandidate& c) {
  using Kind = InputSignal::Kind;
  double amplitude = c.input.amplitude;
  if (c.input.kind == Kind::kSteps || c.input.kind == Kind::kRecorded) {
    amplitude = 0.0;
    for (double v : c.input.values) amplitude = std::max(amplitude, std::abs(v));
  }
  json s = {{"amplitude", amplitude}};
  if (c.input.kind == Kind::kSquare) {
    s["period_s"] = c.input.period;
  } else if (c.family == "steps") {
    s["dwell_s"] = c.dwell;
    s["levels_per_direction"] = c.levels;
  } else if (c.input.kind == Kind::kPrbs) {
    s["clock_s"] = c.input.clock;
    s["order"] = c.input.order;
    s["seed"] = c.input.seed;
    s["sequence_period_s"] = (std::exp2(c.input.order) - 1.0) * c.input.clock;
  } else if (c.input.kind == Kind::kChirp) {
    s["f0_hz"] = c.input.f0;
    s["f1_hz"] = c.input.f1;
    s["shape"] = c.input.shape == InputSignal::ChirpShape::kLog ? "log" : "linear";
    s["sweep_s"] = c.input.sweep;
  }
  return s;
}

json Predicted(const DesignReport& report, const PrecisionPrediction& p) {
  json out = json::object();
  for (std::size_t k = 0; k < p.names.size(); ++k) {
    const auto i = static_cast<Eigen::Index>(k);
    json entry = {{"prior", p.values[k]},
                  {"ci95_halfwidth", p.ci95_halfwidth[k]},
                  {"ci95_relative_halfwidth", p.ci95_halfwidth[k] / std::abs(p.values[k])},
                  {"std_search", std::sqrt(p.covariance(i, i))},
                  {"search_scale", p.log_scale[k] ? "log" : "linear"},
                  {"cramer_rao_ci95_halfwidth", p.cramer_rao_ci95_halfwidth[k]}};
    if (!report.units[k].empty()) entry["unit"] = report.units[k];
    out[p.names[k]] = entry;
  }
  return out;
}

json Correlation(const PrecisionPrediction& p) {
  json rows = json::array();
  for (Eigen::Index i = 0; i < p.covariance.rows(); ++i) {
    json row = json::array();
    for (Eigen::Index j = 0; j < p.covariance.cols(); ++j) {
      row.push_back(p.covariance(i, j) / std::sqrt(p.covariance(i, i) * p.covariance(j, j)));
    }
    rows.push_back(row);
  }
  return {{"names", p.names}, {"matrix", rows}};
}

json CandidateJson(const DesignReport& report, const DesignCandidate& c) {
  json out = {{"family", c.family},
              {"input", InputJson(c.input)},
              {"settings", Settings(c)},
              {"criterion", c.criterion},
              {"log_det_covariance", c.prediction.log_det},
              {"peaks", c.prediction.peaks},
              {"predicted", Predicted(report, c.prediction)}};
  if (c.family == "recorded") out.erase("input");
  return out;
}

}  // namespace

nlohmann::json DesignReportJson(const DesignReport& report) {
  json noise = json::object();
  for (std::size_t c = 0; c < report.observe.size(); ++c) {
    noise[report.observe[c]] = {{"sigma", report.sigma[c]}, {"source", report.noise_source[c]}};
  }
  json limits = json::object();
  if (report.options.input_limit > 0.0) limits["u"] = report.options.input_limit;
  for (const auto& [column, value] : report.options.output_limits) limits[column] = value;
  json out = {{"tool", "blmd-design"},
              {"version", kVersion},
              {"config", {{"path", report.config_path}, {"sha256", report.config_sha256}}},
              {"model", report.model},
              {"mode", report.evaluate_trace ? "trace" : "search"},
              {"criterion", report.criterion},
              {"target", report.target},
              {"duration_s", report.options.duration},
              {"sample_rate_hz", report.options.sample_rate},
              {"limits", limits},
              {"observe", report.observe},
              {"noise", noise},
              {"ok", report.ok}};
  if (report.evaluate_trace) {
    out["trace"] = {{"path", report.trace_path}, {"sha256", report.trace_sha256}};
  }
  if (!report.report_path.empty()) {
    out["from_report"] = {{"path", report.report_path},
                          {"sha256", report.report_sha256},
                          {"variance_factor", report.variance_factor}};
  }
  out["breakaway"] = report.breakaway_u > 0.0
                         ? json{{"torque", report.breakaway_torque}, {"u", report.breakaway_u}}
                         : json();
  json warnings = json::array();
  for (const auto& [code, message] : report.warnings)
    warnings.push_back({{"code", code}, {"message", message}});
  out["warnings"] = warnings;
  if (!report.ok) {
    out["failure"] = report.reason;
  } else {
    const DesignCandidate& c = report.chosen;
    json design = CandidateJson(report, c);
    design["within_limits"] = report.chosen_within_limits;
    out["design"] = design;
    out["predicted"] = Predicted(report, c.prediction);
    out["correlation"] = Correlation(c.prediction);
  }
  if (report.reference) {
    json reference = CandidateJson(report, *report.reference);
    reference["within_limits"] = report.reference_within_limits;
    if (report.ok) {
      json ratio = json::object();
      for (std::size_t k = 0; k < report.chosen.prediction.names.size(); ++k) {
        ratio[report.chosen.prediction.names[k]] = report.reference->prediction.ci95_halfwidth[k] /
                                                   report.chosen.prediction.ci95_halfwidth[k];
      }
      reference["halfwidth_over_design"] = ratio;
    }
    out["reference"] = reference;
  }
  if (!report.evaluate_trace) {
    json families = json::array();
    for (const auto& c : report.family_best) families.push_back(CandidateJson(report, c));
    out["families"] = families;
    out["search"] = {{"evaluated", report.evaluated}, {"rejected", report.rejected}};
  }
  SanitizeJson(&out);
  return out;
}

namespace {

std::string Describe(const DesignCandidate& c) {
  using Kind = InputSignal::Kind;
  if (c.family == "recorded") return "the recorded input";
  std::string text = c.family + ", amplitude " + Sig(c.input.amplitude);
  // The same settings as the report's "settings" (Settings above), from the candidate itself.
  if (c.input.kind == Kind::kSquare) {
    text += ", period " + Sig(c.input.period) + " s";
  } else if (c.family == "steps") {
    text += c.levels == 1 ? std::string(" (+a, 0, -a, 0)")
                          : ", a staircase of " + std::to_string(c.levels) + " levels each way";
    text += ", " + Sig(c.dwell) + " s per level";
  } else if (c.input.kind == Kind::kPrbs) {
    text += ", clock " + Sig(c.input.clock) + " s, order " + std::to_string(c.input.order);
  } else if (c.input.kind == Kind::kChirp) {
    text += ", " + Sig(c.input.f0) + " -> " + Sig(c.input.f1) + " Hz " +
            (c.input.shape == InputSignal::ChirpShape::kLog ? "log" : "linear");
  }
  return text;
}

}  // namespace

std::string DesignSummary(const DesignReport& report) {
  std::ostringstream out;
  out << "blmd-design: " << report.model << " '" << report.config_path << "', "
      << (report.evaluate_trace ? "the recorded input of " + report.trace_path
                                : report.criterion + " design")
      << " over " << Sig(report.options.duration) << " s\n";
  const auto warnings = [&] {
    for (const auto& [code, message] : report.warnings)
      out << "warning [" << code << "]: " << message << "\n";
  };
  if (!report.ok) {
    out << "  no design: " << report.reason << "\n";
    warnings();
    return out.str();
  }
  out << "  experiment: " << Describe(report.chosen);
  if (!report.evaluate_trace) out << " (best of " << report.evaluated << " candidates)";
  out << "\n";
  const PrecisionPrediction& p = report.chosen.prediction;
  for (std::size_t k = 0; k < p.names.size(); ++k) {
    char line[256];
    std::snprintf(line, sizeof line, "  %-4s %-12s +- %-10s (%.3g %%)", p.names[k].c_str(),
                  Sig(p.values[k], 5).c_str(), Sig(p.ci95_halfwidth[k], 3).c_str(),
                  100.0 * p.ci95_halfwidth[k] / std::abs(p.values[k]));
    out << line << " predicted 95 % half-width " << report.units[k];
    if (report.reference) {
      out << "; the config's input: +- " << Sig(report.reference->prediction.ci95_halfwidth[k], 3)
          << " (" << Sig(report.reference->prediction.ci95_halfwidth[k] / p.ci95_halfwidth[k], 3)
          << "x)";
    }
    out << "\n";
  }
  if (!report.chosen_within_limits) out << "  note: the recorded response exceeds a --limit\n";
  if (!report.variance_factor.empty()) {
    out << "  from the report: variances widened by what its record's residual cost beyond white "
           "noise (";
    bool first = true;
    for (const auto& [name, factor] : report.variance_factor) {
      out << (first ? "" : ", ") << name << " x" << Sig(factor, 3);
      first = false;
    }
    out << ")\n";
  }
  if (report.breakaway_u > 0.0) {
    out << "  breakaway: " << Sig(report.breakaway_torque, 4)
        << " N·m of friction, cogging and load at rest; |u| >= " << Sig(report.breakaway_u, 4)
        << " moves the shaft with a 20 % margin";
    if (!report.evaluate_trace)
      out << " (the input's amplitude: " << Sig(report.chosen.input.amplitude, 4) << ")";
    out << "\n";
  }
  warnings();
  return out.str();
}

nlohmann::json DesignConfigJson(const Config& config, const DesignReport& report) {
  json doc = ConfigDocumentOf(config);
  doc["name"] = config.name + "-design";
  doc["description"] =
      "blmd-design: " + Describe(report.chosen) + ", " + report.criterion + " for " +
      (report.target.empty() ? std::string("all free parameters") : Join(report.target));
  json experiment = doc.contains("experiment") && doc["experiment"].is_object() ? doc["experiment"]
                                                                                : json::object();
  experiment.erase("pid");
  experiment.erase("coast_off_time");
  experiment["input"] = InputJson(report.chosen.input);
  experiment["duration"] = report.options.duration;
  experiment["sample_rate"] = report.options.sample_rate;
  doc["experiment"] = experiment;
  json predicted = json::object();
  const PrecisionPrediction& p = report.chosen.prediction;
  for (std::size_t k = 0; k < p.names.size(); ++k) predicted[p.names[k]] = p.ci95_halfwidth[k];
  json notes = {{"designed_by", std::string("blmd-design ") + kVersion},
                {"from_config", report.config_path},
                {"criterion", report.criterion},
                {"predicted_ci95_halfwidth", predicted}};
  SetNotes(config, std::move(notes), &doc);
  return doc;
}

Trace DesignInputTable(const DesignReport& report) {
  Experiment experiment;
  experiment.duration = report.options.duration;
  experiment.sample_rate = report.options.sample_rate;
  std::vector<double> times = experiment.SampleTimes();
  std::vector<double> u;
  u.reserve(times.size());
  InputCursor cursor(report.chosen.input);
  for (double t : times) u.push_back(cursor.At(t));
  Trace table;
  table.Append("t", std::move(times));
  table.Append("u", std::move(u));
  table.comments.push_back("blmd-design " + std::string(kVersion) + " " + Describe(report.chosen) +
                           " (zero-order hold: u holds from each row to the next)");
  return table;
}

}  // namespace blmd
