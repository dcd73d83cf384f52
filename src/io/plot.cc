// Placeholder until the plotting module lands (the plotting helper replaces this file).
#include "blmd/io/plot.h"

namespace blmd {

std::string SurfaceSvg(const std::vector<GridAxis>&, const std::vector<SurfacePoint>&,
                       const std::vector<std::size_t>&, const SurfacePlotOptions&) {
  return "<svg xmlns=\"http://www.w3.org/2000/svg\"/>\n";
}

}  // namespace blmd
