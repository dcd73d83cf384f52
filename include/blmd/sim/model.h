// A model is a const description: its parameters, outputs and equations. Simulate() reads
// values from a ParameterSet and never mutates the model, so one model serves every thread.
#pragma once

#include <cstddef>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "blmd/sim/experiment.h"
#include "blmd/sim/linear_model.h"
#include "blmd/sim/parameters.h"
#include "blmd/sim/trace.h"

namespace blmd {

// How a simulation ended: a status value, never an exception (the caller decides).
struct SimStatus {
  enum class Code { kOk, kDiverged, kInvalidParameters };
  Code code = Code::kOk;
  std::string message;   // empty when kOk
  double at_time = 0.0;  // s, where it went wrong

  bool ok() const { return code == Code::kOk; }
  static SimStatus Ok() { return {}; }
};

// Everything one simulation needs; all pointers are borrowed for the call only.
struct SimulationRequest {
  const ParameterSet* parameters = nullptr;
  const std::vector<std::string>* effects = nullptr;  // enabled effect names
  const Experiment* experiment = nullptr;             // input, closed loop, initial state
  SimulationSettings settings;
  // Output instants (s), strictly increasing; the run starts at sample_times.front().
  const std::vector<double>* sample_times = nullptr;
};

// What the rest of the code asks of a model besides its equations (the code asks
// the model, never its name).
struct ModelTraits {
  // The input u is the drive torque (or force) itself, in N·m (rigid_load): the equation
  // error (inverse dynamics) applies and the measured torque balance ranks cogging orders.
  // Otherwise u is a voltage (V) and the drive torque is a state of the model.
  bool input_is_torque = false;
  // The experiments of a DC servo: a coast-down (coast_off_time) and closed-loop PID
  // position control (dc_servo).
  bool coast_down_and_pid = false;
  // Closed-loop control as a drive runs it (rigid_load, blmd): experiment.pid is a digital PI
  // speed loop, or a P position loop over it, sampled with a computation delay (PidSettings).
  bool sampled_pid = false;
  // The drive carries its own current loops (blmd: compensators and PWM): experiment.pid's
  // current_bandwidth does not apply, and CurrentLoopBandwidthHz gives the loops' bandwidth.
  bool own_current_loop = false;
  // The input's range when the drive states one (blmd: a torque demand linear in ±10 V, the
  // analogue interface of the paper's drive, docs/model-blmd.md); 0: none stated.
  double input_limit = 0.0;
  // The steady-state and coast-down estimators of Ganesh et al. (2012), method classic.
  bool classic_estimators = false;
  // A config's experiment without a duration (s) or sample rate (Hz) gets these.
  double default_duration = 1.0;
  double default_sample_rate = 10000.0;
  // simulation.method "events" (the switching instants located, docs/model-blmd.md §9) is
  // implemented; otherwise only "fixed_euler".
  bool event_integrator = false;
  // The observed columns when the config's identification names none.
  std::vector<std::string> default_observe;
  // The measured column whose multiple by Kt is the drive torque (dc_servo: the armature
  // current i); empty when the model has none (its input is the torque, or it states no torque
  // constant). What the feed-forward's drive input and the online tracker read.
  std::string torque_current_column;
};

class Model {
 public:
  virtual ~Model() = default;
  virtual std::string_view name() const = 0;
  // The model's own parameters (effects bring theirs, see effects.h).
  virtual const std::vector<ParamInfo>& parameters() const = 0;
  // Output columns written besides "t" and "u", e.g. {"i", "w", "theta"}.
  virtual std::vector<std::string> outputs() const = 0;
  // outputs() and the columns the `effects` add (EffectInfo::outputs: two_mass's load side).
  std::vector<std::string> OutputsWith(const std::vector<std::string>& effects) const;
  virtual SimulationSettings default_settings() const = 0;
  virtual ModelTraits traits() const = 0;
  // Returns an error message for values the model cannot run with (empty: fine).
  virtual std::string Validate(const ParameterSet& values,
                               const SimulationSettings& settings) const;
  // The checks every simulation starts with: the parameters valid for the settings
  // (Validate) and sample times to fill. ok() when the request can run.
  SimStatus CheckRequest(const SimulationRequest& request) const;
  // Fills *out with t, u and outputs() at the request's sample times.
  virtual SimStatus Simulate(const SimulationRequest& request, Trace* out) const = 0;
  // Simulates `count` parameter points at once: outs[k] and statuses[k] are what
  // Simulate(requests[k]) gives. The requests should differ only in their parameters; a
  // model with a batched path (blmd: parameter points in SIMD lanes) runs such points
  // together. The default simulates them one after the other.
  virtual void SimulateBatch(const SimulationRequest* requests, std::size_t count, Trace* outs,
                             SimStatus* statuses) const;
  // The largest drive torque a record shows, N·m, from the peaks of its current i_max (A),
  // input u_max and speed w_max (rad/s) at the parameters `values`: the scale of discovery's
  // search boxes (docs/discovery.md §2).
  virtual double DriveTorqueScale(const ParameterSet& values, double i_max, double u_max,
                                  double w_max) const = 0;

  // The linear part of the model at `values` (linear_model.h, docs/export.md): the model
  // without its effects, idealised where the page of the model says so.
  virtual LinearModel Linearise(const ParameterSet& values) const = 0;

  // The drive torque per unit of u with the shaft at rest (no back-EMF), N·m per unit of u:
  // what a designed input must reach to break the shaft away from its friction
  // (docs/design.md §7). 0 where it is not a constant of the parameters (the blmd's current
  // loops and PWM).
  virtual double StallTorquePerInput(const ParameterSet& /*values*/) const { return 0.0; }
  // The -3 dB bandwidth (Hz) of the drive's own current loop at `values` (own_current_loop),
  // as a first-order lag for the design of the loops around it; 0 for a model without one.
  virtual double CurrentLoopBandwidthHz(const ParameterSet& /*values*/) const { return 0.0; }
  // The highest speed (rad/s) at which the drive still has voltage to control its current
  // (blmd: the DC bus against the back-EMF); +inf when the model states none.
  virtual double SpeedLimit(const ParameterSet& /*values*/) const {
    return std::numeric_limits<double>::infinity();
  }

  const ParamInfo* FindParameter(std::string_view name) const;
};

// The one registry of models, sorted by name. FindModel throws InputError listing the
// valid names when `name` is unknown.
const std::vector<const Model*>& ModelRegistry();
const Model& FindModel(std::string_view name);

}  // namespace blmd
