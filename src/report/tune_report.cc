// blmd-tune's JSON report, summary and closed-loop config (docs/tuning.md §5–6).
#include "blmd/report/tune_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <sstream>

#include "blmd/format.h"
#include "blmd/report/report.h"
#include "blmd/sim/effects.h"
#include "blmd/version.h"
#include "report/config_document.h"

namespace blmd {
namespace {

using nlohmann::json;

json Number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

std::string Text(double value, int digits = 4) { return FormatSignificantOrWord(value, digits); }

bool IsSpeed(const TuneRequest& request) {
  return request.design.loop == PidSettings::Loop::kSpeed;
}

// The unit of the model's input ("V" from "u (V)").
std::string InputUnit(const TuneInput& input) {
  const std::string text = input.config.model->Linearise(input.config.parameters).input;
  const auto open = text.find('('), close = text.rfind(')');
  return open != std::string::npos && close > open ? text.substr(open + 1, close - open - 1) : "";
}

// The gains' units: the input's unit over the measured output's (rad, or rad/s), times s^k.
GainUnits UnitsOfGains(const TuneInput& input, const TuneRequest& request) {
  if (input.config.model->traits().sampled_pid) {
    // rigid_load: the speed PI (u per speed), or the position P (speed per position: 1/s).
    const std::string u = SampledInputUnit(input.config);
    const std::string x = input.config.linear_axis ? "m" : "rad";
    if (IsSpeed(request)) return {u + "·s/" + x, u + "/" + x, u + "·s²/" + x};
    return {"1/s", "1/s²", "-"};
  }
  const std::string u = InputUnit(input);
  if (IsSpeed(request)) return {u + "·s/rad", u + "/rad", u + "·s²/rad"};
  return {u + "/rad", u + "/(rad·s)", u + "·s/rad"};
}

// experiment.pid.notch as the config reads it (notch_filter.h).
json NotchJson(const NotchFilter& notch) {
  return {{"frequency", notch.frequency}, {"width", notch.width}, {"depth", notch.depth}};
}

// experiment.pid of the tuned loop's checked step, as blmd-sim reads it.
json PidExperimentJson(const TuneRequest& request, const TuneResult& result,
                       bool report_own_current_loop) {
  if (result.sampled.used) {
    const Experiment e = SampledStepExperiment(request, result.sampled.gains, result.step,
                                               result.duration, result.sample_rate);
    json out = {
        {"loop", IsSpeed(request) ? "speed" : "position"}, {"Kp", e.pid.Kp}, {"Ki", e.pid.Ki}};
    if (!IsSpeed(request)) {
      out["speed_Kp"] = e.pid.speed_Kp;
      out["speed_Ki"] = e.pid.speed_Ki;
    }
    out["u_max"] = e.pid.u_max;
    if (!std::isnan(e.pid.u_min)) out["u_min"] = e.pid.u_min;
    out["sample_rate"] = e.pid.sample_rate;
    out["delay"] = e.pid.delay;
    // A drive with its own current loops (blmd) takes no current_bandwidth: they are simulated.
    if (!report_own_current_loop) out["current_bandwidth"] = e.pid.current_bandwidth;
    // The notch the loop was tuned with (the drive's own or designed): the gains need it.
    if (result.sampled.notch.active()) out["notch"] = NotchJson(result.sampled.notch);
    return out;
  }
  const Experiment e = StepExperiment(request.design.loop, result.design.controller, request.u_max,
                                      result.step, result.duration, result.sample_rate);
  return {{"loop", IsSpeed(request) ? "speed" : "position"},
          {"Kp", e.pid.Kp},
          {"Ki", e.pid.Ki},
          {"Kd", e.pid.Kd},
          {"tau_d", e.pid.tau_d},
          {"u_max", e.pid.u_max}};
}

json StepJson(const ClosedLoopStep& s) {
  json out = json::object();
  if (!s.simulated) {
    out["failed"] = s.failure;
    return out;
  }
  out["valid"] = s.valid;
  out["rise_time_s"] = Number(s.rise_time_s);
  out["overshoot_percent"] = Number(s.overshoot_percent);
  out["settling_time_s"] = Number(s.settling_time_s);
  out["final_value"] = Number(s.final_value);
  out["steady_state_error"] = Number(s.steady_state_error);
  out["peak_u"] = Number(s.peak_u);
  out["peak_i"] = Number(s.peak_i);
  out["peak_w"] = Number(s.peak_w);
  out["saturated"] = s.saturated;
  return out;
}

json LoopMarginsJson(const LoopMargins& m) {
  json out = {{"crossover_hz", Number(m.crossover_hz)},
              {"phase_margin_deg", Number(m.phase_margin_deg)},
              {"gain_margin_db", Number(m.gain_margin_db)},
              {"phase_crossover_hz", Number(m.phase_crossover_hz)},
              {"gain_crossovers", m.gain_crossovers}};
  if (!m.ok) out["failed"] = m.reason;
  return out;
}

json MarginsJson(const LoopCheck& check) {
  const LoopMargins& m = check.margins;
  json out = {{"crossover_hz", Number(m.crossover_hz)},
              {"phase_margin_deg", Number(m.phase_margin_deg)},
              {"gain_margin_db", Number(m.gain_margin_db)},
              {"phase_crossover_hz", Number(m.phase_crossover_hz)},
              {"lower_gain_margin_db", Number(m.lower_gain_margin_db)},
              {"gain_crossovers", m.gain_crossovers},
              {"stable", check.poles.stable}};
  if (!m.ok) out["failed"] = m.reason;
  return out;
}

json Where(const WorstFigure& figure) { return figure.corner; }

json WorstStepJson(const WorstCase& w) {
  return {{"rise_time_s", Number(w.rise_time_s.value)},
          {"overshoot_percent", Number(w.overshoot_percent.value)},
          {"settling_time_s", Number(w.settling_time_s.value)},
          {"steady_state_error", Number(w.steady_state_error.value)},
          {"peak_u", Number(w.peak_u.value)},
          {"peak_i", Number(w.peak_i.value)},
          {"where",
           {{"rise_time_s", Where(w.rise_time_s)},
            {"overshoot_percent", Where(w.overshoot_percent)},
            {"settling_time_s", Where(w.settling_time_s)},
            {"steady_state_error", Where(w.steady_state_error)},
            {"peak_u", Where(w.peak_u)},
            {"peak_i", Where(w.peak_i)}}}};
}

json RobustnessJson(const TuneInput& input, const TuneResult& result) {
  json box = json::object();
  for (const auto& axis : input.box) {
    box[axis.name] = {{"value", Number(axis.value)},
                      {"ci95", {Number(axis.low), Number(axis.high)}},
                      {"clipped", axis.clipped}};
  }
  json corners = json::array();
  for (const auto& corner : result.corners) {
    json values = json::object();
    for (const auto& [name, value] : corner.values) values[name] = Number(value);
    json entry = MarginsJson(corner);
    entry["parameters"] = values;
    entry["step"] = StepJson(corner.step);
    corners.push_back(entry);
  }
  const WorstCase& w = result.worst;
  json worst = {{"crossover_hz_min", Number(w.crossover_low_hz.value)},
                {"crossover_hz_max", Number(w.crossover_high_hz.value)},
                {"phase_margin_deg", Number(w.phase_margin_deg.value)},
                {"gain_margin_db", Number(w.gain_margin_db.value)},
                {"unstable_corners", w.unstable},
                {"saturated_corners", w.saturated},
                {"where",
                 {{"crossover_hz_min", Where(w.crossover_low_hz)},
                  {"crossover_hz_max", Where(w.crossover_high_hz)},
                  {"phase_margin_deg", Where(w.phase_margin_deg)},
                  {"gain_margin_db", Where(w.gain_margin_db)}}}};
  return {{"box_source", input.box_source.empty() ? json(nullptr) : json(input.box_source)},
          {"parameters", box},
          {"corners", corners},
          {"worst_case", worst}};
}

// rigid_load: the drive's digital loop, each loop's gains (continuous SI and per sample) and
// margins on the sampled loop beside the continuous one's (docs/tuning.md §7).
json SampledLoopJson(const TuneInput& input, const TuneRequest& request, const TuneResult& result) {
  const SampledTuning& s = result.sampled;
  const double ts = 1.0 / request.drive.sample_rate_hz;
  const Config& config = input.config;
  const std::string x = config.linear_axis ? "m" : "rad";
  const std::string u = SampledInputUnit(config);
  json speed = {{"crossover_hz_requested", request.design.crossover_hz},
                {"kp", s.gains.speed_kp},
                {"ki", s.gains.speed_ki},
                {"units", {{"kp", u + "·s/" + x}, {"ki", u + "/" + x}}},
                {"per_sample", {{"kp", s.gains.speed_kp}, {"ki_ts", s.gains.speed_ki * ts}}},
                {"sampled", LoopMarginsJson(s.speed)},
                {"continuous", LoopMarginsJson(s.speed_continuous)},
                {"highest_feasible_crossover_hz", Number(s.design.highest_crossover_hz)},
                {"stable", s.speed_poles.stable}};
  json out = {
      {"axis", config.linear_axis ? "linear" : "rotary"},
      {"units", {{"u", u}, {"speed", config.linear_axis ? "m/s" : "rad/s"}, {"position", x}}},
      {"controller_sample_rate_hz", request.drive.sample_rate_hz},
      {"delay_samples", request.drive.delay_samples},
      {"current_bandwidth_hz", request.drive.current_bandwidth_hz > 0.0
                                   ? json(request.drive.current_bandwidth_hz)
                                   : json(nullptr)},
      {"current_loop",
       config.model->traits().own_current_loop
           ? "the drive's own (compensator, PWM, winding): its bandwidth "
             "computed, a first-order lag in the design, simulated in the check"
           : (request.drive.current_bandwidth_hz > 0.0 ? "a first-order lag" : "ideal")},
      {"speed_limit_rad_s", Number(request.w_max)},
      {"limits", {{"u_min", request.LowerLimit()}, {"u_max", request.u_max}}},
      {"discretisation",
       std::string(config.model->Linearise(config.parameters).has_shaft
                       ? "plant: exact zero-order hold of the two-mass shaft (the motor's speed; "
                         "docs/effects.md, two_mass) and the current lag"
                       : "plant: exact zero-order hold of K/(J s + B) (K: Kt, or blmd's 1.5 Ke "
                         "Kc/Kf; and the current lag)") +
           "; z^-d delay; PI C(z) = kp + ki Ts z/(z - 1) (backward Euler integral); "
           "anti-windup by conditional integration"},
      {"closed_loop_poles_plane", "z"},
      {"speed_loop", speed},
      {"resonance_hz", Number(s.resonance_hz)},
      {"resonance_limited_crossover_hz", Number(s.resonance_limited_crossover_hz)},
      {"notch", nullptr}};
  if (s.notch.active()) {
    out["notch"] = {{"frequency_hz", s.notch.frequency},
                    {"width_hz", s.notch.width},
                    {"depth", s.notch.depth},
                    {"depth_db", 20.0 * std::log10(std::max(s.notch.depth, 1e-12))},
                    {"source", s.notch_designed ? "designed" : "drive"},
                    {"placement", "the speed PI's output (the torque command), before the limit"},
                    {"discretisation", "bilinear (Tustin) prewarped at the notch frequency"},
                    {"peak_ratio", Number(s.notch_peak_ratio)},
                    {"worst_variant_margin_deg", Number(s.notch_worst_variant_margin_deg)}};
  }
  if (!IsSpeed(request)) {
    out["position_loop"] = {{"crossover_hz_requested", s.design.position_crossover_hz},
                            {"kp", s.gains.position_kp},
                            {"units", {{"kp", "1/s"}}},
                            {"sampled", LoopMarginsJson(s.position)},
                            {"continuous", LoopMarginsJson(s.position_continuous)}};
  }
  return out;
}

json RequestJson(const TuneRequest& request, const TuneResult& result) {
  const bool speed = IsSpeed(request);
  const std::string step_unit =
      result.sampled.used
          ? (result.sampled.linear_axis ? (speed ? "m/s" : "m") : (speed ? "rad/s" : "rad"))
          : (speed ? "rad/s" : "rad");
  json out = {
      {"loop", speed ? "speed" : "position"},
      {"crossover_hz", request.design.crossover_hz},
      {"phase_margin_deg", request.design.phase_margin_deg},
      {"step", result.step},
      {"step_unit", step_unit},
      {"limits", {{"u", request.u_max}, {"i", Number(request.i_max > 0 ? request.i_max : NAN)}}},
      {"duration_s", result.duration},
      {"sample_rate_hz", result.sample_rate}};
  if (!speed && !result.sampled.used) {
    out["integral_ratio"] = request.design.integral_ratio;
    out["derivative_filter_ratio"] = request.design.filter_ratio;
  }
  return out;
}

json PlantJson(const TuneInput& input, const TuneResult& result) {
  json parameters = json::object();
  for (const auto& [name, value] : input.config.parameters.entries()) parameters[name] = value;
  return {{"input", input.config.model->Linearise(input.config.parameters).input},
          {"output", result.plant_output},
          {"numerator", result.plant.numerator},
          {"denominator", result.plant.denominator},
          {"gain_at_crossover", Number(result.design.plant_gain)},
          {"phase_at_crossover_deg", Number(result.design.plant_phase_deg)},
          {"parameters", parameters},
          {"effects", input.config.effects}};
}

json ControllerJson(const TuneReport& report) {
  const Controller& c = report.result.design.controller;
  const char* structure = IsSpeed(report.request)      ? "PI"
                          : report.result.sampled.used ? "P over the speed PI (cascade)"
                                                       : "PID";
  return {
      {"structure", structure},
      {"kp", c.kp},
      {"ki", c.ki},
      {"kd", c.kd},
      {"derivative_filter_hz", c.derivative_filter_hz},
      {"units", {{"kp", report.units.kp}, {"ki", report.units.ki}, {"kd", report.units.kd}}},
      {"pid_experiment", PidExperimentJson(report.request, report.result,
                                           report.input.config.model->traits().own_current_loop)}};
}

json PolesJson(const ClosedLoopPoles& poles) {
  json out = json::array();
  for (const auto& p : poles.poles) out.push_back({Number(p.real()), Number(p.imag())});
  return out;
}

// rigid_load's summary: each loop's gains (continuous SI and per sample) and its margins on
// the sampled loop beside the continuous loop's, the step, the box.
// The summary's line of the worst case over the corners of the 95 % box ("" without corners);
// `peak`: the peak input's words, appended (the sampled loop's), or "".
std::string WorstLine(const TuneInput& input, const TuneResult& result, const std::string& peak) {
  if (result.corners.empty()) return "";
  const WorstCase& w = result.worst;
  return "  worst over the " + std::to_string(result.corners.size()) +
         " corners of the 95 % box (" + input.box_source + "): crossover " +
         Text(w.crossover_low_hz.value) + " to " + Text(w.crossover_high_hz.value) +
         " Hz, phase margin " + Text(w.phase_margin_deg.value) + " deg, gain margin " +
         Text(w.gain_margin_db.value) + " dB, overshoot " + Text(w.overshoot_percent.value) +
         " %, settling " + Text(w.settling_time_s.value) + " s" + peak + "\n";
}

std::string SampledSummary(const TuneReport& report) {
  const TuneInput& input = report.input;
  const TuneRequest& request = report.request;
  const TuneResult& result = report.result;
  const SampledTuning& t = result.sampled;
  const Config& config = input.config;
  const bool speed = IsSpeed(request);
  const std::string x = config.linear_axis ? "m" : "rad";
  const std::string u = SampledInputUnit(config);
  const std::string unit = SampledOutputUnit(config, speed);
  const double ts = 1.0 / request.drive.sample_rate_hz;
  const ClosedLoopStep& s = result.nominal.step;
  auto margins = [](const LoopMargins& m) {
    return "crossover " + Text(m.crossover_hz) + " Hz, phase margin " + Text(m.phase_margin_deg) +
           " deg, gain margin " + Text(m.gain_margin_db) + " dB";
  };
  std::ostringstream out;
  out << "blmd-tune: " << (speed ? "speed loop (PI)" : "position loop (P over the speed PI)")
      << " of " << config.model->name() << " '" << config.name << "'"
      << (config.linear_axis ? " (linear axis)" : "") << ", sampled at "
      << Text(request.drive.sample_rate_hz) << " Hz with " << request.drive.delay_samples
      << " sample(s) of delay, current loop "
      << (config.model->traits().own_current_loop ? "the drive's own, " : "")
      << (request.drive.current_bandwidth_hz > 0.0
              ? Text(request.drive.current_bandwidth_hz) + " Hz"
              : std::string("ideal"))
      << ", for " << Text(request.design.crossover_hz) << " Hz, "
      << Text(request.design.phase_margin_deg) << " deg\n";
  out << "  speed PI: kp " << Text(t.gains.speed_kp, 6) << " " << u << "·s/" << x << "   ki "
      << Text(t.gains.speed_ki, 6) << " " << u << "/" << x << "   (per sample: kp "
      << Text(t.gains.speed_kp, 6) << ", ki·Ts " << Text(t.gains.speed_ki * ts, 6) << ")\n";
  if (t.notch.active()) {
    out << "  notch on the torque command: " << Text(t.notch.frequency, 4) << " Hz, width "
        << Text(t.notch.width, 3) << " Hz, depth " << Text(t.notch.depth, 2) << " ("
        << Text(20.0 * std::log10(std::max(t.notch.depth, 1e-12)), 3) << " dB), "
        << (t.notch_designed ? "designed at the resonance: without it the resonance (" +
                                   Text(t.resonance_hz, 3) + " Hz) allows at most " +
                                   Text(t.resonance_limited_crossover_hz, 4) +
                                   " Hz; the drive must run it with these gains"
                             : std::string("the drive's own (experiment.pid.notch)"))
        << "\n";
  }
  out << "  speed loop, sampled: " << margins(t.speed) << "\n";
  out << "  speed loop, continuous (same gains, no hold or delay): " << margins(t.speed_continuous)
      << "\n";
  if (!speed) {
    out << "  position P: kp " << Text(t.gains.position_kp, 6) << " 1/s\n";
    out << "  position loop, sampled: " << margins(t.position) << "\n";
    out << "  position loop, continuous: " << margins(t.position_continuous) << "\n";
  }
  out << "  step " << Text(result.step) << " " << unit << ": rise " << Text(s.rise_time_s)
      << " s, overshoot " << Text(s.overshoot_percent) << " %, settling " << Text(s.settling_time_s)
      << " s, steady-state error " << Text(s.steady_state_error) << " " << unit << ", peak "
      << Text(s.peak_u) << " " << u << "\n";
  out << WorstLine(input, result, ", peak " + Text(result.worst.peak_u.value) + " " + u);
  for (const auto& [code, message] : result.warnings)
    out << "  warning (" << code << "): " << message << "\n";
  return out.str();
}

}  // namespace

TuneReport MakeTuneReport(TuneInput input, TuneRequest request, TuneResult result) {
  TuneReport report;
  report.units = UnitsOfGains(input, request);
  report.input = std::move(input);
  report.request = std::move(request);
  report.result = std::move(result);
  return report;
}

void to_json(json& out, const TuneReport& report) {
  const TuneInput& input = report.input;
  const TuneRequest& request = report.request;
  const TuneResult& result = report.result;
  out = json::object();
  out["tool"] = "blmd-tune";
  out["version"] = kVersion;
  out["schema_version"] = kTuneReportSchemaVersion;
  out["model"] = std::string(input.config.model->name());
  out["config"] = {
      {"path", input.config.path}, {"name", input.config.name}, {"sha256", input.config_sha256}};
  out["from_report"] = input.report_path.empty()
                           ? json(nullptr)
                           : json{{"path", input.report_path}, {"sha256", input.report_sha256}};
  out["request"] = RequestJson(request, result);
  out["plant"] = PlantJson(input, result);
  const char* method = result.sampled.used
                           ? "sampled PI placing L(e^{j w_c Ts}) at e^{j(PM - 180 deg)} (ZOH "
                             "plant, z^-d delay); position: P for |L| = 1 at its crossover"
                       : IsSpeed(request) ? "PI placing L(j w_c) at e^{j(PM - 180 deg)}"
                                          : "PID (Ti = a Td, derivative filter at n f_c) placing "
                                            "L(j w_c) at e^{j(PM - 180 deg)}";
  out["method"] = {{"name", method},
                   {"controller_phase_deg", Number(result.design.controller_phase_deg)},
                   {"source",
                    "Astrom & Hagglund, PID Controllers: Theory, Design, and Tuning (1995), ch. 4; "
                    "docs/tuning.md"}};
  out["controller"] = ControllerJson(report);
  json achieved = MarginsJson(result.nominal);
  achieved["closed_loop_poles"] = PolesJson(result.nominal.poles);
  out["achieved"] = achieved;
  out["step_response"] = {{"nominal", StepJson(result.nominal.step)},
                          {"worst_case", WorstStepJson(result.worst)}};
  out["robustness"] = RobustnessJson(input, result);
  if (result.sampled.used) out["sampled_loop"] = SampledLoopJson(input, request, result);
  json warnings = json::array();
  for (const auto& [code, message] : result.warnings)
    warnings.push_back({{"code", code}, {"message", message}});
  out["warnings"] = warnings;
  SanitizeJson(&out);
}

std::string TuneSummary(const TuneReport& report) {
  const TuneInput& input = report.input;
  const TuneRequest& request = report.request;
  const TuneResult& result = report.result;
  const Controller& c = result.design.controller;
  const GainUnits& units = report.units;
  const LoopMargins& m = result.nominal.margins;
  const ClosedLoopStep& s = result.nominal.step;
  if (result.sampled.used) return SampledSummary(report);
  const std::string unit = IsSpeed(request) ? "rad/s" : "rad";
  std::ostringstream out;
  out << "blmd-tune: " << (IsSpeed(request) ? "speed loop (PI)" : "position loop (PID)") << " of "
      << input.config.model->name() << " '" << input.config.name << "' for "
      << Text(request.design.crossover_hz) << " Hz, " << Text(request.design.phase_margin_deg)
      << " deg\n";
  out << "  kp " << Text(c.kp, 6) << " " << units.kp << "   ki " << Text(c.ki, 6) << " " << units.ki
      << "   kd " << Text(c.kd, 6) << " " << units.kd << "   derivative filter "
      << Text(c.derivative_filter_hz) << " Hz\n";
  out << "  achieved: crossover " << Text(m.crossover_hz) << " Hz, phase margin "
      << Text(m.phase_margin_deg) << " deg, gain margin " << Text(m.gain_margin_db) << " dB\n";
  out << "  step " << Text(result.step) << " " << unit << ": rise " << Text(s.rise_time_s)
      << " s, overshoot " << Text(s.overshoot_percent) << " %, settling " << Text(s.settling_time_s)
      << " s, steady-state error " << Text(s.steady_state_error) << " " << unit << ", peak "
      << Text(s.peak_u) << " V / " << Text(s.peak_i) << " A\n";
  out << WorstLine(input, result, "");
  for (const auto& [code, message] : result.warnings)
    out << "  warning (" << code << "): " << message << "\n";
  return out.str();
}

json ClosedLoopConfigJson(const TuneReport& report) {
  const TuneInput& input = report.input;
  const TuneRequest& request = report.request;
  const TuneResult& result = report.result;
  const Config& config = input.config;
  json doc = ConfigDocumentOf(config);
  doc["description"] = std::string("The ") + (IsSpeed(request) ? "speed" : "position") +
                       " loop tuned by blmd-tune for " + Text(request.design.crossover_hz) +
                       " Hz and " + Text(request.design.phase_margin_deg) +
                       " deg of phase margin: a step of the reference from rest.";
  SetModelValues(config, config.parameters, &doc);
  if (result.sampled.used) {
    // The step on the controller's grid, as Tune simulated it (a whole number of steps per
    // sample).
    const double ts = 1.0 / request.drive.sample_rate_hz, dt = config.simulation.dt;
    doc["simulation"]["dt"] = ts / std::max(1.0, std::ceil(ts / dt * (1.0 - 1e-9)));
  }
  doc["experiment"] = {
      {"input", {{"type", "step"}, {"amplitude", result.step}}},
      {"pid", PidExperimentJson(request, result, config.model->traits().own_current_loop)},
      {"duration", result.duration},
      {"sample_rate", result.sample_rate}};
  json notes = {{"tuned_by", std::string("blmd-tune ") + kVersion},
                {"from_config", config.path},
                {"request", RequestJson(request, result)},
                {"controller", ControllerJson(report)}};
  if (!input.report_path.empty()) notes["from_report"] = input.report_path;
  SetNotes(config, std::move(notes), &doc);
  return doc;
}

}  // namespace blmd
