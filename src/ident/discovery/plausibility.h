// Physical plausibility of the position-dependent candidates (private to ident/discovery;
// docs/discovery.md §2, "Plausibility"), and the measured motion it reads.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "blmd/ident/fit/problem.h"
#include "blmd/sim/parameters.h"

namespace blmd::internal {

// Physical plausibility of a position-dependent torque (spring, gravity) at standstill
// (docs/discovery.md §2, "Plausibility"). Where the measured shaft is held still, nothing
// accelerates it, so the drive torque balances every torque that acts there:
//   T_drive = T_position(theta) + T_other(theta) + f,  |f| <= Tc + Ts (static friction).
// A spring or gravity torque that the drive does not hold where the shaft rests is not on
// the shaft: a free rotor's residual taken up by a slow position function (a spring whose
// rest angle lies turns away, gravity on a rotor that rests anywhere with no torque).
struct StillRun {
  double theta = 0.0;  // the run's mean measured angle, rad (m)
  double drive = 0.0;  // its mean measured drive (u, or i for dc_servo)
};

// The trace's measured speed: its w column, else the central differences of `theta` (the
// measured angle, MeasuredAngle), the ends repeating their neighbours.
std::vector<double> MeasuredSpeed(const FitTrace& trace, const std::vector<double>& theta);

// The median fraction of a revolution the shaft turns between two samples in motion; 0 when
// it does not move.
double TurnsBetweenSamples(const FitProblem& problem);

// The runs of at least 0.1 s and 20 samples over which the measured speed stays within 2 % of
// the record's top speed `w_max` (a quantised angle's derivative dithers about zero there).
std::vector<StillRun> StandstillRuns(const FitProblem& problem, double w_max);

// Empty when the candidate's torque is held where the shaft rests; else why not
// (HeldAtStandstill in plausibility.cc gives the rule).
std::string HeldAtStandstill(const std::vector<StillRun>& runs, const ParameterSet& values,
                             const std::vector<std::string>& effects, const std::string& candidate,
                             bool torque_input, double torque_scale);

// HeldAtStandstill as a candidate plan's constraint: the rest runs of `problem` found once, the
// candidate's torque checked against them at each refit's values.
std::function<std::string(const ParameterSet&)> HeldAtStandstillCheck(const FitProblem& problem,
                                                                      double w_max,
                                                                      double torque_scale,
                                                                      const std::string& candidate);

}  // namespace blmd::internal
