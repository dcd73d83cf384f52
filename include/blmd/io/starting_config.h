// The starting config of a model (blmd-sim --init-config MODEL, docs/cli.md §1.1): a config
// that the commands accept as it is, with every parameter of the model at its typical value
// (ParamInfo::typical), a default simulation step, an experiment that excites J and B, and
// an identification of J and B. Units, descriptions, sign rules and default ranges of the
// parameters, and the effects the model can carry, go under "notes", the one key of a config
// that takes any JSON and that the commands do not interpret (docs/config.md).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "blmd/sim/model.h"

namespace blmd {

// The starting config of `model` as JSON, keys in the order of docs/config.md.
nlohmann::ordered_json StartingConfig(const Model& model);

// The same as text, for the model named `model`, laid out as the bundled configs are: an
// object or array on one line when it fits in 100 characters, else one member a line, two
// spaces a level; a final newline. Throws InputError listing the valid models when the name
// is unknown.
std::string StartingConfigText(std::string_view model);

}  // namespace blmd
