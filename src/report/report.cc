#include "blmd/report/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "blmd/error.h"
#include "blmd/ident/diagnostics.h"
#include "blmd/ident/stats.h"
#include "blmd/version.h"

namespace blmd {
namespace {

nlohmann::json Number(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

std::string G(double v, int digits = 5) {
  if (!std::isfinite(v)) return "n/a";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*g", digits, v);
  return buffer;
}

std::string G(const nlohmann::json& v, int digits = 5) {
  return v.is_number() ? G(v.get<double>(), digits) : std::string("n/a");
}

}  // namespace

void SanitizeJson(nlohmann::json* value) {
  if (value->is_number_float() && !std::isfinite(value->get<double>())) {
    *value = nullptr;
  } else if (value->is_structured()) {
    for (auto& item : *value) SanitizeJson(&item);
  }
}

nlohmann::json ErrorsJson(const ErrorFigures& errors) {
  nlohmann::json out;
  if (!errors.ok) {
    out["nrmse"] = nullptr;
    out["failed"] = errors.reason;
    return out;
  }
  out["nrmse"] = Number(errors.nrmse);
  out["mse"] = Number(errors.mse);
  nlohmann::json rmse = nlohmann::json::object();
  for (std::size_t c = 0; c < errors.observe.size(); ++c)
    rmse[errors.observe[c]] = Number(errors.rmse[c]);
  out["rmse"] = rmse;
  return out;
}

nlohmann::json SimulatedErrors(const FitProblem& problem, const Config& config,
                               const std::vector<std::string>& free,
                               const std::vector<double>& values) {
  if (!problem.equation_error()) return nullptr;
  Config output = config;
  output.identification.error = "output";
  const std::string column = problem.traces().front().trace.Has("w") ? "w" : "theta";
  for (const auto& t : problem.traces()) {
    if (!t.trace.Has(column)) return nullptr;
  }
  try {
    const FitProblem simulated(output, problem.traces(), {column}, NamedFreeParameters(free));
    nlohmann::json out = ErrorsJson(ComputeErrors(simulated, values));
    out["observe"] = {column};
    return out;
  } catch (const InputError& error) {
    return {{"nrmse", nullptr}, {"failed", error.what()}};
  }
}

nlohmann::json ResidualDiagnostics(const FitProblem& problem, const std::vector<double>& values) {
  return ResidualJson(AnalyseResidual(problem, values));
}

nlohmann::json MakeReport(const ReportInputs& inputs) {
  const FitProblem& problem = *inputs.problem;
  const FitResult& result = *inputs.result;
  const Config& config = problem.config();
  nlohmann::json report;
  report["tool"] = "blmd-ident";
  report["version"] = kVersion;
  report["schema_version"] = kReportSchemaVersion;
  report["model"] = std::string(config.model->name());
  report["method"] = result.summary.method;
  report["config"] = {
      {"path", inputs.config_path}, {"name", config.name}, {"effects", config.effects}};
  report["effects"] = config.effects;  // the model's (after discovery: with the added ones)
  const FitTrace& first = problem.traces().front();
  report["trace"] = {
      {"path", first.path}, {"samples", first.trace.rows()}, {"sha256", first.sha256}};
  nlohmann::json traces = nlohmann::json::array();
  const Evaluation& evaluation = result.evaluation;
  for (std::size_t k = 0; k < problem.traces().size(); ++k) {
    const FitTrace& t = problem.traces()[k];
    nlohmann::json entry = {{"path", t.path}, {"samples", t.trace.rows()}, {"sha256", t.sha256}};
    if (evaluation.ok) {
      nlohmann::json rmse = nlohmann::json::object();
      double normalised = 0.0;
      for (std::size_t c = 0; c < problem.observe().size(); ++c) {
        rmse[problem.observe()[c]] = Number(std::sqrt(evaluation.mse_per_trace[k][c]));
        normalised += evaluation.mse_per_trace[k][c] / problem.variance()[c];
      }
      entry["rmse"] = rmse;
      entry["nrmse"] =
          Number(std::sqrt(normalised / static_cast<double>(problem.observe().size())));
    }
    traces.push_back(entry);
  }
  report["traces"] = traces;

  nlohmann::json parameters = nlohmann::json::object();
  for (const auto& e : result.estimates) {
    nlohmann::json p;
    p["value"] = Number(e.value);
    p["initial"] = Number(e.initial);
    p["std"] = e.has_interval ? Number(e.std) : nlohmann::json(nullptr);
    p["ci95"] = e.has_interval ? nlohmann::json::array({Number(e.ci95_low), Number(e.ci95_high)})
                               : nlohmann::json(nullptr);
    if (e.has_interval) p["interval_method"] = e.interval_method;
    if (e.has_hac_interval) {  // widened by the spread between traces
      p["std_hac"] = Number(e.std_hac);
      p["ci95_hac"] = nlohmann::json::array({Number(e.ci95_hac_low), Number(e.ci95_hac_high)});
    }
    // The white-noise interval for comparison (docs/uncertainty.md).
    if (e.has_white_interval) {
      p["std_white"] = Number(e.std_white);
      p["ci95_white"] =
          nlohmann::json::array({Number(e.ci95_white_low), Number(e.ci95_white_high)});
      p["white_interval_method"] = e.white_method;
    }
    if (const ParamInfo* info = config.FindParameterInfo(e.name)) p["unit"] = info->unit;
    p["free"] = true;
    for (const auto& fp : problem.free()) {
      if (fp.name != e.name) continue;
      p["bounds"] = {fp.lower, fp.upper};
      // An estimate on a bound is the bound's answer, not the data's: its interval means
      // little, and a wider bound (or another model) is needed.
      const double span = fp.log_scale ? std::log(fp.upper / fp.lower) : fp.upper - fp.lower;
      const double below = fp.log_scale ? std::log(e.value / fp.lower) : e.value - fp.lower;
      const double above = fp.log_scale ? std::log(fp.upper / e.value) : fp.upper - e.value;
      // Within 1e-6 of the range, and (linear scale) closer to the bound than a hundredth of
      // its standard deviation: Cd = 4.3e-7 +- 2.8e-8 on [0, 1] is within 1e-6 of the range
      // but forty deviations from 0, a value the data set, not the bound.
      const double std_search = e.has_interval && !fp.log_scale ? e.std : 0.0;
      auto near = [&](double distance) {
        return distance <= 1e-6 * span && (std_search <= 0.0 || distance <= 0.01 * std_search);
      };
      p["at_bound"] = near(below) || near(above);
    }
    parameters[e.name] = p;
  }
  for (const auto& [name, value] : result.extra_estimates) {
    if (parameters.contains(name)) continue;
    nlohmann::json p = {
        {"value", Number(value)}, {"std", nullptr}, {"ci95", nullptr}, {"free", false}};
    if (const ParamInfo* info = config.FindParameterInfo(name)) p["unit"] = info->unit;
    parameters[name] = p;
  }
  report["parameters"] = parameters;

  const ErrorFigures errors = ComputeErrors(problem, result.values);
  nlohmann::json fit = ErrorsJson(errors);
  fit["observe"] = problem.observe();
  fit["fit_percent"] = errors.ok ? Number(100.0 * (1.0 - errors.nrmse)) : nlohmann::json(nullptr);
  const OptimizerSummary& s = result.summary;
  fit["evaluations"] = s.evaluations;
  fit["failed_evaluations"] = s.failed_evaluations;
  fit["iterations"] = s.iterations;
  fit["converged"] = s.converged;
  fit["termination"] = s.termination;
  fit["wall_time_s"] = Number(s.wall_time_s);
  std::vector<std::string> free_names;
  for (const auto& p : problem.free()) free_names.push_back(p.name);
  if (problem.equation_error()) {
    const EquationTrace& first_equation = problem.equation_traces().front();
    std::size_t samples = 0;
    for (std::size_t k = 0; k < problem.traces().size(); ++k) samples += problem.measured(k).rows();
    fit["error"] = {{"type", "equation"},
                    {"filter_hz", Number(first_equation.cutoff_hz)},
                    {"decimate", first_equation.decimate},
                    {"samples", samples}};
    fit["simulated"] = SimulatedErrors(problem, config, free_names, result.values);
  } else {
    fit["error"] = {{"type", "output"}};
  }
  report["fit"] = fit;

  nlohmann::json summary = {{"method", s.method},
                            {"algorithm", s.algorithm},
                            {"converged", s.converged},
                            {"termination", s.termination},
                            {"message", s.message},
                            {"raw_code", s.raw_code},
                            {"evaluations", s.evaluations},
                            {"failed_evaluations", s.failed_evaluations},
                            {"failure_reasons", s.failure_reasons},
                            {"iterations", s.iterations},
                            {"wall_time_s", Number(s.wall_time_s)},
                            {"seed", inputs.seed},
                            {"threads", inputs.threads},
                            {"details", s.details}};
  report["method_summary"] = summary;

  nlohmann::json residual = errors.ok ? ResidualDiagnostics(problem, result.values)
                                      : nlohmann::json{{"whiteness_p", nullptr}};
  bool any_interval = false;
  // Intervals that take the residuals as white are optimistic when they are not; the HAC
  // sandwich's account for the correlation (docs/uncertainty.md).
  for (const auto& e : result.estimates) {
    any_interval = any_interval || (e.has_interval && e.interval_method != "hac_prewhitened" &&
                                    e.interval_method != "leave_one_trace_out");
  }
  if (any_interval && residual.contains("white") && !residual["white"].get<bool>()) {
    residual["note"] =
        "the residual is not white: the intervals assume white noise and are optimistic";
    report["intervals_optimistic"] = true;
  } else {
    report["intervals_optimistic"] = false;
  }
  report["residual"] = residual;

  if (inputs.validation) {
    const ErrorFigures v = ComputeErrors(*inputs.validation, result.values);
    nlohmann::json validation = ErrorsJson(v);
    nlohmann::json paths = nlohmann::json::array();
    for (const auto& t : inputs.validation->traces()) paths.push_back(t.path);
    validation["traces"] = paths;
    if (inputs.validation->equation_error()) {
      validation["simulated"] = SimulatedErrors(*inputs.validation, inputs.validation->config(),
                                                free_names, result.values);
    }
    report["validation"] = validation;
  }
  SanitizeJson(&report);
  return report;
}

nlohmann::json FinalModelReport(nlohmann::json final_report, const nlohmann::json& first_report,
                                nlohmann::json discovery) {
  nlohmann::json before = nlohmann::json::object();
  for (const char* key : {"method", "effects", "parameters", "fit", "residual", "validation",
                          "intervals_optimistic", "method_summary"}) {
    if (first_report.contains(key)) before[key] = first_report[key];
  }
  discovery["before"] = before;
  final_report["discovery"] = std::move(discovery);
  final_report["config"]["effects"] = first_report["config"]["effects"];
  return final_report;
}

namespace {

bool IsTrue(const nlohmann::json& object, const char* key) {
  return object.is_object() && object.contains(key) && object[key].is_boolean() &&
         object[key].get<bool>();
}
bool IsFalse(const nlohmann::json& object, const char* key) {
  return object.is_object() && object.contains(key) && object[key].is_boolean() &&
         !object[key].get<bool>();
}
const nlohmann::json& Field(const nlohmann::json& object, const char* key) {
  static const nlohmann::json kNull;
  return object.is_object() && object.contains(key) ? object[key] : kNull;
}

}  // namespace

void WidenForAmbiguity(nlohmann::json* report) {
  if (!report->contains("discovery") || !(*report)["discovery"].contains("ambiguous")) return;
  nlohmann::json& parameters = (*report)["parameters"];
  for (const auto& group : (*report)["discovery"]["ambiguous"]) {
    if (!group.contains("models")) continue;
    for (const auto& model : group["models"]) {
      for (const auto& [name, value] : model["parameters"].items()) {
        if (!parameters.contains(name) || !value.is_number()) continue;
        nlohmann::json& p = parameters[name];
        if (!p["ci95"].is_array() || !p["ci95"][0].is_number() || !p["ci95"][1].is_number())
          continue;
        const double v = value.get<double>();
        const double low = p["ci95"][0].get<double>(), high = p["ci95"][1].get<double>();
        if (v >= low && v <= high) continue;
        if (!p.contains("ci95_before_ambiguity")) {
          p["ci95_before_ambiguity"] = p["ci95"];
          p["interval_method"] = p.value("interval_method", std::string()) + "+ambiguity";
        }
        p["ci95"] = {std::min(low, v), std::max(high, v)};
      }
    }
  }
}

void AddWarnings(nlohmann::json* report_pointer) {
  const nlohmann::json& report = *report_pointer;
  nlohmann::json warnings = nlohmann::json::array();
  auto add = [&](const std::string& code, const std::string& message) {
    warnings.push_back({{"code", code}, {"message", message}});
  };
  const nlohmann::json& summary = Field(report, "method_summary");
  if (IsFalse(summary, "converged")) {
    add("not_converged", "the fit did not converge (" + Field(summary, "termination").dump() +
                             "): the values are where the method stopped, not a minimum");
  }
  const nlohmann::json& fit = Field(report, "fit");
  if (Field(fit, "nrmse").is_number() && fit["nrmse"].get<double>() >= 1.0) {
    add("nrmse_at_least_one",
        "NRMSE " + G(fit["nrmse"], 4) +
            " >= 1: the model explains the measured columns no better than their means");
  }
  const nlohmann::json& validation = Field(report, "validation");
  if (Field(validation, "nrmse").is_number() && validation["nrmse"].get<double>() >= 1.0) {
    add("nrmse_at_least_one",
        "validation NRMSE " + G(validation["nrmse"], 4) +
            " >= 1: on the held-out traces the model is no better than the columns' means");
  }
  const nlohmann::json& residual = Field(report, "residual");
  if (IsFalse(residual, "white")) {
    add("residual_not_white",
        "the residual is not white (Ljung-Box p = " + G(Field(residual, "whiteness_p"), 3) +
            "): structure is left that the model does not explain; the intervals allow for "
            "correlated noise, not for a missing effect, which may bias the estimates");
  }
  std::string no_interval;
  for (const auto& [name, p] : Field(report, "parameters").items()) {
    if (!IsTrue(p, "free")) continue;
    if (IsTrue(p, "at_bound")) {
      add("parameter_at_bound",
          name + " = " + G(Field(p, "value"), 6) + " is at its bound [" +
              G(Field(p, "bounds")[0], 4) + ", " + G(Field(p, "bounds")[1], 4) +
              "]: the bound, not the data, set it; widen the bound or change the model");
    }
    const nlohmann::json& ci = Field(p, "ci95");
    if (!ci.is_array()) {
      no_interval += (no_interval.empty() ? "" : ", ") + name;
    } else if (Field(p, "value").is_number() && ci[0].is_number() && ci[1].is_number()) {
      const double value = p["value"].get<double>();
      const double half = 0.5 * (ci[1].get<double>() - ci[0].get<double>());
      if (!(half <= 0.5 * std::abs(value))) {
        add("parameter_poorly_determined",
            name + " = " + G(value, 4) + " with a 95 % interval of [" + G(ci[0], 4) + ", " +
                G(ci[1], 4) + "] (more than ±50 %): these traces hardly determine it");
      }
    }
  }
  if (!no_interval.empty()) {
    const nlohmann::json& interval = Field(Field(summary, "details"), "interval");
    const nlohmann::json& reason = Field(interval, "unavailable");
    add("interval_unavailable", "no interval for " + no_interval +
                                    (reason.is_string() ? ": " + reason.get<std::string>() : ""));
  }
  const nlohmann::json& discovery = Field(report, "discovery");
  for (const auto& group : Field(discovery, "ambiguous")) {
    std::string effects;
    for (const auto& e : Field(group, "effects"))
      effects += (effects.empty() ? "" : ", ") + e.get<std::string>();
    std::string models;
    for (const auto& m : Field(group, "models")) {
      models += (models.empty() ? "" : "; ") + m["effect"].get<std::string>() + ":";
      for (const char* name : {"J", "B"}) {
        if (Field(m, "parameters").contains(name)) {
          models += std::string(" ") + name + " = " + G(m["parameters"][name], 4);
        }
      }
      models += " (NRMSE " + G(Field(m, "nrmse"), 4) + ")";
    }
    add("discovery_ambiguous",
        "discovery could not tell " + effects + " apart and added neither (" +
            (Field(group, "reason").is_string() ? group["reason"].get<std::string>() : "") +
            "); the competing models: " + (models.empty() ? "see discovery.ambiguous" : models) +
            "; the intervals cover them");
  }
  const nlohmann::json& held_out = Field(discovery, "validation");
  const nlohmann::json& before = Field(Field(held_out, "before"), "nrmse");
  const nlohmann::json& after = Field(Field(held_out, "after"), "nrmse");
  if (before.is_number() && after.is_number() && after.get<double>() > before.get<double>()) {
    add("validation_worse_after_discovery",
        "the validation NRMSE rose from " + G(before, 4) + " to " + G(after, 4) +
            " when discovery added effects: they may fit the fit traces' noise, not the "
            "motor; compare with discovery.before");
  }
  (*report_pointer)["warnings"] = warnings;
}

std::string HumanSummary(const nlohmann::json& report) {
  std::ostringstream out;
  out << "blmd-ident " << report["version"].get<std::string>() << ": "
      << report["model"].get<std::string>() << " '" << report["config"]["name"].get<std::string>()
      << "', method " << report["method"].get<std::string>() << " ("
      << report["method_summary"]["algorithm"].get<std::string>() << ")\n";
  const auto& traces = report["traces"];
  out << "trace" << (traces.size() > 1 ? "s" : "") << ":";
  for (const auto& t : traces) {
    out << " " << t["path"].get<std::string>() << " (" << t["samples"].get<long>() << " samples)";
  }
  out << "\n";
  const bool discovered = report.contains("discovery") && !report["discovery"]["added"].empty();
  if (discovered) {
    std::string added;
    for (const auto& e : report["discovery"]["added"]) added += " + " + e.get<std::string>();
    out << "parameters of the final model (after discovery:" << added << "):\n";
  } else {
    out << "parameters:\n";
  }
  for (const auto& [name, p] : report["parameters"].items()) {
    const std::string unit = p.contains("unit") ? " " + p["unit"].get<std::string>() : "";
    char line[256];
    std::snprintf(line, sizeof line, "  %-6s = %-12s%s", name.c_str(), G(p["value"], 6).c_str(),
                  unit.c_str());
    out << line;
    if (p["ci95"].is_array()) {
      const bool widened = p.contains("ci95_before_ambiguity");
      out << "   ± " << G(p["std"], 3) << " (95 %: [" << G(p["ci95"][0], 5) << ", "
          << G(p["ci95"][1], 5) << "]" << (widened ? ", widened to cover the ambiguous models" : "")
          << ")";
    }
    if (p.contains("initial") && !p["initial"].is_null())
      out << "   initial " << G(p["initial"], 4);
    if (p.contains("free") && !p["free"].get<bool>()) out << "   (classic estimate)";
    if (p.contains("at_bound") && p["at_bound"].get<bool>()) out << "   AT ITS BOUND";
    out << "\n";
  }
  const auto& fit = report["fit"];
  out << "fit: ";
  if (fit["nrmse"].is_null()) {
    out << "failed (" << (fit.contains("failed") ? fit["failed"].get<std::string>() : "") << ")\n";
  } else {
    out << "NRMSE " << G(fit["nrmse"], 4) << " (fit " << G(fit["fit_percent"], 4) << " %), RMSE";
    for (const auto& [column, value] : fit["rmse"].items())
      out << " " << column << " " << G(value, 4);
    out << "\n";
    if (fit.contains("error") && fit["error"]["type"] == "equation") {
      out << "  equation error (the input the model needs along the measured motion): low-pass "
          << G(fit["error"]["filter_hz"], 4) << " Hz, decimation "
          << fit["error"]["decimate"].get<int>() << ", " << fit["error"]["samples"].get<long>()
          << " samples";
      if (fit.contains("simulated") && fit["simulated"].is_object() &&
          !fit["simulated"]["nrmse"].is_null()) {
        out << "; simulated " << fit["simulated"]["observe"][0].get<std::string>() << ": NRMSE "
            << G(fit["simulated"]["nrmse"], 4);
      }
      out << "\n";
    }
  }
  const auto& s = report["method_summary"];
  out << "method: " << (s["converged"].get<bool>() ? "converged" : "NOT converged") << " ("
      << s["termination"].get<std::string>() << "), " << s["evaluations"].get<long>()
      << " evaluations";
  if (s["failed_evaluations"].get<long>() > 0) {
    out << " (" << s["failed_evaluations"].get<long>() << " failed)";
  }
  out << ", " << s["iterations"].get<long>() << " iterations, " << G(s["wall_time_s"], 3) << " s\n";
  const auto& residual = report["residual"];
  if (residual.contains("whiteness_p") && !residual["whiteness_p"].is_null()) {
    out << "residual: Ljung-Box p = " << G(residual["whiteness_p"], 3)
        << (residual["white"].get<bool>() ? " (white)"
                                          : " (NOT white: structure left in the residual)")
        << "\n";
  }
  if (report.contains("intervals_optimistic") && report["intervals_optimistic"].get<bool>()) {
    out << "note: the intervals assume white residuals and are optimistic here\n";
  }
  if (report.contains("validation")) {
    const auto& v = report["validation"];
    out << "validation: NRMSE " << G(v["nrmse"], 4) << " on " << v["traces"].size()
        << " held-out trace(s)\n";
  }
  if (report.contains("discovery")) {
    const auto& d = report["discovery"];
    out << "discovery: " << d["conclusion"].get<std::string>() << "\n";
    for (const auto& step : d["steps"]) {
      out << "  + " << step["effect"].get<std::string>() << ":";
      for (const auto& [name, value] : step["parameters"].items()) {
        out << " " << name << " = " << G(value, 5);
        if (step["intervals"].contains(name)) {
          const auto& ci = step["intervals"][name]["ci95"];
          out << " (95 %: [" << G(ci[0], 4) << ", " << G(ci[1], 4) << "])";
        }
      }
      out << "\n    evidence: " << step["evidence"].get<std::string>() << "\n";
    }
    const auto& before = d["error_before"];
    const auto& after = d["error_after"];
    out << "  error before -> after: NRMSE " << G(before["nrmse"], 4) << " -> "
        << G(after["nrmse"], 4);
    if (before.contains("rmse") && after.contains("rmse")) {
      for (const auto& [column, value] : before["rmse"].items()) {
        out << ", " << column << " " << G(value, 4) << " -> " << G(after["rmse"][column], 4);
      }
    }
    out << "\n";
    if (d.contains("validation")) {
      out << "  validation NRMSE before -> after: " << G(d["validation"]["before"]["nrmse"], 4)
          << " -> " << G(d["validation"]["after"]["nrmse"], 4) << "\n";
    }
    // Equation error: the same models judged as simulations of the motion.
    const auto simulated_nrmse = [](const nlohmann::json& parent, const char* key) {
      return parent.is_object() && parent.contains(key) && parent[key].is_object() &&
                     parent[key].contains("nrmse") && !parent[key]["nrmse"].is_null()
                 ? G(parent[key]["nrmse"], 4)
                 : std::string("n/a");
    };
    if (d.contains("simulated_after") && fit.contains("simulated")) {
      out << "  simulated "
          << (fit["simulated"].is_object() && fit["simulated"].contains("observe")
                  ? fit["simulated"]["observe"][0].get<std::string>()
                  : std::string("motion"))
          << " NRMSE before -> after: " << simulated_nrmse(fit, "simulated") << " -> "
          << simulated_nrmse(d, "simulated_after");
      if (d.contains("validation") && report.contains("validation")) {
        out << "; validation " << simulated_nrmse(report["validation"], "simulated") << " -> "
            << simulated_nrmse(d["validation"], "simulated_after");
      }
      out << "\n";
    }
    if (!d["added"].empty() && d.contains("before")) {
      out << "  parameters before discovery:";
      for (const auto& [name, p] : d["before"]["parameters"].items()) {
        out << " " << name << " = " << G(p["value"], 5);
      }
      out << "\n";
    }
  }
  if (report.contains("warnings")) {
    for (const auto& w : report["warnings"]) {
      out << "warning [" << w["code"].get<std::string>() << "]: " << w["message"].get<std::string>()
          << "\n";
    }
  }
  return out.str();
}

}  // namespace blmd
