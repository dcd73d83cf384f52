// blmd-sim: simulate the configured model and experiment, write a trace CSV.
#include <cmath>
#include <cstdio>
#include <iostream>

#include "../common/app_main.h"
#include "../common/trace_flags.h"
#include "blmd/io/config.h"
#include "blmd/io/csv.h"
#include "blmd/io/files.h"
#include "blmd/io/flags.h"
#include "blmd/random.h"
#include "blmd/run.h"

namespace {

std::string Fixed(double value, int digits = 4) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*g", digits, value);
  return buffer;
}

// Every flag of blmd-sim (docs/cli.md §1).
struct SimFlags {
  std::string config_path, out_path, input_path;
  std::vector<std::string> effects, noises;
  std::uint64_t seed = 1;
  bool quiet = false;
  blmd::app::DialectFlags trace_flags;  // for --input

  void Add(CLI::App& app) {
    app.add_option("--config", config_path, "model and experiment (JSON)")->required();
    app.add_option("--out", out_path, "trace CSV to write")->required();
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
  }
};

// --noise NAME=SIGMA (absolute, column units) or NAME=P% (P % of the column's peak |value|).
struct NoiseSpec {
  std::string column;
  double sigma = 0.0;
  bool relative = false;
};

std::vector<NoiseSpec> ParseNoise(const std::vector<std::string>& specs) {
  std::vector<NoiseSpec> noise;
  for (const auto& spec : specs) {
    NoiseSpec n;
    std::string text = spec;
    if (!text.empty() && text.back() == '%') {
      n.relative = true;
      text.pop_back();
    }
    const auto assignment = blmd::ParseAssignment(text, "--noise");
    if (assignment.second < 0.0) {
      throw blmd::InputError("--noise " + assignment.first + ": sigma must be >= 0");
    }
    if (assignment.first == "t" || assignment.first == "open") {
      // Noise on the time would make it go backwards; "open" is a switch, not a signal.
      throw blmd::InputError("--noise " + assignment.first + ": '" + assignment.first +
                             "' takes no noise (time must increase); noise an output column");
    }
    n.column = assignment.first;
    n.sigma = n.relative ? assignment.second / 100.0 : assignment.second;
    noise.push_back(n);
  }
  return noise;
}

// The --input trace as a recorded input signal (t, u, and the open-armature switch if any).
blmd::InputSignal ReadRecordedInput(const SimFlags& f, const blmd::Config& config) {
  blmd::CsvReadOptions options;
  options.required = {"t", "u"};
  options.strict_columns = {"t", "u", "open"};  // other columns may hold text
  options.delimiter = f.trace_flags.Delimiter();
  options.duplicate_time = f.trace_flags.Duplicates();
  const blmd::Trace input = blmd::ReadTraceCsv(f.input_path, options);
  blmd::InputSignal recorded;
  recorded.kind = blmd::InputSignal::Kind::kRecorded;
  recorded.times = input.Column("t");
  recorded.values = input.Column("u");
  if (input.Has("open")) recorded.open = input.Column("open");
  if (const std::string error = blmd::RunLengthError(recorded.times.back() - recorded.times.front(),
                                                     config.simulation.dt, 0.0);
      !error.empty()) {
    throw blmd::InputError(f.input_path + ": " + error);
  }
  return recorded;
}

// Adds the noise to the simulated columns (sigma of a relative spec scaled by the peak).
void AddNoise(std::vector<NoiseSpec>* noise, std::uint64_t seed, blmd::Trace* trace) {
  for (auto& [column, sigma, relative] : *noise) {
    if (!trace->Has(column)) {
      throw blmd::InputError("--noise: no output column '" + column +
                             "' (have: " + blmd::Join(trace->names(), ",") + ")");
    }
    if (relative) {
      double peak = 0.0;
      for (double v : trace->Column(column)) peak = std::max(peak, std::abs(v));
      sigma *= peak;
    }
  }
  blmd::Random random(seed);
  for (const auto& [column, sigma, relative] : *noise) {
    for (double& value : trace->Column(column)) {
      value += sigma * random.Normal();
      if (!std::isfinite(value)) {  // sigma near the double range: never write inf
        throw blmd::InputError("--noise " + column + "=" + blmd::FormatNumber(sigma) +
                               ": the noisy '" + column +
                               "' is not finite (sigma too large for a double)");
      }
    }
  }
}

// A run the user asked for failed: exit 1, one line, nothing written.
int ReportFailedRun(const std::string& config_path, const blmd::Config& config,
                    const blmd::SimStatus& status) {
  std::cerr << "error: " << config_path << ": " << status.message
            << " at t = " << Fixed(status.at_time) << " s";
  if (status.code == blmd::SimStatus::Code::kDiverged) {
    std::cerr << "; the step simulation.dt = " << blmd::FormatNumber(config.simulation.dt)
              << " s may be too large for the model's fastest dynamics, or a parameter is "
                 "unphysical: reduce dt or check the parameters";
  }
  std::cerr << "\n";
  return blmd::kExitFailed;
}

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
    const auto metrics = blmd::ComputeStepMetrics(trace.Column("t"), trace.Column("theta"),
                                                  config.experiment.input.t0);
    if (metrics.valid) {
      std::printf(
          "  closed loop: rise time (10-90 %%) %s s, overshoot %s %%, settling (2 %%) %s s\n",
          Fixed(metrics.rise_time).c_str(), Fixed(metrics.overshoot_percent).c_str(),
          Fixed(metrics.settling_time).c_str());
    } else {
      std::printf("  closed loop: theta did not respond (no step metrics)\n");
    }
  }
}

int Run(SimFlags& f) {
  blmd::CheckOutputs({{"--out", f.out_path}},
                     {{"--config", f.config_path}, {"--input", f.input_path}});
  blmd::Config config = blmd::LoadConfig(f.config_path);
  for (const auto& spec : f.effects) {
    const auto [name, values] = blmd::ParseEffectSpec(spec);
    config.AddEffect(name, values);
  }
  std::vector<NoiseSpec> noise = ParseNoise(f.noises);
  blmd::InputSignal recorded;
  if (!f.input_path.empty()) recorded = ReadRecordedInput(f, config);
  if (f.input_path.empty()) config.experiment.CheckRunnable();  // the config's own time base
  blmd::CheckWritable(f.out_path);                              // before the run, not after it
  blmd::Trace trace;
  const blmd::SimStatus status = f.input_path.empty()
                                     ? blmd::RunExperiment(config, &trace)
                                     : blmd::RunRecordedInput(config, recorded, &trace);
  if (!status.ok()) return ReportFailedRun(f.config_path, config, status);
  AddNoise(&noise, f.seed, &trace);
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
  CLI::App app{"blmd-sim: simulate a dc_servo or blmd model and write a trace CSV"};
  blmd::app::AddVersionFlag(app, "blmd-sim");
  SimFlags flags;
  flags.Add(app);
  return blmd::app::Main(app, argc, argv, [&]() -> int { return Run(flags); });
}
