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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"blmd-sim: simulate a dc_servo or blmd model and write a trace CSV"};
  blmd::app::AddVersionFlag(app, "blmd-sim");
  std::string config_path, out_path, input_path;
  std::vector<std::string> effects, noises;
  std::uint64_t seed = 1;
  bool quiet = false;
  app.add_option("--config", config_path, "model and experiment (JSON)")->required();
  app.add_option("--out", out_path, "trace CSV to write")->required();
  app.add_option("--effect", effects,
                 "add an undeclared effect, NAME:KEY=VALUE[,KEY=VALUE...] (repeatable)");
  app.add_option(
      "--noise", noises,
      "white Gaussian noise on a column, NAME=SIGMA or NAME=P% of its peak (repeatable)");
  app.add_option("--seed", seed, "noise seed (default 1)")
      ->check(blmd::app::NonNegativeWholeNumber());
  blmd::app::DialectFlags trace_flags;  // for --input
  trace_flags.Add(app);
  app.add_option("--input", input_path, "drive the model with the u column of this trace");
  app.add_flag("--quiet", quiet, "print nothing on success");

  return blmd::app::Main(app, argc, argv, [&]() -> int {
    blmd::CheckOutputs({{"--out", out_path}}, {{"--config", config_path}, {"--input", input_path}});
    blmd::Config config = blmd::LoadConfig(config_path);
    for (const auto& spec : effects) {
      const auto [name, values] = blmd::ParseEffectSpec(spec);
      config.AddEffect(name, values);
    }
    // --noise NAME=SIGMA (absolute, column units) or NAME=P% (P % of the column's peak |value|).
    struct NoiseSpec {
      std::string column;
      double sigma = 0.0;
      bool relative = false;
    };
    std::vector<NoiseSpec> noise;
    for (const auto& spec : noises) {
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
    blmd::InputSignal recorded;
    if (!input_path.empty()) {
      blmd::CsvReadOptions options;
      options.required = {"t", "u"};
      options.strict_columns = {"t", "u", "open"};  // other columns may hold text
      options.delimiter = trace_flags.Delimiter();
      options.duplicate_time = trace_flags.Duplicates();
      const blmd::Trace input = blmd::ReadTraceCsv(input_path, options);
      recorded.kind = blmd::InputSignal::Kind::kRecorded;
      recorded.times = input.Column("t");
      recorded.values = input.Column("u");
      if (input.Has("open")) recorded.open = input.Column("open");
      // The run covers the recorded span at the recorded instants.
      config.experiment.duration = recorded.times.back() - recorded.times.front();
      if (const std::string error =
              blmd::RunLengthError(config.experiment.duration, config.simulation.dt, 0.0);
          !error.empty()) {
        throw blmd::InputError(input_path + ": " + error);
      }
    }
    if (input_path.empty()) config.experiment.CheckRunnable();  // the config's own time base
    blmd::CheckWritable(out_path);                              // before the run, not after it
    blmd::Trace trace;
    blmd::SimStatus status;
    if (input_path.empty()) {
      status = blmd::RunExperiment(config, &trace);
    } else {
      blmd::Experiment experiment = config.experiment;
      experiment.input = recorded;
      blmd::SimulationRequest request;
      request.parameters = &config.parameters;
      request.effects = &config.effects;
      request.experiment = &experiment;
      request.settings = config.simulation;
      request.sample_times = &recorded.times;
      status = config.model->Simulate(request, &trace);
    }
    if (!status.ok()) {
      // A run the user asked for failed: exit 1, one line, nothing written.
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
    for (auto& [column, sigma, relative] : noise) {
      if (!trace.Has(column)) {
        std::string have;
        for (const auto& name : trace.names()) have += (have.empty() ? "" : ",") + name;
        throw blmd::InputError("--noise: no output column '" + column + "' (have: " + have + ")");
      }
      if (relative) {
        double peak = 0.0;
        for (double v : trace.Column(column)) peak = std::max(peak, std::abs(v));
        sigma *= peak;
      }
    }
    blmd::Random random(seed);
    for (const auto& [column, sigma, relative] : noise) {
      for (double& value : trace.Column(column)) {
        value += sigma * random.Normal();
        if (!std::isfinite(value)) {  // sigma near the double range: never write inf
          throw blmd::InputError("--noise " + column + "=" + blmd::FormatNumber(sigma) +
                                 ": the noisy '" + column +
                                 "' is not finite (sigma too large for a double)");
        }
      }
    }
    trace.comments.push_back("blmd-sim " + std::string(blmd::kVersion) + " model=" +
                             std::string(config.model->name()) + " config=" + config_path);
    for (const auto& name : config.effects) trace.comments.push_back("effect " + name);
    for (const auto& [column, sigma, relative] : noise) {
      trace.comments.push_back("noise " + column + " sigma=" + blmd::FormatNumber(sigma) +
                               " seed=" + std::to_string(seed));
    }
    blmd::WriteTraceCsv(trace, out_path);
    if (quiet) return blmd::kExitOk;

    std::cout << "blmd-sim: " << config.model->name() << " '" << config.name << "', "
              << trace.rows() << " samples over " << Fixed(trace.Column("t").back()) << " s -> "
              << out_path << "\n";
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
    return blmd::kExitOk;
  });
}
