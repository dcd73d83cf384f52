// The reading of a sampled drive's controller (experiment.pid of rigid_load and blmd: the
// inner speed PI, the limits, the controller's rate, delay, current loop and notch), split from
// config.cc, which calls it.
#pragma once

#include "blmd/sim/experiment.h"
#include "io/json_reader.h"

namespace blmd {

// Reads the sampled loop's keys of experiment.pid into *out (dt: the simulation's step, which
// the controller's period must be a whole number of); fails at the key's line and column.
void ReadSampledPid(const json_reader::Reader& reader, const nlohmann::json& pid, double dt,
                    PidSettings* out);

// Reads sample_rate (Hz, default 1/dt) and delay (samples, default 1) of any model's digital
// controller into *out.
void ReadControllerRate(const json_reader::Reader& reader, const nlohmann::json& pid, double dt,
                        PidSettings* out);

}  // namespace blmd
