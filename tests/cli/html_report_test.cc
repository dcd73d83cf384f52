// The HTML report (include/blmd/report/html/html_report.h, docs/report.md): its parts counted on
// real fits of the bundled traces, the cost slices against direct evaluations, the first
// transient window on a first-order response with a known time constant, and the size of
// the page for a 1e6-sample trace through the real blmd-ident --html.
#include "blmd/report/html/html_report.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include "blmd/app/page_analysis.h"
#include "blmd/ident/fit/trace_input.h"
#include "blmd/io/config.h"
#include "blmd/report/report.h"
#include "blmd/report/svg/plot.h"
#include "blmd/version.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

// The page as blmd-ident makes it: the analysis (simulations, cost slices), then the renderer.
std::string Page(const IdentReport& report, const FitProblem& problem, const FitResult& result,
                 const DiscoveryResult* discovery, const HtmlReportOptions& options) {
  const PageViews views = AnalysePage(problem, result, discovery, options);
  return MakeHtmlReport({&report, &problem, &views}, options);
}

std::size_t Count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos;
       at = text.find(what, at + what.size()))
    ++n;
  return n;
}

double kNaNForTests() { return std::numeric_limits<double>::quiet_NaN(); }

// The text of each <figure class="plot" ...>...</figure>.
std::vector<std::string> Figures(const std::string& html) {
  std::vector<std::string> figures;
  const std::string open = "<figure class=\"plot\"";
  for (std::size_t at = html.find(open); at != std::string::npos; at = html.find(open, at + 1)) {
    figures.push_back(html.substr(at, html.find("</figure>", at) - at));
  }
  return figures;
}

std::string Attribute(const std::string& element, const std::string& name) {
  const std::string key = name + "=\"";
  const std::size_t at = element.find(key);
  if (at == std::string::npos) return "";
  const std::size_t begin = at + key.size();
  return element.substr(begin, element.find('"', begin) - begin);
}

// Nothing that a browser would fetch or run: no script, no link, no external URL. The only
// "http" allowed is the SVG namespace, which is a name, not a fetch.
void ExpectSelfContained(const std::string& html) {
  EXPECT_EQ(Count(html, "<script"), 0u);
  EXPECT_EQ(Count(html, "<link"), 0u);
  EXPECT_EQ(Count(html, "<img"), 0u);
  EXPECT_EQ(Count(html, "@import"), 0u);
  EXPECT_EQ(Count(html, "url(http"), 0u);
  EXPECT_EQ(Count(html, "http"), Count(html, "xmlns=\"http://www.w3.org/2000/svg\""));
  const std::regex non_finite("\\b(nan|inf)\\b", std::regex::icase);
  EXPECT_FALSE(std::regex_search(html, non_finite));
}

// A fitted problem on a bundled trace.
struct Fitted {
  std::unique_ptr<FitProblem> problem;
  FitResult result;
  IdentReport report;
};

Fitted Fit(const std::string& config_name, const std::string& trace_name) {
  const Config config = LoadConfig(SourcePath("configs/" + config_name));
  TraceInputOptions input;
  input.required = config.identification.observe;
  std::vector<FitTrace> traces = {
      LoadFitTrace(SourcePath("testdata/" + trace_name), input, config.experiment.initial)};
  Fitted fitted;
  fitted.problem =
      std::make_unique<FitProblem>(config, std::move(traces), config.identification.observe,
                                   MakeFreeParameters(config, config.identification.free));
  OptimizerOptions options;
  options.threads = 2;
  fitted.result = FindOptimizer("ceres").Minimize(*fitted.problem, options);
  ReportInputs inputs;
  inputs.config_path = "configs/" + config_name;
  inputs.problem = fitted.problem.get();
  inputs.result = &fitted.result;
  fitted.report = MakeReport(inputs);
  return fitted;
}

const Fitted& NoloadFit() {
  static const Fitted fitted = Fit("ganesh-noload.json", "ganesh-noload-step.csv");
  return fitted;
}

// ---- the LinePlotSvg extensions the page uses (plot.h: Band, drawing inside an x range) ----

