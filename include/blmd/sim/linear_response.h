// Responses of a model's linear part (linear_model.h, docs/report.md "Frequency response" and
// "Step response"): its frequency response (Bode magnitude and phase) and its step response
// with the classical figures (rise time, overshoot, settling time). Exact: the frequency
// response is C (jωI - A)^-1 B + D, the step response is sampled from the exact zero-order-hold
// discretisation x+ = Φ x + Γ u, [Φ Γ; 0 I] = exp([A B; 0 0]·dt) (Franklin, Powell & Workman,
// Digital Control of Dynamic Systems, 3rd ed. 1998, §4.3.3), so neither depends on a step size.
#pragma once

#include <Eigen/Dense>
#include <complex>
#include <cstddef>
#include <string>
#include <vector>

#include "blmd/sim/linear_model.h"

namespace blmd {

// G_k(j·2π·f) = C_k (j·2π·f·I - A)^-1 B + D_k: output k's response to the input at f_hz.
// With sample_interval_s = T > 0, the response of the samples instead: the input held between
// samples (zero-order hold, as a trace's u is: docs/trace-format.md) and the output sampled,
// H_k(z) = C_k (zI - Φ)^-1 Γ + D_k at z = exp(j·2π·f·T), the exact discretisation's
// transfer function (Franklin, Powell & Workman §4.3.3); it equals G_k up to the hold's
// delay of T/2 and its gain sinc(f·T) for f well below 1/(2T), and is what the Welch estimate
// of sampled records measures. `model` must be available and k one of its outputs.
std::complex<double> FrequencyResponse(const LinearModel& model, std::size_t output, double f_hz,
                                       double sample_interval_s = 0.0);

// 20·log10|G| (dB) and the phase of G (degrees) of output k at increasing frequencies `f_hz`
// (continuous, or sampled with sample_interval_s > 0 as FrequencyResponse).
// The phase is unwrapped along the frequencies: it starts from its principal value
// (-180°, 180°] at the first frequency and moves continuously (no jump of more than 180°
// between neighbours), so an integrator with two lags reads -90° falling to -270°.
struct BodeCurve {
  std::vector<double> f_hz, magnitude_db, phase_deg;
};
BodeCurve Bode(const LinearModel& model, std::size_t output, const std::vector<double>& f_hz,
               double sample_interval_s = 0.0);

// The exact zero-order-hold discretisation of `model` over `dt_s`:
// [Φ Γ; 0 I] = exp([A B; 0 0]·dt).
void DiscretiseLinearModel(const LinearModel& model, double dt_s, Eigen::MatrixXd* phi,
                           Eigen::VectorXd* gamma);

// The classical figures of a response y(t) to a unit step at t = 0 with final value `final_value`
// (all times in s from the step; between samples the response is interpolated linearly):
//   rise time        from the first reaching of 10 % to the first reaching of 90 % of the
//                    final value (y(0) counts: a response starting beyond 10 % starts at 0);
//   peak, overshoot  the largest y/final (its y and time); overshoot = 100·(peak - final)/
//                    |final| in %, 0 when the response never passes its final value;
//   settling time    the last time y is outside final ± settling_band·|final| (2 % by default).
// Not ok (reason set) when final_value is zero or not finite, or the samples do not reach 90 %.
// settling_time_s is NaN when y is still outside the band at the last sample.
struct StepFigures {
  bool ok = false;
  std::string reason;
  double final_value = 0.0;  // output units per input unit
  double rise_time_s = 0.0;
  double overshoot_percent = 0.0;
  double peak_value = 0.0, peak_time_s = 0.0;
  double settling_time_s = 0.0;
};
StepFigures MeasureStep(const std::vector<double>& t_s, const std::vector<double>& y,
                        double final_value, double settling_band = 0.02);

// The response of every output to a unit step of the input (1 V, or 1 N·m for a torque input)
// at t = 0 from rest (x = 0). Duration: 8 times the slowest time constant 1/|Re λ| of the
// non-zero eigenvalues λ of A (2 % settling of a first-order lag takes 3.9 of them); samples:
// at least 2000 and 50 per fastest time constant 1/max|λ|, at most 200 000. The final value
// of output k is its DC gain G_k(0) = num_k(0)/den_k(0) (TransferFunctions); an output whose
// transfer function keeps a pole at s = 0 (an angle: it integrates) or whose poles are not all
// in the left half-plane has no final value and no figures (the reason says which).
struct StepResponse {
  bool ok = false;
  std::string reason;  // why there is none (no linear part, no stable pole to set a time scale)
  double duration_s = 0.0;
  double dt_s = 0.0;
  std::vector<double> t_s;             // 0, dt, ..., duration
  std::vector<std::vector<double>> y;  // per output of the model, at t_s
  std::vector<StepFigures> figures;    // per output
};
StepResponse ComputeStepResponse(const LinearModel& model);

}  // namespace blmd
