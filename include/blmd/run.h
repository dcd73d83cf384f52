// Running a config's experiment, and the figures a control engineer reads off a response.
#pragma once

#include <string>
#include <vector>

#include "blmd/io/config.h"
#include "blmd/sim/model.h"
#include "blmd/sim/trace.h"

namespace blmd {

// Simulates config.experiment at its own sample times; `input` (optional) replaces the
// experiment's input signal.
SimStatus RunExperiment(const Config& config, Trace* out, const InputSignal* input = nullptr);

// Simulates the config's model driven by a recorded input (`recorded.kind` kRecorded: its
// times, its u held between them, its open-armature switch if any), sampled at the recorded
// instants (blmd-sim --input). The config's experiment gives the rest (initial state, PID).
// InputError when the recorded span is too long for the step (RunLengthError).
SimStatus RunRecordedInput(const Config& config, const InputSignal& recorded, Trace* out);

// Step-response figures of y(t) towards its final value (the mean of the last 2 % of the
// samples), from y(t[0]).
struct StepMetrics {
  bool valid = false;  // false when y never moves
  double final_value = 0.0;
  double rise_time = 0.0;  // s, 10 % to 90 % of the change
  double overshoot_percent = 0.0;
  double settling_time = 0.0;  // s, after which |y - final| stays within 2 % of the change
};
StepMetrics ComputeStepMetrics(const std::vector<double>& t, const std::vector<double>& y,
                               double t_step = 0.0);

}  // namespace blmd
