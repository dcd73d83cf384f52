// The human summary of a report (docs/cli.md "Output"): what blmd-ident prints without
// --json, rendered from the typed report.
#include <cmath>
#include <cstdio>
#include <sstream>

#include "blmd/io/config.h"
#include "blmd/report/report.h"
#include "blmd/version.h"
#include "report/html/html_page.h"
#include "report/text.h"

namespace blmd {
namespace {

using internal::Figure;

// The error's NRMSE, "n/a" when it could not be computed.
std::string Nrmse(const ErrorFigures& errors) {
  return errors.ok ? Figure(errors.nrmse, 4) : "n/a";
}

std::string Nrmse(const std::optional<SimulatedFit>& simulated) {
  return simulated ? Nrmse(simulated->errors) : "n/a";
}

void Parameters(const ModelReport& model, std::ostringstream& out) {
  for (const auto& [name, p] : model.parameters) {
    const ParameterEstimate& e = p.estimate;
    const std::string unit = p.unit.empty() ? "" : " " + p.unit;
    char line[256];
    std::snprintf(line, sizeof line, "  %-6s = %-12s%s", name.c_str(), Figure(e.value, 6).c_str(),
                  unit.c_str());
    out << line;
    if (p.free && e.has_interval) {
      // ± is the 95 % interval's half-width (the JSON keeps std and ci95).
      out << "   ± " << Figure(0.5 * (e.ci95_high - e.ci95_low), 3) << " (95 %: ["
          << Figure(e.ci95_low, 5) << ", " << Figure(e.ci95_high, 5) << "]"
          << (p.widened_by_ambiguity ? ", widened to cover the ambiguous models" : "") << ")";
      if (e.has_crb && e.std_crb > 0.0) out << "   " << Figure(e.std / e.std_crb, 3) << "x CRB";
    }
    if (p.free && std::isfinite(e.initial)) out << "   initial " << Figure(e.initial, 4);
    if (!p.free) out << "   (classic estimate)";
    if (p.has_bounds && p.at_bound) out << "   AT ITS BOUND";
    out << "\n";
  }
}

void Fit(const FitReport& fit, std::ostringstream& out) {
  out << "fit: ";
  const ErrorFigures& errors = fit.errors;
  if (!errors.ok || !std::isfinite(errors.nrmse)) {
    out << "failed (" << (errors.ok ? "" : errors.reason) << ")\n";
    return;
  }
  out << "NRMSE " << Figure(errors.nrmse, 4) << " (fit " << Figure(100.0 * (1.0 - errors.nrmse), 4)
      << " %), RMSE";
  for (const auto& [column, value] : RmseByColumn(errors))
    out << " " << column << " " << Figure(value, 4);
  out << "\n";
  if (fit.equation_error) {
    out << "  equation error (the input the model needs along the measured motion): low-pass "
        << Figure(fit.filter_hz, 4) << " Hz, decimation " << fit.decimate << ", " << fit.samples
        << " samples";
    if (fit.simulated && fit.simulated->errors.ok && std::isfinite(fit.simulated->errors.nrmse)) {
      out << "; simulated " << fit.simulated->column << ": NRMSE "
          << Figure(fit.simulated->errors.nrmse, 4);
    }
    out << "\n";
  }
}

void Method(const OptimizerSummary& s, std::ostringstream& out) {
  out << "method: " << (s.converged ? "converged" : "NOT converged") << " (" << s.termination
      << "), " << s.evaluations << " evaluations";
  if (s.failed_evaluations > 0) out << " (" << s.failed_evaluations << " failed)";
  out << ", " << s.iterations << " iterations, " << Figure(s.wall_time_s, 3) << " s\n";
}

void Discovery(const IdentReport& report, std::ostringstream& out) {
  const DiscoveryReport& d = *report.discovery;
  out << "discovery: " << d.conclusion << "\n";
  for (const auto& step : d.steps) {
    out << "  + " << step.effect << ":";
    for (const StepParameter& p : StepParameters(step)) {
      out << " " << p.name << " = " << Figure(p.value, 5);
      if (p.fitted && p.fitted->has_interval) {
        out << " (95 %: [" << Figure(p.fitted->ci95_low, 4) << ", "
            << Figure(p.fitted->ci95_high, 4) << "])";
      }
    }
    out << "\n    evidence: " << step.evidence << "\n";
  }
  out << "  error before -> after: NRMSE " << Nrmse(d.error_before) << " -> "
      << Nrmse(d.error_after);
  if (d.error_before.ok && d.error_after.ok) {
    const std::map<std::string, double> after = RmseByColumn(d.error_after);
    for (const auto& [column, value] : RmseByColumn(d.error_before)) {
      const auto found = after.find(column);
      out << ", " << column << " " << Figure(value, 4) << " -> "
          << (found == after.end() ? std::string("n/a") : Figure(found->second, 4));
    }
  }
  out << "\n";
  if (d.has_validation) {
    out << "  validation NRMSE before -> after: " << Nrmse(d.validation_before) << " -> "
        << Nrmse(d.validation_after) << "\n";
  }
  // Equation error: the same models judged as simulations of the motion, the first fit's
  // (discovery.before) against the final model's.
  const ModelReport& before = d.before;
  if (d.equation_error && before.fit.equation_error) {
    out << "  simulated "
        << (before.fit.simulated && !before.fit.simulated->column.empty()
                ? before.fit.simulated->column
                : std::string("motion"))
        << " NRMSE before -> after: " << Nrmse(before.fit.simulated) << " -> "
        << Nrmse(d.simulated_after);
    if (d.has_validation && before.validation) {
      out << "; validation " << Nrmse(before.validation->simulated) << " -> "
          << Nrmse(d.validation_simulated_after);
    }
    out << "\n";
  }
  // What is left: the final residual's whiteness and the adequacy check (docs/discovery.md §7).
  const ResidualAnalysis& left = d.residual_after;
  if (left.ok && std::isfinite(left.whiteness_p)) {
    out << "  final residual: Ljung-Box p = " << Figure(left.whiteness_p, 3)
        << (left.white ? " (white)" : " (not white)");
    if (d.has_adequacy && d.adequacy.ok) {
      out << "; adequacy: "
          << (d.adequacy.flagged.empty()
                  ? "no structure above " + Figure(100.0 * d.adequacy.min_share, 2) +
                        " % of its variance depends on theta, w, sign(w), "
                        "u or t"
                  : d.adequacy.StructureMessage());
    }
    out << "\n";
  }
  if (d.has_adequacy && d.adequacy.stability_checked) {
    out << "  effects across " << d.adequacy.parts << ": "
        << (d.adequacy.unstable.empty() ? std::string("stable")
                                        : "UNSTABLE: " + Join(d.adequacy.unstable))
        << "\n";
  }
  for (const auto& o : d.last_round) {
    if (o.reason.rfind("tried, not needed", 0) == 0)
      out << "  " << o.effect << ": " << o.reason << "\n";
  }
  for (const auto& o : d.unstable) out << "  " << o.effect << ": " << o.reason << "\n";
  if (!d.added.empty()) {
    out << "  parameters before discovery:";
    for (const auto& [name, p] : before.parameters)
      out << " " << name << " = " << Figure(p.estimate.value, 5);
    out << "\n";
  }
}

// "6.4e-06 s^2 + 0.000287 s + 0.00188", descending powers of s.
std::string Polynomial(const std::vector<double>& coefficients) {
  std::string text;
  for (std::size_t k = 0; k < coefficients.size(); ++k) {
    const double c = coefficients[k];
    const std::size_t power = coefficients.size() - 1 - k;
    if (c == 0.0 && coefficients.size() > 1) continue;
    text += text.empty() ? (c < 0 ? "-" : "") : (c < 0 ? " - " : " + ");
    text += Figure(std::abs(c), 4);
    if (power >= 1) text += " s";
    if (power >= 2) text += "^" + std::to_string(power);
  }
  return text.empty() ? "0" : text;
}

void Baseline(const BaselineReport& b, std::ostringstream& out) {
  out << "baseline " << b.path << ": "
      << (b.changed() ? "CHANGED (" + Join(b.moved) + " moved)" : std::string("unchanged")) << "\n";
  for (const auto& p : b.parameters) {
    out << "  " << p.name << ": " << Figure(p.baseline, 6);
    if (p.verdict == "not_compared") {
      out << "  not compared: " << p.reason << "\n";
      continue;
    }
    out << " -> " << Figure(p.value, 6) << " (shift " << Figure(p.shift, 3) << ", "
        << Figure(p.baseline != 0.0 ? 100.0 * p.shift / p.baseline : NAN, 3) << " %; limit ±"
        << Figure(p.combined_limit, 3) << " from both 95 % intervals): " << p.verdict << "\n";
  }
}

}  // namespace

std::string HumanSummary(const IdentReport& report) {
  const ModelReport& model = report.final_model;
  std::ostringstream out;
  out << "blmd-ident " << kVersion << ": " << report.model << " '" << report.config_name
      << "', method " << model.method << " (" << model.summary.algorithm << ")\n";
  out << "trace" << (report.traces.size() > 1 ? "s" : "") << ":";
  for (const auto& t : report.traces) out << " " << t.path << " (" << t.samples << " samples)";
  out << "\n";
  if (report.discovered()) {
    std::string added;
    for (const auto& e : report.discovery->added) added += " + " + e;
    out << "parameters of the final model (after discovery:" << added << "):\n";
  } else {
    out << "parameters:\n";
  }
  Parameters(model, out);
  Fit(model.fit, out);
  Method(model.summary, out);
  if (!report.noise.columns.empty()) {
    out << "noise";
    if (report.noise.weighting == "noise") {
      out << " (the cost weighs each column by 1/sigma^2";
      if (report.noise.fits > 1) out << ", " << report.noise.fits << " fits";
      if (!report.noise.converged) out << ", NOT settled";
      out << "):";
      for (const auto& c : report.noise.columns) {
        out << " " << c.column << " sigma " << Figure(c.std, 3) << " (" << c.source;
        if (c.quantum > 0.0) out << ", step " << Figure(c.quantum, 3);
        out << ")";
      }
    } else {
      out << ": weighted by each column's variance (--weighting variance)";
    }
    out << "\n";
  }
  const ResidualAnalysis* residual = model.residual.analysis ? &*model.residual.analysis : nullptr;
  if (residual && residual->ok && std::isfinite(residual->whiteness_p)) {
    out << "residual: Ljung-Box p = " << Figure(residual->whiteness_p, 3)
        << (residual->white ? " (white)" : " (coloured: the intervals allow for correlated noise)")
        << "\n";
  }
  if (report.adequacy && report.adequacy->ok) {
    out << "adequacy: "
        << (report.adequacy->flagged.empty()
                ? "no structure above " + Figure(100.0 * report.adequacy->min_share, 2) +
                      " % of the residual's variance depends on theta, w, sign(w), u or t"
                : report.adequacy->StructureMessage())
        << "\n";
  }
  if (report.cutoff && report.cutoff->ran) {
    out << "cut-off: the equation error's low-pass at " << Figure(report.cutoff->chosen_hz, 3)
        << " Hz, " << report.cutoff->reason << "\n";
  }
  for (const std::string& note : report.notes) out << "note: " << note << "\n";
  if (model.intervals_optimistic) {
    out << "note: the intervals assume white residuals and are optimistic here\n";
  }
  for (const CorrelatedPair& pair : model.correlation.poorly_separable) {
    out << "note: " << pair.first << " and " << pair.second
        << " are correlated (rho = " << Figure(pair.rho, 3)
        << "): these traces determine a combination of the two far better than either\n";
  }
  if (model.validation) {
    out << "validation: NRMSE " << Nrmse(model.validation->errors) << " on "
        << model.validation->traces.size() << " held-out trace(s)\n";
  }
  if (report.discovery) Discovery(report, out);
  if (report.linear_model.available) {
    for (const auto& tf : TransferFunctions(report.linear_model)) {
      if (tf.output != "w") continue;
      out << "linear part: u -> w = " << Polynomial(tf.numerator) << " / ("
          << Polynomial(tf.denominator) << ")  (" << report.linear_model.assumption << ")\n";
    }
  }
  if (report.step_response && report.step_response->available) {
    const StepResponseReport& step = *report.step_response;
    for (std::size_t k = 0; k < step.outputs.size(); ++k) {
      const StepFigures& f = step.response.figures[k];
      if (step.outputs[k] != "w" || !f.ok) continue;
      out << "step of u (linear part): w -> " << Figure(f.final_value, 4) << " rad/s per "
          << internal::DescribeColumn("u", report.model).unit << ", rise "
          << Figure(f.rise_time_s, 3) << " s (10-90 %), overshoot "
          << Figure(f.overshoot_percent, 3) << " %, settled (2 %) after "
          << Figure(f.settling_time_s, 3) << " s\n";
    }
  }
  if (report.baseline) Baseline(*report.baseline, out);
  for (const auto& w : report.warnings) out << "warning [" << w.code << "]: " << w.message << "\n";
  return out.str();
}

}  // namespace blmd
