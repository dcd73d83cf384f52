// Internal helpers of the SVG plots (src/report/svg/plot.cc): "nice" axis ticks, compact number
// labels and min/max decimation. Exposed for tests only.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace blmd::internal {

struct Tick {
  double value = 0.0;  // data units
  bool major = true;   // majors are longer and keep their label first when space is short
  std::string label;   // empty: an unlabelled tick
};

// Step of 1, 2 or 5 times a power of ten giving about `target` intervals over [low, high].
double NiceStep(double low, double high, int target);
// The multiples of NiceStep inside [low, high] (ends included within 1e-9 of a step),
// computed as exact decimal values (3 * 2e-4 is 6e-4, not 6.000000000000001e-4).
std::vector<double> NiceLinearTicks(double low, double high, int target);

// Labelled ticks of a linear axis. All labels of one axis share one style: exponent form
// ("2.5e-3") when the largest |tick| is below 1e-2 or at least 1e4, fixed otherwise, with
// just enough digits to tell neighbours apart.
std::vector<Tick> LinearAxisTicks(double low, double high, int target);
// Ticks of a log axis (0 < low < high): decades as labelled majors (every n-th decade if
// there are more than `target`), 2x and 5x sub-ticks as minors, labelled when the range
// spans at most 2.5 decades. With fewer than two decades inside: the 1-2-5 values if at
// least three fall inside, else every m x 10^k (m = 1..9) if three do, else linear ticks.
std::vector<Tick> LogAxisTicks(double low, double high, int target);

// Compact label: "0", "0.25", "150", "1.2e-3", "2.5e4"; `significant` digits at most,
// trailing zeros dropped. Non-finite values give "-" (never "nan" or "inf").
std::string FormatValue(double value, int significant = 3);

// Indices of the samples to draw for (x[i], y[i]) when x is mapped to pixel columns by
// column_of(x) (floored): per column the first, last, lowest and highest finite sample, and
// the first sample with a non-finite x or y (which breaks the line), in index order.
// At most five samples per column survive, so extremes (spikes) are kept. If the finite x
// are not non-decreasing, every index is returned (no decimation).
std::vector<std::size_t> DecimateMinMax(const std::vector<double>& x, const std::vector<double>& y,
                                        const std::function<double(double)>& column_of);

}  // namespace blmd::internal