std::string PathData(const std::string& svg) {
  const std::size_t at = svg.find("<path class=\"curve\" d=\"");
  if (at == std::string::npos) return "";
  const std::size_t begin = at + 24;
  return svg.substr(begin, svg.find('"', begin) - begin);
}

TEST(LinePlotBands, DrawBandsAndLinesUnderTheSeriesAndWidenTheRange) {
  Series line{"data", {0, 1, 2, 3}, {0.1, 0.2, 0.3, 0.4}, "", "", 1.5, 0.0};
  LinePlotOptions options;
  options.bands.push_back({"95 % band", false, -2.0, 2.0, "#7f7f7f", 0.2, ""});
  options.bands.push_back({"estimate", true, 1.5, 1.5, "#222222", 1.0, "5 3"});
  options.bands.push_back({"", false, kNaNForTests(), 1.0, "#000000", 0.2, ""});  // not drawn
  const std::string svg = LinePlotSvg(options, {line});
  EXPECT_EQ(Count(svg, "class=\"band\""), 1u);
  EXPECT_EQ(Count(svg, "class=\"reference-line\""), 1u);
  EXPECT_EQ(Count(svg, "stroke-dasharray=\"5 3\""), 2u);  // the line and its legend symbol
  EXPECT_EQ(Count(svg, ">95 % band</text>"), 1u);
  EXPECT_EQ(Count(svg, ">estimate</text>"), 1u);
  EXPECT_EQ(Count(svg, ">-2</text>"), 1u);  // the y axis reaches down to the band's -2
  EXPECT_LT(svg.find("class=\"band\""), svg.find("class=\"series\""));  // under the data
  // Without bands the range is the data's: no tick at -2.
  EXPECT_EQ(Count(LinePlotSvg({}, {line}), ">-2</text>"), 0u);
}

TEST(LinePlotRange, DrawsOnlyTheSamplesInsideAGivenXRangeAndOneEachSide) {
  Series s{"long", {}, {}, "", "", 1.5, 0.0};
  for (int k = 0; k < 1000000; ++k) {
    s.x.push_back(k);
    s.y.push_back(std::sin(k * 1e-3));
  }
  LinePlotOptions options;
  options.x_min = 2000;
  options.x_max = 2999;  // 1000 samples, under 4 per pixel column: drawn in full
  const std::string d = PathData(LinePlotSvg(options, {s}));
  EXPECT_EQ(Count(d, ","), 1002u);  // 1000 inside, 1999 and 3000 beside
  EXPECT_LT(d.size(), 20000u);
}

TEST(CostSlices, PassThroughTheEstimateAndHaveTheirMinimumThere) {
  const Fitted& f = NoloadFit();
  ASSERT_TRUE(f.result.summary.converged);
  const std::vector<CostSlice> slices = ComputeCostSlices(*f.problem, f.result.values, 41, 0.2, 2);
  ASSERT_EQ(slices.size(), 2u);  // J, B
  const double cost_at_estimate = f.problem->Evaluate(f.result.values).cost;
  for (const CostSlice& s : slices) {
    SCOPED_TRACE(s.parameter);
    ASSERT_EQ(s.x.size(), 41u);
    ASSERT_EQ(s.cost.size(), 41u);
    EXPECT_EQ(s.centre, 20u);
    EXPECT_EQ(s.x[20], s.estimate);  // exactly the estimate, so exactly the fit's cost
    EXPECT_EQ(s.cost[20], cost_at_estimate);
    EXPECT_EQ(s.argmin, 20u);  // a converged fit: no lower point on a 1 % grid
    EXPECT_NEAR(s.x.front(), s.estimate / 1.2, 1e-12 * s.estimate);
    EXPECT_NEAR(s.x.back(), s.estimate * 1.2, 1e-12 * s.estimate);
    for (std::size_t m = 1; m < 41; ++m) {  // log spacing: a constant ratio
      EXPECT_NEAR(std::log(s.x[m] / s.x[m - 1]), std::log(1.44) / 40, 1e-9);
    }
    // Each point is the cost with only this parameter moved.
    std::vector<double> point = f.result.values;
    point[s.index] = s.x[7];
    EXPECT_EQ(s.cost[7], f.problem->Evaluate(point).cost);
    EXPECT_GT(s.cost.front(), s.cost[20]);
    EXPECT_GT(s.cost.back(), s.cost[20]);
  }
  // The thread count does not change a single bit.
  const std::vector<CostSlice> serial = ComputeCostSlices(*f.problem, f.result.values, 41, 0.2, 1);
  for (std::size_t k = 0; k < slices.size(); ++k) EXPECT_EQ(serial[k].cost, slices[k].cost);
}

