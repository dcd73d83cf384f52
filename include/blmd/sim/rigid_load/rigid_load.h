// The shaft alone (docs/model-rigid-load.md): a rigid inertia driven by a torque (or force)
// input, with the shared effects. For rigs whose drive torque is measured or commanded
// (current-controlled drives: u = current with Kt the torque constant), and for linear
// axes: read J as the mass M (kg), B as the viscous coefficient (N·s/m), torques as forces
// (N), w as the velocity (m/s) and theta as the position (m).
//
//   J dw/dt   = Kt u - B w - T_effects      (T_effects: effects.h)
//   dtheta/dt = w
//
// States w (rad/s), theta (rad). Input u: torque in N·m when Kt = 1 (the default), or any
// signal proportional to it (a current in A with Kt in N·m/A). Outputs: t, u, w, theta.
// Closed loop (experiment.pid): the drive's digital speed PI, or a position P over it,
// sampled with a computation delay and a first-order current loop (PidSettings); outputs
// then also r, the reference.
// Numerics: exact zero-order-hold discretisation over each step dt (as dc_servo), with the
// effects' torque held over the step; Coulomb/Stribeck friction sticks at rest.
#pragma once

#include "blmd/sim/model.h"

namespace blmd {

class RigidLoadModel final : public Model {
 public:
  std::string_view name() const override { return "rigid_load"; }
  const std::vector<ParamInfo>& parameters() const override;
  std::vector<std::string> outputs() const override { return {"w", "theta"}; }
  SimulationSettings default_settings() const override;
  ModelTraits traits() const override;
  SimStatus Simulate(const SimulationRequest& request, Trace* out) const override;
  LinearModel Linearise(const ParameterSet& values) const override;
  // max(Kt u_max, B w_max): the drive torque, or the damping torque at the top speed when
  // the shaft moves without a drive (a coast-down, u = 0).
  double DriveTorqueScale(const ParameterSet& values, double i_max, double u_max,
                          double w_max) const override;
  // At rest, u is the torque command: Kt.
  double StallTorquePerInput(const ParameterSet& values) const override;

 private:
  // experiment.pid: the drive's digital PI speed loop or P-over-PI cascade (PidSettings).
  SimStatus SimulateClosedLoop(const SimulationRequest& request, Trace* out) const;
};

}  // namespace blmd
