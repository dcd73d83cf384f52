#include "app/tune_run.h"

#include "blmd/error.h"
#include "blmd/io/config.h"
#include "io/flags.h"

namespace blmd {
namespace {

// rigid_load's --limit u=LOW:HIGH: an asymmetric drive (LOW < 0 < HIGH).
bool ReadAsymmetricLimit(const std::string& text, const Config& config, TuneRequest* request) {
  const auto [name, value] = ParseTextAssignment(text, "--limit");
  const auto colon = value.find(':');
  if (name != "u" || colon == std::string::npos) return false;
  if (!config.model->traits().sampled_pid) {
    throw InputError("--limit " + text + ": u=LOW:HIGH applies to models rigid_load and blmd");
  }
  const double low = ParseNumber(value.substr(0, colon), "--limit u (LOW)");
  const double high = ParseNumber(value.substr(colon + 1), "--limit u (HIGH)");
  if (!(low < 0.0 && high > 0.0)) {
    throw InputError("--limit " + text + ": LOW must be < 0 and HIGH > 0");
  }
  request->u_min = low;
  request->u_max = high;
  return true;
}

// --limit u=V, i=A; u defaults to the config's experiment.pid.u_max when it has a pid.
void ReadLimits(const TuneSettings& settings, const Config& config, TuneRequest* request) {
  for (const std::string& text : settings.limits) {
    if (ReadAsymmetricLimit(text, config, request)) continue;
    const auto [name, value] = ParseAssignment(text, "--limit");
    if (name != "u" && name != "i") {
      throw InputError("--limit: unknown limit '" + InputError::Excerpt(name) +
                       "' (valid: u=VOLTS, i=AMPS)");
    }
    if (!(value > 0.0)) throw InputError("--limit " + text + ": the limit must be > 0");
    (name == "u" ? request->u_max : request->i_max) = value;
  }
  if (request->u_max > 0.0) return;
  const double stated = config.model->traits().input_limit;
  if (!config.experiment.closed_loop && stated > 0.0) {
    // The drive's own input range (blmd: ±10 V of torque demand).
    request->u_max = stated;
    return;
  }
  if (!config.experiment.closed_loop) {
    throw InputError("--limit u=VOLTS is needed: the drive's voltage limit (" + config.path +
                     " has no experiment.pid.u_max)");
  }
  request->u_max = config.experiment.pid.u_max;
  request->u_min = config.experiment.pid.u_min;
}

// rigid_load: the drive's digital loop (--sample-rate, --delay, --current-bandwidth,
// --position-crossover), the sample rate defaulting to the config's experiment.pid; refused
// for a model whose loop is continuous (dc_servo), so that its runs stay as they were.
void ReadDrive(const TuneSettings& settings, const Config& config, TuneRequest* request) {
  const bool sampled = config.model->traits().sampled_pid;
  if (!sampled) {
    for (const auto& [flag, given] :
         {std::pair<const char*, bool>{"--sample-rate", settings.sample_rate_hz.has_value()},
          {"--delay", settings.delay_samples.has_value()},
          {"--current-bandwidth", settings.current_bandwidth_hz.has_value()},
          {"--position-crossover", settings.position_crossover_hz.has_value()},
          {"--notch", settings.notch.has_value()}}) {
      if (given) {
        throw InputError(
            std::string(flag) + " applies to models rigid_load and blmd (the drive's sampled " +
            "loop); model " + std::string(config.model->name()) + " is tuned continuous");
      }
    }
    return;
  }
  if (settings.integral_ratio || settings.filter_ratio) {
    throw InputError(std::string(settings.integral_ratio ? "--integral-ratio" : "--filter-ratio") +
                     " applies to dc_servo's position PID (rigid_load's position loop is a P "
                     "over the speed PI)");
  }
  const PidSettings& pid = config.experiment.pid;
  const bool has_pid = config.experiment.closed_loop;
  SampledDrive& drive = request->drive;
  drive.sample_rate_hz = settings.sample_rate_hz.value_or(has_pid ? pid.sample_rate : 0.0);
  if (!(drive.sample_rate_hz > 0.0)) {
    // Neither given nor in the config: the simulation's rate, said in a warning (a drive's
    // controller rate is rarely that; the gains depend on it).
    drive.sample_rate_hz = 1.0 / config.simulation.dt;
    request->sample_rate_assumed = true;
  }
  drive.delay_samples = settings.delay_samples.value_or(has_pid ? pid.delay : 1);
  if (has_pid) drive.notch = pid.notch;
  if (settings.notch) {
    if (*settings.notch != "auto" && *settings.notch != "off") {
      throw InputError("--notch: '" + InputError::Excerpt(*settings.notch) +
                       "' is not a choice (valid: auto, off)");
    }
    request->notch = *settings.notch == "off" ? NotchMode::kOff : NotchMode::kAuto;
  }
  if (config.model->traits().own_current_loop) {
    // blmd: the drive's own current loops, their bandwidth computed from the compensator,
    // the PWM and the winding (Model::CurrentLoopBandwidthHz).
    if (settings.current_bandwidth_hz) {
      throw InputError("--current-bandwidth: model " + std::string(config.model->name()) +
                       " carries its own current loops (Kp, Ki, Kf, the PWM), whose bandwidth "
                       "is computed from its parameters");
    }
    drive.current_bandwidth_hz = config.model->CurrentLoopBandwidthHz(config.parameters);
  } else {
    drive.current_bandwidth_hz =
        settings.current_bandwidth_hz.value_or(has_pid ? pid.current_bandwidth : 0.0);
  }
  request->w_max = config.model->SpeedLimit(config.parameters);
  if (settings.position_crossover_hz) {
    if (settings.loop == "speed") {
      throw InputError("--position-crossover applies to the position loop (--loop position)");
    }
    request->position_crossover_hz = *settings.position_crossover_hz;
  }
}

}  // namespace

TuneRequest MakeTuneRequest(const TuneSettings& settings, const Config& config) {
  TuneRequest request;
  if (settings.loop != "speed" && settings.loop != "position") {
    throw InputError("--loop: '" + InputError::Excerpt(settings.loop) +
                     "' is not a loop (valid: speed, position)");
  }
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
  ReadDrive(settings, config, &request);
  if (const std::string error = request.Validate(); !error.empty()) throw InputError(error);
  return request;
}

TuneReport RunTune(const std::string& config_path, const std::string& report_path,
                   const TuneSettings& settings) {
  JsonSource report{report_path, std::nullopt};
  return RunTune(JsonSource{config_path, std::nullopt}, report_path.empty() ? nullptr : &report,
                 settings);
}

TuneReport RunTune(const JsonSource& config, const JsonSource* report,
                   const TuneSettings& settings) {
  TuneInput input = LoadTuneInput(config, report);
  TuneRequest request = MakeTuneRequest(settings, input.config);
  TuneResult result = Tune(input, request);
  if (!result.refused && !input.report_inadequacy.empty()) {
    result.warnings.emplace_back(
        "report_inadequate",
        "the identified model is not to be trusted (" + Join(input.report_inadequacy, "; ") +
            "): the gains and margins rest on it; " +
            (input.report_ran_discovery ? std::string("identify again from a better record "
                                                      "(one that drives what the model misses: "
                                                      "the report's warnings say what) or leave "
                                                      "more margin")
                                        : std::string("identify again with --discover (or "
                                                      "from a better record) or leave more "
                                                      "margin")));
  }
  return MakeTuneReport(std::move(input), std::move(request), std::move(result));
}

}  // namespace blmd