TEST(CostSlices, AreClippedToTheBounds) {
  const Fitted& f = NoloadFit();
  std::vector<FreeParameter> free = f.problem->free();
  free[0].lower = f.result.values[0];  // J's lower bound at the estimate
  const FitProblem bounded(f.problem->config(), f.problem->traces(), f.problem->observe(), free);
  const std::vector<CostSlice> slices = ComputeCostSlices(bounded, f.result.values, 41, 0.2, 2);
  ASSERT_EQ(slices.size(), 2u);
  EXPECT_EQ(slices[0].x.front(), f.result.values[0]);
  EXPECT_EQ(slices[0].centre, 0u);
  EXPECT_NEAR(slices[0].x.back(), 1.2 * f.result.values[0], 1e-12);
  EXPECT_EQ(slices[1].centre, 20u);  // B untouched
}

// A trace whose "speed" is an exact first-order response 1 - exp(-(t - t0)/tau) to a step
// of u at t0: the window starts at t0 (less 5 % of its length) and lasts 2 tau.
TEST(FirstTransientWindow, LastsTwoTimeConstantsFromTheStep) {
  const Config config = LoadConfig(SourcePath("configs/ganesh-noload.json"));
  for (const double t0 : {0.0, 0.1}) {
    SCOPED_TRACE(t0);
    TempDir dir;
    const double tau = 0.05;
    std::string csv = "t,u,w\n";
    for (int k = 0; k <= 1000; ++k) {
      const double t = k * 1e-3;
      const bool on = k >= static_cast<int>(std::lround(t0 / 1e-3));
      char line[128];
      std::snprintf(line, sizeof line, "%.6f,%g,%.17g\n", t, on ? 1.0 : 0.0,
                    on ? 1.0 - std::exp(-(t - t0) / tau) : 0.0);
      csv += line;
    }
    TraceInputOptions input;
    input.required = {"w"};
    std::vector<FitTrace> traces = {LoadFitTrace(dir.Write("first-order.csv", csv), input, {})};
    const FitProblem problem(config, std::move(traces), {"w"},
                             MakeFreeParameters(config, {"J", "B"}));
    const auto window = FirstTransientWindow(problem, 0, problem.traces()[0].trace);
    ASSERT_TRUE(window.has_value());
    const auto [begin, end] = *window;
    // 63.2 % is first reached at the sample t0 + tau (1 - e^-1 = 0.63212 > 0.632).
    EXPECT_NEAR(end, t0 + 2 * tau, 1e-9);
    EXPECT_NEAR(begin, std::max(0.0, t0 - 0.05 * 2 * tau), 1e-9);
  }
}

