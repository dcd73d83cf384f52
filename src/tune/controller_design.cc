#include "blmd/tune/controller_design.h"

#include <cmath>
#include <cstdio>
#include <numbers>

#include "blmd/constants.h"
#include "blmd/format.h"

namespace blmd {
namespace {

constexpr double kDegree = kRadiansPerDegree;

std::string Text(double value, int digits = 4) { return FormatSignificant(value, digits); }

double WrapDegrees(double degrees) {
  double wrapped = std::fmod(degrees, 360.0);
  if (wrapped <= -180.0) wrapped += 360.0;
  if (wrapped > 180.0) wrapped -= 360.0;
  return wrapped;
}

bool IsPid(const ControllerDesignOptions& options) {
  return options.loop == PidSettings::Loop::kPosition;
}

// The phase range (degrees) the structure covers at the crossover: a PI lags by 0..90°
// (kp cos, ki/ω sin); the PID with Ti = α·Td and the derivative filter at n·ω_c reaches
// from −90° (Td -> 0) to atan(n) (Td -> infinity).
double MaxPhase(const ControllerDesignOptions& options) {
  return IsPid(options) ? std::atan(options.filter_ratio) / kDegree : 0.0;
}
constexpr double kMinPhase = -90.0;

// The controller phase needed at f (Hz) for the phase margin, wrapped to (−180°, 180°].
double NeededPhase(const TransferFunction& plant, const ControllerDesignOptions& options,
                   double f) {
  const auto g = FrequencyResponse(plant, kTwoPi * f);
  return WrapDegrees(options.phase_margin_deg - 180.0 - std::arg(g) / kDegree);
}

bool Feasible(double phase, const ControllerDesignOptions& options) {
  return phase > kMinPhase && (IsPid(options) ? phase < MaxPhase(options) : phase <= 0.0);
}

// The edge of the feasible crossovers nearest to the request, searching down (too much lead
// needed) or up (too much lag needed) over four decades; NaN when there is none.
double FeasibleEdge(const TransferFunction& plant, const ControllerDesignOptions& options,
                    bool down) {
  constexpr int kSteps = 400;  // 100 per decade
  const double ratio = std::pow(10.0, down ? -0.01 : 0.01);
  double previous = options.crossover_hz;
  for (int k = 1; k <= kSteps; ++k) {
    const double f = options.crossover_hz * std::pow(ratio, k);
    if (Feasible(NeededPhase(plant, options, f), options)) {
      double good = f, bad = previous;  // refine the edge between them
      for (int i = 0; i < 60; ++i) {
        const double mid = std::sqrt(good * bad);
        (Feasible(NeededPhase(plant, options, mid), options) ? good : bad) = mid;
      }
      return good;
    }
    previous = f;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

std::string RefusalReason(const TransferFunction& plant, const ControllerDesignOptions& options,
                          const ControllerDesignResult& result) {
  const bool lead = result.controller_phase_deg > 0.0;
  const std::string structure =
      IsPid(options)
          ? "a PID (derivative filter at " + Text(options.filter_ratio) + " x the crossover)"
          : "a PI";
  std::string reason = structure + " cannot give " + Text(options.phase_margin_deg) +
                       " deg of phase margin at " + Text(options.crossover_hz) +
                       " Hz: the plant's phase there is " + Text(result.plant_phase_deg) +
                       " deg, so the controller would need " + Text(result.controller_phase_deg) +
                       " deg, and it gives between " + Text(result.min_controller_phase_deg) +
                       " and " + Text(result.max_controller_phase_deg) + " deg";
  const double edge = FeasibleEdge(plant, options, lead);
  if (std::isfinite(edge)) {
    reason += std::string("; the ") + (lead ? "highest" : "lowest") + " crossover with " +
              Text(options.phase_margin_deg) + " deg is " + Text(edge) + " Hz";
  }
  return reason + " (or ask for a " + (lead ? "smaller" : "larger") + " phase margin)";
}

// PI: kp + ki/(jω) = (1/g) e^{jθ}: kp = cos θ / g, ki = −ω sin θ / g.
Controller DesignPi(double omega, double gain, double phase_deg) {
  Controller c;
  c.kp = std::cos(phase_deg * kDegree) / gain;
  c.ki = std::max(0.0, -omega * std::sin(phase_deg * kDegree) / gain);
  return c;
}

// PID K(1 + 1/(s Ti) + s Td/(1 + s/ω_f)), Ti = α Td, ω_f = n ω_c. With x = ω_c Td and
// q = 1/(1 + 1/n²), C(jω_c)/K = 1 + q x/n + j(q x − 1/(α x)); its phase is θ where
// q(1 − t/n) x² − t x − 1/α = 0, t = tan θ (docs/tuning.md §2.2).
Controller DesignPid(const ControllerDesignOptions& options, double omega, double gain,
                     double phase_deg) {
  const double n = options.filter_ratio, alpha = options.integral_ratio;
  const double q = 1.0 / (1.0 + 1.0 / (n * n)), t = std::tan(phase_deg * kDegree);
  const double a = q * (1.0 - t / n);
  const double x = (t + std::sqrt(t * t + 4.0 * a / alpha)) / (2.0 * a);
  const double re = 1.0 + q * x / n, im = q * x - 1.0 / (alpha * x);
  const double k = 1.0 / (gain * std::hypot(re, im));
  const double td = x / omega;
  Controller c;
  c.kp = k;
  c.ki = k / (alpha * td);
  c.kd = k * td;
  c.derivative_filter_hz = n * options.crossover_hz;
  return c;
}

}  // namespace

std::string ControllerDesignOptions::Validate() const {
  if (!(crossover_hz > 0.0) || !std::isfinite(crossover_hz))
    return "the crossover must be a finite frequency > 0 Hz";
  if (!(phase_margin_deg > 0.0 && phase_margin_deg < 180.0))
    return "the phase margin must be between 0 and 180 degrees (exclusive)";
  if (!(integral_ratio > 0.0) || !std::isfinite(integral_ratio))
    return "the integral ratio Ti/Td must be > 0";
  if (!(filter_ratio > 1.0) || !std::isfinite(filter_ratio))
    return "the derivative filter ratio f_d/f_c must be > 1";
  return "";
}

ControllerDesignResult DesignController(const TransferFunction& plant,
                                        const ControllerDesignOptions& options) {
  ControllerDesignResult result;
  const double omega = kTwoPi * options.crossover_hz;
  const auto g = FrequencyResponse(plant, omega);
  result.plant_gain = std::abs(g);
  result.plant_phase_deg = std::arg(g) / kDegree;
  result.controller_phase_deg = NeededPhase(plant, options, options.crossover_hz);
  result.max_controller_phase_deg = MaxPhase(options);
  result.min_controller_phase_deg = kMinPhase;
  if (!(result.plant_gain > 0.0) || !std::isfinite(result.plant_gain)) {
    result.reason = "the plant's gain at " + Text(options.crossover_hz) + " Hz is " +
                    Text(result.plant_gain) + ": no crossover can be placed there";
    return result;
  }
  if (!Feasible(result.controller_phase_deg, options)) {
    result.reason = RefusalReason(plant, options, result);
    return result;
  }
  result.controller =
      IsPid(options) ? DesignPid(options, omega, result.plant_gain, result.controller_phase_deg)
                     : DesignPi(omega, result.plant_gain, result.controller_phase_deg);
  result.ok = true;
  return result;
}

}  // namespace blmd
