#include "io/config_pid.h"

#include <cmath>
#include <string>

#include "blmd/format.h"
#include "blmd/sim/notch_filter.h"

namespace blmd {
namespace {

using nlohmann::json;
using namespace json_reader;  // NOLINT(google-build-using-namespace): the loader's own reader

// The drive's notch on its torque command (experiment.pid.notch, notch_filter.h), checked
// against the controller's sample rate.
void ReadNotch(const Reader& reader, const json& node, PidSettings* out) {
  const std::string pointer = "/experiment/pid/notch";
  reader.RequireObject(node, pointer);
  reader.CheckKeys(node, pointer, {"frequency", "width", "depth"});
  for (const char* key : {"frequency", "width", "depth"}) {
    if (!node.contains(key)) {
      reader.Fail(pointer, std::string("the notch needs '") + key +
                               "' (frequency and width in "
                               "Hz, depth its gain at the centre, 0 to < 1)");
    }
  }
  NotchFilter& notch = out->notch;
  notch.frequency = reader.Positive(node["frequency"], pointer + "/frequency");
  notch.width = reader.Positive(node["width"], pointer + "/width");
  notch.depth = reader.Number(node["depth"], pointer + "/depth");
  if (!(notch.depth >= 0.0 && notch.depth < 1.0)) {
    reader.Fail(pointer + "/depth", "the notch depth (its gain at the centre) must be in [0, 1)");
  }
  if (!(notch.frequency < 0.5 * out->sample_rate)) {
    reader.Fail(pointer + "/frequency",
                NotchFilter{notch.frequency, 1.0, 0.0}.Validate(out->sample_rate));
  }
}

}  // namespace

// A digital controller's rate (every model's pid): sample_rate, Hz, a whole number of
// simulation steps (default 1/dt: every step), and the output's delay in samples (default 1).
void ReadControllerRate(const Reader& reader, const json& pid, double dt, PidSettings* out) {
  out->sample_rate = 1.0 / dt;
  if (pid.contains("sample_rate")) {
    out->sample_rate = reader.Positive(pid["sample_rate"], "/experiment/pid/sample_rate");
    const double steps = 1.0 / (out->sample_rate * dt);
    if (steps < 1.0 - 1e-9 || std::abs(steps - std::round(steps)) > 1e-6 * steps) {
      reader.Fail("/experiment/pid/sample_rate",
                  "the controller's period must be a whole number of simulation steps (dt = " +
                      DisplayNumber(dt) + " s)");
    }
  }
  if (pid.contains("delay")) {
    const double delay = reader.Number(pid["delay"], "/experiment/pid/delay");
    if (!(delay >= 0.0 && delay <= 100.0 && delay == std::floor(delay))) {
      reader.Fail("/experiment/pid/delay", "delay must be a whole number of samples, 0 to 100");
    }
    out->delay = static_cast<int>(delay);
  }
}

// rigid_load's digital loop (PidSettings): the inner speed PI, the lower limit, the
// controller's sample rate (a whole number of simulation steps), delay and current loop.
void ReadSampledPid(const Reader& reader, const json& pid, double dt, PidSettings* out) {
  auto get = [&](const char* key, double* field) {
    if (pid.contains(key)) *field = reader.Number(pid[key], std::string("/experiment/pid/") + key);
  };
  get("speed_Kp", &out->speed_Kp);
  get("speed_Ki", &out->speed_Ki);
  get("speed_feedforward", &out->speed_feedforward);
  if (pid.contains("speed_difference_samples")) {
    const double n =
        reader.Number(pid["speed_difference_samples"], "/experiment/pid/speed_difference_samples");
    if (!(n >= 0.0 && n <= 100.0 && n == std::floor(n))) {
      reader.Fail("/experiment/pid/speed_difference_samples",
                  "speed_difference_samples must be a whole number of samples, 0 to 100");
    }
    out->speed_difference_samples = static_cast<int>(n);
  }
  if (!std::isfinite(out->speed_feedforward)) {
    reader.Fail("/experiment/pid/speed_feedforward", "speed_feedforward must be a finite number");
  }
  get("u_min", &out->u_min);
  if (!(out->LowerLimit() < out->u_max)) {
    reader.Fail("/experiment/pid/u_min", "u_min must be below u_max");
  }
  ReadControllerRate(reader, pid, dt, out);
  if (pid.contains("notch")) ReadNotch(reader, pid["notch"], out);
  if (pid.contains("current_bandwidth")) {
    out->current_bandwidth =
        reader.Number(pid["current_bandwidth"], "/experiment/pid/current_bandwidth");
    if (!(out->current_bandwidth >= 0.0) || !std::isfinite(out->current_bandwidth)) {
      reader.Fail("/experiment/pid/current_bandwidth",
                  "current_bandwidth must be >= 0 Hz (0: an ideal current loop)");
    }
  }
}

}  // namespace blmd