// No step, no view: u that creeps over 5 % of its range (a loop's torque, a ramp: here
// u = t^2 from rest) or that steps but changes again within 20 samples. (Before, a 36 ms
// window was drawn over a closed-loop record's noisy torque, with no step in it.)
TEST(FirstTransientWindow, NoneWithoutAStepThatHolds) {
  const Config config = LoadConfig(SourcePath("configs/ganesh-noload.json"));
  const auto window = [&](const std::function<double(int)>& u) {
    TempDir dir;
    std::string csv = "t,u,w\n";
    double w = 0.0;
    for (int k = 0; k <= 1000; ++k) {
      char line[128];
      std::snprintf(line, sizeof line, "%.6f,%.17g,%.17g\n", k * 1e-3, u(k), w);
      csv += line;
      w += 0.05 * (u(k) - w);
    }
    TraceInputOptions input;
    input.required = {"w"};
    std::vector<FitTrace> traces = {LoadFitTrace(dir.Write("u.csv", csv), input, {})};
    const FitProblem problem(config, std::move(traces), {"w"},
                             MakeFreeParameters(config, {"J", "B"}));
    return FirstTransientWindow(problem, 0, problem.traces()[0].trace);
  };
  EXPECT_FALSE(window([](int k) { return 1e-6 * k * k; }).has_value());  // creeps
  EXPECT_FALSE(window([](int k) { return k >= 100 ? (k / 10) % 2 : 0.0; }).has_value());
  const auto step = window([](int k) { return k >= 100 ? 1.0 : 0.0; });  // a step that holds
  ASSERT_TRUE(step.has_value());
  EXPECT_NEAR(step->first, 0.1 - 0.05 * (step->second - 0.1) / 1.0, 1e-3);
}

TEST(HtmlReport, HasEveryPartOfAFitWithoutDiscovery) {
  const Fitted& f = NoloadFit();
  HtmlReportOptions options;
  options.date = "2001-02-03 04:05 UTC";
  options.threads = 2;
  const std::string html = Page(f.report, *f.problem, f.result, nullptr, options);
  ExpectSelfContained(html);
  // Header.
  EXPECT_EQ(Count(html, "<h1>blmd-ident report: ganesh-noload</h1>"), 1u);
  EXPECT_EQ(Count(html, "2001-02-03 04:05 UTC"), 2u);  // header and footer
  EXPECT_EQ(Count(html, "<code>dc_servo</code>"), 1u);
  EXPECT_EQ(Count(html, "<code>ceres</code>"), 1u);
  EXPECT_GE(Count(html, "ganesh-noload-step.csv</code>, 10001 samples"), 1u);
  EXPECT_EQ(Count(html, std::string("blmd-ident ") + std::string(kVersion)), 3u);
  // Parameter table: J and B, with initial values and intervals.
  EXPECT_EQ(Count(html, "<tr class=\"parameter\""), 2u);
  EXPECT_EQ(Count(html, "class=\"parameter\" data-name=\"J\""), 1u);
  EXPECT_EQ(Count(html, "class=\"parameter\" data-name=\"B\""), 1u);
  EXPECT_LT(html.find("class=\"parameter\" data-name=\"J\""),
            html.find("class=\"parameter\" data-name=\"B\""));  // the config's order
  // The headline: J and B with their intervals, first, before the figures of merit.
  EXPECT_EQ(Count(html, "class=\"card estimate\" data-name=\"J\""), 1u);
  EXPECT_EQ(Count(html, "class=\"card estimate\" data-name=\"B\""), 1u);
  EXPECT_LT(html.find("class=\"card estimate\" data-name=\"B\""), html.find("NRMSE of the fit"));
  EXPECT_EQ(Count(html, "before discovery"), 0u);
  EXPECT_EQ(Count(html, "<td class=\"num\">1e-5</td>"), 2u);  // both start at 1e-5
  // Plots: per observed column (i, w) the trace, its first transient, the residual and its
  // autocorrelation; one cost slice per free parameter (J, B). Each is one inline SVG.
  const std::vector<std::string> figures = Figures(html);
  ASSERT_EQ(figures.size(), 10u);
  EXPECT_EQ(Count(html, "<svg "), 10u);
  std::map<std::string, int> kinds;
  for (const auto& figure : figures) {
    ++kinds[Attribute(figure, "data-kind")];
    EXPECT_EQ(Count(figure, "<svg "), 1u);
    EXPECT_GE(Count(figure, "class=\"curve\""), 1u) << figure.substr(0, 200);
    EXPECT_EQ(Count(figure, "class=\"zoom\" href=\"#" + Attribute(figure, "id") + "\""), 1u);
    EXPECT_EQ(Count(figure, "class=\"axis-label\""), 2u);  // both axes labelled
  }
  EXPECT_EQ(kinds, (std::map<std::string, int>{
                       {"trace", 2}, {"detail", 2}, {"residual", 2}, {"acf", 2}, {"slice", 2}}));
  for (const auto& figure : figures) {
    const std::string kind = Attribute(figure, "data-kind");
    if (kind == "trace" || kind == "detail") {  // measured and simulated: two series
      EXPECT_EQ(Count(figure, "class=\"series\""), 2u);
      EXPECT_EQ(Count(figure, "data-series=\"2\""), 0u);
    }
    if (kind == "acf") {  // stems and dots of the fit, the 95 % band and the zero line
      EXPECT_EQ(Count(figure, "class=\"series\""), 2u);
      EXPECT_EQ(Count(figure, "class=\"band\""), 1u);
      EXPECT_EQ(Count(figure, "<circle cx="), 20u);  // lags 1..20
    }
    if (kind == "slice") {
      EXPECT_EQ(Attribute(figure, "data-points"), "41");
      EXPECT_EQ(Attribute(figure, "data-argmin"), "20");
      EXPECT_EQ(Attribute(figure, "data-model"), "fit");
      EXPECT_EQ(Count(figure, "<circle cx="), 41u);
      EXPECT_EQ(Count(figure, "class=\"band\""), 1u);            // the 95 % interval
      EXPECT_EQ(Count(figure, "class=\"reference-line\""), 1u);  // the estimate
    }
  }
  EXPECT_EQ(Count(html, "id=\"discovery\""), 0u);
  EXPECT_EQ(Count(html, "id=\"method\""), 1u);
  EXPECT_EQ(Count(html, "LEVENBERG_MARQUARDT"), 2u);  // header and method summary
  // Unique SVG ids on the page.
  std::set<std::string> ids;
  const std::regex id_pattern("id=\"([^\"]+)\"");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), id_pattern);
       it != std::sregex_iterator(); ++it) {
    EXPECT_TRUE(ids.insert((*it)[1]).second) << "duplicate id " << (*it)[1];
  }
}

