// Units hints (docs/identification.md §5, warning units_suspect): a trace whose speed is in
// rpm or deg/s, whose angle is in degrees or revolutions, or whose current is in mA, while
// the model works in rad/s, rad and A. Two signs, both measured against what the config
// implies:
//  - a measured column that is, sample by sample, a known unit factor times the one the
//    model simulates at the config's values (or at the fitted ones): the least-squares gain
//    g = sum(m s) / sum(s^2) lies within 20 % of the factor, and m ~ g s explains at least
//    90 % of the column's power (uncentred R^2), so the shape agrees and only the scale is
//    off;
//  - a fitted back-EMF constant (a parameter in V·s/rad: Kb, Ke) that is the config's
//    divided by the factor (within 20 %): the fit absorbed a speed in other units.
// A hint names the --scale flag that converts the column. Output-error fits only (with the
// equation error the recorded input is compared, not the motion).
#pragma once

#include <string>
#include <vector>

#include "blmd/ident/fit/problem.h"

namespace blmd {

struct UnitsHint {
  std::string column;      // the measured column: "w", "theta" or "i"
  std::string unit;        // the unit it looks like: "rpm", "deg/s", "rev/s", "deg", "rev", "mA"
  std::string model_unit;  // the model's: "rad/s", "rad" or "A"
  double factor = 1.0;     // one model unit in that unit (rpm: 60/(2 pi) = 9.549)
  double observed = 0;     // the ratio seen (a gain, or config / fitted back-EMF constant)
  std::string evidence;    // what showed it, one phrase for the warning
  // "--scale w=0.10471975511965977": multiplies the column into the model's unit.
  std::string ScaleFlag() const;
};

// The hints for `problem` at its start values (the config's) and at `fitted` (the fit's free
// values, same order as problem.free()); at most one per column, empty when nothing points
// at another unit.
std::vector<UnitsHint> CheckUnits(const FitProblem& problem, const std::vector<double>& fitted);

}  // namespace blmd
