// blmd-tune's outputs (docs/tuning.md §5, schema/tune.schema.json): the JSON report, the
// human summary, and the closed-loop config that blmd-sim runs (--write-config). Rendering
// only: every figure was computed by Tune (tune/tune.h).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "blmd/tune/tune.h"

namespace blmd {

// The tuning report's schema version (schema/tune.schema.json).
inline constexpr int kTuneReportSchemaVersion = 1;

// The JSON report of a tuning that was not refused.
nlohmann::json TuneReportJson(const TuneInput& input, const TuneRequest& request,
                              const TuneResult& result);

// The summary printed on stdout: the gains, the achieved margins, the step nominal and worst
// case, the warnings.
std::string TuneSummary(const TuneInput& input, const TuneRequest& request,
                        const TuneResult& result);

// The input config's document with the tuned plant's parameters and effects and the
// experiment replaced by the tuned loop's step (experiment.pid with its loop, gains, tau_d and
// u_max; the step, duration and sample rate of the checked step), provenance under "notes".
// blmd-sim runs it and prints the same step figures (docs/tuning.md §6).
nlohmann::json ClosedLoopConfigJson(const TuneInput& input, const TuneRequest& request,
                                    const TuneResult& result);

}  // namespace blmd
