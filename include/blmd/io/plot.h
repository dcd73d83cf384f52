// SVG plots shared by blmd-surface --svg and the HTML report (docs/plots.md).
// Self-contained SVG text: no script, no external font or stylesheet.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "blmd/ident/surface.h"

namespace blmd {

struct SurfacePlotOptions {
  std::string title;                  // e.g. "blmd-d31x: cost over J, B (observe i)"
  std::vector<std::string> units;     // one per axis, e.g. "kg·m²"
  std::string value_label = "cost (normalised MSE)";
  int width = 720, height = 540;      // px
};

// 2-D: heat map of log10(cost) with contour lines, axis ticks and labels with units, a
// colour bar, the grid minimum marked and local minima marked. 1-D: the cost curve on a
// log axis with its local minima and the global minimum labelled.
// Non-finite points are drawn as gaps (hatched cells in 2-D).
std::string SurfaceSvg(const std::vector<GridAxis>& axes, const std::vector<SurfacePoint>& points,
                       const std::vector<std::size_t>& minima, const SurfacePlotOptions& options);

}  // namespace blmd
