// blmd-sim: simulate the configured model and experiment, write a trace CSV.
#include <cmath>
#include <cstdio>
#include <iostream>

#include "../common/app_main.h"
#include "../common/init_config.h"
#include "../common/trace_flags.h"
#include "app/request.h"
#include "blmd/io/config.h"
#include "blmd/io/csv.h"
#include "blmd/io/files.h"
#include "blmd/io/starting_config.h"
#include "blmd/run.h"
#include "io/flags.h"

namespace {

std::string Fixed(double value, int digits = 4) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*g", digits, value);
  return buffer;
}

// Every flag of blmd-sim (docs/cli.md §1).
struct SimFlags {
  std::string config_path, out_path, input_path, init_model;
  std::vector<std::string> effects, noises;
  std::uint64_t seed = 1;
  bool quiet = false;
  blmd::app::DialectFlags trace_flags;  // for --input

  void Add(CLI::App& app) {
    // Required unless --init-config (checked in Run, with CLI11's message).
    app.add_option("--config", config_path, "model and experiment (JSON) (required)");
    app.add_option("--out", out_path, "trace CSV to write (required)");
    app.add_option("--effect", effects,
                   "add an undeclared effect, NAME:KEY=VALUE[,KEY=VALUE...] (repeatable)");
    app.add_option(
        "--noise", noises,
        "white Gaussian noise on a column, NAME=SIGMA or NAME=P% of its peak (repeatable)");
    app.add_option("--seed", seed, "noise seed (default 1)")
        ->check(blmd::app::NonNegativeWholeNumber());
    trace_flags.Add(app);
    app.add_option("--input", input_path, "drive the model with the u column of this trace");
    app.add_flag("--quiet", quiet, "print nothing on success");
    blmd::app::AddInitConfigFlag(app, &init_model);
  }
};

// The summary: samples, each column's range and final value, the closed loop's step figures.
void PrintSummary(const SimFlags& f, const blmd::Config& config, const blmd::Trace& trace) {
  std::cout << "blmd-sim: " << config.model->name() << " '" << config.name << "', " << trace.rows()
            << " samples over " << Fixed(trace.Column("t").back()) << " s -> " << f.out_path
            << "\n";
  for (const auto& name : trace.names()) {
    if (name == "t") continue;
    const auto& column = trace.Column(name);
    double lo = column.front(), hi = column.front();
    for (double v : column) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
    std::printf("  %-6s min %12s  max %12s  final %12s\n", name.c_str(), Fixed(lo).c_str(),
                Fixed(hi).c_str(), Fixed(column.back()).c_str());
  }
  if (config.experiment.closed_loop) {
    // The loop's measured column: theta, or w for the speed loop (docs/model-dc-servo.md §6.1).
    const bool speed = config.experiment.pid.loop == blmd::PidSettings::Loop::kSpeed;
    const char* measured = speed ? "w" : "theta";
    const auto metrics = blmd::ComputeStepMetrics(trace.Column("t"), trace.Column(measured),
                                                  config.experiment.input.t0);
    if (metrics.valid) {
      std::printf(
          "  closed loop: rise time (10-90 %%) %s s, overshoot %s %%, settling (2 %%) %s s\n",
          Fixed(metrics.rise_time).c_str(), Fixed(metrics.overshoot_percent).c_str(),
          Fixed(metrics.settling_time).c_str());
    } else {
      std::printf("  closed loop: %s did not respond (no step metrics)\n", measured);
    }
  }
}

int Run(const CLI::App& app, SimFlags& f) {
  if (app.count("--init-config") > 0) return blmd::app::PrintStartingConfig(app, f.init_model);
  for (const char* flag : {"--config", "--out"}) {
    if (app.count(flag) == 0) {
      throw blmd::InputError(std::string(flag) + " is required (see " + app.get_name() +
                             " --help)");
    }
  }
  blmd::CheckOutputs({{"--out", f.out_path}},
                     {{"--config", f.config_path}, {"--input", f.input_path}});
  blmd::Config config = blmd::LoadConfig(f.config_path);
  for (const auto& spec : f.effects) {
    const auto [name, values] = blmd::ParseEffectSpec(spec);
    config.AddEffect(name, values);
  }
  std::vector<blmd::NoiseSpec> noise = blmd::ParseNoise(f.noises);
  blmd::InputSignal recorded;
  if (!f.input_path.empty()) {
    recorded = blmd::RecordedInput(blmd::ReadInputTrace(f.input_path, f.trace_flags), f.input_path,
                                   config);
  }
  if (f.input_path.empty()) config.experiment.CheckRunnable();  // the config's own time base
  blmd::CheckWritable(f.out_path);                              // before the run, not after it
  blmd::Trace trace;
  const blmd::SimStatus status = f.input_path.empty()
                                     ? blmd::RunExperiment(config, &trace)
                                     : blmd::RunRecordedInput(config, recorded, &trace);
  if (!status.ok()) {
    // A run the user asked for failed: exit 1, one line, nothing written.
    std::cerr << "error: " << blmd::SimulationFailureMessage(f.config_path, config, status) << "\n";
    return blmd::kExitFailed;
  }
  blmd::AddNoise(&noise, f.seed, &trace);
  trace.comments.push_back("blmd-sim " + std::string(blmd::kVersion) + " model=" +
                           std::string(config.model->name()) + " config=" + f.config_path);
  for (const auto& name : config.effects) trace.comments.push_back("effect " + name);
  for (const auto& [column, sigma, relative] : noise) {
    trace.comments.push_back("noise " + column + " sigma=" + blmd::FormatNumber(sigma) +
                             " seed=" + std::to_string(f.seed));
  }
  blmd::WriteTraceCsv(trace, f.out_path);
  if (!f.quiet) PrintSummary(f, config, trace);
  return blmd::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"blmd-sim: simulate a model of a drive and write a trace CSV"};
  blmd::app::AddVersionFlag(app, "blmd-sim");
  blmd::app::AddHelpFooter(app, "blmd-sim");
  SimFlags flags;
  flags.Add(app);
  return blmd::app::Main(app, argc, argv, [&]() -> int { return Run(app, flags); });
}
