// Parsing of the small text forms the commands accept in flags (docs/cli.md).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "blmd/sim/parameters.h"

namespace blmd {

// A finite number written as text ("1e-3", "+2"; not "", "1x", "inf"): InputError
// "<context>: '<text>' is not a finite number" otherwise.
double ParseNumber(const std::string& text, const std::string& context);

// "NAME=VALUE" with a finite number; throws InputError naming the flag.
std::pair<std::string, double> ParseAssignment(const std::string& text, const std::string& flag);
// "NAME=TEXT"; throws InputError naming the flag.
std::pair<std::string, std::string> ParseTextAssignment(const std::string& text,
                                                        const std::string& flag);
// "coulomb_friction:Tc=0.01[,KEY=VALUE...]" -> effect name and its values, keyed by the
// parameters' flat names ("gravity:Tg=1,phase=0.3" sets Tg and gravity_phase).
std::pair<std::string, ParameterSet> ParseEffectSpec(const std::string& text);
// "J,B" -> {"J","B"} (empty items rejected).
std::vector<std::string> ParseNameList(const std::string& text, const std::string& flag);

}  // namespace blmd