TEST(HtmlReport, ShowsTheModelBeforeAndAfterDiscovery) {
  const Fitted f = Fit("ganesh-square.json", "dc-hidden-coulomb.csv");
  DiscoveryOptions options;
  options.candidates = {"coulomb_friction", "load_torque"};  // the answer and one rival: quick
  options.refit.threads = 2;
  const DiscoveryResult discovery = Discover(*f.problem, f.result, options);
  ASSERT_EQ(discovery.added, std::vector<std::string>{"coulomb_friction"});
  // The report as blmd-ident writes it: the final model as the headline (schema 2).
  const std::unique_ptr<FitProblem> final_problem = FinalProblem(*f.problem, discovery);
  ASSERT_TRUE(final_problem);
  ReportInputs final_inputs;
  final_inputs.config_path = "configs/ganesh-square.json";
  final_inputs.problem = final_problem.get();
  final_inputs.result = &discovery.final_fit;
  IdentReport report =
      FinalModelReport(MakeReport(final_inputs), f.report,
                       MakeDiscoveryReport(*f.problem, f.result, discovery, nullptr, nullptr));
  AddWarnings(&report);
  HtmlReportOptions html_options;
  html_options.threads = 2;
  const std::string html = Page(report, *f.problem, f.result, &discovery, html_options);
  ExpectSelfContained(html);
  // Parameters: J, B and the added Tc of the final model, the first fit's beside them.
  EXPECT_EQ(Count(html, "<tr class=\"parameter\""), 3u);
  EXPECT_EQ(Count(html, "class=\"parameter\" data-name=\"Tc\""), 1u);
  // The headline: J, B and the added Tc, each with its interval; the "before discovery" card.
  EXPECT_EQ(Count(html, "class=\"card estimate\" data-name=\"Tc\""), 1u);
  EXPECT_EQ(Count(html, "<div class=\"label\">before discovery</div>"), 1u);
  // The initial column is the user's start (the first fit's), not the round's: Tc, which
  // discovery added, has none.
  EXPECT_EQ(Count(html, "— (discovery)"), 1u);
  EXPECT_EQ(Count(html, "<th>before discovery</th>"), 1u);
  EXPECT_EQ(Count(html, "— (added by discovery)"), 1u);  // Tc had no value before
  EXPECT_EQ(Count(html, "NRMSE of the final model"), 1u);
  // The discovery section: one step, the error before -> after.
  EXPECT_EQ(Count(html, "id=\"discovery\""), 1u);
  EXPECT_EQ(Count(html, "<tr class=\"discovery-step\""), 1u);
  EXPECT_EQ(Count(html, "<b>coulomb_friction</b>"), 1u);
  // Plots: 8 for the two columns as before, 2 residuals after discovery, slices of the fit
  // (J, B) and after (J, B, Tc).
  const std::vector<std::string> figures = Figures(html);
  ASSERT_EQ(figures.size(), 15u);
  int after_residuals = 0;
  int after_slices = 0;
  for (const auto& figure : figures) {
    const std::string kind = Attribute(figure, "data-kind");
    if (kind == "trace" || kind == "detail") {  // measured, fit, after discovery
      EXPECT_EQ(Count(figure, "class=\"series\""), 3u);
      EXPECT_EQ(Count(figure, "stroke-dasharray=\"7 4\""), 2u);  // the after line and its legend
    }
    if (kind == "residual") {  // one model per plot, both on the same scale
      EXPECT_EQ(Count(figure, "class=\"series\""), 1u);
      after_residuals += Attribute(figure, "data-model") == "after";
    }
    if (kind == "acf") {  // 20 lags, before (dots) and after (rings)
      EXPECT_EQ(Count(figure, "<circle cx="), 40u);
      EXPECT_EQ(Count(figure, "fill=\"#ffffff\" stroke=\"#d55e00\""), 21u);  // and its legend
    }
    if (kind == "slice" && Attribute(figure, "data-model") == "after") {
      ++after_slices;
      EXPECT_EQ(Attribute(figure, "data-argmin"), Attribute(figure, "data-centre"))
          << Attribute(figure, "data-parameter");
    }
  }
  EXPECT_EQ(after_slices, 3);
  EXPECT_EQ(after_residuals, 2);
  // The adequacy check (docs/discovery.md §7): adequate, Tc stable across the halves.
  EXPECT_EQ(Count(html, "data-adequate=\"true\""), 1u);
  EXPECT_EQ(Count(html, "<table class=\"stability\">"), 1u);
  EXPECT_EQ(Count(html, "<td>Tc</td>"), 1u);
  // The first fit's residual, which still holds the friction, as the final model's: the
  // check names the structure, the page plots the residual against each flagged state and
  // lists the warning.
  report.discovery->adequacy = CheckResidualStructure(*f.problem, f.result.values);
  ASSERT_FALSE(report.discovery->adequacy.flagged.empty());
  AddWarnings(&report);
  const std::string flagged = Page(report, *f.problem, f.result, &discovery, html_options);
  ExpectSelfContained(flagged);
  EXPECT_EQ(Count(flagged, "data-adequate=\"false\""), 1u);
  std::size_t adequacy_plots = 0;
  for (const auto& figure : Figures(flagged))
    adequacy_plots += Attribute(figure, "data-kind") == "adequacy";
  EXPECT_EQ(adequacy_plots, report.discovery->adequacy.flagged.size());
  EXPECT_EQ(Count(html, "data-code=\"unexplained_structure\""), 0u);
  EXPECT_EQ(Count(flagged, "data-code=\"unexplained_structure\""), 1u);
}

