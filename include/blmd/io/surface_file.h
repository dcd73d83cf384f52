// The surface CSV (docs/surfaces.md): '#' metadata lines that identify the sweep (tool
// version, config and trace hashes, observed columns, grid), an optional shard line, the
// header P[,Q],mse_<col>...,cost, one row per grid point in grid order (first axis
// outermost). A point whose simulation failed has cost "inf" and empty mse fields.
#pragma once

#include <string>
#include <vector>

#include "blmd/ident/surface.h"

namespace blmd {

struct SurfaceMetadata {
  std::vector<std::string> lines;  // without the shard line, without "# "
  int shard_index = 1, shard_count = 1;
};

std::string FormatSurfaceCsv(const SurfaceMetadata& metadata, const std::vector<GridAxis>& axes,
                             const std::vector<std::string>& observe,
                             const std::vector<SurfacePoint>& points);

// Joins shard files into the unsharded CSV text; throws InputError when the parts do not
// belong to one sweep, overlap, or miss a shard.
std::string MergeSurfaceParts(const std::vector<std::string>& paths);

}  // namespace blmd
