// A guard for a local fit that stopped in a side valley (docs/identification.md §2a). A local
// method (Ceres, BOBYQA) finds the minimum of the basin it starts in; a cost with several
// basins (the BLMD drive's phase current is periodic in the rotor angle, so a start 15 %
// off in J already sits in another one) can leave it on a bound or at an NRMSE far above the
// data's noise. When the fit looks like that, a low-discrepancy scan of the bounds box finds
// the best start points, the same method is run again from the few best, and the fit with
// the lowest cost is kept (only when it is lower by more than 1 %, so that the choice never
// hinges on the last bits of the data).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "blmd/ident/optimizers/optimizer.h"

namespace blmd {

struct StartScanRecord {
  bool ran = false;
  std::string reason;         // why the first fit looked stuck ("" when it did not)
  int points = 0;             // scan points evaluated (Halton sequence over the scaled box)
  int restarts = 0;           // local fits from the best of them
  bool improved = false;      // a restart replaced the first fit
  double nrmse_final = 0.0;   // of the fit kept (the first fit's is in `reason` when it set it)
  std::vector<double> start;  // the start of the fit kept, physical units (when improved)
};

// Why `fit` of `problem` may have stopped in a side valley, or "" when it looks settled: its
// cost is not finite, a free parameter sits on a bound, or its NRMSE exceeds both 0.1 and 3x
// the data's noise floor (NoiseFloorNrmse, fit/noise_floor.h).
std::string SideValleyReason(const FitProblem& problem, const FitResult& fit);

// `optimizer` on `problem`, then, when SideValleyReason says so, the scan and the restarts.
// The result is the best fit found, its summary counting every evaluation made; `record`
// (may be null) says what ran.
FitResult MinimizeWithStartScan(const Optimizer& optimizer, const FitProblem& problem,
                                const OptimizerOptions& options, StartScanRecord* record);

// A positive parameter without bounds in the config is searched over three decades either side
// of its start (Config::Bounds): a start written for another machine (a 20 g rotor fitted from
// a config made for a 10 kg axis) can put the optimum outside that range, and the fit then
// stops on an end of it. Such an end is not evidence: when the fit stops on an end of a range
// that the config did not give and that lies inside the model's own limits, the range is
// moved to three decades either side of that end and the fit repeated from it (at most
// kMaxRangeMoves times). The moved fit is kept only when every moved parameter ends inside its
// new range with a cost lower by more than 1 %; otherwise nothing changes and the report's
// parameter_at_bound says what to do (docs/identification.md §2b).
struct RangeShift {
  std::string name;
  double from_lower = 0.0, from_upper = 0.0;  // the default range the first fit stopped on
  double to_lower = 0.0, to_upper = 0.0;      // the range of the fit kept
};

struct RangeMove {
  std::unique_ptr<FitProblem> problem;  // the problem with the moved ranges (null: none kept)
  FitResult fit;                        // its fit (with the start scan's guard)
  StartScanRecord start_scan;           // the guard's record of that fit
  std::vector<RangeShift> shifts;       // one per moved parameter
};

inline constexpr int kMaxRangeMoves = 2;

// The moved fit of `problem` after `fit`, or a RangeMove whose `problem` is null when no
// parameter stopped on a movable default end or moving did not free it.
RangeMove MoveDefaultRanges(const Optimizer& optimizer, const FitProblem& problem,
                            const FitResult& fit, const OptimizerOptions& options);

}  // namespace blmd
