// blmd-surface: sweep the identification cost over a 1-D or 2-D parameter grid.
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <mutex>

#include "../common/app_main.h"
#include "../common/error_flags.h"
#include "../common/trace_flags.h"
#include "blmd/ident/surface.h"
#include "blmd/ident/trace_input.h"
#include "blmd/io/config.h"
#include "blmd/io/csv.h"
#include "blmd/io/files.h"
#include "blmd/io/flags.h"
#include "blmd/report/plot.h"
#include "blmd/report/surface_file.h"
#include "blmd/sim/effects.h"
#include "blmd/sim/model.h"

// The largest sweep blmd-surface runs without --force (docs/cli.md §3).
constexpr std::size_t kMaxSurfacePoints = 1000000;
constexpr double kMaxSurfaceBytes = 1e9;

namespace {

std::string G(double v, int digits = 5) {
  if (!std::isfinite(v)) return "inf";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*g", digits, v);
  return buffer;
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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"blmd-surface: sweep the MSE cost over a grid of parameters"};
  blmd::app::AddVersionFlag(app, "blmd-surface");
  std::string config_path, trace_path, out_path, observe_text, svg_path, shard_text;
  std::vector<std::string> grids;
  int threads = 0;
  bool force = false;
  bool json = false, quiet = false;
  blmd::app::ErrorFlags error_flags;
  blmd::app::TraceFlags trace_flags;
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
  plot->add_flag("--quiet", quiet, "no summary");