// The linear views (docs/report.md): with Identify's AddLinearViews the page gains, per
// observed output, the Bode magnitude and phase (measured points against the model's curve)
// and the coherence, a step response per output with a final value, its table, and after the
// parameter table the correlation matrix; each drawn from the report's numbers.
TEST(HtmlReport, ShowsTheFrequencyResponseStepResponseAndCorrelation) {
  const Fitted f = Fit("ganesh-square.json", "dc-hidden-coulomb.csv");
  IdentReport report = f.report;
  AddLinearViews(&report, *f.problem, f.problem->config(), f.problem->Parameters(f.result.values));
  ASSERT_TRUE(report.frequency_response && report.frequency_response->available)
      << report.frequency_response->reason;
  ASSERT_TRUE(report.step_response && report.step_response->available);
  HtmlReportOptions options;
  options.threads = 2;
  const std::string html = Page(report, *f.problem, f.result, nullptr, options);
  ExpectSelfContained(html);
  EXPECT_EQ(Count(html, "<section id=\"frequency-response\">"), 1u);
  EXPECT_EQ(Count(html, "<section id=\"step-response\">"), 1u);
  const std::vector<std::string> figures = Figures(html);
  ASSERT_EQ(figures.size(), 18u);  // the 10 of a fit, 3 per output (i, w), 2 steps (i, w)
  std::map<std::string, int> kinds;
  for (const auto& figure : figures) ++kinds[Attribute(figure, "data-kind")];
  EXPECT_EQ(kinds["bode-magnitude"], 2);
  EXPECT_EQ(kinds["bode-phase"], 2);
  EXPECT_EQ(kinds["coherence"], 2);
  EXPECT_EQ(kinds["step"], 2);
  const FrequencyResponseReport& r = *report.frequency_response;
  for (const auto& figure : figures) {
    const std::string kind = Attribute(figure, "data-kind");
    if (kind != "bode-magnitude" && kind != "bode-phase" && kind != "coherence") continue;
    const std::string column = Attribute(figure, "data-column");
    const FrequencyResponseOutput* o = nullptr;
    for (const auto& candidate : r.outputs) o = candidate.output == column ? &candidate : o;
    ASSERT_NE(o, nullptr) << column;
    const std::size_t points = o->f_hz.size();
    std::size_t low = 0;
    for (bool b : o->low_coherence) low += b;
    EXPECT_EQ(Attribute(figure, "data-points"), std::to_string(points));
    EXPECT_EQ(Attribute(figure, "data-low"), std::to_string(low));
    EXPECT_EQ(Count(figure, "<svg "), 1u);
    EXPECT_EQ(Count(figure, "class=\"axis-label\""), 2u);
    EXPECT_EQ(Count(figure, ">frequency (Hz)</text>"), 1u);
    if (kind == "coherence") {  // one marker per point, and the threshold line
      EXPECT_EQ(Count(figure, "<circle cx="), points);
      EXPECT_EQ(Count(figure, "class=\"reference-line\""), 1u);
      continue;
    }
    // The model's curve, a dark dot per trusted point and a grey ring per low-coherence one
    // (each series also once in the legend).
    EXPECT_EQ(Count(figure, "class=\"curve\""), 1u);
    EXPECT_EQ(Count(figure, "<circle cx="), points);
    EXPECT_EQ(Count(figure, "fill=\"#ffffff\" stroke=\"#9a9a9a\""), low + (low > 0));
    EXPECT_EQ(Count(figure, "r=\"2.6\" fill=\"#222222\""), points - low + (points > low));
    EXPECT_EQ(Count(figure, "nonlinear effects left out"), 1u);  // said on the plot
  }
  // The step table: one row per output of the linear part; the angle integrates.
  EXPECT_EQ(Count(html, "<tr class=\"step-output\""), 3u);
  EXPECT_NE(html.find("integrating output"), std::string::npos);
  const StepFigures& w = report.step_response->response.figures[1];
  ASSERT_TRUE(w.ok);
  ASSERT_GT(w.rise_time_s, 1e-3);  // printed plainly, 3 significant digits, in the caption
  char rise[64];
  std::snprintf(rise, sizeof rise, "rise time %.3g s", w.rise_time_s);
  EXPECT_EQ(Count(html, rise), 1u);
  // The correlation matrix: J and B, unit diagonal, the report's off-diagonal value.
  const ParameterCorrelation& c = report.final_model.correlation;
  ASSERT_TRUE(c.available);
  EXPECT_EQ(Count(html, "<table class=\"correlation\""), 1u);
  EXPECT_EQ(Count(html, "<td class=\"num rho"), 4u);
  EXPECT_EQ(Count(html, "data-rho=\"1\""), 2u);
  char rho[32];
  std::snprintf(rho, sizeof rho, "data-rho=\"%.6g\"", c.correlation(0, 1));
  EXPECT_EQ(Count(html, rho), 2u);
  EXPECT_LT(html.find("<table class=\"correlation\""), html.find("<section id=\"traces\""));
}

