// The linear views of the HTML report (docs/report.md): the correlation of the estimates, the
// empirical frequency response against the model's Bode plot, and the model's step response.
// Rendering only: every number was computed when the report was built (report/linear_views.h,
// ident/uncertainty/parameter_correlation.h).
#include <algorithm>
#include <cmath>

#include "blmd/report/svg/plot.h"
#include "report/html/html_page.h"

namespace blmd::internal {
namespace {

constexpr const char* kMeasuredDots = "#222222";  // reliable empirical points
constexpr const char* kLowDots = "#9a9a9a";       // low coherence: grey rings

// The background of a correlation cell: white at 0, towards the Okabe-Ito vermilion for
// positive and blue for negative values (|rho| = 1: the full colour).
std::string RhoColour(double rho) {
  const double a = std::clamp(std::abs(rho), 0.0, 1.0);
  const int target[2][3] = {{0xd5, 0x5e, 0x00}, {0x00, 0x72, 0xb2}};
  const int* c = target[rho < 0 ? 1 : 0];
  char buffer[8];
  std::snprintf(buffer, sizeof buffer, "#%02x%02x%02x",
                static_cast<int>(std::lround(255 - a * (255 - c[0]))),
                static_cast<int>(std::lround(255 - a * (255 - c[1]))),
                static_cast<int>(std::lround(255 - a * (255 - c[2]))));
  return buffer;
}

Series Points(std::string label, const char* colour, bool hollow) {
  Series series;
  series.label = std::move(label);
  series.colour = colour;
  series.line_width = 0.0;
  series.marker_radius = 2.6;
  series.hollow_markers = hollow;
  return series;
}

Series Curve(std::string label, std::vector<double> x, std::vector<double> y) {
  Series series;
  series.label = std::move(label);
  series.x = std::move(x);
  series.y = std::move(y);
  series.colour = kFitColour;
  series.line_width = 1.8;
  return series;
}

LinePlotOptions LogFrequencyPlot(const Page& page, const std::string& title,
                                 const std::string& y_label, const std::string& y_unit) {
  LinePlotOptions plot;
  plot.title = title;
  plot.x_label = "frequency";
  plot.x_unit = "Hz";
  plot.x_log = true;
  plot.y_label = y_label;
  plot.y_unit = y_unit;
  plot.width = page.options().plot_width;
  plot.height = page.options().plot_height;
  plot.id_prefix = page.NextPrefix();
  return plot;
}

// One Bode plot (magnitude or phase) of an output: the model's curve, the empirical points
// (reliable ones dark, low-coherence ones as grey rings).
std::string BodePlot(const Page& page, const FrequencyResponseOutput& o, bool phase,
                     const std::string& title) {
  LinePlotOptions plot =
      LogFrequencyPlot(page, title, phase ? "phase" : "magnitude", phase ? "deg" : "dB");
  const std::vector<double>& model = phase ? o.model_curve.phase_deg : o.model_curve.magnitude_db;
  const std::vector<double>& measured = phase ? o.empirical_phase_deg : o.empirical_mag_db;
  std::vector<Series> series = {
      Curve("model: linear part (nonlinear effects left out)", o.model_curve.f_hz, model),
      Points("measured H1", kMeasuredDots, false),
      Points("measured, low coherence", kLowDots, true)};
  for (std::size_t k = 0; k < o.f_hz.size(); ++k) {
    Series& s = series[o.low_coherence[k] ? 2 : 1];
    s.x.push_back(o.f_hz[k]);
    s.y.push_back(measured[k]);
  }
  if (series[2].x.empty()) series.pop_back();
  if (series[1].x.empty()) series.erase(series.begin() + 1);
  return LinePlotSvg(plot, series);
}

std::string CoherencePlot(const Page& page, const FrequencyResponseOutput& o, double threshold,
                          const std::string& title) {
  LinePlotOptions plot = LogFrequencyPlot(page, title, "coherence", "γ²");
  plot.y_min = 0.0;
  plot.y_max = 1.05;
  plot.bands.push_back(
      {"threshold " + G(threshold, 2), false, threshold, threshold, "#444444", 1.0, "5 3"});
  Series line = Curve("coherence", o.f_hz, o.coherence);
  line.line_width = 1.2;
  line.marker_radius = 2.0;
  return LinePlotSvg(plot, {line});
}

std::string Count(std::size_t n, const std::string& what) {
  return std::to_string(n) + " " + what + (n == 1 ? "" : "s");
}

}  // namespace

void WriteCorrelation(Page& page, const ParameterCorrelation& c) {
  std::string& h = page.html();
  h += "<h3>Correlation of the estimates</h3>\n";
  if (!c.available) {
    h += "<p class=\"note\">No correlation matrix: " + Escape(c.reason) + ".</p>\n";
    return;
  }
  std::vector<std::string> head = {"ρ"};
  head.insert(head.end(), c.names.begin(), c.names.end());
  h += "<table class=\"correlation\" data-method=\"" + Escape(c.method) + "\">\n" + HeaderRow(head);
  bool poor = false;
  for (std::size_t j = 0; j < c.names.size(); ++j) {
    h += "<tr data-row=\"" + Escape(c.names[j]) + "\"><th>" + Escape(c.names[j]) + "</th>";
    for (std::size_t k = 0; k < c.names.size(); ++k) {
      const double rho = c.correlation(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(k));
      const bool marked = j != k && std::abs(rho) > kPoorlySeparableCorrelation;
      poor = poor || marked;
      // The diagonal (1 by definition) neutral; the others coloured by ρ.
      const std::string style = j == k ? "background:#eeeeee"
                                : std::abs(rho) > 0.6
                                    ? "background:" + RhoColour(rho) + ";color:#fff"
                                    : "background:" + RhoColour(rho);
      h += "<td class=\"num rho" + std::string(marked ? " poor" : "") + "\" data-rho=\"" +
           G(rho, 6) + "\" style=\"" + style + "\">" +
           (marked ? "<b>" + G(rho, 3) + " !</b>" : G(rho, 3)) + "</td>";
    }
    h += "</tr>\n";
  }
  h += "</table>\n<p class=\"note\">ρ = cov/(σσ) of the covariance the intervals come from "
       "(the prewhitened HAC sandwich at the estimate; the same for the physical parameters). "
       "Vermilion: positive, blue: negative, the stronger the larger |ρ|.";
  if (poor) {
    h += " <b>|ρ| &gt; " + G(kPoorlySeparableCorrelation, 2) +
         " (marked !): these traces determine a combination of the two far better than "
         "either; the intervals allow for it, and an input with other excitation (another "
         "amplitude, frequency or direction) separates them.</b>";
  }
  h += "</p>\n";
}

void WriteFrequencyResponse(Page& page, const IdentReport& report) {
  if (!report.frequency_response) return;
  const FrequencyResponseReport& r = *report.frequency_response;
  std::string& h = page.html();
  page.Section("frequency-response", "Frequency response");
  if (!r.available) {
    h += "<p class=\"note\">No empirical frequency response: " + Escape(r.reason) + ".</p>\n";
    page.EndSection();
    return;
  }
  if (!r.caveat.empty())
    h += "<p class=\"note\"><strong>Caveat:</strong> " + Escape(r.caveat) + ".</p>\n";
  std::size_t points = r.outputs.empty() ? 0 : r.outputs.front().f_hz.size();
  h += "<p class=\"note\">Measured: H1 = P<sub>uy</sub>/P<sub>uu</sub> from the recorded input u "
       "to each output, Welch's averaged spectra over " +
       Count(r.averages, "segment") + " of " + std::to_string(r.segment_length) + " samples (" +
       G(r.equivalent_averages, 3) +
       " independent averages; Hann window, 50 % overlap, each segment's line removed), "
       "resolution " +
       G(r.resolution_hz, 3) + " Hz, at the " + std::to_string(points) +
       " frequencies where u has power (" + std::to_string(r.bins_with_content) + " of " +
       std::to_string(r.bins) +
       " bins; above the resolution averaged in bands of 1/100 decade). Grey rings: "
       "coherence γ² below " +
       G(r.coherence_threshold, 2) +
       " (noise, a nonlinearity, or too little input there), not to be trusted. Blue: " +
       Escape(r.note) + ".</p>\n";
  for (const FrequencyResponseOutput& o : r.outputs) {
    const ColumnInfo info = DescribeColumn(o.output, report.model);
    const std::size_t low =
        static_cast<std::size_t>(std::count(o.low_coherence.begin(), o.low_coherence.end(), true));
    const std::string name = o.output + " / u";
    const std::string attributes = " data-column=\"" + Escape(o.output) + "\" data-points=\"" +
                                   std::to_string(o.f_hz.size()) + "\" data-low=\"" +
                                   std::to_string(low) + "\"";
    const std::string points_note = std::to_string(o.f_hz.size()) + " measured points, " +
                                    std::to_string(low) + " of them with low coherence.";
    h += "<div class=\"grid\">\n";
    page.Figure("bode-magnitude", attributes, BodePlot(page, o, false, name + ": magnitude"),
                "Magnitude of " + Escape(info.quantity) + " per unit of u (dB of " +
                    Escape(info.unit) +
                    " per input unit): measured against the model's linear "
                    "part. " +
                    points_note);
    page.Figure("bode-phase", attributes, BodePlot(page, o, true, name + ": phase"),
                "Phase of " + Escape(info.quantity) +
                    " against u, the measured points on the "
                    "model's branch (within ±180° of it). " +
                    points_note);
    page.Figure("coherence", attributes,
                CoherencePlot(page, o, r.coherence_threshold, name + ": coherence"),
                "Coherence of " + Escape(info.quantity) +
                    " with u: 1 for a noise-free linear "
                    "relation; the random error of |H1| is √(1 − γ²)/(|γ|·√(2·n<sub>d</sub>)) "
                    "(Bendat &amp; Piersol).");
    h += "</div>\n";
  }
  page.EndSection();
}

void WriteStepResponse(Page& page, const IdentReport& report) {
  if (!report.step_response) return;
  const StepResponseReport& r = *report.step_response;
  std::string& h = page.html();
  page.Section("step-response", "Step response of the identified model");
  if (!r.available) {
    h += "<p class=\"note\">No step response: " + Escape(r.reason) + ".</p>\n";
    page.EndSection();
    return;
  }
  const StepResponse& s = r.response;
  const std::string input_unit = DescribeColumn("u", report.model).unit;
  h += "<p class=\"note\">The final model's linear part (effects left out) after a step of 1 " +
       Escape(input_unit) + " in u at t = 0, from rest; exact (zero-order-hold discretisation, " +
       G(s.dt_s, 3) + " s steps over " + G(s.duration_s, 3) +
       " s, eight times the slowest time constant). Rise time: 10 % to 90 % of the final value; "
       "settling: the last time outside ±2 % of it.</p>\n";
  h += "<table class=\"step\">\n" + HeaderRow({"output", "final value", "rise time 10–90 %",
                                               "overshoot", "settling time (2 %)", "peak"});
  for (std::size_t k = 0; k < r.outputs.size(); ++k) {
    const StepFigures& f = s.figures[k];
    const ColumnInfo info = DescribeColumn(r.outputs[k], report.model);
    const std::string per = Escape(info.unit + " per " + input_unit);
    if (!f.ok) {
      h += Row({Escape(r.outputs[k]), "—", Escape(f.reason), "", "", ""},
               " class=\"step-output\" data-column=\"" + Escape(r.outputs[k]) + "\"");
      continue;
    }
    h += Row({Escape(r.outputs[k]), G(f.final_value, 4) + " " + per, G(f.rise_time_s, 4) + " s",
              G(f.overshoot_percent, 3) + " %",
              std::isfinite(f.settling_time_s) ? G(f.settling_time_s, 4) + " s" : "not settled",
              G(f.peak_value, 4) + " at " + G(f.peak_time_s, 4) + " s"},
             " class=\"step-output\" data-column=\"" + Escape(r.outputs[k]) + "\"",
             {false, true, true, true, true, true});
  }
  h += "</table>\n<div class=\"grid\">\n";
  for (std::size_t k = 0; k < r.outputs.size(); ++k) {
    const StepFigures& f = s.figures[k];
    if (!f.ok) continue;
    const ColumnInfo info = DescribeColumn(r.outputs[k], report.model);
    LinePlotOptions plot;
    plot.title = info.quantity + ": step response of the model";
    plot.x_label = "time after the step";
    plot.x_unit = "s";
    plot.y_label = r.outputs[k];
    plot.y_unit = info.unit;
    plot.width = page.options().plot_width;
    plot.height = page.options().plot_height;
    plot.id_prefix = page.NextPrefix();
    const double band = 0.02 * std::abs(f.final_value);
    plot.bands.push_back({"final value ±2 %", false, f.final_value - band, f.final_value + band,
                          kBandColour, 0.3, ""});
    plot.bands.push_back(
        {"settled", true, f.settling_time_s, f.settling_time_s, "#222222", 1.0, "5 3"});
    plot.bands.push_back({"", false, 0.0, 0.0, "#444444", 1.0, ""});
    page.Figure("step", " data-column=\"" + Escape(r.outputs[k]) + "\"",
                LinePlotSvg(plot, {Curve("response to 1 " + input_unit, s.t_s, s.y[k])}),
                Escape(info.quantity) + " after a step of 1 " + Escape(input_unit) +
                    ": final value " + G(f.final_value, 4) + " " + Escape(info.unit) +
                    ", rise time " + G(f.rise_time_s, 3) + " s, overshoot " +
                    G(f.overshoot_percent, 3) + " %, settled (±2 %) after " +
                    (std::isfinite(f.settling_time_s) ? G(f.settling_time_s, 3) + " s"
                                                      : std::string("the window")) +
                    ".");
  }
  h += "</div>\n";
  page.EndSection();
}

}  // namespace blmd::internal
