// The fleet's page, fleet.html (docs/fleet.md): one row per drive, those whose latest record
// failed or drifted first, with J and B over the drive's records against the baseline's 95 %
// band, the drift z, the latest message and a link to each record's report. Rendered from the
// table's lines (results.jsonl: the columns of app/fleet.h), nothing else.
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace blmd {

// The rows of the table and how they ended, for the page's heading.
struct FleetPageCounts {
  std::size_t rows = 0, ok = 0, drift = 0, error = 0;
};

std::string FleetHtml(const std::vector<nlohmann::json>& lines, const FleetPageCounts& counts);

}  // namespace blmd
