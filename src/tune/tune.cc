// Tune: design, the nominal checks, the refusals, and the box's corners (docs/tuning.md).
#include "blmd/tune/tune.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "blmd/constants.h"
#include "blmd/error.h"
#include "blmd/format.h"
#include "blmd/run.h"
#include "blmd/tune/resonance.h"
#include "parallel.h"

namespace blmd {
namespace {

// The margins are searched over four decades either side of the requested crossover.
constexpr double kSearchDecades = 1e4;
// More parameters with intervals than this would make 2^k corners too many to simulate.
constexpr std::size_t kMaxBoxParameters = 12;

std::string Text(double value, int digits = 4) { return FormatSignificant(value, digits); }

bool IsSpeed(const TuneRequest& request) {
  return request.design.loop == PidSettings::Loop::kSpeed;
}
const char* Unit(const TuneRequest& request) { return IsSpeed(request) ? "rad/s" : "rad"; }

// The plant u -> the loop's measured output at `values`.
TransferFunction PlantAt(const Model& model, const ParameterSet& values,
                         const std::string& output) {
  for (auto& tf : TransferFunctions(model.Linearise(values))) {
    if (tf.output == output) return tf;
  }
  throw std::logic_error("PlantAt: the linear model has no output " + output);
}

// Simulates the step of `experiment` at `values` and reads its figures off the measured
// column.
ClosedLoopStep SimulateStep(const Config& config, const ParameterSet& values,
                            const Experiment& experiment, const std::string& measured) {
  ClosedLoopStep figures;
  const std::vector<double> times = experiment.SampleTimes();
  SimulationRequest request;
  request.parameters = &values;
  request.effects = &config.effects;
  request.experiment = &experiment;
  request.settings = config.simulation;
  request.sample_times = &times;
  Trace trace;
  const SimStatus status = config.model->Simulate(request, &trace);
  if (!status.ok()) {
    figures.failure = status.message + " at t = " + Text(status.at_time) + " s";
    return figures;
  }
  figures.simulated = true;
  const auto& t = trace.Column("t");
  const auto& y = trace.Column(measured);
  const StepMetrics metrics = ComputeStepMetrics(t, y, experiment.input.t0);
  figures.valid = metrics.valid;
  if (metrics.valid) {
    figures.rise_time_s = metrics.rise_time;
    figures.overshoot_percent = metrics.overshoot_percent;
    figures.settling_time_s = metrics.settling_time;
  }
  // The final value as ComputeStepMetrics takes it: the mean of the last 2 % of the samples.
  const std::size_t tail = std::max<std::size_t>(1, y.size() / 50);
  double sum = 0.0;
  for (std::size_t k = y.size() - tail; k < y.size(); ++k) sum += y[k];
  figures.final_value = sum / static_cast<double>(tail);
  figures.steady_state_error = experiment.input.amplitude - figures.final_value;
  figures.peak_u = figures.peak_i = figures.peak_w = 0.0;
  for (double u : trace.Column("u")) figures.peak_u = std::max(figures.peak_u, std::abs(u));
  figures.saturated = figures.peak_u >= experiment.pid.u_max * (1.0 - 1e-12);
  // The lower limit may differ from -u_max (an asymmetric drive, --limit u=LOW:HIGH).
  const double low = experiment.pid.LowerLimit();
  for (double u : trace.Column("u")) {
    if (u <= low + std::abs(low) * 1e-12) figures.saturated = true;
  }
  for (double w : trace.Column("w")) figures.peak_w = std::max(figures.peak_w, std::abs(w));
  if (trace.Has("i")) {
    for (double i : trace.Column("i")) figures.peak_i = std::max(figures.peak_i, std::abs(i));
  } else {
    figures.peak_i = std::numeric_limits<double>::quiet_NaN();  // torque-driven: no current
  }
  return figures;
}

// The default step: 1 rad for the position loop; for the speed loop 10 % of the steady speed
// that u_max gives (|G_w(0)|·u_max), so that the step leaves the drive headroom.
double DefaultStep(const TuneRequest& request, const TransferFunction& plant) {
  if (!IsSpeed(request)) return 1.0;
  const double dc = std::abs(plant.numerator.back() / plant.denominator.back());
  return std::isfinite(dc) && dc > 0.0 ? 0.1 * request.u_max * dc : 1.0;
}

// Long enough for the slowest closed-loop mode to settle (8 time constants: e^-8 = 3e-4) and
// for 20/ω_c, at most 400/ω_c; the sample rate about 1000 samples per crossover period, on the
// step grid.
void ChooseTimeBase(const TuneRequest& request, const ClosedLoopPoles& poles, double dt,
                    TuneResult* result) {
  const double wc = kTwoPi * request.design.crossover_hz;
  result->duration = request.duration > 0.0
                         ? request.duration
                         : std::clamp(8.0 * poles.slowest_time_constant, 20.0 / wc, 400.0 / wc);
  const double target = 1000.0 * request.design.crossover_hz;
  const double every = std::max(1.0, std::floor(1.0 / (dt * target)));
  result->sample_rate = 1.0 / (every * dt);
}

LoopCheck CheckSampledAt(const TuneInput& input, const TuneRequest& request,
                         const TuneResult& result, const ParameterSet& values);

LoopCheck CheckAt(const TuneInput& input, const TuneRequest& request, const TuneResult& result,
                  const ParameterSet& values) {
  if (result.sampled.used) return CheckSampledAt(input, request, result, values);
  LoopCheck check;
  const TransferFunction plant = PlantAt(*input.config.model, values, result.plant_output);
  const double fc = request.design.crossover_hz;
  check.margins =
      ComputeMargins(plant, result.design.controller, fc / kSearchDecades, fc * kSearchDecades);
  check.poles = ComputeClosedLoopPoles(plant, result.design.controller);
  const Experiment experiment =
      StepExperiment(request.design.loop, result.design.controller, request.u_max, result.step,
                     result.duration, result.sample_rate);
  check.step = SimulateStep(input.config, values, experiment, result.plant_output);
  return check;
}

// Refuses when the nominal step needs more than the drive gives: the voltage (found by the
// same step with the limit lifted) or the current.
void CheckLimits(const TuneInput& input, const TuneRequest& request, TuneResult* result) {
  const ClosedLoopStep& step = result->nominal.step;
  const std::string what_unit =
      result->sampled.used ? SampledOutputUnit(input.config, IsSpeed(request)) : Unit(request);
  const std::string what = "a " + Text(result->step) + " " + what_unit + " step";
  if (!step.simulated) {
    result->refused = true;
    result->refusal = "the simulated closed loop failed for " + what + ": " + step.failure;
    return;
  }
  if (step.saturated) {
    Experiment unlimited = StepExperiment(request.design.loop, result->design.controller, 1e12,
                                          result->step, result->duration, result->sample_rate);
    std::string u_unit = "V";
    double limit = request.u_max;
    if (result->sampled.used) {
      TuneRequest lifted = request;
      lifted.u_max = 1e12;
      lifted.u_min = -1e12;
      unlimited = SampledStepExperiment(lifted, result->sampled.gains, result->step,
                                        result->duration, result->sample_rate);
      u_unit = SampledInputUnit(input.config);
      limit = std::min(request.u_max, std::abs(request.LowerLimit()));
    }
    const ClosedLoopStep demand =
        SimulateStep(input.config, input.config.parameters, unlimited, result->plant_output);
    result->demand_peak_u = demand.peak_u;
    result->refused = true;
    result->refusal = "the loop needs " + Text(demand.peak_u) + " " + u_unit + " for " + what +
                      ", beyond the drive's " + Text(limit) + " " + u_unit +
                      ": at this crossover the largest step within the limit is " +
                      Text(result->step * limit / demand.peak_u) + " " + what_unit +
                      " (ask for a lower crossover or a smaller --step)";
    return;
  }
  if (step.peak_w > request.w_max) {
    result->refused = true;
    result->refusal = "the loop reaches " + Text(step.peak_w) + " rad/s for " + what +
                      ", beyond the " + Text(request.w_max) +
                      " rad/s at which the DC bus leaves no voltage to control the current "
                      "(Ud/(2 Ke)): ask for a smaller --step";
    return;
  }
  if (request.i_max > 0.0 && step.peak_i > request.i_max) {
    result->refused = true;
    result->refusal = "the loop draws " + Text(step.peak_i) + " A for " + what +
                      ", beyond the drive's " + Text(request.i_max) +
                      " A: the largest step within the limit is about " +
                      Text(result->step * request.i_max / step.peak_i) + " " + Unit(request) +
                      " (ask for a lower crossover or a smaller --step)";
  }
}

void Consider(WorstFigure* worst, double value, int corner, bool larger_is_worse) {
  if (!std::isfinite(value) && !std::isinf(value)) return;
  const bool worse =
      std::isnan(worst->value) || (larger_is_worse ? value > worst->value : value < worst->value);
  if (worse) *worst = {value, corner};
}

void AddToWorst(const LoopCheck& check, int corner, WorstCase* worst) {
  const LoopMargins& m = check.margins;
  if (m.ok) {
    Consider(&worst->crossover_low_hz, m.crossover_hz, corner, false);
    Consider(&worst->crossover_high_hz, m.crossover_hz, corner, true);
    Consider(&worst->phase_margin_deg, m.phase_margin_deg, corner, false);
    Consider(&worst->gain_margin_db, m.gain_margin_db, corner, false);
  }
  if (!check.poles.stable) ++worst->unstable;
  const ClosedLoopStep& s = check.step;
  if (s.simulated) {
    if (s.saturated) ++worst->saturated;
    if (!s.valid) ++worst->invalid;
    Consider(&worst->rise_time_s, s.rise_time_s, corner, true);
    Consider(&worst->overshoot_percent, s.overshoot_percent, corner, true);
    Consider(&worst->settling_time_s, s.settling_time_s, corner, true);
    if (std::isnan(worst->steady_state_error.value) ||
        std::abs(s.steady_state_error) > std::abs(worst->steady_state_error.value)) {
      worst->steady_state_error = {s.steady_state_error, corner};
    }
    Consider(&worst->peak_u, s.peak_u, corner, true);
    Consider(&worst->peak_i, s.peak_i, corner, true);
  }
}

// The parameters at corner `corner` of the 95 % box (bit j: axis j at its high end), and the
// box's values there when `at` is given.
ParameterSet CornerValues(const TuneInput& input, std::size_t corner,
                          std::vector<std::pair<std::string, double>>* at = nullptr) {
  ParameterSet values = input.config.parameters;
  for (std::size_t j = 0; j < input.box.size(); ++j) {
    const ParameterInterval& axis = input.box[j];
    const double v = (corner >> j) & 1u ? axis.high : axis.low;
    values.Set(axis.name, v);
    if (at) at->emplace_back(axis.name, v);
  }
  return values;
}

void EvaluateBox(const TuneInput& input, const TuneRequest& request, TuneResult* result) {
  const std::size_t k = input.box.size();
  if (k > kMaxBoxParameters) {
    throw InputError(std::to_string(k) + " parameters have 95 % intervals: the box's 2^" +
                     std::to_string(k) + " corners are too many (at most " +
                     std::to_string(kMaxBoxParameters) + " parameters)");
  }
  const std::size_t count = k == 0 ? 0 : std::size_t{1} << k;
  result->corners.resize(count);
  internal::ParallelFor(count, request.threads, [&](std::size_t corner) {
    std::vector<std::pair<std::string, double>> at;
    const ParameterSet values = CornerValues(input, corner, &at);
    result->corners[corner] = CheckAt(input, request, *result, values);
    result->corners[corner].values = std::move(at);
  });
  AddToWorst(result->nominal, -1, &result->worst);
  for (std::size_t c = 0; c < count; ++c)
    AddToWorst(result->corners[c], static_cast<int>(c), &result->worst);
}

// The shaft the sampled loops act on (sampled_loop.h, docs/tuning.md §7), from the model's
// linear part J dw/dt = -B w + K u: rigid_load's Kt, or blmd's 1.5 Ke Kc/Kf (N·m per V of
// torque demand, its current loops ideal; their lag is the drive's current bandwidth).
RigidPlant RigidAt(const Model& model, const ParameterSet& values) {
  const LinearModel linear = model.Linearise(values);
  if (linear.has_shaft) {
    const LinearModel::Shaft& shaft = linear.shaft;
    return {shaft.J,
            shaft.B,
            shaft.K,
            shaft.inertia_ratio,
            shaft.anti_resonance_hz,
            shaft.shaft_damping_ratio,
            shaft.load_damping_share};
  }
  const double J = values.Get("J");
  return {J, -linear.A(0, 0) * J, linear.B(0, 0) * J};
}

LoopCheck CheckSampledAt(const TuneInput& input, const TuneRequest& request,
                         const TuneResult& result, const ParameterSet& values) {
  LoopCheck check;
  const bool position = !IsSpeed(request);
  const SampledRigidLoop loop(RigidAt(*input.config.model, values), request.drive);
  const CascadeGains& gains = result.sampled.gains;
  SampledMargins(
      loop, gains, position,
      position ? result.sampled.design.position_crossover_hz : request.design.crossover_hz,
      &check.margins, nullptr);
  check.poles = loop.Poles(gains, position);
  const Experiment experiment =
      SampledStepExperiment(request, gains, result.step, result.duration, result.sample_rate);
  check.step = SimulateStep(input.config, values, experiment, result.plant_output);
  return check;
}

void Warn(TuneResult* result, const std::string& code, const std::string& message) {
  result->warnings.emplace_back(code, message);
}

// What the box says: no intervals, clipped ones, unstable or saturating corners.
void AddBoxWarnings(const TuneInput& input, TuneResult* result) {
  auto warn = [&](const std::string& code, const std::string& message) {
    Warn(result, code, message);
  };
  if (input.box.empty()) {
    warn("no_intervals",
         "no 95 % intervals (give --from-report with a blmd-ident report): the gains are "
         "checked on the nominal model only");
  }
  for (const auto& axis : input.box) {
    if (axis.clipped) {
      warn("interval_clipped", "the 95 % interval of " + axis.name +
                                   " reaches below its lower bound; the box starts at " +
                                   Text(axis.low));
    }
  }
  const WorstCase& w = result->worst;
  const int corners = static_cast<int>(result->corners.size());
  if (w.unstable > 0) {
    warn("unstable_corner", std::to_string(w.unstable) + " of " + std::to_string(corners) +
                                " corners of the 95 % box give an unstable closed loop");
  }
  if (w.saturated > 0) {
    warn("saturated_corner", std::to_string(w.saturated) + " of " + std::to_string(corners) +
                                 " corners of the 95 % box reach the " +
                                 (result->sampled.used ? "drive's limit" : "voltage limit") +
                                 " in the step");
  }
}

// What the simulated step says: a coarse sampled controller, a shaft held short, no figures.
void AddStepWarnings(const TuneInput& input, const TuneRequest& request, TuneResult* result) {
  auto warn = [&](const std::string& code, const std::string& message) {
    Warn(result, code, message);
  };
  // The simulated PID is sampled at the step dt and holds its output over it (a delay of about
  // dt/2, left out of the margins: 180·f_c·dt degrees at the crossover), and its derivative
  // filter is discretised by backward Euler: both matter once f_c or f_d nears 1/dt.
  const double dt = input.config.simulation.dt;
  const double hold_deg = 180.0 * request.design.crossover_hz * dt;
  const double filter_steps = kTwoPi * result->design.controller.derivative_filter_hz * dt;
  if (!result->sampled.used && (hold_deg > 1.0 || filter_steps > 0.1)) {
    warn("sampled_controller",
         "the simulated PID runs at dt = " + Text(dt) + " s: its sample-and-hold costs " +
             Text(hold_deg) + " deg at the crossover and its derivative filter (2 pi f_d dt = " +
             Text(filter_steps) +
             ") is discretised: the step may differ from the continuous loop's margins "
             "(reduce simulation.dt)");
  }
  const ClosedLoopStep& nominal = result->nominal.step;
  if (std::abs(nominal.steady_state_error) > 0.02 * result->step) {
    warn("steady_state_error",
         "the simulated step ends " + Text(nominal.steady_state_error) + " short of the " +
             Text(result->step) + " reference (" +
             Text(100.0 * nominal.steady_state_error / result->step) +
             " %): an effect of the model (friction, a load) holds the shaft within the " +
             Text(result->duration) + " s simulated");
  }
  if (result->worst.invalid > 0) {
    warn("no_step_figures", std::to_string(result->worst.invalid) +
                                " simulated steps (nominal and corners) never rose through 90 %: "
                                "friction or a load holds the shaft short of the reference");
  }
}

}  // namespace

std::string SampledInputUnit(const Config& config) {
  if (config.model->traits().own_current_loop) return "V";  // blmd: the torque demand Td
  if (config.parameters.Get("Kt") != 1.0) return "u";
  return config.linear_axis ? "N" : "N·m";
}

std::string SampledOutputUnit(const Config& config, bool speed) {
  if (config.linear_axis) return speed ? "m/s" : "m";
  return speed ? "rad/s" : "rad";
}

std::string TuneRequest::Validate() const {
  if (std::string error = design.Validate(); !error.empty()) return error;
  if (!(u_max > 0.0) || !std::isfinite(u_max)) return "the voltage limit u must be > 0";
  if (!(i_max >= 0.0) || !std::isfinite(i_max)) return "the current limit i must be > 0";
  if (!(step >= 0.0) || !std::isfinite(step)) return "the step must be > 0";
  if (!(duration >= 0.0) || !std::isfinite(duration)) return "the duration must be > 0";
  if (!(w_max > 0.0)) return "the speed limit must be > 0";
  if (drive.sample_rate_hz > 0.0) {
    if (std::string error = drive.Validate(); !error.empty()) return error;
    if (!(position_crossover_hz >= 0.0) || !std::isfinite(position_crossover_hz))
      return "the position crossover must be > 0 Hz";
    if (!std::isnan(u_min) && !(u_min < u_max)) return "the lower limit must be below the upper";
  }
  return "";
}

Experiment SampledStepExperiment(const TuneRequest& request, const CascadeGains& gains, double step,
                                 double duration, double sample_rate) {
  Experiment experiment;
  experiment.input.kind = InputSignal::Kind::kStep;
  experiment.input.amplitude = step;
  experiment.duration = duration;
  experiment.sample_rate = sample_rate;
  experiment.closed_loop = true;
  PidSettings& pid = experiment.pid;
  pid.loop = request.design.loop;
  if (pid.loop == PidSettings::Loop::kSpeed) {
    pid.Kp = gains.speed_kp;
    pid.Ki = gains.speed_ki;
  } else {
    pid.Kp = gains.position_kp;
    pid.speed_Kp = gains.speed_kp;
    pid.speed_Ki = gains.speed_ki;
  }
  pid.u_max = request.u_max;
  pid.u_min = request.u_min;
  pid.sample_rate = request.drive.sample_rate_hz;
  pid.delay = request.drive.delay_samples;
  pid.current_bandwidth = request.drive.current_bandwidth_hz;
  pid.notch = request.drive.notch;
  return experiment;
}

Experiment StepExperiment(PidSettings::Loop loop, const Controller& controller, double u_max,
                          double step, double duration, double sample_rate) {
  Experiment experiment;
  experiment.input.kind = InputSignal::Kind::kStep;
  experiment.input.amplitude = step;
  experiment.duration = duration;
  experiment.sample_rate = sample_rate;
  experiment.closed_loop = true;
  experiment.pid.loop = loop;
  experiment.pid.Kp = controller.kp;
  experiment.pid.Ki = controller.ki;
  experiment.pid.Kd = controller.kd;
  experiment.pid.tau_d = controller.derivative_filter_hz > 0.0
                             ? 1.0 / (kTwoPi * controller.derivative_filter_hz)
                             : 1e-3;
  experiment.pid.u_max = u_max;
  return experiment;
}

namespace {

// The simulation step for the sampled loop: the config's dt, shortened where needed to a
// whole number of steps per controller sample.
TuneInput WithControllerGrid(const TuneInput& input, const SampledDrive& drive) {
  TuneInput out = input;
  const double ts = 1.0 / drive.sample_rate_hz, dt = input.config.simulation.dt;
  const double steps = std::ceil(ts / dt * (1.0 - 1e-9));
  out.config.simulation.dt = ts / std::max(1.0, steps);
  return out;
}

// The default step of the sampled loop: the dc_servo default, shortened so that the
// proportional kick of the step (speed: kp·step; position: speed_kp·position_kp·step) is at
// most half the drive's limit.
double SampledDefaultStep(const TuneRequest& request, const TuneResult& result) {
  const double limit = std::min(request.u_max, std::abs(request.LowerLimit()));
  const CascadeGains& g = result.sampled.gains;
  const double kick = IsSpeed(request) ? g.speed_kp : g.speed_kp * g.position_kp;
  const double fallback = DefaultStep(request, result.plant);
  double step = IsSpeed(request) ? fallback * limit / request.u_max : fallback;
  // A speed step within a fifth of the speed the drive can hold (blmd: its DC bus).
  if (IsSpeed(request) && std::isfinite(request.w_max)) step = std::min(step, 0.2 * request.w_max);
  return kick > 0.0 ? std::min(step, 0.5 * limit / kick) : step;
}

// The checks every tuned loop gets (docs/tuning.md §3, §4): the simulated step of
// `experiment` on the nominal model, the drive's limits (a refusal ends there), the box's
// corners and the warnings they raise.
void CheckTunedLoop(const TuneInput& input, const TuneRequest& request,
                    const Experiment& experiment, TuneResult* result) {
  const Config& config = input.config;
  result->nominal.step = SimulateStep(config, config.parameters, experiment, result->plant_output);
  CheckLimits(input, request, result);
  if (result->refused) return;
  EvaluateBox(input, request, result);
  AddBoxWarnings(input, result);
  AddStepWarnings(input, request, result);
}

// The plants the notch's width is chosen on (docs/tuning.md §7.7): the corners of the 95 % box
// with the lowest and the highest resonance; without a box, the anti-resonance 10 % either
// side of the model's (a resonance drifts with the load and the temperature).
std::vector<RigidPlant> ResonanceVariants(const TuneInput& input, const RigidPlant& nominal) {
  const std::size_t k = input.box.size();
  if (k == 0) {
    RigidPlant low = nominal, high = nominal;
    low.anti_resonance_hz *= 0.9;
    high.anti_resonance_hz *= 1.1;
    return {low, high};
  }
  if (k > kMaxBoxParameters) return {};  // EvaluateBox refuses it, naming the count
  RigidPlant lowest = nominal, highest = nominal;
  double low = MotorResonanceHz(nominal), high = low;
  for (std::size_t corner = 0; corner < (std::size_t{1} << k); ++corner) {
    const RigidPlant plant = RigidAt(*input.config.model, CornerValues(input, corner));
    const double fr = MotorResonanceHz(plant);
    if (fr < low) {
      low = fr;
      lowest = plant;
    }
    if (fr > high) {
      high = fr;
      highest = plant;
    }
  }
  return {lowest, highest};
}

std::string NotchText(const NotchFilter& notch) {
  return Text(notch.frequency, 4) + " Hz, width " + Text(notch.width, 3) + " Hz, depth " +
         Text(notch.depth, 2);
}

// The refusal of a speed loop the resonance does not allow: the crossing nearest -1 of the PI
// placed at f_c, the resonance-limited crossover and, when a notch was tried, what it allows.
std::string TwoMassRefusal(const SampledRigidLoop& loop, const SampledTuning& sampled, double fc,
                           double pm, const NotchDesign* notch) {
  const double highest = sampled.resonance_limited_crossover_hz;
  std::string where = "the sampled speed loop placed at " + Text(fc) +
                      " Hz on the two-mass shaft (resonance " + Text(sampled.resonance_hz, 3) +
                      " Hz) ";
  if (!sampled.design.ok) {
    // No PI gives the margin at f_c: the shaft's phase there (near its anti-resonance).
    where += "needs " + Text(sampled.design.controller_phase_deg) +
             " deg of the PI (the shaft's phase there, sampled, is " +
             Text(sampled.design.plant_phase_deg) + " deg), beyond the " +
             Text(sampled.design.min_controller_phase_deg) + " to 0 deg it gives";
  } else {
    LoopMargins speed;
    SampledMargins(loop, sampled.design.gains, false, fc, &speed, nullptr);
    where += loop.Poles(sampled.design.gains, false).stable && speed.ok
                 ? "crosses 1 " + std::to_string(speed.gain_crossovers) +
                       " time(s), at one of them " + Text(std::abs(speed.phase_margin_deg), 3) +
                       " deg from -180 deg"
                 : std::string("is unstable");
  }
  std::string text = where + ": the resonance limits the crossover; " +
                     (std::isfinite(highest)
                          ? "the highest crossover with " + Text(pm) +
                                " deg from -180 deg at every crossing on the two-mass shaft is " +
                                Text(highest, 4) + " Hz"
                          : std::string("no crossover within two decades below meets the request"));
  if (notch == nullptr) return text + " (or allow a notch on the torque command: --notch auto)";
  if (std::isfinite(notch->highest_crossover_hz)) {
    return text + "; with a notch at the resonance (" + NotchText(notch->notch) +
           ", the best of widths 0.05-1 times it) it is " + Text(notch->highest_crossover_hz, 4) +
           " Hz";
  }
  return text + "; no notch at the resonance (widths 0.05-1 times it) meets the request either";
}

TuneResult TuneSampled(const TuneInput& original, const TuneRequest& asked) {
  const TuneInput input = WithControllerGrid(original, asked.drive);
  // The request the loop is checked with: the drive's notch may be designed here.
  TuneRequest request = asked;
  if (request.notch == NotchMode::kOff) request.drive.notch = NotchFilter{};
  TuneResult result;
  const bool position = !IsSpeed(request);
  result.plant_output = position ? "theta" : "w";
  const Config& config = input.config;
  result.plant = PlantAt(*config.model, config.parameters, result.plant_output);
  SampledTuning& sampled = result.sampled;
  sampled.used = true;
  sampled.linear_axis = config.linear_axis;
  const RigidPlant shaft = RigidAt(*config.model, config.parameters);
  const double fc = request.design.crossover_hz, pm = request.design.phase_margin_deg;
  SampledRigidLoop loop(shaft, request.drive);
  sampled.design = DesignSampledSpeedPi(loop, fc, pm);
  if (shaft.two_mass() && fc < loop.nyquist_hz() &&
      !MeetsAtEveryCrossing(loop, sampled.design, fc, pm)) {
    // A flexible coupling (two_mass): the resonance, not the delay, limits the loop.
    sampled.resonance_hz = MotorResonanceHz(shaft);
    sampled.resonance_limited_crossover_hz = ResonanceLimitedCrossover(loop, fc, pm);
    if (request.notch == NotchMode::kOff) {
      result.refused = true;
      result.refusal = TwoMassRefusal(loop, sampled, fc, pm, nullptr);
      return result;
    }
    SampledDrive bare = request.drive;
    bare.notch = NotchFilter{};
    const NotchDesign notch = DesignNotch(shaft, ResonanceVariants(input, shaft), bare, fc, pm);
    if (!notch.ok) {
      result.refused = true;
      result.refusal = TwoMassRefusal(loop, sampled, fc, pm, &notch);
      return result;
    }
    request.drive.notch = notch.notch;
    loop = SampledRigidLoop(shaft, request.drive);
    sampled.design = notch.design;
    sampled.notch_designed = true;
    sampled.notch_peak_ratio = notch.peak_ratio;
    sampled.notch_worst_variant_margin_deg = notch.worst_variant_margin_deg;
  }
  sampled.notch = request.drive.notch;
  sampled.gains = sampled.design.gains;
  // The dc_servo fields the report shares: the tuned loop's gains and the plant at f_c.
  result.design.plant_gain = sampled.design.plant_gain;
  result.design.plant_phase_deg = sampled.design.plant_phase_deg;
  result.design.controller_phase_deg = sampled.design.controller_phase_deg;
  if (!sampled.design.ok) {
    result.refused = true;
    result.refusal = sampled.design.reason;
    return result;
  }
  SampledMargins(loop, sampled.gains, false, fc, &sampled.speed, &sampled.speed_continuous);
  sampled.speed_poles = loop.Poles(sampled.gains, false);
  if (!sampled.speed_poles.stable) {
    result.refused = true;
    result.refusal = "the sampled speed loop placed at " + Text(fc) +
                     " Hz is unstable on the model: ask for another crossover or phase margin";
    return result;
  }
  double tuned_hz = fc;
  if (position) {
    sampled.design.position_crossover_hz = request.position_crossover_hz > 0.0
                                               ? request.position_crossover_hz
                                               : kDefaultPositionRatio * fc;
    tuned_hz = sampled.design.position_crossover_hz;
    std::string reason;
    if (!DesignSampledPositionP(loop, tuned_hz, &sampled.gains, &reason)) {
      result.refused = true;
      result.refusal = reason;
      return result;
    }
    SampledMargins(loop, sampled.gains, true, tuned_hz, &sampled.position,
                   &sampled.position_continuous);
  }
  result.design.ok = true;
  result.design.controller.kp = position ? sampled.gains.position_kp : sampled.gains.speed_kp;
  result.design.controller.ki = position ? 0.0 : sampled.gains.speed_ki;
  result.nominal.margins = position ? sampled.position : sampled.speed;
  result.nominal.poles = loop.Poles(sampled.gains, position);
  if (!result.nominal.poles.stable) {
    result.refused = true;
    result.refusal = "the sampled position loop placed at " + Text(tuned_hz) +
                     " Hz is unstable on the model: ask for a lower --position-crossover";
    return result;
  }
  result.step = request.step > 0.0 ? request.step : SampledDefaultStep(request, result);
  TuneRequest timing = request;
  timing.design.crossover_hz = tuned_hz;
  ChooseTimeBase(timing, result.nominal.poles, config.simulation.dt, &result);
  if (const std::string error = RunLengthError(result.duration, config.simulation.dt,
                                               result.duration * result.sample_rate);
      !error.empty()) {
    throw InputError(error);
  }
  const Experiment experiment = SampledStepExperiment(request, sampled.gains, result.step,
                                                      result.duration, result.sample_rate);
  CheckTunedLoop(input, request, experiment, &result);
  if (result.refused) return result;
  if (request.sample_rate_assumed) {
    Warn(&result, "sample_rate_assumed",
         "no --sample-rate (nor experiment.pid.sample_rate): the controller is taken to run at "
         "1/simulation.dt = " +
             Text(request.drive.sample_rate_hz) +
             " Hz; give the drive's own rate, the gains and margins depend on it");
  }
  if (position && sampled.position.ok &&
      sampled.position.phase_margin_deg < request.design.phase_margin_deg) {
    Warn(&result, "position_phase_margin",
         "the position loop's phase margin on the sampled loop is " +
             Text(sampled.position.phase_margin_deg) + " deg, below the " +
             Text(request.design.phase_margin_deg) +
             " deg asked of the speed loop (ask for a lower --position-crossover)");
  }
  return result;
}

}  // namespace

TuneResult Tune(const TuneInput& input, const TuneRequest& request) {
  if (std::string error = request.Validate(); !error.empty()) throw InputError(error);
  if (input.config.model->traits().sampled_pid) {
    if (!(request.drive.sample_rate_hz > 0.0))
      throw InputError("model " + std::string(input.config.model->name()) +
                       " is tuned on the drive's sampled loop: give --sample-rate HZ");
    return TuneSampled(input, request);
  }
  TuneResult result;
  result.plant_output = IsSpeed(request) ? "w" : "theta";
  const Config& config = input.config;
  result.plant = PlantAt(*config.model, config.parameters, result.plant_output);
  result.design = DesignController(result.plant, request.design);
  if (!result.design.ok) {
    result.refused = true;
    result.refusal = result.design.reason;
    return result;
  }
  const double fc = request.design.crossover_hz;
  result.nominal.margins = ComputeMargins(result.plant, result.design.controller,
                                          fc / kSearchDecades, fc * kSearchDecades);
  result.nominal.poles = ComputeClosedLoopPoles(result.plant, result.design.controller);
  if (!result.nominal.poles.stable) {
    result.refused = true;
    result.refusal = "the loop placed at " + Text(fc) + " Hz is unstable on the model (" +
                     std::to_string(result.nominal.margins.gain_crossovers) +
                     " gain crossovers): ask for another crossover or phase margin";
    return result;
  }
  result.step = request.step > 0.0 ? request.step : DefaultStep(request, result.plant);
  ChooseTimeBase(request, result.nominal.poles, config.simulation.dt, &result);
  if (const std::string error = RunLengthError(result.duration, config.simulation.dt,
                                               result.duration * result.sample_rate);
      !error.empty()) {
    throw InputError(error);
  }
  const Experiment experiment =
      StepExperiment(request.design.loop, result.design.controller, request.u_max, result.step,
                     result.duration, result.sample_rate);
  CheckTunedLoop(input, request, experiment, &result);
  if (result.refused) return result;
  return result;
}

}  // namespace blmd
