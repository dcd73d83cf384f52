// Work against precision of the blmd integrators (docs/performance.md §7): the
// 160 ms run of configs/blmd-d31x.json with the fixed backward-Euler step (dt = 1, 0.5, 0.2,
// 0.1 µs) and with the events method (max_step = Tpwm/2 ... Tpwm/64), side by side in one
// run. Each benchmark's counters give the relative RMS error of the sampled phase current
// (err_i) and speed (err_w) against the converged reference, the same model at the fixed
// step dt = 0.02 µs (8 million steps; computed once and cached in the build folder,
// events-reference-d31x.bin), and (err_i_x, err_w_x) against Richardson's extrapolation
// 2 x(0.02 µs) - x(0.04 µs) of the first-order fixed step.
//
//   build/bin/blmd_bench --benchmark_filter=BM_BlmdWorkPrecision \
//       --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "blmd/io/config.h"
#include "blmd/sim/blmd/blmd_drive.h"

namespace {

constexpr double kReferenceDt = 2e-8;  // s

blmd::Config BundledStep() {
  return blmd::LoadConfig(std::string(BLMD_SOURCE_DIR) + "/configs/blmd-d31x.json");
}

blmd::Trace Run(const blmd::Config& config, const blmd::SimulationSettings& settings) {
  const std::vector<double> times = config.experiment.SampleTimes();
  blmd::SimulationRequest request;
  request.parameters = &config.parameters;
  request.effects = &config.effects;
  request.experiment = &config.experiment;
  request.settings = settings;
  request.sample_times = &times;
  blmd::Trace trace;
  const blmd::SimStatus status = config.model->Simulate(request, &trace);
  if (!status.ok()) std::fprintf(stderr, "simulation failed: %s\n", status.message.c_str());
  return trace;
}

struct Reference {
  std::vector<double> i, w;  // dt = 0.02 µs
  // Richardson's extrapolation of the first-order fixed step, 2 x(0.02 µs) - x(0.04 µs): its
  // O(dt) error term removed (a closer view of the events method's own error).
  std::vector<double> i_extrapolated, w_extrapolated;
};

// The dt = 0.02 µs and 0.04 µs runs, from the cache when it is there (a binary file of the
// sample count and the four columns), else computed (a few seconds) and cached.
const Reference& ReferenceRun() {
  static const Reference reference = [] {
    Reference r;
    const blmd::Config config = BundledStep();
    const std::size_t n = config.experiment.SampleTimes().size();
    std::vector<std::vector<double>*> columns = {&r.i, &r.w, &r.i_extrapolated, &r.w_extrapolated};
    const std::string path = std::string(BLMD_BIN_DIR) + "/../events-reference-d31x.bin";
    std::ifstream in(path, std::ios::binary);
    std::size_t stored = 0;
    if (in && in.read(reinterpret_cast<char*>(&stored), sizeof stored) && stored == n) {
      for (std::vector<double>* column : columns) {
        column->resize(n);
        in.read(reinterpret_cast<char*>(column->data()),
                static_cast<std::streamsize>(n * sizeof(double)));
      }
      if (in) return r;
    }
    blmd::SimulationSettings settings = config.simulation;
    settings.method = blmd::SimulationMethod::kFixedEuler;
    settings.dt = kReferenceDt;
    const blmd::Trace fine = Run(config, settings);
    settings.dt = 2.0 * kReferenceDt;
    const blmd::Trace coarse = Run(config, settings);
    r.i = fine.Column("i");
    r.w = fine.Column("w");
    r.i_extrapolated = r.i;
    r.w_extrapolated = r.w;
    for (std::size_t k = 0; k < n; ++k) {
      r.i_extrapolated[k] = 2.0 * r.i[k] - coarse.Column("i")[k];
      r.w_extrapolated[k] = 2.0 * r.w[k] - coarse.Column("w")[k];
    }
    std::ofstream cache(path, std::ios::binary);
    cache.write(reinterpret_cast<const char*>(&n), sizeof n);
    for (const std::vector<double>* column : columns) {
      cache.write(reinterpret_cast<const char*>(column->data()),
                  static_cast<std::streamsize>(n * sizeof(double)));
    }
    return r;
  }();
  return reference;
}

// RMS(x - ref) / RMS(ref).
double RelativeRms(const std::vector<double>& x, const std::vector<double>& ref) {
  double error = 0.0, scale = 0.0;
  for (std::size_t k = 0; k < ref.size() && k < x.size(); ++k) {
    error += (x[k] - ref[k]) * (x[k] - ref[k]);
    scale += ref[k] * ref[k];
  }
  return x.size() == ref.size() ? std::sqrt(error / scale) : INFINITY;
}

// Args: method (0 fixed_euler, 1 events), step in ns (dt, or max_step).
void BM_BlmdWorkPrecision(benchmark::State& state) {
  const blmd::Config config = BundledStep();
  blmd::SimulationSettings settings = config.simulation;
  const double step = static_cast<double>(state.range(1)) * 1e-9;
  if (state.range(0) == 0) {
    settings.method = blmd::SimulationMethod::kFixedEuler;
    settings.dt = step;
  } else {
    settings.method = blmd::SimulationMethod::kEvents;
    settings.max_step = step;
  }
  const Reference& reference = ReferenceRun();
  const blmd::Trace first = Run(config, settings);
  state.counters["err_i"] = RelativeRms(first.Column("i"), reference.i);
  state.counters["err_w"] = RelativeRms(first.Column("w"), reference.w);
  state.counters["err_i_x"] = RelativeRms(first.Column("i"), reference.i_extrapolated);
  state.counters["err_w_x"] = RelativeRms(first.Column("w"), reference.w_extrapolated);
  const std::vector<double> times = config.experiment.SampleTimes();
  blmd::SimulationRequest request;
  request.parameters = &config.parameters;
  request.effects = &config.effects;
  request.experiment = &config.experiment;
  request.settings = settings;
  request.sample_times = &times;
  blmd::Trace trace;
  for (auto _ : state) {
    const blmd::SimStatus status = config.model->Simulate(request, &trace);
    if (!status.ok()) {
      state.SkipWithError(status.message.c_str());
      break;
    }
    benchmark::DoNotOptimize(trace.Column("i").data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_BlmdWorkPrecision)
    ->ArgNames({"events", "step_ns"})
    ->Args({0, 1000})
    ->Args({0, 500})
    ->Args({0, 200})
    ->Args({0, 100})
    ->Args({1, 100000})
    ->Args({1, 50000})
    ->Args({1, 25000})
    ->Args({1, 12500})
    ->Args({1, 6250})
    ->Args({1, 3125})
    ->Unit(benchmark::kMillisecond);

}  // namespace
