// blmd-surface: sweep the identification cost over a 1-D or 2-D parameter grid.
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>

#include "../common/app_main.h"
#include "../common/error_flags.h"
#include "../common/trace_flags.h"
#include "app/request.h"
#include "blmd/app/sweep.h"
#include "blmd/ident/fit/surface.h"
#include "blmd/io/config.h"
#include "blmd/io/csv.h"
#include "blmd/io/files.h"
#include "blmd/report/surface_file.h"
#include "blmd/report/svg/plot.h"
#include "blmd/sim/effects.h"
#include "blmd/sim/model.h"

namespace {

std::string G(double v, int digits = 5) {
  return std::isfinite(v) ? blmd::FormatSignificant(v, digits) : "inf";
}

std::string Clock(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--";
  char buffer[32];
  const long s = std::lround(seconds);
  std::snprintf(buffer, sizeof buffer, "%ld:%02ld", s / 60, s % 60);
  return buffer;
}

// Description of a grid axis' parameter: the model's (when the model is known), else an
// effect's; nullptr when neither has it (the axis is then drawn without a unit).
const blmd::ParamInfo* FindParameterInfo(const std::string& model, const std::string& name) {
  for (const blmd::Model* candidate : blmd::ModelRegistry()) {
    if (candidate->name() != model) continue;
    if (const blmd::ParamInfo* info = candidate->FindParameter(name)) return info;
  }
  for (const auto& effect : blmd::EffectRegistry()) {
    for (const auto& info : effect.parameters) {
      if (info.name == name) return &info;
    }
  }
  return nullptr;
}

// `blmd-surface plot`: draws a surface CSV (unsharded, merged or one shard) as SVG.
int PlotSurfaceFile(const std::string& csv_path, const std::string& svg_path,
                    const std::string& title, bool quiet) {
  const blmd::SurfaceFile file = blmd::ReadSurfaceCsv(csv_path);
  constexpr std::size_t kMaxDrawn = 4'000'000;  // SurfaceSvg's limit
  if (file.grid_size > kMaxDrawn) {
    throw blmd::InputError(csv_path + ": a grid of " + std::to_string(file.grid_size) +
                           " points is too large to draw (at most " + std::to_string(kMaxDrawn) +
                           ")");
  }
  // The whole grid; on a shard the points outside its slice are missing (NaN), so a local
  // minimum is only reported where all its neighbours are in the file.
  const std::vector<blmd::SurfacePoint> points = blmd::SurfaceGridPoints(file);
  const std::vector<std::size_t> minima = blmd::LocalMinima(file.axes, points);
  std::string observe_text;
  for (std::size_t c = 0; c < file.observe.size(); ++c)
    observe_text += (c ? "," : "") + file.observe[c];
  blmd::SurfacePlotOptions plot;
  plot.title = title;
  if (plot.title.empty()) {
    const auto slash = csv_path.find_last_of('/');
    plot.title =
        (slash == std::string::npos ? csv_path : csv_path.substr(slash + 1)) + ": cost over ";
    for (std::size_t a = 0; a < file.axes.size(); ++a)
      plot.title += (a ? ", " : "") + file.axes[a].name;
    plot.title += " (observe " + observe_text + ")";
    if (file.is_shard()) {
      plot.title += ", shard " + std::to_string(file.metadata.shard_index) + "/" +
                    std::to_string(file.metadata.shard_count);
    }
  }
  for (const auto& axis : file.axes) {
    const blmd::ParamInfo* info = FindParameterInfo(file.model, axis.name);
    plot.units.push_back(info ? info->unit : "");
  }
  const std::string svg = blmd::SurfaceSvg(file.axes, points, minima, plot);
  blmd::WriteFileAtomically(svg_path, svg);
  if (quiet) return blmd::kExitOk;

  std::size_t best = points.size(), failed = 0;
  for (std::size_t k = 0; k < points.size(); ++k) {
    if (!std::isfinite(points[k].evaluation.cost)) continue;
    if (best == points.size() || points[k].evaluation.cost < points[best].evaluation.cost) best = k;
  }
  for (const auto& point : file.points) failed += point.evaluation.ok ? 0 : 1;
  auto where = [&](std::size_t k) {
    std::string text;
    for (std::size_t a = 0; a < file.axes.size(); ++a) {
      text += " " + file.axes[a].name + " = " + G(points[k].coordinates[a], 6);
    }
    return text + ", cost " + G(points[k].evaluation.cost);
  };
  std::cout << "blmd-surface: plotted " << file.points.size() << " points";
  if (file.is_shard()) {
    std::cout << " (shard " << file.metadata.shard_index << "/" << file.metadata.shard_count
              << " of " << file.grid_size << ")";
  }
  std::cout << " of " << csv_path << " -> " << svg_path << "\n";
  if (best < points.size()) std::cout << "  grid minimum:" << where(best) << "\n";
  std::cout << "  local minima: " << minima.size()
            << (file.is_shard() ? " (only where every neighbour is in the shard)" : "") << "\n";
  for (std::size_t k : minima)
    std::cout << "   " << where(k) << (k == best ? "  (global)" : "") << "\n";
  if (failed) std::cout << "  failed points: " << failed << " (cost inf)\n";
  return blmd::kExitOk;
}

// Every flag of blmd-surface's sweep (docs/cli.md §3); merge and plot are subcommands.
struct SurfaceFlags {
  std::string config_path, trace_path, out_path, observe_text, svg_path, shard_text;
  std::vector<std::string> grids;
  int threads = 0;
  bool force = false, json = false, quiet = false;
  blmd::app::ErrorFlags error_flags;
  blmd::app::TraceFlags trace_flags;

