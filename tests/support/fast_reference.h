// A config's experiment simulated by a model's fast path (Simulate) and by its reference path
// (SimulateReference), for the tests that compare them (fast_path_test, inputs_test).
#pragma once

#include <vector>

#include "blmd/io/config.h"
#include "blmd/sim/model.h"
#include "blmd/sim/trace.h"

namespace blmd::testing {

struct FastAndReference {
  Trace fast, reference;
  SimStatus fast_status, reference_status;
};

template <typename ModelT>
FastAndReference RunFastAndReference(const Config& config) {
  const auto& model = dynamic_cast<const ModelT&>(*config.model);
  const std::vector<double> times = config.experiment.SampleTimes();
  SimulationRequest request;
  request.parameters = &config.parameters;
  request.effects = &config.effects;
  request.experiment = &config.experiment;
  request.settings = config.simulation;
  request.sample_times = &times;
  FastAndReference runs;
  runs.fast_status = model.Simulate(request, &runs.fast);
  runs.reference_status = model.SimulateReference(request, &runs.reference);
  return runs;
}

}  // namespace blmd::testing
