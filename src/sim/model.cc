#include "blmd/sim/model.h"

#include <cmath>

#include "blmd/error.h"
#include "blmd/sim/blmd/blmd_drive.h"
#include "blmd/sim/dc_servo/dc_servo.h"
#include "blmd/sim/effects.h"
#include "blmd/sim/rigid_load/rigid_load.h"

namespace blmd {

std::vector<std::string> Model::OutputsWith(const std::vector<std::string>& effects) const {
  std::vector<std::string> out = outputs();
  for (const std::string& name : effects) {
    for (const EffectInfo& info : EffectRegistry()) {
      if (info.name == name) out.insert(out.end(), info.outputs.begin(), info.outputs.end());
    }
  }
  return out;
}

std::string Model::Validate(const ParameterSet& values, const SimulationSettings& settings) const {
  for (const auto& info : parameters()) {
    if (!values.Has(info.name)) return "missing parameter '" + info.name + "'";
    const double v = values.Get(info.name);
    if (!std::isfinite(v)) return "parameter '" + info.name + "' is not finite";
    if (info.positive && !(v > 0.0)) return "parameter '" + info.name + "' must be > 0";
    if (info.non_negative && v < 0.0) return "parameter '" + info.name + "' must be >= 0";
  }
  if (!(settings.dt > 0.0) || !std::isfinite(settings.dt)) return "simulation.dt must be > 0";
  return {};
}

void Model::SimulateBatch(const SimulationRequest* requests, std::size_t count, Trace* outs,
                          SimStatus* statuses) const {
  for (std::size_t k = 0; k < count; ++k) statuses[k] = Simulate(requests[k], &outs[k]);
}

SimStatus Model::CheckRequest(const SimulationRequest& request) const {
  if (std::string error = Validate(*request.parameters, request.settings); !error.empty()) {
    return {SimStatus::Code::kInvalidParameters, error, 0.0};
  }
  if (request.sample_times->empty()) {
    return {SimStatus::Code::kInvalidParameters, "no sample times", 0.0};
  }
  return {};
}

const ParamInfo* Model::FindParameter(std::string_view name) const {
  for (const auto& info : parameters()) {
    if (info.name == name) return &info;
  }
  return nullptr;
}

const std::vector<const Model*>& ModelRegistry() {
  static const DcServoModel dc_servo;
  static const BlmdDriveModel blmd_drive;
  static const RigidLoadModel rigid_load;
  static const std::vector<const Model*> registry = {&blmd_drive, &dc_servo, &rigid_load};
  return registry;
}

const Model& FindModel(std::string_view name) {
  for (const Model* model : ModelRegistry()) {
    if (model->name() == name) return *model;
  }
  std::string valid;
  for (const Model* model : ModelRegistry()) {
    valid += (valid.empty() ? "" : ", ") + std::string(model->name());
  }
  throw InputError("unknown model '" + InputError::Excerpt(std::string(name)) +
                   "' (valid: " + valid + ")");
}

}  // namespace blmd