// The real command on a 1e6-sample trace: the page stays small because every plot draws at
// most five samples per pixel column.
TEST(HtmlReportCli, MillionSampleTraceGivesAPageUnderTwoMegabytes) {
  TempDir dir;
  nlohmann::json config = nlohmann::json::parse(Slurp(SourcePath("configs/ganesh-noload.json")));
  config["experiment"]["duration"] = 10.0;
  config["experiment"]["sample_rate"] = 100000;  // 1e6 + 1 samples, one per simulation step
  const std::string config_path = dir.Write("long.json", config.dump(2));
  const std::string trace = dir.File("long.csv"), html = dir.File("long.html");
  const CommandResult sim =
      blmd::testing::Run(BinPath("blmd-sim") + " --config " + config_path + " --out " + trace +
                         " --noise i=1% --noise w=1% --seed 7");
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  ASSERT_NE(sim.out.find("1000001 samples"), std::string::npos) << sim.out;
  // A small evaluation budget: the fit stops early (exit 1) but the page is still written.
  const CommandResult ident = blmd::testing::Run(
      BinPath("blmd-ident") + " --config " + config_path + " --trace " + trace +
      " --method powell --max-evaluations 12 --threads 2 --quiet --html " + html);
  ASSERT_TRUE(ident.exit_code == 0 || ident.exit_code == 1) << ident.err;
  ASSERT_TRUE(FileExists(html));
  const auto size = std::filesystem::file_size(html);
  std::cout << "HTML report of a 1000001-sample trace: " << size << " bytes\n";
  EXPECT_LT(size, 2u * 1024 * 1024);
  const std::string page = Slurp(html);
  // 10 of the fit and the steps of i and w; a step from t = 0 holds u constant: no frequency
  // response, and the page says why.
  EXPECT_EQ(Figures(page).size(), 12u);
  EXPECT_EQ(Count(page, "<svg "), 12u);
  EXPECT_EQ(Count(page,
                  "No empirical frequency response: the input u has no power at any "
                  "frequency (it is constant)."),
            1u);
  EXPECT_GE(Count(page, "1000001 samples"), 2u);
  ExpectSelfContained(page);
}

