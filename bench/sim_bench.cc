// Simulator speed: one whole experiment per iteration, as identification runs it (every cost
// evaluation is one such run). Counters: `steps` per run, `sec_per_step` (printed with an SI
// prefix, e.g. "62n" = 62 ns per integration step). The wall time per iteration is the time
// of one run. Target (issue): the 160 ms default blmd run at dt = 1 µs under 20 ms on one
// core in Release.
//
//   build/bin/blmd_bench --benchmark_filter='BM_(Blmd|DcServo)' \
//       --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>

#include "blmd/io/config.h"
#include "blmd/run.h"

namespace {

blmd::Config LoadBundled(const std::string& name) {
  return blmd::LoadConfig(std::string(BLMD_SOURCE_DIR) + "/configs/" + name);
}

void RunConfig(benchmark::State& state, const blmd::Config& config) {
  const double steps = std::round(config.experiment.duration / config.simulation.dt);
  blmd::Trace trace;
  for (auto _ : state) {
    const blmd::SimStatus status = blmd::RunExperiment(config, &trace);
    if (!status.ok()) {
      state.SkipWithError(status.message.c_str());
      break;
    }
    benchmark::DoNotOptimize(trace.Column("i").data());
    benchmark::ClobberMemory();
  }
  state.counters["steps"] = steps;
  state.counters["sec_per_step"] = benchmark::Counter(
      steps, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

// The reference run: configs/blmd-d31x.json, 1 V torque-demand step, 160 ms at
// dt = 1 µs (160 000 steps), outputs at 50 kHz.
void BM_BlmdDefaultRun(benchmark::State& state) {
  const blmd::Config config = LoadBundled("blmd-d31x.json");
  RunConfig(state, config);
}
BENCHMARK(BM_BlmdDefaultRun)->Unit(benchmark::kMillisecond);

// The same without regula falsi (the comparator sampled at step ends).
void BM_BlmdDefaultRunNoRegulaFalsi(benchmark::State& state) {
  blmd::Config config = LoadBundled("blmd-d31x.json");
  config.simulation.regula_falsi = false;
  RunConfig(state, config);
}
BENCHMARK(BM_BlmdDefaultRunNoRegulaFalsi)->Unit(benchmark::kMillisecond);

// The same with the diagnostics columns (phase voltages, neutral, torque).
void BM_BlmdDefaultRunDiagnostics(benchmark::State& state) {
  blmd::Config config = LoadBundled("blmd-d31x.json");
  config.simulation.diagnostics = true;
  RunConfig(state, config);
}
BENCHMARK(BM_BlmdDefaultRunDiagnostics)->Unit(benchmark::kMillisecond);

// DC servo, configs/ganesh-noload.json: 24 V step, 1 s at dt = 10 µs (100 000 steps).
void BM_DcServoNoLoadRun(benchmark::State& state) {
  const blmd::Config config = LoadBundled("ganesh-noload.json");
  RunConfig(state, config);
}
BENCHMARK(BM_DcServoNoLoadRun)->Unit(benchmark::kMillisecond);

}  // namespace
