// The drift guard (docs/export.md "Drift guard"): this identification's free parameters against
// those of a stored blmd-ident report (--baseline).
#pragma once

#include <string>

#include "blmd/report/report.h"

namespace blmd {

// Compares the report's final free parameters with those of a stored blmd-ident report
// (docs/export.md "Drift guard"). InputError (file, line, column) when the file is not a
// blmd-ident report of the same model.
BaselineReport CompareWithBaseline(const IdentReport& report, const std::string& baseline_path);

}  // namespace blmd
