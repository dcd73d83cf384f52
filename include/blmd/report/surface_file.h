// The surface CSV (docs/surfaces.md): '#' metadata lines that identify the sweep (tool
// version, config and trace hashes, observed columns, grid), an optional shard line, the
// header P[,Q],mse_<col>...,cost, one row per grid point in grid order (first axis
// outermost). A point whose simulation failed has cost "inf" and empty mse fields.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "blmd/ident/fit/surface.h"

namespace blmd {

struct SurfaceMetadata {
  std::vector<std::string> lines;  // without the shard line, without "# "
  int shard_index = 1, shard_count = 1;
};

std::string FormatSurfaceCsv(const SurfaceMetadata& metadata, const std::vector<GridAxis>& axes,
                             const std::vector<std::string>& observe,
                             const std::vector<SurfacePoint>& points);

// A surface CSV read back (ReadSurfaceCsv): what `blmd-surface plot` draws.
struct SurfaceFile {
  // The '#' lines without "# " and without the shard line, in file order; shard K/N from
  // the "# shard: K/N" line (1/1 when there is none).
  SurfaceMetadata metadata;
  std::string model;                 // from "# model: NAME"; empty when the line is absent
  std::vector<GridAxis> axes;        // from the "# grid: SPEC" lines, in order (1 or 2)
  std::vector<std::string> observe;  // from "# observe: a,b"
  // The rows in file order. Coordinates are the exact grid values; a failed point ("inf")
  // has evaluation.ok = false, cost = +inf and no mse.
  std::vector<SurfacePoint> points;
  std::vector<std::size_t> grid_indices;  // row-major grid index of each row
  std::size_t grid_size = 0;              // points of the whole grid (product of the counts)
  bool is_shard() const { return metadata.shard_count > 1; }
};

// Reads a surface CSV written by blmd-surface (unsharded, merged, or one shard). Strict:
// the '#' lines must give the observed columns and 1 or 2 grid axes, the header must be
// the one they imply, every row must hold the next grid point of the file's slice of the
// grid (coordinates equal to the grid values to 1e-9 relative), finite mse values >= 0
// and a finite cost >= 0, or "inf" for a failed point; the row count must be the slice's.
// Every problem is an InputError naming file:line[:column].
SurfaceFile ReadSurfaceCsv(const std::string& path);
// The same on text; `path` only labels errors.
SurfaceFile ParseSurfaceCsv(const std::string& text, const std::string& path);

// The whole grid in row-major order (as ComputeSurface gives an unsharded run and as
// LocalMinima expects): the file's points at their grid indices, every point the file lacks
// (outside a shard's slice) with evaluation.ok = false and cost NaN. On an unsharded file
// this is the file's points unchanged.
std::vector<SurfacePoint> SurfaceGridPoints(const SurfaceFile& file);

// Joins shard files into the unsharded CSV text; throws InputError when the parts do not
// belong to one sweep, overlap, or miss a shard.
std::string MergeSurfaceParts(const std::vector<std::string>& paths);

}  // namespace blmd
