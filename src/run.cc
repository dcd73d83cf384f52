#include "blmd/run.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "blmd/error.h"

namespace blmd {

SimStatus RunExperiment(const Config& config, Trace* out, const InputSignal* input) {
  config.experiment.CheckRunnable();  // InputError when the config's run cannot be made
  Experiment experiment = config.experiment;
  if (input) experiment.input = *input;
  const std::vector<double> times = experiment.SampleTimes();
  SimulationRequest request;
  request.parameters = &config.parameters;
  request.effects = &config.effects;
  request.experiment = &experiment;
  request.settings = config.simulation;
  request.sample_times = &times;
  SimStatus status = config.model->Simulate(request, out);
  if (status.ok() && experiment.coast_off_time >= 0.0) {
    // Mark the open armature so that the trace replays correctly as a recorded input.
    std::vector<double> open(times.size());
    for (std::size_t k = 0; k < times.size(); ++k) {
      open[k] = times[k] >= experiment.coast_off_time ? 1.0 : 0.0;
    }
    out->Set("open", std::move(open));
  }
  return status;
}

SimStatus RunRecordedInput(const Config& config, const InputSignal& recorded, Trace* out) {
  Experiment experiment = config.experiment;
  experiment.input = recorded;
  // The run covers the recorded span at the recorded instants.
  experiment.duration = recorded.times.back() - recorded.times.front();
  if (const std::string error = RunLengthError(experiment.duration, config.simulation.dt, 0.0);
      !error.empty()) {
    throw InputError(error);
  }
  SimulationRequest request;
  request.parameters = &config.parameters;
  request.effects = &config.effects;
  request.experiment = &experiment;
  request.settings = config.simulation;
  request.sample_times = &recorded.times;
  return config.model->Simulate(request, out);
}

StepMetrics ComputeStepMetrics(const std::vector<double>& t, const std::vector<double>& y,
                               double t_step) {
  StepMetrics metrics;
  const std::size_t n = y.size();
  if (n < 10 || t.size() != n) return metrics;
  const std::size_t tail = std::max<std::size_t>(1, n / 50);
  double final_value = 0.0;
  for (std::size_t k = n - tail; k < n; ++k) final_value += y[k];
  final_value /= static_cast<double>(tail);
  std::size_t start = 0;
  while (start < n && t[start] < t_step) ++start;
  if (start >= n) return metrics;
  const double initial = y[start];
  const double change = final_value - initial;
  if (std::abs(change) <= 1e-12 * (std::abs(final_value) + 1.0)) return metrics;
  metrics.final_value = final_value;
  const double direction = change > 0.0 ? 1.0 : -1.0;
  auto fraction = [&](std::size_t k) { return (y[k] - initial) / change; };
  double t10 = -1.0, t90 = -1.0, peak = 0.0;
  for (std::size_t k = start; k < n; ++k) {
    const double f = fraction(k);
    if (t10 < 0.0 && f >= 0.1) t10 = t[k];
    if (t90 < 0.0 && f >= 0.9) t90 = t[k];
    peak = std::max(peak, f);
  }
  if (t10 < 0.0 || t90 < 0.0) return metrics;
  metrics.rise_time = t90 - t10;
  metrics.overshoot_percent = std::max(0.0, (peak - 1.0) * 100.0);
  std::size_t last_outside = start;
  for (std::size_t k = start; k < n; ++k) {
    if (std::abs(y[k] - final_value) > 0.02 * std::abs(change)) last_outside = k;
  }
  metrics.settling_time = (last_outside + 1 < n ? t[last_outside + 1] : t[n - 1]) - t[start];
  (void)direction;
  metrics.valid = true;
  return metrics;
}

}  // namespace blmd
