// Numbers as text: the one family every output uses, each name saying what it prints.
//   FormatRoundTrip(v)        shortest text that reads back to the same double ("0.1", "1e-05")
//   FormatExact17(v)          %.17g, for scripts that re-read it ("0.10000000000000001")
//   FormatSignificant(v, d)   d significant digits, printf's %g ("500", "0.0009", "1.2e-05")
//   FormatSignificantOrWord(v, d)  the same, "infinite", "-infinite" or "n/a" when not finite
//   FormatReadable(v, d)      d significant digits, a compact exponent form only below 1e-3
//                             or from 1e6 ("0.0226", "2.2613e-5"); "n/a" when not finite
//   FormatFixedTrimmed(v, d)  at most d decimals, trailing zeros dropped ("1.5", "2"); a
//                             coordinate: never "nan" or "inf", clamped to ±1e6
//   DisplayNumber(v)          as a person writes it (0.0001 rather than 1e-04), round trip exact
#pragma once

#include <string>

namespace blmd {

std::string FormatRoundTrip(double value);
std::string FormatExact17(double value);
std::string FormatSignificant(double value, int digits);
std::string FormatSignificantOrWord(double value, int digits);
std::string FormatReadable(double value, int digits);
std::string FormatFixedTrimmed(double value, int decimals);
std::string DisplayNumber(double value);

// The same text as FormatRoundTrip (the name the trace and config writers use).
inline std::string FormatNumber(double value) { return FormatRoundTrip(value); }

}  // namespace blmd
