// Private: how the summary and the warnings write a number.
#pragma once

#include <cmath>
#include <string>

#include "blmd/io/csv.h"

namespace blmd::internal {

// `digits` significant digits (printf's %g), "n/a" when not finite.
inline std::string Figure(double v, int digits = 5) {
  return std::isfinite(v) ? FormatSignificant(v, digits) : std::string("n/a");
}

}  // namespace blmd::internal
