// blmd-track: the online J and load-torque tracker (docs/export.md §7) run over a recorded
// trace, seeded by an identification report: what the generated C tracker does in the drive,
// sample for sample. Flags -> the config and the report (Compensation) -> the trace (read as
// blmd-ident reads it) -> InertiaTracker per sample -> TRACK.csv (t, J, J_low, J_high,
// changed, TL, excited), and a JSON summary and an HTML page when asked; exit 2 on bad input
// with nothing written.
#include <cmath>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "../common/app_main.h"
#include "../common/trace_flags.h"
#include "../common/tracker_flags.h"
#include "app/request.h"
#include "blmd/format.h"
#include "blmd/io/config.h"
#include "blmd/io/files.h"
#include "blmd/io/stored_report.h"
#include "blmd/report/svg/plot.h"
#include "report/markup.h"
#include "tune/compensation.h"
#include "tune/inertia_tracker.h"

namespace {

struct TrackFlags {
  std::string config_path, report_in_path, trace_path, out_path, report_path, html_path;
  blmd::app::TraceFlags trace;
  blmd::app::TrackerFlags tracker;
  bool quiet = false, fail_on_change = false;

  void Add(CLI::App& app) {
    app.add_option("--config", config_path, "the config that was identified (JSON)")->required();
    app.add_option("--from-report", report_in_path,
                   "the identification report (blmd-ident --report): the tracker's start")
        ->required();
    app.add_option("--trace", trace_path, "the record to track (CSV or .mat)")->required();
    app.add_option("--out", out_path, "TRACK.csv: t, J, J_low, J_high, changed, TL, excited")
        ->required();
    app.add_option("--report", report_path, "a JSON summary of the track");
    app.add_option("--html", html_path, "a page with J, its interval and the offline interval");
    trace.Add(app);
    tracker.Add(app);
    app.add_flag("--fail-on-change", fail_on_change,
                 "exit 3 when J has left its offline interval at the end of the trace");
    app.add_flag("--quiet", quiet, "print nothing on success");
  }
};

struct Row {
  double t, J, J_low, J_high, TL;
  bool changed, excited;
};

std::string HtmlPage(const std::vector<Row>& rows, const blmd::TrackerSeed& seed,
                     const std::string& title) {
  blmd::Series estimate, low, high;
  estimate.label = "J (online)";
  estimate.colour = "#0072b2";
  low.label = "95 % interval";
  low.colour = high.colour = "#56b4e9";
  low.dash = high.dash = "4 3";
  for (const Row& row : rows) {
    for (blmd::Series* s : {&estimate, &low, &high}) s->x.push_back(row.t);
    estimate.y.push_back(row.J);
    low.y.push_back(row.J_low);
    high.y.push_back(row.J_high);
  }
  blmd::LinePlotOptions options;
  options.title = "J along the record";
  options.x_label = "t";
  options.x_unit = "s";
  options.y_label = "J";
  options.y_unit = "kg·m²";
  blmd::Band offline;
  offline.label = "offline 95 % interval";
  offline.low = seed.J_low;
  offline.high = seed.J_high;
  options.bands.push_back(offline);
  // The title names a file: escaped, so that no path breaks (or scripts) the page.
  const std::string text = blmd::internal::Escape(title);
  std::ostringstream page;
  page << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" << text
       << "</title></head><body>\n<h1>" << text << "</h1>\n"
       << blmd::LinePlotSvg(options, {estimate, low, high}) << "\n</body></html>\n";
  return page.str();
}

int Run(TrackFlags& f) {
  blmd::CheckOutputs({{"--out", f.out_path}, {"--report", f.report_path}, {"--html", f.html_path}},
                     {{"--config", f.config_path},
                      {"--from-report", f.report_in_path},
                      {"--trace", f.trace_path}});
  const blmd::Config config = blmd::LoadConfig(f.config_path);
  const blmd::StoredReport report =
      blmd::StoredReport::Load(f.report_in_path, "identification report");
  const blmd::Compensation model = blmd::Compensation::FromReport(config, report);
  if (!(model.torque_per_input > 0.0)) {
    throw blmd::InputError(f.config_path + ": model " + model.model +
                           " states no torque constant: the tracker needs the drive's torque "
                           "(rigid_load: Kt u; dc_servo: Kt i)");
  }
  // The drive's torque comes from u (rigid_load) or the measured current (dc_servo).
  const std::string& torque_column = model.torque_column;
  std::vector<std::string> needed = {"w"};
  if (torque_column != "u") needed.push_back(torque_column);
  const bool position_terms =
      model.Value("Tcog") != 0.0 || model.Value("K") != 0.0 || model.Value("Tg") != 0.0;
  if (position_terms) needed.push_back("theta");
  const std::vector<blmd::FitTrace> traces = blmd::LoadTraceSource(
      {f.trace_path, std::nullopt}, f.trace.Options(needed, /*equation_error=*/false),
      config.experiment.initial);
  if (traces.size() != 1) {
    throw blmd::InputError("--trace: the tracker runs over one record (got " +
                           std::to_string(traces.size()) +
                           " experiments): select one with "
                           "--select, or track each part on its own");
  }
  const blmd::Trace& trace = traces.front().trace;
  const std::vector<double>& t = trace.Column("t");
  const std::vector<double>& w = trace.Column("w");
  const std::vector<double>& drive = trace.Column(torque_column);
  const std::vector<double>* theta = trace.Has("theta") ? &trace.Column("theta") : nullptr;
  if (t.size() < 3) throw blmd::InputError(f.trace_path + ": fewer than 3 samples to track");
  const double dt = (t.back() - t.front()) / static_cast<double>(t.size() - 1);
  for (std::size_t k = 1; k < t.size(); ++k) {
    if (std::abs(t[k] - t[k - 1] - dt) > 1e-3 * dt) {
      throw blmd::InputError(f.trace_path + ": the samples are not evenly spaced (row " +
                             std::to_string(k + 2) +
                             "): the tracker runs at a fixed rate; "
                             "resample the record (--resample auto)");
    }
  }
  blmd::SpeedNoise noise = blmd::SpeedNoiseOf(f.tracker, report);
  if (!(noise.sigma > 0.0)) {
    double sum = 0.0;
    for (double v : w) sum += v * v;
    noise = {0.01 * std::sqrt(sum / static_cast<double>(w.size())),
             "1 % of the trace's RMS speed (the report gives no noise for w)"};
  }
  const double speed_noise = noise.sigma;
  const std::string& noise_source = noise.source;
  const blmd::TrackerSeed seed = blmd::MakeTrackerSeed(model, f.tracker, dt, speed_noise);
  blmd::InertiaTracker tracker(model, seed);
  std::vector<Row> rows;
  rows.reserve(t.size());
  std::size_t excited = 0, first_change = t.size();
  for (std::size_t k = 0; k < t.size(); ++k) {
    tracker.Update(model.torque_per_input * drive[k], w[k], theta ? (*theta)[k] : 0.0);
    if (!std::isfinite(tracker.J()) || !std::isfinite(tracker.J_high())) {
      throw blmd::InputError(f.trace_path + ": the tracker diverged at t = " +
                             blmd::FormatNumber(t[k]) + " s (a non-finite value in the record)");
    }
    rows.push_back({t[k], tracker.J(), tracker.J_low(), tracker.J_high(), tracker.TL(),
                    tracker.changed(), tracker.excited()});
    if (tracker.excited()) ++excited;
    if (tracker.changed() && first_change == t.size()) first_change = k;
  }
  std::ostringstream csv;
  csv << "# blmd-track " << blmd::kVersion << " config=" << f.config_path
      << " report=" << f.report_in_path << " trace=" << f.trace_path << "\n"
      << "t,J,J_low,J_high,changed,TL,excited\n";
  for (const Row& row : rows) {
    csv << blmd::FormatNumber(row.t) << ',' << blmd::FormatNumber(row.J) << ','
        << blmd::FormatNumber(row.J_low) << ',' << blmd::FormatNumber(row.J_high) << ','
        << (row.changed ? 1 : 0) << ',' << blmd::FormatNumber(row.TL) << ','
        << (row.excited ? 1 : 0) << '\n';
  }
  const Row& last = rows.back();
  nlohmann::json summary = {
      {"tool", "blmd-track"},
      {"version", blmd::kVersion},
      {"config", f.config_path},
      {"from_report", f.report_in_path},
      {"trace", f.trace_path},
      {"samples", rows.size()},
      {"excited_samples", excited},
      {"seed",
       {{"J", seed.J},
        {"J_ci95", {seed.J_low, seed.J_high}},
        {"TL", seed.TL},
        {"filter_hz", seed.filter_hz},
        {"memory_s", f.tracker.memory_s},
        {"lambda", seed.lambda},
        {"gate_acceleration", seed.gate_acceleration},
        {"speed_noise", speed_noise},
        {"speed_noise_source", noise_source},
        {"change_margin", seed.change_margin}}},
      {"final", {{"J", last.J}, {"J_ci95", {last.J_low, last.J_high}}, {"TL", last.TL}}},
      {"changed", last.changed},
      {"first_change_t", first_change < rows.size() ? nlohmann::json(rows[first_change].t)
                                                    : nlohmann::json(nullptr)}};
  if (!f.out_path.empty() || !f.report_path.empty() || !f.html_path.empty())
    blmd::InstallCleanupOnSignal();
  blmd::WriteFileAtomically(f.out_path, csv.str());
  if (!f.report_path.empty()) blmd::WriteFileAtomically(f.report_path, summary.dump(2) + "\n");
  if (!f.html_path.empty()) {
    blmd::WriteFileAtomically(f.html_path, HtmlPage(rows, seed, "blmd-track: " + f.trace_path));
  }
  if (!f.quiet) {
    std::cout << "blmd-track: " << rows.size() << " samples, J updated on " << excited
              << " (|filtered acceleration| > "
              << blmd::FormatSignificant(seed.gate_acceleration, 3) << " rad/s², speed noise from "
              << noise_source << ")\n"
              << "  offline J " << blmd::FormatSignificant(seed.J, 6) << " ["
              << blmd::FormatSignificant(seed.J_low, 6) << ", "
              << blmd::FormatSignificant(seed.J_high, 6) << "]\n"
              << "  final   J " << blmd::FormatSignificant(last.J, 6) << " ["
              << blmd::FormatSignificant(last.J_low, 6) << ", "
              << blmd::FormatSignificant(last.J_high, 6) << "], TL "
              << blmd::FormatSignificant(last.TL, 4) << "\n"
              << (first_change < rows.size()
                      ? "  changed: J left its offline interval (by more than " +
                            blmd::FormatSignificant(100.0 * seed.change_margin, 3) +
                            " %) at t = " + blmd::FormatNumber(rows[first_change].t) + " s" +
                            (last.changed ? "" : ", and is back within it at the end")
                      : std::string("  unchanged: J stayed within its offline interval"))
              << "\ntrack: " << f.out_path << "\n";
  }
  if (f.fail_on_change && last.changed) return blmd::kExitGate;
  return blmd::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "blmd-track: the online J and load-torque tracker over a record, seeded by an "
      "identification report"};
  blmd::app::AddVersionFlag(app, "blmd-track");
  blmd::app::AddHelpFooter(app, "blmd-track");
  TrackFlags flags;
  flags.Add(app);
  return blmd::app::Main(app, argc, argv, [&]() -> int { return Run(flags); });
}
