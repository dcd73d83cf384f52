// The controller that puts the open loop's gain crossover at a requested frequency with a
// requested phase margin (docs/tuning.md §2): the point L(jω_c) = C(jω_c)·G(jω_c) placed on the
// unit circle at e^{j(φ_m − 180°)} (Åström & Hägglund, PID Controllers: Theory, Design, and
// Tuning, 2nd ed., 1995, ch. 4, the modified Ziegler–Nichols method that moves one point of
// the Nyquist curve; Åström & Murray, Feedback Systems, 2008, ch. 11 "Frequency Domain
// Design", loop shaping).
//  - speed loop: PI, C = kp + ki/s, two gains for the two conditions (gain and phase at ω_c);
//  - position loop: PID with the derivative filtered at f_d = filter_ratio·f_c and the
//    integral time Ti = integral_ratio·Td (Ti = 4·Td, the ratio of the Ziegler–Nichols rules
//    and of Åström & Hägglund's modified method), which leaves Td and the gain for the two
//    conditions: a quadratic in ω_c·Td with one positive root.
#pragma once

#include <limits>
#include <string>

#include "blmd/sim/experiment.h"
#include "blmd/sim/linear_model.h"
#include "blmd/tune/loop.h"

namespace blmd {

struct ControllerDesignOptions {
  PidSettings::Loop loop = PidSettings::Loop::kPosition;
  double crossover_hz = 0.0;      // f_c, > 0
  double phase_margin_deg = 0.0;  // φ_m, in (0°, 90°)
  double integral_ratio = 4.0;    // PID: Ti/Td, > 0
  double filter_ratio = 10.0;     // PID: f_d/f_c, > 1
  // "" when the options can be used, else what is wrong (one line).
  std::string Validate() const;
};

struct ControllerDesignResult {
  bool ok = false;
  // Why the controller cannot give the request on this plant (ok false): the phase the
  // controller would need at f_c, what the structure can give, and the highest crossover at
  // which it can still give the phase margin.
  std::string reason;
  Controller controller;
  double plant_gain = std::numeric_limits<double>::quiet_NaN();            // |G(jω_c)|
  double plant_phase_deg = std::numeric_limits<double>::quiet_NaN();       // arg G(jω_c)
  double controller_phase_deg = std::numeric_limits<double>::quiet_NaN();  // arg C(jω_c) needed
  // The largest phase (lead) and smallest (lag) the structure gives at ω_c, degrees.
  double max_controller_phase_deg = std::numeric_limits<double>::quiet_NaN();
  double min_controller_phase_deg = std::numeric_limits<double>::quiet_NaN();
};

// The gains for `plant` (u -> w for the speed loop, u -> theta for the position loop).
ControllerDesignResult DesignController(const TransferFunction& plant,
                                        const ControllerDesignOptions& options);

}  // namespace blmd
