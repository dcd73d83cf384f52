// The HTML report (docs/report.md). Every plot is a LinePlotSvg inlined in the page; the
// page's only styling is the <style> block below. Nothing is fetched and nothing runs.
#include "blmd/report/html/html_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <limits>
#include <memory>
#include <stdexcept>

#include "blmd/io/files.h"
#include "blmd/report/svg/plot.h"
#include "blmd/version.h"
#include "parallel.h"
#include "report/html/html_page.h"
#include "report/markup.h"

namespace blmd {
namespace {

using nlohmann::json;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

using internal::ColumnInfo;
using internal::DescribeColumn;
using internal::G;
using internal::HeaderRow;
using internal::kAfterColour;
using internal::kAfterDash;
using internal::kBandColour;
using internal::kFitColour;
using internal::kMeasuredColour;
using internal::Page;
using internal::Row;

// ---- text ------------------------------------------------------------------------------

using internal::Escape;  // report/markup.h

// The method's figures as the JSON report gives them (MethodDetailsJson), as text.
std::string Text(const json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_number_float()) return G(v.get<double>(), 6);
  if (v.is_null()) return "n/a";
  if (v.is_object()) {  // {"i": 0.025, "w": 7.9} -> "i 0.025, w 7.9"
    std::string out;
    for (const auto& [key, value] : v.items())
      out += (out.empty() ? "" : ", ") + key + " " + Text(value);
    return out;
  }
  return v.dump();
}

// The error's NRMSE, "n/a" when it could not be computed.
std::string Nrmse(const ErrorFigures& errors) { return errors.ok ? G(errors.nrmse, 4) : "n/a"; }

std::string Interval(double low, double high, int digits) {
  return "[" + G(low, digits) + ", " + G(high, digits) + "]";
}

std::string NowUtc() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char buffer[64];
  std::strftime(buffer, sizeof buffer, "%Y-%m-%d %H:%M UTC", &utc);
  return buffer;
}

// ---- columns ---------------------------------------------------------------------------

// ---- page pieces -----------------------------------------------------------------------

constexpr const char* kStyle = R"css(
:root { color-scheme: light; }
body { font-family: sans-serif; color: #222; background: #fff; margin: 0 auto;
       max-width: 1260px; padding: 14px 22px 40px; line-height: 1.4; }
