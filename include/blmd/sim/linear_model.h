// The linear part of a model (docs/export.md): dx/dt = A·x + B·u, y = C·x + D·u from the
// input u, with every nonlinear or constant effect left out (friction, load, cogging, ...),
// and its transfer functions u -> y for each output. For controller design and for taking the
// identified model to MATLAB/Octave (blmd-ident --export-matlab).
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

namespace blmd {

struct LinearModel {
  bool available = false;
  std::string reason;                        // why there is none (available false)
  std::string input;                         // the input's name and unit, e.g. "u (V)"
  std::string assumption;                    // what is idealised or left out, one line
  std::vector<std::string> states, outputs;  // names of x and y (SI units of the columns)
  Eigen::MatrixXd A, B, C, D;
  // The shaft the drive's loops act on, when the states hold more than the rigid
  // J dw/dt = -B w + K u (rigid_load with two_mass: the motor, the load and the twist): J and B
  // the totals, K in N·m per unit of u, and the coupling (docs/effects.md, two_mass; ratio 0:
  // rigid). Absent: the first state's row is that shaft's (J = the values' J).
  struct Shaft {
    double J = 0.0, B = 0.0, K = 0.0;
    double inertia_ratio = 0.0, anti_resonance_hz = 0.0, shaft_damping_ratio = 0.0,
           load_damping_share = 0.0;
  };
  bool has_shaft = false;
  Shaft shaft;
};

class ParameterSet;

// The linear part of a shaft J dw/dt = -B w + K u, dtheta/dt = w, driven with
// `torque_per_input` N·m per unit of u; with a two-mass coupling among the values
// (docs/effects.md, two_mass) the motor, the load and the twist, [w, theta, w_load, twist],
// the measured w and theta the motor's (rigid_load, blmd). Sets states, outputs, A, B, C, D
// and, with the coupling, the shaft the tuning's loops act on; the caller names the input and
// the assumption.
void LinearShaft(const ParameterSet& values, double torque_per_input, LinearModel* model);

// G(s) = num(s)/den(s), coefficients in descending powers of s (MATLAB's tf order).
struct TransferFunction {
  std::string output;
  std::vector<double> numerator, denominator;
};

// The transfer function u -> y_k of every output: den(s) = det(sI - A) and
// num(s) = C_k·adj(sI - A)·B + D_k·den(s) by the Faddeev-LeVerrier recursion (exact for the
// small systems here, n <= 4), with common factors of s cancelled (an integrator that the
// output does not see) and the numerator's leading zeros dropped.
std::vector<TransferFunction> TransferFunctions(const LinearModel& model);

}  // namespace blmd