  void Add(CLI::App& app) {
    app.add_option("--config", config_path, "model (JSON)");
    app.add_option("--trace", trace_path, "measured trace CSV");
    app.add_option("--grid", grids, "axis P=LO:HI:N or P=log:LO:HI:N (one or two)");
    app.add_option("--out", out_path, "surface CSV to write");
    app.add_option("--observe", observe_text, "trace columns in the cost, e.g. i,w");
    error_flags.Add(app, "the cost of blmd-ident --error");
    trace_flags.Add(app);
    app.add_option("--threads", threads, "worker threads (0: all cores)")
        ->check(blmd::app::NonNegativeWholeNumber());
    app.add_option("--shard", shard_text, "compute only slice K of N, K/N (1-based)");
    app.add_option("--svg", svg_path, "write a heat map (2-D) or curve (1-D) SVG");
    app.add_flag("--json", json, "print the surface as JSON on stdout instead of the summary");
    app.add_flag("--quiet", quiet, "no progress bar, no summary");
    app.add_flag("--force", force, "sweep a grid beyond the size cap (1e6 points or 1 GB)");
  }
};

// A progress bar on stderr, redrawn at most every 200 ms: points, rate, time left.
std::function<void(std::size_t, std::size_t)> ProgressBar() {
  struct State {
    std::mutex mutex;
    std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now();
    std::chrono::steady_clock::time_point last_draw = started;
  };
  auto state = std::make_shared<State>();
  return [state](std::size_t done, std::size_t total) {
    std::lock_guard<std::mutex> lock(state->mutex);
    const auto now = std::chrono::steady_clock::now();
    if (done != total && now - state->last_draw < std::chrono::milliseconds(200)) return;
    state->last_draw = now;
    const double elapsed = std::chrono::duration<double>(now - state->started).count();
    const double rate = elapsed > 0 ? static_cast<double>(done) / elapsed : 0.0;
    const double left = rate > 0 ? static_cast<double>(total - done) / rate : -1.0;
    const int width = 30;
    const int filled = static_cast<int>(width * done / std::max<std::size_t>(1, total));
    std::fprintf(stderr, "\r[%s%s] %zu/%zu points, %.1f pt/s, %s left ",
                 std::string(filled, '#').c_str(), std::string(width - filled, ' ').c_str(), done,
                 total, rate, Clock(left).c_str());
    if (done == total) std::fprintf(stderr, "\n");
  };
}

// The surface as JSON on stdout (--json, docs/cli.md §3).
void PrintJson(const SurfaceFlags& f, const blmd::SweepRequest& request,
               const blmd::SweepOutcome& outcome, int shard_index, int shard_count) {
  const auto& points = outcome.points;
  const auto& axes = request.axes;
  auto point_json = [&](std::size_t k) {
    nlohmann::json p = nlohmann::json::object();
    for (std::size_t a = 0; a < axes.size(); ++a) p[axes[a].name] = points[k].coordinates[a];
    p["cost"] = points[k].evaluation.ok ? nlohmann::json(points[k].evaluation.cost)
                                        : nlohmann::json(nullptr);
    return p;
  };
  nlohmann::json out;
  out["tool"] = "blmd-surface";
  out["version"] = blmd::kVersion;
  out["config"] = {{"path", f.config_path}, {"sha256", request.config_sha256}};
  out["trace"] = {{"path", f.trace_path}, {"sha256", outcome.trace_sha256}};
  out["observe"] = request.observe;
  out["grid"] = nlohmann::json::array();
  for (const auto& axis : axes) {
    out["grid"].push_back({{"name", axis.name},
                           {"low", axis.low},
                           {"high", axis.high},
                           {"count", axis.count},
                           {"log", axis.log_scale}});
  }
  out["shard"] = {shard_index, shard_count};
  out["minimum"] =
      outcome.best < points.size() ? point_json(outcome.best) : nlohmann::json(nullptr);
  out["local_minima"] = nlohmann::json::array();
  for (std::size_t k : outcome.minima) out["local_minima"].push_back(point_json(k));
  out["failed_points"] = outcome.failed;
  out["failure_reasons"] = outcome.failure_reasons;
  out["points"] = nlohmann::json::array();
  for (std::size_t k = 0; k < points.size(); ++k) {
    nlohmann::json p = point_json(k);
    if (points[k].evaluation.ok) {
      for (std::size_t c = 0; c < request.observe.size(); ++c)
        p["mse_" + request.observe[c]] = points[k].evaluation.mse[c];
    }
    out["points"].push_back(p);
  }
  out["wall_time_s"] = outcome.wall_time_s;
  std::cout << out.dump(2) << "\n";
}

// The human summary: points, rate, grid minimum, local minima, failures.
void PrintSummary(const SurfaceFlags& f, const std::vector<blmd::GridAxis>& axes,
                  const blmd::SweepOutcome& outcome, int shard_index, int shard_count) {
  const auto& points = outcome.points;
  const double elapsed = outcome.wall_time_s;
  std::cout << "blmd-surface: " << points.size() << " points";
  if (shard_count > 1) std::cout << " (shard " << shard_index << "/" << shard_count << ")";
  std::cout << " in " << G(elapsed, 3) << " s (" << G(points.size() / std::max(elapsed, 1e-9), 3)
            << " points/s) -> " << f.out_path << "\n";
  if (outcome.best < points.size()) {
    std::cout << "  grid minimum:";
    for (std::size_t a = 0; a < axes.size(); ++a)
      std::cout << " " << axes[a].name << " = " << G(points[outcome.best].coordinates[a], 6);
    std::cout << ", cost " << G(points[outcome.best].evaluation.cost) << "\n";
  }
  if (shard_count == 1) {
    std::cout << "  local minima: " << outcome.minima.size() << "\n";
    for (std::size_t k : outcome.minima) {
      std::cout << "   ";
      for (std::size_t a = 0; a < axes.size(); ++a)
        std::cout << " " << axes[a].name << " = " << G(points[k].coordinates[a], 6);
      std::cout << ", cost " << G(points[k].evaluation.cost)
                << (k == outcome.best ? "  (global)" : "") << "\n";
    }
  }
  if (outcome.failed) {
    std::cout << "  failed points: " << outcome.failed << " (cost inf)";
    for (const auto& [reason, n] : outcome.failure_reasons)
      std::cout << "; " << n << " x " << reason;
    std::cout << "\n";
  }
  if (!f.svg_path.empty()) std::cout << "  svg: " << f.svg_path << "\n";
}

// The sweep itself: flags -> SweepRequest -> blmd::Sweep -> CSV, SVG, JSON or summary.
int RunSweep(const CLI::App& app, SurfaceFlags& f) {
  for (const auto& [flag, value] :
       {std::pair<const char*, const std::string*>{"--config", &f.config_path},
        {"--trace", &f.trace_path},
        {"--out", &f.out_path}}) {
    if (value->empty())
      throw blmd::InputError(std::string(flag) + " is required (see blmd-surface --help)");
  }
  f.threads = blmd::app::CapThreads(f.threads);
  // Every output checked before any work: writable, not an input, not the other output.
  blmd::CheckOutputs({{"--out", f.out_path}, {"--svg", f.svg_path}},
                     {{"--config", f.config_path}, {"--trace", f.trace_path}});
  blmd::CheckGridCount(f.grids);  // before the config is read
  blmd::SweepSettings settings;
  settings.trace = {f.trace_path, std::nullopt};
  settings.grids = f.grids;
  if (app.count("--observe") > 0) settings.observe = f.observe_text;  // '' refused there
  settings.shard = f.shard_text;
  settings.force = f.force;
  settings.threads = f.threads;
  settings.error = f.error_flags;
  settings.preparation = f.trace_flags;
  blmd::SweepRequest request = blmd::MakeSweepRequest(blmd::LoadConfig(f.config_path), settings);
  const int shard_index = request.shard_index, shard_count = request.shard_count;
  blmd::InstallCleanupOnSignal();
  request.config_sha256 = blmd::Sha256Hex(blmd::ReadFileText(f.config_path));
  if (!f.quiet && isatty(STDERR_FILENO)) request.progress = ProgressBar();
  const blmd::Config& config = request.config;
  const std::vector<blmd::GridAxis>& axes = request.axes;
  const blmd::SweepOutcome outcome = blmd::Sweep(request);

  std::string svg;
  if (!f.svg_path.empty()) {
    if (shard_count > 1)
      throw blmd::InputError(
          "--svg needs the whole grid: draw it from the merged surface, not a shard");
    blmd::SurfacePlotOptions plot;
    plot.title = config.name + ": cost over ";
    for (std::size_t a = 0; a < axes.size(); ++a) {
      plot.title += (a ? ", " : "") + axes[a].name;
      const blmd::ParamInfo* info = config.FindParameterInfo(axes[a].name);
      plot.units.push_back(info ? info->unit : "");
    }
    plot.title += " (observe " + blmd::Join(request.observe, ",") + ")";
    svg = blmd::SurfaceSvg(axes, outcome.points, outcome.minima, plot);
  }
  blmd::WriteFileAtomically(f.out_path, outcome.csv);
  if (!svg.empty()) blmd::WriteFileAtomically(f.svg_path, svg);
  if (f.json) {
    PrintJson(f, request, outcome, shard_index, shard_count);
  } else if (!f.quiet) {
    PrintSummary(f, axes, outcome, shard_index, shard_count);
  }
  return blmd::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"blmd-surface: sweep the MSE cost over a grid of parameters"};
  blmd::app::AddVersionFlag(app, "blmd-surface");
  blmd::app::AddHelpFooter(app, "blmd-surface");
  SurfaceFlags flags;
  flags.Add(app);
  CLI::App* merge = app.add_subcommand("merge", "join shard files into the unsharded surface CSV");
  std::vector<std::string> parts;
  std::string merge_out;
  merge->add_option("parts", parts, "shard CSV files")->required();
  merge->add_option("--out", merge_out, "merged CSV to write")->required();
  CLI::App* plot = app.add_subcommand(
      "plot", "draw a surface CSV (unsharded, merged, or one shard) as SVG, like --svg");
  std::string plot_csv, plot_svg, plot_title;
  plot->add_option("surface", plot_csv, "surface CSV written by blmd-surface or merge")->required();
  plot->add_option("--svg", plot_svg, "SVG to write")->required();
  plot->add_option("--title", plot_title,
                   "title (default: \"FILE: cost over P[, Q] (observe COLS)\")");
  plot->add_flag("--quiet", flags.quiet, "no summary");
  return blmd::app::Main(app, argc, argv,
                         [&]() -> int {
                           if (plot->parsed()) {
                             blmd::CheckOutputs({{"--svg", plot_svg}}, {{"surface", plot_csv}});
                             return PlotSurfaceFile(plot_csv, plot_svg, plot_title, flags.quiet);
                           }
                           if (merge->parsed()) {
                             std::vector<blmd::NamedPath> part_files;
                             part_files.reserve(parts.size());
                             for (const auto& part : parts) part_files.push_back({"part", part});
                             blmd::CheckOutputs({{"--out", merge_out}}, part_files);
                             blmd::WriteFileAtomically(merge_out, blmd::MergeSurfaceParts(parts));
                             if (!flags.quiet)
                               std::cout << "blmd-surface: merged " << parts.size() << " shards -> "
                                         << merge_out << "\n";
                             return blmd::kExitOk;
                           }
                           return RunSweep(app, flags);
                         },
                         {"--observe"});
}
