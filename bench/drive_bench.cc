// Into the drive (docs/export.md §6-7): the cost of one update of the online J tracker and of
// one evaluation of the feed-forward, as the C the export writes runs them (the same
// arithmetic, here the library's C++ in double), on a rigid shaft with Coulomb friction and
// cogging, 1 kHz, over a 4096-sample torque square wave replayed in a loop.
//
//   build/bin/blmd_bench --benchmark_filter='BM_Tracker|BM_FeedForward' \
//       --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "tune/compensation.h"
#include "tune/inertia_tracker.h"

namespace {

blmd::Compensation Shaft() {
  blmd::Compensation model;
  model.torque_per_input = 0.5;
  model.torque_is_command = true;
  for (const char* name : {"J", "B", "dB", "Cd", "Tc", "Ts", "ws", "TL", "Tcog", "periods", "phase",
                           "K", "theta0", "Tg", "gravity_phase"}) {
    model.values[name] = blmd::ExportedValue{};
  }
  model.values["J"] = {1e-3, true, true, true, 0.99e-3, 1.01e-3, "kg·m²", "inertia"};
  model.values["B"].value = 0.02;
  model.values["Tc"].value = 0.05;
  model.values["Tcog"].value = 0.01;
  model.values["periods"].value = 6.0;
  model.Refresh();
  return model;
}

struct Signal {
  std::vector<double> torque, w, theta;
};

Signal Record() {
  Signal s;
  double w = 0.0, theta = 0.0;
  for (int k = 0; k < 4096; ++k) {
    const double u = (k / 250) % 2 == 0 ? 1.0 : -1.0;
    w += 1e-3 * (0.5 * u - 0.02 * w) / 1e-3;
    theta += 1e-3 * w;
    s.torque.push_back(0.5 * u);
    s.w.push_back(w + 0.01 * std::sin(0.37 * k));
    s.theta.push_back(theta);
  }
  return s;
}

void BM_TrackerUpdate(benchmark::State& state) {
  const blmd::Compensation model = Shaft();
  const blmd::TrackerSeed seed = blmd::MakeTrackerSeed(model, {}, 1e-3, 0.01);
  blmd::InertiaTracker tracker(model, seed);
  const Signal s = Record();
  std::size_t k = 0;
  for (auto _ : state) {
    tracker.Update(s.torque[k], s.w[k], s.theta[k]);
    benchmark::DoNotOptimize(tracker.J());
    k = (k + 1) % s.torque.size();
  }
}
BENCHMARK(BM_TrackerUpdate)->Unit(benchmark::kNanosecond);

void BM_FeedForward(benchmark::State& state) {
  const blmd::Compensation model = Shaft();
  const Signal s = Record();
  std::size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(model.Torque(s.theta[k], s.w[k], 100.0));
    k = (k + 1) % s.torque.size();
  }
}
BENCHMARK(BM_FeedForward)->Unit(benchmark::kNanosecond);

}  // namespace