  return blmd::app::Main(
      app, argc, argv,
      [&]() -> int {
        if (plot->parsed()) {
          blmd::CheckOutputs({{"--svg", plot_svg}}, {{"surface", plot_csv}});
          return PlotSurfaceFile(plot_csv, plot_svg, plot_title, quiet);
        }
        if (merge->parsed()) {
          std::vector<blmd::NamedPath> part_files;
          for (const auto& part : parts) part_files.push_back({"part", part});
          blmd::CheckOutputs({{"--out", merge_out}}, part_files);
          const std::string merged = blmd::MergeSurfaceParts(parts);
          blmd::WriteFileAtomically(merge_out, merged);
          if (!quiet)
            std::cout << "blmd-surface: merged " << parts.size() << " shards -> " << merge_out
                      << "\n";
          return blmd::kExitOk;
        }
        for (const auto& [flag, value] :
             {std::pair<const char*, const std::string*>{"--config", &config_path},
              {"--trace", &trace_path},
              {"--out", &out_path}}) {
          if (value->empty())
            throw blmd::InputError(std::string(flag) + " is required (see blmd-surface --help)");
        }
        threads = blmd::app::CapThreads(threads);
        // Every output checked before any work: writable, not an input, not the other output.
        blmd::CheckOutputs({{"--out", out_path}, {"--svg", svg_path}},
                           {{"--config", config_path}, {"--trace", trace_path}});
        if (grids.empty() || grids.size() > 2) {
          throw blmd::InputError("--grid: give one or two axes, P=LO:HI:N (got " +
                                 std::to_string(grids.size()) + ")");
        }
        blmd::Config config = blmd::LoadConfig(config_path);
        std::vector<blmd::GridAxis> axes;
        for (const auto& text : grids) {
          blmd::GridAxis axis = blmd::ParseGridAxis(text);
          if (!config.parameters.Has(axis.name)) {
            std::vector<std::string> known;
            for (const auto& [name, value] : config.parameters.entries()) known.push_back(name);
            const std::string near = blmd::NearestName(axis.name, known);
            throw blmd::InputError("--grid: unknown parameter '" + axis.name + "'" +
                                   (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                                   "; valid: " + blmd::Join(known));
          }
          const blmd::ParamInfo* info = config.FindParameterInfo(axis.name);
          if (info && info->positive && !(axis.low > 0.0)) {
            throw blmd::InputError("--grid " + axis.name + ": the parameter must be > 0 (LO = " +
                                   blmd::FormatNumber(axis.low) + ")");
          }
          for (const auto& other : axes) {
            if (other.name == axis.name)
              throw blmd::InputError("--grid: '" + axis.name + "' given twice");
          }
          axes.push_back(axis);
        }
        int shard_index = 1, shard_count = 1;
        if (!shard_text.empty()) {
          const auto slash = shard_text.find('/');
          // Digits, '/', digits: std::stoi alone would take " 1" and "+1".
          if (shard_text.find_first_not_of("0123456789/") != std::string::npos) {
            throw blmd::InputError("--shard '" + shard_text + "': expected K/N, e.g. 3/8");
          }
          try {
            std::size_t used = 0;
            shard_index = std::stoi(shard_text.substr(0, slash), &used);
            if (used != slash) throw std::invalid_argument("K");
            const std::string count = shard_text.substr(slash + 1);
            shard_count = std::stoi(count, &used);
            if (used != count.size()) throw std::invalid_argument("N");  // "1/3abc"
          } catch (const std::exception&) {
            throw blmd::InputError("--shard '" + shard_text + "': expected K/N, e.g. 3/8");
          }
          if (slash == std::string::npos || shard_count < 1 || shard_index < 1 ||
              shard_index > shard_count) {
            throw blmd::InputError("--shard '" + shard_text + "': expected K/N with 1 <= K <= N");
          }
        }
        const std::vector<std::string> outputs = config.model->outputs();
        std::string valid_outputs;
        for (const auto& name : outputs)
          valid_outputs += (valid_outputs.empty() ? "" : ", ") + name;
        if (app.count("--observe") > 0 && observe_text.empty()) {
          throw blmd::InputError("--observe: empty (valid: " + valid_outputs + ")");
        }
        const std::vector<std::string> observe = error_flags.Apply(&config, observe_text);
        const bool equation_error = config.identification.error == "equation";
        for (const auto& name : observe) {
          if (equation_error) break;
          if (std::find(outputs.begin(), outputs.end(), name) == outputs.end()) {
            throw blmd::InputError("--observe: '" + name + "' is not an output of model " +
                                   std::string(config.model->name()) + " (valid: " + valid_outputs +
                                   ")");
          }
        }
        const blmd::TraceInputOptions input_options = trace_flags.Options(observe, equation_error);
        // The row selection, recorded in the CSV so that merge tells sweeps apart.
        const std::string rows_line = trace_flags.RowsLine();
        std::vector<blmd::FitTrace> traces =
            blmd::LoadFitTraces(trace_path, input_options, config.experiment.initial);
        const std::size_t experiments = traces.size();
        const std::string trace_sha = traces.front().sha256;

        // The grid axes are the free parameters; bounds are the grid's (the cost does not clip).
        std::vector<blmd::FreeParameter> free;
        for (const auto& axis : axes) {
          blmd::FreeParameter p;
          p.name = axis.name;
          p.lower = axis.low;
          p.upper = axis.high;
          p.log_scale = axis.log_scale;
          p.initial = config.parameters.Get(axis.name);
          free.push_back(p);
        }
        {
          // The sweep's size before it starts: a typo in N must not ask for gigabytes.
          std::size_t points = 1;
          for (const auto& axis : axes) points *= static_cast<std::size_t>(axis.count);
          points = (points + static_cast<std::size_t>(shard_count) - 1) /
                   static_cast<std::size_t>(shard_count);
          const std::size_t columns = observe.size(), trace_count = traces.size();
          // Per point: the result (coordinates, cost, MSE per column and per trace) and its CSV
          // row.
          const double bytes =
              static_cast<double>(points) *
              (160.0 + 8.0 * static_cast<double>(axes.size()) +
               16.0 * static_cast<double>(columns) +
               static_cast<double>(trace_count) * (24.0 + 8.0 * static_cast<double>(columns)) +
               24.0 * static_cast<double>(axes.size() + columns + 1));
          if (!force && (points > kMaxSurfacePoints || bytes > kMaxSurfaceBytes)) {
            throw blmd::InputError(
                "--grid: " + std::to_string(points) + " points" +
                (shard_count > 1 ? " in this shard" : "") + " (about " +
                blmd::FormatSignificant(bytes / 1e9, 3) +
                " GB) is more than the cap of 1000000 points or 1 GB; narrow the "
                "grid, shard it (--shard K/N), or add --force");
          }
        }
        blmd::InstallCleanupOnSignal();
        const std::string config_sha = blmd::Sha256Hex(blmd::ReadFileText(config_path));
        const blmd::FitProblem problem(config, std::move(traces), observe, free);

        blmd::SurfaceOptions options;
        options.threads = threads;
        options.shard_index = shard_index;
        options.shard_count = shard_count;
        const bool show_progress = !quiet && isatty(STDERR_FILENO);
        const auto started = std::chrono::steady_clock::now();
        std::mutex progress_mutex;
        auto last_draw = started;
        if (show_progress) {
          options.progress = [&](std::size_t done, std::size_t total) {
            std::lock_guard<std::mutex> lock(progress_mutex);
            const auto now = std::chrono::steady_clock::now();
            if (done != total && now - last_draw < std::chrono::milliseconds(200)) return;
            last_draw = now;
            const double elapsed = std::chrono::duration<double>(now - started).count();
            const double rate = elapsed > 0 ? static_cast<double>(done) / elapsed : 0.0;
            const double left = rate > 0 ? static_cast<double>(total - done) / rate : -1.0;
            const int width = 30;
            const int filled = static_cast<int>(width * done / std::max<std::size_t>(1, total));
            std::fprintf(stderr, "\r[%s%s] %zu/%zu points, %.1f pt/s, %s left ",
                         std::string(filled, '#').c_str(), std::string(width - filled, ' ').c_str(),
                         done, total, rate, Clock(left).c_str());
            if (done == total) std::fprintf(stderr, "\n");
          };
        }
        const std::vector<blmd::SurfacePoint> points = blmd::ComputeSurface(problem, axes, options);
        const double elapsed =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();

        blmd::SurfaceMetadata metadata;
        metadata.lines = {"blmd-surface " + std::string(blmd::kVersion),
                          "model: " + std::string(config.model->name()),
                          "config_sha256: " + config_sha, "trace_sha256: " + trace_sha};
        std::string observe_line = "observe: ";
        for (std::size_t c = 0; c < observe.size(); ++c)
          observe_line += (c ? "," : "") + observe[c];
        metadata.lines.push_back(observe_line);
        if (problem.equation_error()) {
          const blmd::EquationTrace& first = problem.equation_traces().front();
          metadata.lines.push_back("error: equation, filter_hz " + G(first.cutoff_hz, 6) +
                                   ", decimate " + std::to_string(first.decimate));
        }
        if (!rows_line.empty()) {
          metadata.lines.push_back("rows:" + rows_line + " (" + std::to_string(experiments) +
                                   " experiment" + (experiments == 1 ? "" : "s") + ")");
        }
        for (const auto& axis : axes) metadata.lines.push_back("grid: " + axis.Spec());
        metadata.shard_index = shard_index;
        metadata.shard_count = shard_count;
        const std::string csv = blmd::FormatSurfaceCsv(metadata, axes, observe, points);

        // Summary figures (on a shard: of that shard only).
        std::vector<std::size_t> minima;
        std::size_t best = points.size();
        std::size_t failed = 0;
        std::map<std::string, long> reasons;
        for (std::size_t k = 0; k < points.size(); ++k) {
          if (!points[k].evaluation.ok) {
            ++failed;
            ++reasons[points[k].evaluation.reason];
            continue;
          }
          if (best == points.size() || points[k].evaluation.cost < points[best].evaluation.cost)
            best = k;
        }
        if (shard_count == 1) minima = blmd::LocalMinima(axes, points);
        std::string svg;
        if (!svg_path.empty()) {
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
          plot.title += " (observe " + observe_line.substr(9) + ")";
          svg = blmd::SurfaceSvg(axes, points, minima, plot);
        }
        blmd::WriteFileAtomically(out_path, csv);
        if (!svg.empty()) blmd::WriteFileAtomically(svg_path, svg);

        auto point_json = [&](std::size_t k) {
          nlohmann::json p = nlohmann::json::object();
          for (std::size_t a = 0; a < axes.size(); ++a) p[axes[a].name] = points[k].coordinates[a];
          p["cost"] = points[k].evaluation.ok ? nlohmann::json(points[k].evaluation.cost)
                                              : nlohmann::json(nullptr);
          return p;
        };
        if (json) {
          nlohmann::json out;
          out["tool"] = "blmd-surface";
          out["version"] = blmd::kVersion;
          out["config"] = {{"path", config_path}, {"sha256", config_sha}};
          out["trace"] = {{"path", trace_path}, {"sha256", trace_sha}};
          out["observe"] = observe;
          out["grid"] = nlohmann::json::array();
          for (const auto& axis : axes) {
            out["grid"].push_back({{"name", axis.name},
                                   {"low", axis.low},
                                   {"high", axis.high},
                                   {"count", axis.count},
                                   {"log", axis.log_scale}});
          }
          out["shard"] = {shard_index, shard_count};
          out["minimum"] = best < points.size() ? point_json(best) : nlohmann::json(nullptr);
          out["local_minima"] = nlohmann::json::array();
          for (std::size_t k : minima) out["local_minima"].push_back(point_json(k));
          out["failed_points"] = failed;
          out["failure_reasons"] = reasons;
          out["points"] = nlohmann::json::array();
          for (std::size_t k = 0; k < points.size(); ++k) {
            nlohmann::json p = point_json(k);
            if (points[k].evaluation.ok) {
              for (std::size_t c = 0; c < observe.size(); ++c)
                p["mse_" + observe[c]] = points[k].evaluation.mse[c];
            }
            out["points"].push_back(p);
          }
          out["wall_time_s"] = elapsed;
          std::cout << out.dump(2) << "\n";
        } else if (!quiet) {
          std::cout << "blmd-surface: " << points.size() << " points";
          if (shard_count > 1) std::cout << " (shard " << shard_index << "/" << shard_count << ")";
          std::cout << " in " << G(elapsed, 3) << " s ("
                    << G(points.size() / std::max(elapsed, 1e-9), 3) << " points/s) -> " << out_path
                    << "\n";
          if (best < points.size()) {
            std::cout << "  grid minimum:";
            for (std::size_t a = 0; a < axes.size(); ++a)
              std::cout << " " << axes[a].name << " = " << G(points[best].coordinates[a], 6);
            std::cout << ", cost " << G(points[best].evaluation.cost) << "\n";
          }
          if (shard_count == 1) {
            std::cout << "  local minima: " << minima.size() << "\n";
            for (std::size_t k : minima) {
              std::cout << "   ";
              for (std::size_t a = 0; a < axes.size(); ++a)
                std::cout << " " << axes[a].name << " = " << G(points[k].coordinates[a], 6);
              std::cout << ", cost " << G(points[k].evaluation.cost)
                        << (k == best ? "  (global)" : "") << "\n";
            }
          }
          if (failed) {
            std::cout << "  failed points: " << failed << " (cost inf)";
            for (const auto& [reason, n] : reasons) std::cout << "; " << n << " x " << reason;
            std::cout << "\n";
          }
          if (!svg_path.empty()) std::cout << "  svg: " << svg_path << "\n";
        }
        return blmd::kExitOk;
      },
      {"--observe"});
}