TEST(HtmlReportCli, WritesBesideTheJsonAndFailsCleanlyOnABadPath) {
  TempDir dir;
  const std::string base = BinPath("blmd-ident") + " --config " +
                           SourcePath("configs/ganesh-noload.json") + " --trace " +
                           SourcePath("testdata/ganesh-noload-step.csv");
  const CommandResult ok = blmd::testing::Run(base + " --report " + dir.File("r.json") +
                                              " --html " + dir.File("r.html"));
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_NE(ok.out.find("html report: " + dir.File("r.html")), std::string::npos);
  const std::string page = Slurp(dir.File("r.html"));
  EXPECT_EQ(page.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_EQ(page.substr(page.size() - 8), "</html>\n");
  const auto report = nlohmann::json::parse(Slurp(dir.File("r.json")));
  EXPECT_NE(page.find(report["trace"]["sha256"].get<std::string>()), std::string::npos);
  // No temporary left beside it.
  std::size_t files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path()))
    files += entry.is_regular_file();
  EXPECT_EQ(files, 2u);

  const std::string missing = dir.File("no-such-folder/r.html");
  const CommandResult bad = blmd::testing::Run(base + " --html " + missing);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_EQ(bad.err.rfind("error: ", 0), 0u) << bad.err;
  EXPECT_NE(bad.err.find("no-such-folder"), std::string::npos) << bad.err;
  EXPECT_FALSE(FileExists(missing));
}

}  // namespace
}  // namespace blmd::testing
