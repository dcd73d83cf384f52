#include "blmd/ident/report.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "blmd/error.h"
#include "blmd/ident/diagnostics.h"
#include "blmd/ident/stats.h"
#include "blmd/version.h"

namespace blmd {
namespace {

nlohmann::json Number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

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

ErrorFigures ComputeErrors(const FitProblem& problem, const std::vector<double>& values) {
  ErrorFigures errors;
  errors.observe = problem.observe();
  const Evaluation evaluation = problem.Evaluate(values);
  errors.ok = evaluation.ok;
  errors.reason = evaluation.reason;
  if (!evaluation.ok) return errors;
  for (double mse : evaluation.mse) errors.rmse.push_back(std::sqrt(mse));
  errors.mse = evaluation.cost;
  errors.nrmse = std::sqrt(evaluation.cost);
  return errors;
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
  for (std::size_t c = 0; c < errors.observe.size(); ++c) rmse[errors.observe[c]] = Number(errors.rmse[c]);
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
  report["model"] = std::string(config.model->name());
  report["method"] = result.summary.method;
  report["config"] = {{"path", inputs.config_path}, {"name", config.name}, {"effects", config.effects}};
  const FitTrace& first = problem.traces().front();
  report["trace"] = {{"path", first.path}, {"samples", first.trace.rows()}, {"sha256", first.sha256}};
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
      entry["nrmse"] = Number(std::sqrt(normalised / static_cast<double>(problem.observe().size())));
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
    // The white-noise interval for comparison (docs/uncertainty.md).
    if (e.has_white_interval) {
      p["std_white"] = Number(e.std_white);
      p["ci95_white"] = nlohmann::json::array({Number(e.ci95_white_low), Number(e.ci95_white_high)});
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
      p["at_bound"] = below <= 1e-6 * span || above <= 1e-6 * span;
    }
    parameters[e.name] = p;
  }
  for (const auto& [name, value] : result.extra_estimates) {
    if (parameters.contains(name)) continue;
    nlohmann::json p = {{"value", Number(value)}, {"std", nullptr}, {"ci95", nullptr}, {"free", false}};
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

  nlohmann::json summary = {{"method", s.method}, {"algorithm", s.algorithm},
                            {"converged", s.converged}, {"termination", s.termination},
                            {"message", s.message}, {"raw_code", s.raw_code},
                            {"evaluations", s.evaluations},
                            {"failed_evaluations", s.failed_evaluations},
                            {"failure_reasons", s.failure_reasons},
                            {"iterations", s.iterations}, {"wall_time_s", Number(s.wall_time_s)},
                            {"seed", inputs.seed}, {"threads", inputs.threads},
                            {"details", s.details}};
  report["method_summary"] = summary;

  nlohmann::json residual = errors.ok ? ResidualDiagnostics(problem, result.values)
                                      : nlohmann::json{{"whiteness_p", nullptr}};
  bool any_interval = false;
  // Intervals that take the residuals as white are optimistic when they are not; the HAC
  // sandwich's account for the correlation (docs/uncertainty.md).
  for (const auto& e : result.estimates) {
    any_interval = any_interval || (e.has_interval && e.interval_method != "hac_prewhitened");
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
      validation["simulated"] =
          SimulatedErrors(*inputs.validation, inputs.validation->config(), free_names, result.values);
    }
    report["validation"] = validation;
  }
  SanitizeJson(&report);
  return report;
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
  out << "parameters:\n";
  for (const auto& [name, p] : report["parameters"].items()) {
    const std::string unit = p.contains("unit") ? " " + p["unit"].get<std::string>() : "";
    char line[256];
    std::snprintf(line, sizeof line, "  %-6s = %-12s%s", name.c_str(), G(p["value"], 6).c_str(),
                  unit.c_str());
    out << line;
    if (p["ci95"].is_array()) {
      out << "   ± " << G(p["std"], 3) << " (95 %: [" << G(p["ci95"][0], 5) << ", "
          << G(p["ci95"][1], 5) << "])";
    }
    if (p.contains("initial") && !p["initial"].is_null()) out << "   initial " << G(p["initial"], 4);
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
    for (const auto& [column, value] : fit["rmse"].items()) out << " " << column << " " << G(value, 4);
    out << "\n";
    if (fit.contains("error") && fit["error"]["type"] == "equation") {
      out << "  equation error (the input the model needs along the measured motion): low-pass "
          << G(fit["error"]["filter_hz"], 4) << " Hz, decimation " << fit["error"]["decimate"].get<int>()
          << ", " << fit["error"]["samples"].get<long>() << " samples";
      if (fit.contains("simulated") && fit["simulated"].is_object() && !fit["simulated"]["nrmse"].is_null()) {
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
        << (residual["white"].get<bool>() ? " (white)" : " (NOT white: structure left in the residual)")
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
    out << "  error before -> after: NRMSE " << G(before["nrmse"], 4) << " -> " << G(after["nrmse"], 4);
    if (before.contains("rmse") && after.contains("rmse")) {
      for (const auto& [column, value] : before["rmse"].items()) {
        out << ", " << column << " " << G(value, 4) << " -> " << G(after["rmse"][column], 4);
      }
    }
    out << "\n";
    if (d.contains("validation")) {
      out << "  validation NRMSE before -> after: " << G(d["validation"]["before"]["nrmse"], 4) << " -> "
          << G(d["validation"]["after"]["nrmse"], 4) << "\n";
    }
    // Equation error: the same models judged as simulations of the motion.
    const auto simulated_nrmse = [](const nlohmann::json& parent, const char* key) {
      return parent.is_object() && parent.contains(key) && parent[key].is_object() &&
                     parent[key].contains("nrmse") && !parent[key]["nrmse"].is_null()
                 ? G(parent[key]["nrmse"], 4)
                 : std::string("n/a");
    };
    if (d.contains("simulated_after") && fit.contains("simulated")) {
      out << "  simulated " << (fit["simulated"].is_object() && fit["simulated"].contains("observe")
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
    if (!d["added"].empty()) {
      out << "  parameters after:";
      for (const auto& [name, value] : d["parameters_after"].items()) {
        out << " " << name << " = " << G(value, 5);
      }
      out << "\n";
    }
  }
  return out.str();
}

}  // namespace blmd
