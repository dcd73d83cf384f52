// Simulator speed: one whole experiment per iteration, as identification runs it (every cost
// evaluation is one such run). Counters: `steps` per run and `ns_per_step` (CPU time of one
// run / steps). Each model is measured on its fast path (Simulate, what everything uses) and
// on its reference path (SimulateReference, the straightforward loop kept as the truth).
// Targets: blmd <= 10 ns per 1 µs step, dc_servo <= 5 ns per step, one core.
//
//   build/bin/blmd_bench --benchmark_filter='BM_(Blmd|DcServo)' \
//       --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
// or scripts/bench (one table of medians).
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>

#include "blmd/io/config.h"
#include "blmd/sim/blmd/blmd_drive.h"
#include "blmd/sim/dc_servo/dc_servo.h"
#include "sim/blmd/blmd_batch.h"

namespace {

blmd::Config LoadBundled(const std::string& name) {
  return blmd::LoadConfig(std::string(BLMD_SOURCE_DIR) + "/configs/" + name);
}

enum class Path { kFast, kReference };

template <typename ModelT>
void RunConfig(benchmark::State& state, const blmd::Config& config, Path path) {
  const auto& model = dynamic_cast<const ModelT&>(*config.model);
  const std::vector<double> times = config.experiment.SampleTimes();
  blmd::SimulationRequest request;
  request.parameters = &config.parameters;
  request.effects = &config.effects;
  request.experiment = &config.experiment;
  request.settings = config.simulation;
  request.sample_times = &times;
  const double steps = std::round((times.back() - times.front()) / config.simulation.dt);
  blmd::Trace trace;
  for (auto _ : state) {
    const blmd::SimStatus status = path == Path::kFast ? model.Simulate(request, &trace)
                                                       : model.SimulateReference(request, &trace);
    if (!status.ok()) {
      state.SkipWithError(status.message.c_str());
      break;
    }
    benchmark::DoNotOptimize(trace.Column("i").data());
    benchmark::ClobberMemory();
  }
  state.counters["steps"] = steps;
  // CPU time per step in ns (kIsIterationInvariantRate | kInvert gives seconds per step).
  state.counters["ns_per_step"] = benchmark::Counter(
      steps * 1e-9, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

// The reference run: configs/blmd-d31x.json, 1 V torque-demand step, 160 ms at
// dt = 1 µs (160 000 steps), outputs at 50 kHz.
void BM_BlmdDefaultRun(benchmark::State& state) {
  RunConfig<blmd::BlmdDriveModel>(state, LoadBundled("blmd-d31x.json"), Path::kFast);
}
BENCHMARK(BM_BlmdDefaultRun)->Unit(benchmark::kMillisecond);

void BM_BlmdDefaultRunReference(benchmark::State& state) {
  RunConfig<blmd::BlmdDriveModel>(state, LoadBundled("blmd-d31x.json"), Path::kReference);
}
BENCHMARK(BM_BlmdDefaultRunReference)->Unit(benchmark::kMillisecond);

// The same without regula falsi (the comparator sampled at step ends).
void BM_BlmdDefaultRunNoRegulaFalsi(benchmark::State& state) {
  blmd::Config config = LoadBundled("blmd-d31x.json");
  config.simulation.regula_falsi = false;
  RunConfig<blmd::BlmdDriveModel>(state, config, Path::kFast);
}
BENCHMARK(BM_BlmdDefaultRunNoRegulaFalsi)->Unit(benchmark::kMillisecond);

// The same with the diagnostics columns (phase voltages, neutral, torque).
void BM_BlmdDefaultRunDiagnostics(benchmark::State& state) {
  blmd::Config config = LoadBundled("blmd-d31x.json");
  config.simulation.diagnostics = true;
  RunConfig<blmd::BlmdDriveModel>(state, config, Path::kFast);
}
BENCHMARK(BM_BlmdDefaultRunDiagnostics)->Unit(benchmark::kMillisecond);

// The batched path (BlmdDriveModel::SimulateBatch): 8 parameter points of the 160 ms run in
// SIMD lanes, as a surface chunk has them (J 1.19e-3, B log-spaced over 1e-4 .. 1e-3; a
// second set with J over +-20 % as well). Arg 0: the instruction set (0 scalar: the points one
// after the other on the fast path, 1 baseline SSE2, 2 AVX2, 3 AVX-512; skipped when the CPU
// lacks it); arg 1: the point set. Counter `ns_per_step_point` = CPU time / (steps x 8).
void BM_BlmdBatchRun(benchmark::State& state) {
  const auto isa = static_cast<blmd::internal::BatchIsa>(state.range(0));
  const blmd::internal::BatchIsa chosen = blmd::internal::ChosenBatchIsa();
  if (!blmd::internal::ForceBatchIsa(isa)) {
    state.SkipWithError("this CPU lacks the instruction set");
    return;
  }
  state.SetLabel(blmd::internal::BatchIsaName(isa));
  const blmd::Config config = LoadBundled("blmd-d31x.json");
  const auto& model = dynamic_cast<const blmd::BlmdDriveModel&>(*config.model);
  const std::vector<double> times = config.experiment.SampleTimes();
  constexpr int kPoints = blmd::internal::kMaxBatchLanes;
  std::vector<blmd::ParameterSet> points(kPoints, config.parameters);
  std::vector<blmd::SimulationRequest> requests(kPoints);
  for (int k = 0; k < kPoints; ++k) {
    const double f = k / (kPoints - 1.0);
    points[k].Set("B", 1e-4 * std::pow(10.0, f));
    if (state.range(1) == 1) points[k].Set("J", 1.19e-3 * (0.8 + 0.4 * f));
    requests[k].parameters = &points[k];
    requests[k].effects = &config.effects;
    requests[k].experiment = &config.experiment;
    requests[k].settings = config.simulation;
    requests[k].sample_times = &times;
  }
  std::vector<blmd::Trace> outs(kPoints);
  std::vector<blmd::SimStatus> statuses(kPoints);
  for (auto _ : state) {
    model.SimulateBatch(requests.data(), kPoints, outs.data(), statuses.data());
    if (!statuses[0].ok()) {
      state.SkipWithError(statuses[0].message.c_str());
      break;
    }
    benchmark::DoNotOptimize(outs[0].Column("i").data());
    benchmark::ClobberMemory();
  }
  blmd::internal::ForceBatchIsa(chosen);
  const double steps = std::round((times.back() - times.front()) / config.simulation.dt);
  state.counters["ns_per_step_point"] =
      benchmark::Counter(steps * kPoints * 1e-9, benchmark::Counter::kIsIterationInvariantRate |
                                                     benchmark::Counter::kInvert);
}
BENCHMARK(BM_BlmdBatchRun)
    ->ArgsProduct({{0, 1, 2, 3}, {0}})
    ->Args({3, 1})
    ->Unit(benchmark::kMillisecond);

// DC servo, configs/ganesh-noload.json: 24 V step, 1 s at dt = 10 µs (100 000 steps).
void BM_DcServoNoLoadRun(benchmark::State& state) {
  RunConfig<blmd::DcServoModel>(state, LoadBundled("ganesh-noload.json"), Path::kFast);
}
BENCHMARK(BM_DcServoNoLoadRun)->Unit(benchmark::kMillisecond);

void BM_DcServoNoLoadRunReference(benchmark::State& state) {
  RunConfig<blmd::DcServoModel>(state, LoadBundled("ganesh-noload.json"), Path::kReference);
}
BENCHMARK(BM_DcServoNoLoadRunReference)->Unit(benchmark::kMillisecond);

// The linear run above takes macro steps (docs/performance.md); this one steps one 10 µs step
// at a time: configs/ganesh-square.json (+-24 V square, 2 s, 200 000 steps, 2 kHz out) with
// Coulomb friction, whose sign makes every step its own.
blmd::Config SquareWithCoulombFriction() {
  blmd::Config config = LoadBundled("ganesh-square.json");
  config.effects.push_back("coulomb_friction");
  config.parameters.Set("Tc", 0.012);
  return config;
}

void BM_DcServoSquareCoulombRun(benchmark::State& state) {
  RunConfig<blmd::DcServoModel>(state, SquareWithCoulombFriction(), Path::kFast);
}
BENCHMARK(BM_DcServoSquareCoulombRun)->Unit(benchmark::kMillisecond);

void BM_DcServoSquareCoulombRunReference(benchmark::State& state) {
  RunConfig<blmd::DcServoModel>(state, SquareWithCoulombFriction(), Path::kReference);
}
BENCHMARK(BM_DcServoSquareCoulombRunReference)->Unit(benchmark::kMillisecond);

}  // namespace
