#include "app/tune_run.h"

#include "blmd/error.h"
#include "blmd/io/config.h"
#include "io/flags.h"

namespace blmd {
namespace {

// --limit u=V, i=A; u defaults to the config's experiment.pid.u_max when it has a pid.
void ReadLimits(const TuneSettings& settings, const Config& config, TuneRequest* request) {
  for (const std::string& text : settings.limits) {
    const auto [name, value] = ParseAssignment(text, "--limit");
    if (name != "u" && name != "i") {
      throw InputError("--limit: unknown limit '" + InputError::Excerpt(name) +
                       "' (valid: u=VOLTS, i=AMPS)");
    }
    if (!(value > 0.0)) throw InputError("--limit " + text + ": the limit must be > 0");
    (name == "u" ? request->u_max : request->i_max) = value;
  }
  if (request->u_max > 0.0) return;
  if (!config.experiment.closed_loop) {
    throw InputError("--limit u=VOLTS is needed: the drive's voltage limit (" + config.path +
                     " has no experiment.pid.u_max)");
  }
  request->u_max = config.experiment.pid.u_max;
}

}  // namespace

TuneRequest MakeTuneRequest(const TuneSettings& settings, const Config& config) {
  TuneRequest request;
  const bool speed = settings.loop == "speed";
  if (speed) {
    if (settings.integral_ratio) {
      throw InputError(
          "--integral-ratio applies to the position loop's PID (the speed loop is "
          "a PI)");
    }
    if (settings.filter_ratio) {
      throw InputError(
          "--filter-ratio applies to the position loop's PID (the speed loop is a "
          "PI)");
    }
  }
  request.design.loop = speed ? PidSettings::Loop::kSpeed : PidSettings::Loop::kPosition;
  request.design.crossover_hz = settings.crossover_hz;
  request.design.phase_margin_deg = settings.phase_margin_deg;
  if (settings.integral_ratio) request.design.integral_ratio = *settings.integral_ratio;
  if (settings.filter_ratio) request.design.filter_ratio = *settings.filter_ratio;
  request.step = settings.step;
  request.duration = settings.duration;
  request.threads = settings.threads;
  ReadLimits(settings, config, &request);
  if (const std::string error = request.Validate(); !error.empty()) throw InputError(error);
  return request;
}

TuneReport RunTune(const std::string& config_path, const std::string& report_path,
                   const TuneSettings& settings) {
  TuneInput input = LoadTuneInput(config_path, report_path);
  TuneRequest request = MakeTuneRequest(settings, input.config);
  TuneResult result = Tune(input, request);
  return MakeTuneReport(std::move(input), std::move(request), std::move(result));
}

}  // namespace blmd
