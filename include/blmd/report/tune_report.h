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

// The units of the gains: the model input's unit over the loop's output (rad, or rad/s),
// times s^k.
struct GainUnits {
  std::string kp, ki, kd;
};

// What blmd-tune reports about a tuning that was not refused, built once (MakeTuneReport) and
// rendered by to_json, TuneSummary and ClosedLoopConfigJson, as IdentReport is for
// blmd-ident.
struct TuneReport {
  TuneInput input;      // the plant: config, identified values, the 95 % box and its source
  TuneRequest request;  // the loop, crossover, phase margin, limits
  TuneResult result;    // the gains and every figure checked
  GainUnits units;      // of result.design.controller's kp, ki, kd
};

TuneReport MakeTuneReport(TuneInput input, TuneRequest request, TuneResult result);

// The JSON report (schema/tune.schema.json).
void to_json(nlohmann::json& out, const TuneReport& report);

// The summary printed on stdout: the gains, the achieved margins, the step nominal and worst
// case, the warnings.
std::string TuneSummary(const TuneReport& report);

// The input config's document with the tuned plant's parameters and effects and the
// experiment replaced by the tuned loop's step (experiment.pid with its loop, gains, tau_d and
// u_max; the step, duration and sample rate of the checked step), provenance under "notes".
// blmd-sim runs it and prints the same step figures (docs/tuning.md §6).
nlohmann::json ClosedLoopConfigJson(const TuneReport& report);

}  // namespace blmd
