// The config every --write-config writes (blmd-ident, blmd-tune, blmd-design): the user's own
// config document (unknown keys kept) patched in the same three places, so that blmd-sim and
// blmd-ident read it back as the config it came from with the new values.
#pragma once

#include <nlohmann/json.hpp>

#include "blmd/io/config.h"

namespace blmd {

// The config's own document (an empty object when it has none) with its model named.
nlohmann::json ConfigDocumentOf(const Config& config);

// "parameters" replaced by the model's parameters at `values`, "effects" by each of the
// config's effects with its parameters at `values` (the key removed when there is none).
void SetModelValues(const Config& config, const ParameterSet& values, nlohmann::json* doc);

// "notes" set to `notes` (the provenance), the config's own notes kept under "config_notes";
// then the whole document sanitised (no NaN or infinity written).
void SetNotes(const Config& config, nlohmann::json notes, nlohmann::json* doc);

}  // namespace blmd
