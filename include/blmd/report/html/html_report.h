// The visual report of blmd-ident (`--html FILE.html`, docs/report.md): one self-contained
// HTML file, the pictures a person would rather look at than the JSON.
//
// The page holds, in this order: the header (model, config, method, traces, date, tool
// version); the key figures; the parameter table (initial value, estimate, standard
// deviation, 95 % interval, bounds, and the values after discovery); measured vs simulated
// for each observed column of each trace, with the fit's parameters and, when discovery
// ran, the final model's; a detail of the first transient of each; the residual over time
// (the fit's, and the final model's on the same scale); its autocorrelation with the 95 %
// band; the cost along each free parameter through the
// optimum (a 1-D slice, the others held); the empirical frequency response against the
// model's Bode plot and the model's step response (when the report has them: Identify's
// AddLinearViews); the discovery steps with the error before and after; the method's
// summary. The parameter table is followed by the correlation matrix of the estimates.
//
// Self-contained: inline SVG (LinePlotSvg, plot.h) and inline CSS, no script, no font,
// image or stylesheet fetched from anywhere. Enlarging a figure is CSS only (:target).
// Long traces are decimated per pixel column by LinePlotSvg, so the file size depends on the
// number of plots, not on the trace length (a 1e6-sample trace gives well under 2 MB).
//
// Elements that tests and readers can find:
//   figure.plot[data-kind]      one per plot: trace | detail | residual | acf | slice |
//                               bode-magnitude | bode-phase | coherence | step;
//                               data-column, data-trace (trace index) on plots of a column,
//                               data-model (fit | after) on residuals and slices,
//                               data-parameter, data-points, data-centre, data-argmin on slices,
//                               data-points, data-low (low-coherence points) on the Bode and
//                               coherence plots
//   table.correlation           the correlation matrix: tr[data-row] per parameter,
//                               td.rho[data-rho] per entry, td.poor where |rho| > 0.95
//   section#frequency-response, section#step-response (table.step, tr.step-output[data-column])
//   tr.parameter[data-name]     one row per parameter of the table
//   tr.discovery-step           one row per effect added by discovery
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "blmd/ident/fit/problem.h"
#include "blmd/report/report.h"

namespace blmd {

struct HtmlReportOptions {
  // Shown in the header. Empty: the current time, UTC ("2025-01-31 14:05 UTC").
  std::string date;
  // Cost slices: this many points per free parameter (odd, so the middle one is the
  // estimate), spread over +-slice_span around it: from x/(1+span) to x*(1+span) evenly in
  // log x for a log-scale parameter, x +- span*|x| for a linear one (+-span/10 of the
  // bounded range when x = 0); clipped to the bounds. 0 points: no slices.
  // (The points, the span and the threads are the analysis's, AnalysePage: the renderer
  // draws the slices it was given.)
  int slice_points = 41;
  double slice_span = 0.2;
  int threads = 0;  // slice evaluations run in parallel; 0: all cores
  // Size of each plot in px (its SVG scales with the page: two plots per row from about
  // 1100 px wide).
  int plot_width = 600, plot_height = 340;
};

// The cost along one free parameter with the others held at `values`.
struct CostSlice {
  std::string parameter;
  std::size_t index = 0;     // of the parameter in problem.free()
  double estimate = 0.0;     // values[index]
  std::vector<double> x;     // increasing, physical units
  std::vector<double> cost;  // problem.Evaluate's cost; +inf where the simulation failed
  std::size_t centre = 0;    // index of the estimate in x (when it lies in the bounds)
  std::size_t argmin = 0;    // index of the lowest finite cost
  bool log_scale = false;    // the parameter is searched on a log scale (its axis is)
  std::string unit;          // the parameter's unit in the config's model ("" when none)
};

// What the page shows of one model that the report does not hold, computed before the page is
// rendered (AnalysePage, app/page_analysis.h): the renderer simulates and evaluates nothing.
struct ModelViews {
  bool simulated = false;     // every trace simulated
  std::string reason;         // why not
  std::vector<Trace> traces;  // the model's simulation of each trace of the problem
  // Its cost along each free parameter (HtmlReportOptions); `sliced` false when none was asked
  // for (no slice points, or no free parameter).
  bool sliced = false;
  std::vector<CostSlice> slices;
};
struct PageViews {
  ModelViews fit;                   // the first fit
  std::optional<ModelViews> after;  // discovery's final model, when it added effects
  std::string after_label;          // "after discovery (+coulomb_friction)"
  double slice_span = 0.0;          // the slices' span around the estimate (their caption)
};

// What the page is built from: the typed report (with its discovery block when discovery
// ran), the problem of its first fit (the measured traces, observed columns and free
// parameters), and the views computed for it.
struct HtmlReportInputs {
  const IdentReport* report = nullptr;
  const FitProblem* problem = nullptr;
  const PageViews* views = nullptr;
};

// The time window [t_begin, t_end] of the first transient of trace k of `problem`, judged on
// `simulated` (its simulated trace). It starts where the input u first moves by more than
// 5 % of its range (at the trace's start when u is not near zero there, or never changes)
// and lasts twice the time the slowest observed column takes to cover 63.2 % of its change
// until u's next change (one time constant of a first-order response, so the window shows
// 86 % of it), with 5 % of that length before the start. At least 20 samples wide, inside
// the trace. None when there is no step there: u reaches the 5 % by a gradual change (more
// than half of the move made before its last sample, as under a feedback loop, a ramp or a
// chirp), u then holds for fewer than 20 samples, or no observed column responds.
std::optional<std::pair<double, double>> FirstTransientWindow(const FitProblem& problem,
                                                              std::size_t k,
                                                              const Trace& simulated);

// The HTML text. Throws std::invalid_argument when an input is null.
std::string MakeHtmlReport(const HtmlReportInputs& inputs, const HtmlReportOptions& options = {});

// MakeHtmlReport written atomically (WriteFileAtomically: complete or absent).
void WriteHtmlReport(const std::string& path, const HtmlReportInputs& inputs,
                     const HtmlReportOptions& options = {});

}  // namespace blmd
