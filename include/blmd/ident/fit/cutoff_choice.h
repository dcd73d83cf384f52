// The equation error's cut-off, chosen where the estimates do not move with it
// (docs/identification.md §8a). The equation error differentiates the measured motion: with
// a quantised angle differentiated twice, the acceleration's noise grows with the fifth power
// of the low-pass cut-off, and a noisy regressor biases J towards zero (errors in variables:
// the estimate is attenuated by Var(noise) / Var(measured acceleration); Söderström,
// "Errors-in-variables methods in system identification", Automatica 43, 2007, §2). Below the
// motion's own band the filter removes what the fit needs, and a friction's sign is smeared.
// Between the two the estimates form a plateau, which a ladder of cut-offs an octave apart
// finds: the fit at each, neighbours that agree (EstimatesAgree), the longest run of them,
// and its highest cut-off.
#pragma once

#include <string>
#include <vector>

#include "blmd/ident/fit/fit_result.h"

namespace blmd {

// The fit at one cut-off of the ladder.
struct CutoffLevel {
  double hz = 0.0;
  bool ok = false;     // the fit ran (a cut-off too low for the record's length fails)
  std::string reason;  // why not
  std::vector<ParameterEstimate> estimates;
  bool agrees_below = false;  // its estimates agree with the next lower level's
};

struct CutoffChoice {
  bool ran = false;
  double sample_hz = 0.0;
  double chosen_hz = 0.0;
  bool user_set = false;            // --filter-hz or identification.filter_hz
  bool plateau = false;             // some neighbouring levels agree
  double stable_low_hz = 0.0;       // the plateau the choice rests on (or, for a user's cut-off,
  double stable_high_hz = 0.0;      // the highest plateau of the ladder)
  bool sensitive = false;           // the cut-off used lies off the plateau: its estimates move
  std::string reason;               // one line: which cut-off and why
  std::vector<CutoffLevel> levels;  // highest cut-off first
};

// Whether two fits' estimates agree: every parameter that the record determines (a white-noise
// 95 % half-width within 50 % of its value) within kCutoffRelativeTolerance of its value.
// Two fits of one record at neighbouring cut-offs share its noise, so their difference is
// mostly the cut-off's bias, far below what two independent records would scatter: an octave
// that moves J by more than 2 % is off the plateau. Intervals do not set the tolerance:
// before discovery the model's misfit widens them (to +-100 % of J on a record with
// friction), and any bias would fit inside.
inline constexpr double kCutoffRelativeTolerance = 0.02;
bool EstimatesAgree(const std::vector<ParameterEstimate>& a,
                    const std::vector<ParameterEstimate>& b);

// The ladder's levels for a record sampled at `sample_hz`: sample_hz / 10 halved `count`
// times, highest first, and the user's cut-off in its place when `user_hz` > 0.
std::vector<double> CutoffLadder(double sample_hz, double user_hz, int count = 6);

// Fills agrees_below and the choice from levels whose fits are set: the plateau is the
// longest run of consecutive agreeing levels (ties: the highest); the default is its highest
// cut-off (none: sample_hz / 10, as before); a user's cut-off is kept and marked sensitive
// when it disagrees with both neighbours or lies above the plateau.
void DecideCutoff(CutoffChoice* choice);

}  // namespace blmd
