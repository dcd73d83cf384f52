// Experiment design speed (docs/design.md §6): one candidate's prediction (its response and the
// 2p central-difference neighbours, p = 2 free parameters) and the whole search of blmd-design
// over the four families, on the Ganesh DC servo (2 s at 2 kHz, dt = 10 µs).
//
//   build/bin/blmd_bench --benchmark_filter='BM_Design' --benchmark_repetitions=5 \
//       --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <string>

#include "blmd/ident/experiment_design/experiment_design.h"
#include "blmd/io/config.h"

namespace {

blmd::DesignProblem Ganesh() {
  blmd::DesignProblem problem = blmd::MakeDesignProblem(
      blmd::LoadConfig(std::string(BLMD_SOURCE_DIR) + "/configs/ganesh-square.json"));
  problem.sigma = {0.014, 2.5};
  return problem;
}

blmd::ExperimentDesignOptions Options(int threads) {
  blmd::ExperimentDesignOptions options;
  options.duration = 2.0;
  options.sample_rate = 2000.0;
  options.input_limit = 12.0;
  options.threads = threads;
  return options;
}

// One candidate: the config's square wave, simulated, checked and predicted (5 simulations).
void BM_DesignCandidate(benchmark::State& state) {
  const blmd::DesignProblem problem = Ganesh();
  blmd::DesignCandidate square;
  square.family = "square";
  square.input = problem.config.experiment.input;
  for (auto _ : state) {
    const blmd::DesignCandidate c = blmd::EvaluateCandidate(problem, Options(1), square);
    benchmark::DoNotOptimize(c.criterion);
  }
}
BENCHMARK(BM_DesignCandidate)->Unit(benchmark::kMillisecond);

// The search of `blmd-design --duration 2 --limit u=12` (every family, both refinements) on
// state.range(0) threads.
void BM_DesignSearch(benchmark::State& state) {
  const blmd::DesignProblem problem = Ganesh();
  long evaluated = 0;
  for (auto _ : state) {
    const blmd::ExperimentDesignResult result =
        blmd::SearchDesign(problem, Options(static_cast<int>(state.range(0))));
    evaluated = result.evaluated;
    benchmark::DoNotOptimize(result.best.criterion);
  }
  state.counters["candidates"] = static_cast<double>(evaluated);
}
BENCHMARK(BM_DesignSearch)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