h1 { font-size: 1.55rem; margin: .4rem 0 .6rem; }
h2 { font-size: 1.2rem; margin: 2rem 0 .6rem; padding-bottom: .2rem; border-bottom: 1px solid #bbb; }
h3 { font-size: 1rem; margin: 1.2rem 0 .5rem; }
p.note { color: #444; font-size: .9rem; max-width: 60rem; }
table { border-collapse: collapse; font-size: .88rem; margin: .4rem 0 .8rem; }
th, td { border-bottom: 1px solid #ddd; padding: .22rem .6rem; text-align: left; vertical-align: top; }
th { background: #f3f3f3; font-weight: 600; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
table.meta th { background: none; width: 9rem; }
code { font-size: .85rem; word-break: break-all; }
.cards { display: flex; flex-wrap: wrap; gap: .7rem; margin: .6rem 0; }
.card { border: 1px solid #ccc; border-radius: 6px; padding: .45rem .8rem; min-width: 10rem; }
.card .label { font-size: .8rem; color: #555; }
.card .value { font-size: 1.35rem; font-weight: bold; }
.card .sub { font-size: .8rem; color: #555; }
.headline .card { border-color: #0b5394; }
.warn { border-left: 4px solid #d55e00; padding-left: .6rem; }
ul.warnings { border-left: 4px solid #d55e00; padding-left: 1.6rem; max-width: 60rem; }
.grid { display: grid; grid-template-columns: repeat(auto-fill, minmax(540px, 1fr)); gap: 14px;
        margin-bottom: 14px; }
figure.plot { margin: 0; border: 1px solid #e0e0e0; border-radius: 4px; padding: 6px 6px 4px;
              position: relative; background: #fff; }
figure.plot svg { display: block; width: 100%; height: auto; }
figcaption { font-size: .82rem; color: #444; margin: .25rem .2rem 0; }
a.zoom, a.close { position: absolute; top: 5px; right: 8px; font-size: .78rem; color: #0b5394;
                  background: #fff; padding: 0 .25rem; }
a.close { display: none; }
figure.plot:target { position: fixed; inset: 0; z-index: 10; margin: 0; border: 0; border-radius: 0;
                     padding: 2rem 1.2rem 1rem; overflow: auto; }
figure.plot:target svg { width: 100%; height: calc(100vh - 5.5rem); }
figure.plot:target a.zoom { display: none; }
figure.plot:target a.close { display: block; font-size: 1rem; }
details { margin: .3rem 0 .8rem; }
summary { cursor: pointer; color: #0b5394; }
footer { margin-top: 2.5rem; font-size: .8rem; color: #555; border-top: 1px solid #ddd; padding-top: .5rem; }
@media print { a.zoom { display: none; } .grid { grid-template-columns: 1fr; } }
)css";

std::string Card(const std::string& label, const std::string& value, const std::string& sub,
                 bool warn = false) {
  return std::string("<div class=\"card") + (warn ? " warn" : "") + "\"><div class=\"label\">" +
         Escape(label) + "</div><div class=\"value\">" + Escape(value) +
         "</div><div class=\"sub\">" + Escape(sub) + "</div></div>\n";
}

// ---- data ------------------------------------------------------------------------------

std::vector<double> Slice(const std::vector<double>& v, std::size_t begin, std::size_t end) {
  begin = std::min(begin, v.size());
  end = std::min(std::max(begin, end), v.size());
  return std::vector<double>(v.begin() + static_cast<std::ptrdiff_t>(begin),
                             v.begin() + static_cast<std::ptrdiff_t>(end));
}

// A line series (no markers) and a marker series (no line).
Series Line(std::string label, std::vector<double> x, std::vector<double> y, const char* colour,
            const char* dash, double width) {
  Series series;
  series.label = std::move(label);
  series.x = std::move(x);
  series.y = std::move(y);
  series.colour = colour;
  series.dash = dash;
  series.line_width = width;
  return series;
}

Series Dots(std::string label, const char* colour, double radius, bool hollow) {
  Series series;
  series.label = std::move(label);
  series.colour = colour;
  series.line_width = 0.0;
  series.marker_radius = radius;
  series.hollow_markers = hollow;
  return series;
}

std::vector<double> Difference(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> out(std::min(a.size(), b.size()));
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = a[i] - b[i];
  return out;
}

// ---- sections --------------------------------------------------------------------------

void WriteHeader(Page& page, const IdentReport& report, const FitProblem& problem,
                 const std::string& date) {
  std::string& h = page.html();
  const std::string& name = report.config_name;
  h += "<header>\n<h1>blmd-ident report: " + Escape(name) + "</h1>\n<table class=\"meta\">\n";
  auto meta = [&](const std::string& key, const std::string& value_html) {
    h += "<tr><th>" + Escape(key) + "</th><td>" + value_html + "</td></tr>\n";
  };
  meta("model", "<code>" + Escape(report.model) + "</code>");
  meta("config", "<code>" + Escape(report.config_path) + "</code> (" + Escape(name) + ")");
  const ModelReport& model = report.final_model;
  meta("method", "<code>" + Escape(model.method) + "</code> — " + Escape(model.summary.algorithm));
  std::string traces_html;
  const std::vector<TraceReport>& traces = report.traces;
  for (std::size_t k = 0; k < traces.size(); ++k) {
    const TraceReport& t = traces[k];
    const std::string& sha = t.sha256;
    traces_html += (k ? "<br>" : "") + std::string("<code>") + Escape(t.path) + "</code>, " +
                   std::to_string(t.samples) + " samples, sha256 <code title=\"" + Escape(sha) +
                   "\">" + Escape(sha.substr(0, 12)) + "…</code>";
  }
  meta(traces.size() > 1 ? "traces" : "trace", traces_html);
  std::string observed, free;
  for (const auto& c : problem.observe()) observed += (observed.empty() ? "" : ", ") + c;
  for (const auto& p : problem.free()) free += (free.empty() ? "" : ", ") + p.name;
  meta("observed", Escape(observed));
  meta("free", Escape(free));
  meta("date", Escape(date));
  meta("tool", "blmd-ident " + Escape(kVersion));
  h += "</table>\n</header>\n";
}

void WriteKeyFigures(Page& page, const IdentReport& report) {
  std::string& h = page.html();
  const ModelReport& model = report.final_model;
  const ErrorFigures& fit = model.fit.errors;
  const ResidualAnalysis* residual = model.residual.analysis ? &*model.residual.analysis : nullptr;
  const OptimizerSummary& summary = model.summary;
  // The headline: what the user came for, the final model's J and B and the values of the
  // effects discovery added, each with its 95 % interval, before any figure of merit.
  h += "<div class=\"cards headline\">\n";
  std::vector<std::string> headline = {"J", "B"};
  if (report.discovery) {
    for (const DiscoveryStep& step : report.discovery->steps) {
      for (const ParameterEstimate& estimate : step.effect_parameters) {
        const std::string& name = estimate.name;
        const auto found = model.parameters.find(name);
        if (found != model.parameters.end() && found->second.free &&
            std::find(headline.begin(), headline.end(), name) == headline.end())
          headline.push_back(name);
      }
    }
  }
  for (const std::string& name : headline) {
    const auto found = model.parameters.find(name);
    if (found == model.parameters.end()) continue;
    const ParameterReport& p = found->second;
    const ParameterEstimate& e = p.estimate;
    const std::string unit = p.unit.empty() ? "" : " " + p.unit;
    const bool interval = p.free && e.has_interval;
    h += "<div class=\"card estimate\" data-name=\"" + Escape(name) + "\"><div class=\"label\">" +
         Escape(name) + "</div><div class=\"value\">" + Escape(G(e.value, 5) + unit) +
         "</div><div class=\"sub\">" +
         Escape(interval ? "95 % " + Interval(e.ci95_low, e.ci95_high, 4) : "no interval") +
         (p.at_bound ? " <b>at its bound</b>" : "") + "</div></div>\n";
  }
  h += "</div>\n<div class=\"cards\">\n";
  h += Card(report.discovered() ? "NRMSE of the final model" : "NRMSE of the fit", Nrmse(fit),
            "fit " + (fit.ok ? G(100.0 * (1.0 - fit.nrmse), 4) : std::string("n/a")) +
                " % (100 % = perfect)");
  const bool white = residual && residual->ok && residual->white;
  h += Card("residual", white ? "white" : "NOT white",
            "Ljung-Box p = " +
                (residual && residual->ok ? G(residual->whiteness_p, 3) : std::string("n/a")),
            !white);
  h += Card("method", summary.converged ? "converged" : "NOT converged",
            summary.termination + ", " + std::to_string(summary.evaluations) + " evaluations, " +
                G(summary.wall_time_s, 3) + " s",
            !summary.converged);
  if (report.discovered()) {  // only when discovery changed the model
    h += Card("before discovery", "NRMSE " + Nrmse(report.discovery->error_before),
              report.discovery->conclusion);
  }
  if (model.validation) {
    h += Card("validation", "NRMSE " + Nrmse(model.validation->errors),
              std::to_string(model.validation->traces.size()) + " held-out trace(s)");
  }
  h += "</div>\n";
  if (!model.residual.note.empty())
    h += "<p class=\"note warn\">" + Escape(model.residual.note) + "</p>\n";
  if (!report.warnings.empty()) {
    h += "<ul class=\"warnings\">\n";
    for (const auto& w : report.warnings) {
      h += "<li class=\"warning\" data-code=\"" + Escape(w.code) + "\"><b>" + Escape(w.code) +
           "</b>: " + Escape(w.message) + "</li>\n";
    }
    h += "</ul>\n";
  }
}

// The user's start of a parameter: the first fit's initial value (the final model's fit
// starts from the previous round's values, which are not what the user gave); a parameter
// that discovery added started where its screening put it.
std::string UserStart(const std::string& name, const ParameterReport& p,
                      const std::map<std::string, ParameterReport>& first) {
  if (!p.free) return "n/a";
  const auto found = first.find(name);
  if (found == first.end()) return "— (discovery)";
  return G(found->second.estimate.initial, 4);
}

void WriteParameters(Page& page, const IdentReport& report, const FitProblem& problem) {
  std::string& h = page.html();
  page.Section("parameters", "Parameters");
  const std::map<std::string, ParameterReport>& parameters = report.final_model.parameters;
  const bool after = report.discovered();
  // The headline is the final model; the first fit beside it when discovery added effects.
  const std::map<std::string, ParameterReport>& before = report.first_fit().parameters;
  std::vector<std::string> head = {"parameter", "unit",          "initial", "estimate",
                                   "± (95 %)",  "95 % interval", "× CRB",   "bounds"};
  if (after) {
    head.emplace_back("before discovery");
    head.emplace_back("95 % interval before");
  }
  h += "<table class=\"parameters\">\n" + HeaderRow(head);
  // The free parameters in the problem's order (J before B), then the others.
  std::vector<std::string> names;
  for (const auto& fp : problem.free()) {
    if (parameters.count(fp.name) != 0) names.push_back(fp.name);
  }
  for (const auto& [name, p] : parameters) {
    if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
  }
  for (const auto& name : names) {
    const ParameterReport& p = parameters.at(name);
    const ParameterEstimate& e = p.estimate;
    const bool interval = p.free && e.has_interval;
    std::string bounds = "—", note;
    if (p.has_bounds) bounds = G(p.lower, 3) + " … " + G(p.upper, 3);
    if (p.has_bounds && p.at_bound) note = " <b>at its bound</b>";
    if (!p.free) note = " (classic estimate)";
    std::vector<std::string> cells = {
        "<b>" + Escape(name) + "</b>",
        Escape(p.unit),
        UserStart(name, p, before),
        G(e.value, 6) + note,
        interval ? G(0.5 * (e.ci95_high - e.ci95_low), 3) : "n/a",
        interval ? Interval(e.ci95_low, e.ci95_high, 5) : "—",
        interval && e.has_crb && e.std_crb > 0.0 ? G(e.std / e.std_crb, 3) : "—",
        bounds};
    std::vector<bool> numeric = {false, false, true, true, true, true, true, true};
    if (after) {
      const auto found = before.find(name);
      const ParameterReport* b = found == before.end() ? nullptr : &found->second;
      const bool value = b && std::isfinite(b->estimate.value);
      const bool ci = b && b->free && b->estimate.has_interval;
      cells.push_back(value ? G(b->estimate.value, 6) : "— (added by discovery)");
      cells.push_back(ci ? Interval(b->estimate.ci95_low, b->estimate.ci95_high, 5) : "—");
      numeric.push_back(true);
      numeric.push_back(true);
    }
    h += Row(cells, " class=\"parameter\" data-name=\"" + Escape(name) + "\"", numeric);
  }
  h += "</table>\n";
  h += "<p class=\"note\">± is the half-width of the 95 % interval (the JSON report keeps the "
       "standard deviation, <code>std</code>); × CRB is the standard deviation over the "
       "experiment's Cramér–Rao bound at the columns' noise (1: as precise as the data "
       "allow).</p>\n";
  if (report.final_model.intervals_optimistic) {
    h += "<p class=\"note warn\">The intervals assume white residuals; the residual is not white, "
         "so "
         "they are optimistic.</p>\n";
  }
  internal::WriteCorrelation(page, report.final_model.correlation);
  page.EndSection();
}

void WriteTraces(Page& page, const IdentReport& report, const FitProblem& problem,
                 const ModelViews& fit, const ModelViews* after, const std::string& after_label) {
  const HtmlReportOptions& o = page.options();
  const std::string& model = report.model;
  const std::size_t traces = problem.traces().size();
  page.Section("traces", "Measured and simulated");
  std::string& h = page.html();
  h += "<p class=\"note\">Grey: the measurement. Blue: simulated with the fitted parameters";
  if (after)
    h += "; vermilion, dashed: simulated with the model and parameters " + Escape(after_label);
  h += ". Each plot draws at most five samples per pixel column (first, last, lowest, highest, "
       "first "
       "gap), so spikes stay visible. The second plot of each column is the first transient, "
       "enlarged, where u has a step; any figure can be enlarged to the whole window with its "
       "<i>enlarge</i> "
       "link.</p>\n";
  if (problem.equation_error()) {
    h += "<p class=\"note\">Equation error (docs/identification.md &sect;8): the measured curve is "
         "the "
         "recorded input u after the filters, the model's is the input the model needs along the "
         "measured "
         "motion, at the kept samples; no motion is simulated here.</p>\n";
  }
  if (!fit.simulated)
    h += "<p class=\"note warn\">The fit's simulation failed: " + Escape(fit.reason) + "</p>\n";
  for (std::size_t k = 0; k < traces; ++k) {
    const FitTrace& ft = problem.traces()[k];
    const Trace& measured = problem.measured(k);
    const std::vector<double>& t = measured.Column("t");
    const std::string trace_note = traces > 1 ? " (trace " + std::to_string(k + 1) + ")" : "";
    if (traces > 1)
      h += "<h3>Trace " + std::to_string(k + 1) + ": <code>" + Escape(ft.path) + "</code></h3>\n";
    const std::optional<std::pair<double, double>> transient =
        FirstTransientWindow(problem, k, fit.simulated ? fit.traces[k] : measured);
    const std::pair<double, double> window = transient.value_or(std::make_pair(0.0, 0.0));
    std::size_t begin = 0, end = t.size();
    while (begin < t.size() && t[begin] < window.first) ++begin;
    end = begin;
    while (end < t.size() && t[end] <= window.second) ++end;
    for (int detail = 0; detail < (transient ? 2 : 1); ++detail) {
      h += "<div class=\"grid\">\n";
      for (const auto& column : problem.observe()) {
        const ColumnInfo info = DescribeColumn(column, model);
        const std::size_t b = detail ? begin : 0, e = detail ? end : t.size();
        std::vector<Series> series;
        series.push_back(Line("measured", Slice(t, b, e), Slice(measured.Column(column), b, e),
                              kMeasuredColour, "", 1.0));
        if (fit.simulated) {
          series.push_back(Line("simulated, fit", Slice(t, b, e),
                                Slice(fit.traces[k].Column(column), b, e), kFitColour, "", 1.6));
        }
        if (after && after->simulated) {
          series.push_back(Line("simulated, " + after_label, Slice(t, b, e),
                                Slice(after->traces[k].Column(column), b, e), kAfterColour,
                                kAfterDash, 1.6));
        }
        LinePlotOptions plot;
        plot.title = detail ? info.quantity + ": first transient" + trace_note
                            : info.quantity + ": measured and simulated" + trace_note;
        plot.x_label = "time";
        plot.x_unit = "s";
        plot.y_label = column;
        plot.y_unit = info.unit;
        plot.width = o.plot_width;
        plot.height = o.plot_height;
        plot.id_prefix = page.NextPrefix();
        const std::string caption = detail ? Escape(info.quantity) + " from " + G(window.first, 4) +
                                                 " s to " + G(window.second, 4) + " s (" +
                                                 std::to_string(end - begin) + " samples)."
                                           : Escape(info.quantity) + " over the whole trace (" +
                                                 std::to_string(t.size()) + " samples).";
        page.Figure(
            detail ? "detail" : "trace",
            " data-column=\"" + Escape(column) + "\" data-trace=\"" + std::to_string(k) + "\"",
            LinePlotSvg(plot, series), caption);
      }
      h += "</div>\n";
    }
    if (!transient) {
      h += "<p class=\"note\">No first-transient view" + trace_note +
           ": u has no step that holds for 20 samples with a response to it (a loop's "
           "output, a ramp or a chirp changes gradually; a fast PRBS does not hold).</p>\n";
    }
  }
  page.EndSection();
}

// Stems from zero with a marker at each value, offset along x by `shift` lags.
void AddStems(std::vector<Series>& series, const std::vector<double>& acf, double shift,
              const std::string& label, const char* colour, bool hollow) {
  Series stems = Line("", {}, {}, colour, "", 1.6);
  Series dots = Dots(label, colour, 3.0, hollow);
  for (std::size_t lag = 1; lag <= acf.size(); ++lag) {
    const double x = static_cast<double>(lag) + shift;
    const double y = std::isfinite(acf[lag - 1]) ? acf[lag - 1] : kNaN;
    stems.x.insert(stems.x.end(), {x, x, x});
    stems.y.insert(stems.y.end(), {0.0, y, kNaN});
    dots.x.push_back(x);
    dots.y.push_back(y);
  }
  series.push_back(std::move(stems));
  series.push_back(std::move(dots));
}

void Range(const std::vector<double>& v, double* lo, double* hi) {
  for (double x : v) {
    if (!std::isfinite(x)) continue;
    *lo = std::min(*lo, x);
    *hi = std::max(*hi, x);
  }
}

// The diagnostics of `column` in `analysis`, null when there are none.
const ColumnDiagnostics* FindColumn(const ResidualAnalysis* analysis, const std::string& column) {
  if (!analysis || !analysis->ok) return nullptr;
  for (const auto& c : analysis->columns) {
    if (c.column == column) return &c;
  }
  return nullptr;
}

void WriteResidual(Page& page, const IdentReport& report, const FitProblem& problem,
                   const ModelViews& fit, const ModelViews* after, const std::string& after_label) {
  const HtmlReportOptions& o = page.options();
  const std::string& model = report.model;
  const std::size_t traces = problem.traces().size();
  const bool show_after = after && after->simulated;
  page.Section("residual", "Residual");
  std::string& h = page.html();
  h += "<p class=\"note\">Residual = measured − simulated, in the column's unit. A model that "
       "explains the data leaves only noise: no visible pattern over time, and an autocorrelation "
       "inside the grey band (95 % of the lags of white noise fall in ±1.96/√n).";
  if (show_after) h += " The residual after discovery is drawn on the same scale as the fit's.";
  h += "</p>\n";
  if (fit.simulated) {
    for (std::size_t k = 0; k < traces; ++k) {
      const Trace& measured = problem.measured(k);
      const std::vector<double>& t = measured.Column("t");
      const std::string trace_note = traces > 1 ? " (trace " + std::to_string(k + 1) + ")" : "";
      std::vector<std::vector<double>> fit_residual, after_residual;
      std::vector<std::pair<double, double>> ranges;
      for (const auto& column : problem.observe()) {
        double lo = kInf, hi = -kInf;
        fit_residual.push_back(Difference(measured.Column(column), fit.traces[k].Column(column)));
        Range(fit_residual.back(), &lo, &hi);
        if (show_after) {
          after_residual.push_back(
              Difference(measured.Column(column), after->traces[k].Column(column)));
          Range(after_residual.back(), &lo, &hi);
        }
        const double pad = 0.05 * (hi - lo);
        ranges.emplace_back(lo - pad, hi + pad);
      }
      for (int which = 0; which < (show_after ? 2 : 1); ++which) {
        h += "<div class=\"grid\">\n";
        for (std::size_t c = 0; c < problem.observe().size(); ++c) {
          const std::string& column = problem.observe()[c];
          const ColumnInfo info = DescribeColumn(column, model);
          const bool is_after = which == 1;
          LinePlotOptions plot;
          plot.title =
              info.quantity + ": residual, " + (is_after ? "after discovery" : "fit") + trace_note;
          plot.x_label = "time";
          plot.x_unit = "s";
          plot.y_label = column + " measured − simulated";
          plot.y_unit = info.unit;
          plot.y_min = ranges[c].first;
          plot.y_max = ranges[c].second;
          plot.width = o.plot_width;
          plot.height = o.plot_height;
          plot.id_prefix = page.NextPrefix();
          plot.bands.push_back({"", false, 0.0, 0.0, "#444444", 1.0, ""});
          const std::vector<Series> series = {
              Line(is_after ? "residual, " + after_label : "residual, fit", t,
                   is_after ? after_residual[c] : fit_residual[c],
                   is_after ? kAfterColour : kFitColour, "", 1.0)};
          page.Figure("residual",
                      " data-column=\"" + Escape(column) + "\" data-trace=\"" + std::to_string(k) +
                          "\" data-model=\"" + (is_after ? "after" : "fit") + "\"",
                      LinePlotSvg(plot, series),
                      "Residual of " + Escape(info.quantity) + " over time, " +
                          (is_after ? "model " + Escape(after_label) : std::string("the fit")) +
                          ".");
        }
        h += "</div>\n";
      }
    }
  }
  const ResidualReport& first_residual = report.first_fit().residual;
  const ResidualAnalysis* columns = first_residual.analysis ? &*first_residual.analysis : nullptr;
  const ResidualAnalysis* after_columns = report.discovery && report.discovery->residual_after.ok
                                              ? &report.discovery->residual_after
                                              : nullptr;
  const bool show_after_acf = show_after && after_columns;
  h += "<div class=\"grid\">\n";
  for (const auto& column : problem.observe()) {
    const ColumnDiagnostics* c = FindColumn(columns, column);
    if (!c || c->acf.empty()) continue;
    const std::vector<double>& acf = c->acf;
    const ColumnInfo info = DescribeColumn(column, model);
    std::vector<Series> series;
    AddStems(series, acf, show_after_acf ? -0.17 : 0.0, "fit", kFitColour, false);
    const ColumnDiagnostics* c_after = FindColumn(after_columns, column);
    if (show_after_acf && c_after) {
      AddStems(series, c_after->acf, 0.17, after_label, kAfterColour, true);
    }
    LinePlotOptions plot;
    plot.title = info.quantity + ": autocorrelation of the residual";
    plot.x_label = "lag";
    plot.x_unit = "samples";
    plot.y_label = "autocorrelation";
    plot.x_min = 0.4;
    plot.x_max = static_cast<double>(acf.size()) + 0.6;
    plot.width = o.plot_width;
    plot.height = o.plot_height;
    plot.id_prefix = page.NextPrefix();
    const double band = std::isfinite(c->acf_band95) ? c->acf_band95 : kNaN;
    plot.bands.push_back({"95 % band of white noise", false, -band, band, kBandColour, 0.22, ""});
    plot.bands.push_back({"", false, 0.0, 0.0, "#444444", 1.0, ""});
    std::string caption = "Autocorrelation of the " + Escape(info.quantity) +
                          " residual at lags 1…" + std::to_string(acf.size()) + "; band ±" +
                          G(band, 3) + ". Ljung-Box p = " + G(c->whiteness_p, 3);
    if (show_after_acf)
      caption += ", after discovery p = " + (c_after ? G(c_after->whiteness_p, 3) : "n/a");
    page.Figure("acf", " data-column=\"" + Escape(column) + "\"", LinePlotSvg(plot, series),
                caption + ".");
  }
  h += "</div>\n";
  page.EndSection();
}

void WriteSlices(Page& page, const ModelViews& views,
                 const std::map<std::string, std::pair<double, double>>& intervals,
                 const std::string& model_tag, const std::string& model_label, const char* colour) {
  const HtmlReportOptions& o = page.options();
  if (!views.sliced) return;
  const std::vector<CostSlice>& slices = views.slices;
  std::string& h = page.html();
  h += "<h3>" + Escape(model_label) + "</h3>\n<div class=\"grid\">\n";
  for (const auto& slice : slices) {
    const std::string& unit = slice.unit;
    std::vector<Series> series;
    Series curve = Line("cost", slice.x, slice.cost, colour, "", 1.6);
    curve.marker_radius = 2.2;
    series.push_back(std::move(curve));
    LinePlotOptions plot;
    plot.title = "cost along " + slice.parameter + " (" + model_tag + ")";
    plot.x_label = slice.parameter;
    plot.x_unit = unit;
    plot.y_label = "cost";
    plot.y_unit = "normalised MSE";
    plot.x_log = slice.log_scale;
    plot.y_log = true;
    plot.width = o.plot_width;
    plot.height = o.plot_height;
    plot.id_prefix = page.NextPrefix();
    const auto ci = intervals.find(slice.parameter);
    if (ci != intervals.end() && std::isfinite(ci->second.first) &&
        std::isfinite(ci->second.second)) {
      plot.bands.push_back(
          {"95 % interval", true, ci->second.first, ci->second.second, kBandColour, 0.3, ""});
    }
    plot.bands.push_back({"estimate", true, slice.estimate, slice.estimate, "#222222", 1.0, "5 3"});
    std::string caption = "Cost along " + Escape(slice.parameter) +
                          " with the other parameters held, " + std::to_string(slice.x.size()) +
                          " points from " + G(slice.x.front(), 4) + " to " + G(slice.x.back(), 4) +
                          (unit.empty() ? "" : " " + Escape(unit)) + "; estimate " +
                          G(slice.estimate, 5) + ".";
    if (!slice.cost.empty() && std::isfinite(slice.cost[slice.argmin]) &&
        slice.argmin != slice.centre) {
      caption += " The lowest point of the slice is at " + G(slice.x[slice.argmin], 5) +
                 ", not at the estimate.";
    }
    page.Figure("slice",
                " data-parameter=\"" + Escape(slice.parameter) + "\" data-model=\"" + model_tag +
                    "\" data-points=\"" + std::to_string(slice.x.size()) + "\" data-centre=\"" +
                    std::to_string(slice.centre) + "\" data-argmin=\"" +
                    std::to_string(slice.argmin) + "\"",
                LinePlotSvg(plot, series), caption);
  }
  h += "</div>\n";
}

// The final model's adequacy (docs/discovery.md §7): what the residual still depends on,
// with the residual's mean against each flagged state, and the effects' stability.
void WriteAdequacy(Page& page, const DiscoveryReport& discovery, const std::string& model) {
  if (!discovery.has_adequacy) return;
  const AdequacyReport& a = discovery.adequacy;
  std::string& h = page.html();
  h += "<h3 id=\"adequacy\">Is the final model adequate?</h3>\n";
  if (!a.ok) {
    h += "<p>The check could not run: " + Escape(a.reason) + "</p>\n";
    return;
  }
  h += "<p class=\"adequacy\" data-adequate=\"" + std::string(a.adequate() ? "true" : "false") +
       "\">" +
       (a.flagged.empty()
            ? "No structure explaining " + G(100.0 * a.min_share, 2) +
                  " % or more of the residual's variance depends on θ, w, sign(w), u or t "
                  "(family-wise level " +
                  G(a.family_level, 2) + ")."
            : "<b>" + Escape(a.StructureMessage()) + "</b>.") +
       "</p>\n";
  if (!a.flagged.empty()) {
    h += "<div class=\"grid\">\n";
    for (const StructureTest& test : a.flagged) {
      if (test.bin_x.empty()) continue;
      const ColumnInfo info = DescribeColumn(test.column, model);
      LinePlotOptions plot;
      plot.title = info.quantity + ": residual against " + test.Describe();
      plot.x_label = test.x_label;
      plot.x_unit = test.x_unit;
      const bool past = test.state == "u (past)";
      plot.y_label = past ? "correlation of the whitened residual and input"
                          : "mean of " + test.column + " measured − simulated";
      plot.y_unit = past ? "" : info.unit;
      plot.width = page.options().plot_width;
      plot.height = page.options().plot_height;
      plot.id_prefix = page.NextPrefix();
      plot.bands.push_back({"", false, 0.0, 0.0, "#444444", 1.0, ""});
      if (past) {  // the 95 % band of a correlation with no dependence
        plot.bands.push_back({"95 % band", false, -test.band95, test.band95, "#999999", 0.25, ""});
      }
      Series means = Line(past ? "correlation per lag" : "residual mean per bin", test.bin_x,
                          test.bin_mean, kAfterColour, "", 1.5);
      means.marker_radius = 3.0;
      page.Figure(
          "adequacy",
          " data-column=\"" + Escape(test.column) + "\" data-state=\"" + Escape(test.state) + "\"",
          LinePlotSvg(plot, {means}),
          (past ? "Correlation of the whitened residual of " + Escape(info.quantity) +
                      " with the whitened input at each lag (grey: the 95 % band with no "
                      "dependence): the response to the input's past makes up " +
                      G(100.0 * test.share, 3) +
                      " % of the residual's variance (p = " + G(test.p_value, 2) + ")."
                : "Mean residual of " + Escape(info.quantity) + " in bins of " +
                      Escape(test.x_label) + ": it explains " + G(100.0 * test.share, 3) +
                      " % of the residual's variance (p = " + G(test.p_value, 2) + ")."));
    }
    h += "</div>\n";
  }
  h +=
      "<details><summary>Every test of the residual</summary>\n<table class=\"adequacy-tests\">\n" +
      HeaderRow({"column", "state", "share of variance", "p (family-wise)", "AR order", "flagged"});
  for (const StructureTest& test : a.tests) {
    h += Row({Escape(test.column), Escape(test.Describe()), G(100.0 * test.share, 3) + " %",
              G(test.p_value, 3), std::to_string(test.ar_order), test.flagged ? "yes" : "no"},
             "", {false, false, true, true, true, false});
  }
  h += "</table>\n</details>\n";
  if (a.stability_checked) {
    h += "<p>Effects across " + Escape(a.parts) + ": " +
         (a.unstable.empty() ? std::string("stable")
                             : "<b>unstable: " + Escape(Join(a.unstable)) + "</b>") +
         "</p>\n<table class=\"stability\">\n" +
         HeaderRow({"effect", "parameter", "first part", "second part", "z", "limit"});
    for (const EffectStability& s : a.stability) {
      h += Row({Escape(s.effect), Escape(s.parameter), G(s.first, 4), G(s.second, 4), G(s.z, 3),
                G(s.limit, 3)},
               s.unstable ? " class=\"unstable\"" : "", {false, false, true, true, true, true});
    }
    h += "</table>\n";
  }
}

void WriteDiscovery(Page& page, const DiscoveryReport& discovery, const std::string& model) {
  std::string& h = page.html();
  page.Section("discovery", "Discovery");
  h += "<p><b>Conclusion:</b> " + Escape(discovery.conclusion) + "</p>\n";
  const ErrorFigures& before = discovery.error_before;
  const ErrorFigures& after = discovery.error_after;
  h += "<table class=\"errors\">\n" + HeaderRow({"error", "before", "after"});
  h += Row({"NRMSE", Nrmse(before), Nrmse(after)}, "", {false, true, true});
  if (before.ok) {
    const std::map<std::string, double> after_rmse = RmseByColumn(after);
    for (const auto& [column, value] : RmseByColumn(before)) {
      const auto found = after_rmse.find(column);
      h += Row({"RMSE " + Escape(column), G(value, 4),
                found == after_rmse.end() ? std::string("n/a") : G(found->second, 4)},
               "", {false, true, true});
    }
  }
  h += "</table>\n";
  const std::vector<DiscoveryStep>& steps = discovery.steps;
  if (!steps.empty()) {
    h += "<table class=\"steps\">\n" +
         HeaderRow({"step", "effect added", "parameters (95 % interval)", "NRMSE before → after",
                    "ΔBIC", "evidence"});
    for (std::size_t k = 0; k < steps.size(); ++k) {
      const DiscoveryStep& step = steps[k];
      std::string parameters;
      for (const StepParameter& p : StepParameters(step)) {
        if (!parameters.empty()) parameters += "<br>";
        parameters += Escape(p.name) + " = " + G(p.value, 5);
        if (p.fitted && p.fitted->has_interval)
          parameters += " " + Interval(p.fitted->ci95_low, p.fitted->ci95_high, 4);
      }
      h += Row({std::to_string(k + 1), "<b>" + Escape(step.effect) + "</b>", parameters,
                G(step.nrmse_before, 4) + " → " + G(step.nrmse_after, 4),
                G(step.bic_after - step.bic_before, 4), Escape(step.evidence)},
               " class=\"discovery-step\"", {true, false, false, true, true, false});
    }
    h += "</table>\n";
  }
  auto candidates_table = [&](const std::vector<CandidateOutcome>& candidates,
                              const std::string& title) {
    if (candidates.empty()) return;
    h += "<details><summary>" + Escape(title) + "</summary>\n<table class=\"candidates\">\n" +
         HeaderRow({"candidate", "fitted", "valid", "ΔBIC", "NRMSE", "parameters", "reason"});
    for (const auto& c : candidates) {
      std::string parameters;
      if (c.fitted) {
        for (const auto& [name, value] : c.parameters) {
          parameters += (parameters.empty() ? "" : ", ") + Escape(name) + " = " + G(value, 4);
        }
      }
      h += Row({Escape(c.effect), c.fitted ? "yes" : "no", c.valid ? "yes" : "no",
                c.fitted ? G(c.delta_bic, 4) : "—", c.fitted ? G(c.nrmse, 4) : "—", parameters,
                Escape(c.reason)},
               "", {false, false, false, true, true, false, false});
    }
    h += "</table>\n</details>\n";
  };
  for (std::size_t k = 0; k < steps.size(); ++k) {
    candidates_table(steps[k].candidates, "Candidates of step " + std::to_string(k + 1));
  }
  candidates_table(discovery.last_round, "Candidates of the last round (nothing added)");
  WriteAdequacy(page, discovery, model);
  page.EndSection();
}

void WriteMethod(Page& page, const ModelReport& model) {
  std::string& h = page.html();
  page.Section("method", "Method summary");
  const OptimizerSummary& s = model.summary;
  h += "<table class=\"meta method\">\n";
  auto row = [&](const std::string& key, const std::string& value) {
    h += "<tr><th>" + key + "</th><td>" + Escape(value) + "</td></tr>\n";
  };
  row("method", s.method);
  row("algorithm", s.algorithm);
  row("converged", s.converged ? "true" : "false");
  row("termination", s.termination);
  row("message", s.message);
  row("raw_code", std::to_string(s.raw_code));
  row("evaluations", std::to_string(s.evaluations));
  row("failed_evaluations", std::to_string(s.failed_evaluations));
  row("iterations", std::to_string(s.iterations));
  row("wall_time_s", G(s.wall_time_s, 4) + " s");
  row("seed", std::to_string(model.seed));
  row("threads", std::to_string(model.threads));
  if (!s.failure_reasons.empty()) row("failure_reasons", json(s.failure_reasons).dump());
  const json details = MethodDetailsJson(s);
  for (const auto& [key, value] : details.items()) row("details." + Escape(key), Text(value));
  h += "</table>\n";
  page.EndSection();
}

void WriteValidation(Page& page, const ValidationReport& validation) {
  std::string& h = page.html();
  page.Section("validation", "Validation on held-out traces");
  h += "<table>\n" + HeaderRow({"held-out trace(s)", "NRMSE", "RMSE"});
  std::string paths, rmse;
  for (const auto& p : validation.traces) paths += (paths.empty() ? "" : "<br>") + Escape(p);
  if (validation.errors.ok) {
    for (const auto& [column, value] : RmseByColumn(validation.errors)) {
      rmse += (rmse.empty() ? "" : ", ") + Escape(column) + " " + G(value, 4);
    }
  }
  h += Row({paths, Nrmse(validation.errors), rmse}, "", {false, true, false});
  h += "</table>\n";
  page.EndSection();
}

}  // namespace

std::string MakeHtmlReport(const HtmlReportInputs& inputs, const HtmlReportOptions& options) {
  if (!inputs.report || !inputs.problem || !inputs.views) {
    throw std::invalid_argument("MakeHtmlReport: report, problem and views are required");
  }
  const IdentReport& report = *inputs.report;
  const FitProblem& problem = *inputs.problem;
  const PageViews& views = *inputs.views;
  const std::string date = options.date.empty() ? NowUtc() : options.date;
  const ModelViews& fit = views.fit;
  const ModelViews* after_ptr = views.after ? &*views.after : nullptr;
  const std::string& after_label = views.after_label;

  Page page(options);
  std::string& h = page.html();
  const std::string& name = report.config_name;
  h += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
       "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
       "<meta name=\"generator\" content=\"blmd-ident " +
       Escape(kVersion) + "\">\n<title>blmd-ident: " + Escape(name) + "</title>\n<style>" + kStyle +
       "</style>\n</head>\n<body>\n";
  WriteHeader(page, report, problem, date);
  WriteKeyFigures(page, report);
  WriteParameters(page, report, problem);
  WriteTraces(page, report, problem, fit, after_ptr, after_label);
  WriteResidual(page, report, problem, fit, after_ptr, after_label);

  page.Section("slices", "Cost along each parameter");
  h += "<p class=\"note\">The cost (normalised MSE, the quantity the fit minimises) along one free "
       "parameter at a time, the others held at their estimates, over ±" +
       G(100 * views.slice_span, 3) +
       " % around the estimate (dashed line). A sharp, centred "
       "valley means a well-determined parameter; a flat one, a poorly determined one. The shaded "
       "band is the 95 % interval.</p>\n";
  std::map<std::string, std::pair<double, double>> fit_intervals, after_intervals;
  for (const auto& [pname, p] : report.first_fit().parameters) {
    if (p.free && p.estimate.has_interval)
      fit_intervals[pname] = {p.estimate.ci95_low, p.estimate.ci95_high};
  }
  if (report.discovery) {
    for (const auto& e : report.discovery->parameters_after) {
      if (e.has_interval) after_intervals[e.name] = {e.ci95_low, e.ci95_high};
    }
  }
  WriteSlices(page, fit, fit_intervals, "fit", after_ptr ? "Fit (the config's model)" : "Fit",
              kFitColour);
  if (after_ptr) {
    WriteSlices(page, *after_ptr, after_intervals, "after", "Model " + after_label, kAfterColour);
  }
  page.EndSection();

  internal::WriteFrequencyResponse(page, report);
  internal::WriteStepResponse(page, report);
  if (report.discovery) WriteDiscovery(page, *report.discovery, report.model);
  if (report.final_model.validation) WriteValidation(page, *report.final_model.validation);
  WriteMethod(page, report.final_model);
  h += "<footer>Written by blmd-ident " + Escape(kVersion) + " on " + Escape(date) +
       ". One self-contained file: inline SVG and CSS, no scripts, nothing fetched. "
       "The numbers come from the JSON report of the same run (<code>--report</code>).</footer>\n"
       "</body>\n</html>\n";
  return h;
}

void WriteHtmlReport(const std::string& path, const HtmlReportInputs& inputs,
                     const HtmlReportOptions& options) {
  WriteFileAtomically(path, MakeHtmlReport(inputs, options));
}

}  // namespace blmd
