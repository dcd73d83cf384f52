// The blmd model (src/sim/blmd/blmd_drive.cc, docs/model-blmd.md) against oracles that do not
// come from its own code: Kirchhoff's current law at the isolated neutral, the PWM average
// and the blanking loss Ud·delta/Ts, the energy balance, Newton's law for the shaft, the
// electrical frequency p·w/2π, convergence towards a ten times finer step, and the paper's
// 1 V step (Figs. 6-7). The measured figures are printed (and recorded as test properties)
// so that docs/model-blmd.md can quote them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "blmd/io/config.h"
#include "blmd/run.h"
#include "blmd/sim/model.h"
#include "support/test_support.h"

namespace blmd {
namespace {

constexpr double kPi = std::numbers::pi;

// The drive of configs/blmd-d31x.json (PI compensator, Tz = Tp = 0).
ParameterSet D31xParameters() {
  ParameterSet values;
  const std::vector<std::pair<std::string, double>> entries = {
      {"Ud", 310.0},    {"Rs", 1.0},      {"Ls", 0.004},   {"Ke", 0.3}, {"p", 3.0},  {"Kc", 1.1},
      {"Kf", 0.5},      {"Kp", 8.0},      {"Ki", 16000.0}, {"Tz", 0.0}, {"Tp", 0.0}, {"Vtri", 10.0},
      {"Tpwm", 200e-6}, {"delta", 20e-6}, {"J", 11.9e-4},  {"B", 5e-4}};
  for (const auto& [name, value] : entries) values.Set(name, value);
  return values;
}

struct RunSetup {
  ParameterSet values = D31xParameters();
  std::vector<std::string> effects;
  Experiment experiment;
  SimulationSettings settings;

  RunSetup() {
    experiment.input.kind = InputSignal::Kind::kStep;
    experiment.input.amplitude = 1.0;  // V of torque demand
    experiment.duration = 0.16;
    experiment.sample_rate = 50000.0;
    settings.dt = 1e-6;
    settings.regula_falsi = true;
    settings.diagnostics = true;
  }
  void EveryStep() { experiment.sample_rate = 1.0 / settings.dt; }
  void AddEffect(const std::string& name,
                 const std::vector<std::pair<std::string, double>>& parameters) {
    effects.push_back(name);
    for (const auto& [key, value] : parameters) values.Set(key, value);
  }
  // Open current loop (Kf = Ki = 0, Tz = Tp = 0, Kp = Kc = 1): the control voltage of leg j
  // is Td cos(p theta - 2(j-1)pi/3), a fixed duty while the rotor angle is fixed.
  void OpenLoop(double Td) {
    for (const char* name : {"Kf", "Ki", "Tz", "Tp"}) values.Set(name, 0.0);
    values.Set("Kp", 1.0);
    values.Set("Kc", 1.0);
    experiment.input.amplitude = Td;
  }
  // Rotor held still by a stiction far above any torque the drive makes.
  void LockRotor(double theta) {
    experiment.initial.theta = theta;
    AddEffect("coulomb_friction", {{"Tc", 1e4}});
  }
};

Trace Simulate(const RunSetup& setup) {
  const std::vector<double> times = setup.experiment.SampleTimes();
  SimulationRequest request;
  request.parameters = &setup.values;
  request.effects = &setup.effects;
  request.experiment = &setup.experiment;
  request.settings = setup.settings;
  request.sample_times = &times;
  Trace trace;
  const SimStatus status = FindModel("blmd").Simulate(request, &trace);
  EXPECT_TRUE(status.ok()) << status.message;
  return trace;
}

void Report(const std::string& key, double value) {
  std::printf("[ measured ] %s = %.6g\n", key.c_str(), value);
  ::testing::Test::RecordProperty(key, std::to_string(value));
}

// Leg-to-ground voltage of phase j (step average): v_jg = v_j + v_sg.
std::vector<double> LegVoltage(const Trace& trace, const char* phase) {
  std::vector<double> leg = trace.Column(phase);
  const auto& neutral = trace.Column("vsg");
  for (std::size_t k = 0; k < leg.size(); ++k) leg[k] += neutral[k];
  return leg;
}

// Mean of the step averages in rows (first, last], i.e. over the steps ending there.
double MeanOfSteps(const std::vector<double>& x, std::size_t first, std::size_t last) {
  double sum = 0.0;
  for (std::size_t k = first + 1; k <= last; ++k) sum += x[k];
  return sum / static_cast<double>(last - first);
}

// Moving average over `width` samples, centred (both ends shortened): on the 50 kHz trace
// a width of one carrier period (10 samples) removes the PWM ripple.
std::vector<double> MovingAverage(const std::vector<double>& x, std::size_t width) {
  std::vector<double> out(x.size(), 0.0);
  for (std::size_t k = 0; k < x.size(); ++k) {
    const std::size_t lo = k >= width / 2 ? k - width / 2 : 0;
    const std::size_t hi = std::min(x.size(), lo + width);
    double sum = 0.0;
    for (std::size_t m = lo; m < hi; ++m) sum += x[m];
    out[k] = sum / static_cast<double>(hi - lo);
  }
  return out;
}

// Instants where x crosses zero, after t_min. A crossing counts once x has moved from beyond
// -band to beyond +band (or back), so that residual ripple near zero cannot count twice; its
// instant is the zero of the least-squares line through the samples of that passage.
std::vector<double> ZeroCrossings(const std::vector<double>& t, const std::vector<double>& x,
                                  double t_min, double band) {
  std::vector<double> crossings;
  int side = 0;  // sign of the last excursion beyond the band, 0: none yet
  std::size_t last_outside = 0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    if (t[k] < t_min || std::abs(x[k]) <= band) continue;
    const int now = x[k] > 0.0 ? 1 : -1;
    if (side != 0 && now != side) {
      double st = 0.0, sx = 0.0, stt = 0.0, stx = 0.0;
      const double n = static_cast<double>(k - last_outside + 1);
      for (std::size_t m = last_outside; m <= k; ++m) {
        const double tm = t[m] - t[last_outside];
        st += tm;
        sx += x[m];
        stt += tm * tm;
        stx += tm * x[m];
      }
      const double slope = (n * stx - st * sx) / (n * stt - st * st);
      const double intercept = (sx - slope * st) / n;
      crossings.push_back(t[last_outside] - intercept / slope);
    }
    side = now;
    last_outside = k;
  }
  return crossings;
}

double Interpolate(const std::vector<double>& t, const std::vector<double>& y, double at) {
  const auto it = std::upper_bound(t.begin(), t.end(), at);
  const std::size_t k = std::clamp<std::size_t>(it - t.begin(), 1, t.size() - 1);
  return y[k - 1] + (y[k] - y[k - 1]) * (at - t[k - 1]) / (t[k] - t[k - 1]);
}

// Kirchhoff at the isolated star point: i_a + i_b + i_c = 0 at every step, with blanking,
// cogging and a load, over the whole 160 ms step response.
TEST(BlmdDrive, PhaseCurrentsSumToZeroAtEveryStep) {
  RunSetup setup;
  setup.EveryStep();
  setup.AddEffect("cogging", {{"Tcog", 0.05}, {"periods", 12.0}, {"phase", 0.3}});
  setup.AddEffect("load_torque", {{"TL", 0.1}});
  const Trace trace = Simulate(setup);
  ASSERT_EQ(trace.rows(), 160001u);
  const auto &ia = trace.Column("i"), &ib = trace.Column("ib"), &ic = trace.Column("ic");
  double amplitude = 0.0, worst = 0.0;
  for (std::size_t k = 0; k < trace.rows(); ++k) {
    amplitude = std::max(amplitude, std::abs(ia[k]));
    worst = std::max(worst, std::abs(ia[k] + ib[k] + ic[k]));
  }
  Report("sum_i_max_over_amplitude", worst / amplitude);
  EXPECT_GT(amplitude, 2.0);
  EXPECT_LT(worst, 1e-12 * amplitude);
}

// Without blanking, the PWM leg applies exactly the commanded average Ud (v_c + Vtri)/(2 Vtri)
// over whole carrier periods (regula falsi on). Rotor locked at p theta = 0.6 rad, so the
// three legs run three different fixed duties.
TEST(BlmdDrive, FixedDutyGivesTheCommandedLegVoltage) {
  const double theta = 0.2, Td = 4.0;  // p theta = 0.6 rad
  for (const bool regula_falsi : {true, false}) {
    RunSetup setup;
    setup.OpenLoop(Td);
    setup.LockRotor(theta);
    setup.values.Set("delta", 0.0);
    setup.settings.regula_falsi = regula_falsi;
    setup.experiment.duration = 0.01;  // 50 carrier periods
    setup.EveryStep();
    const Trace trace = Simulate(setup);
    ASSERT_EQ(trace.Column("w").back(), 0.0);  // locked
    const std::size_t steps_per_period = 200;
    const std::size_t first = steps_per_period, last = trace.rows() - 1;  // whole periods
    ASSERT_EQ((last - first) % steps_per_period, 0u);
    double worst_percent = 0.0;
    const char* phases[3] = {"va", "vb", "vc"};
    for (int j = 0; j < 3; ++j) {
      const double control = Td * std::cos(3.0 * theta - 2.0 * kPi * j / 3.0);
      const double commanded = 310.0 * (control + 10.0) / 20.0;
      const double measured = MeanOfSteps(LegVoltage(trace, phases[j]), first, last);
      worst_percent = std::max(worst_percent, 100.0 * std::abs(measured / commanded - 1.0));
    }
    Report(regula_falsi ? "duty_error_percent_regula_falsi" : "duty_error_percent_no_regula_falsi",
           worst_percent);
    if (regula_falsi) {
      EXPECT_LT(worst_percent, 0.5);
    }
  }
}

// Blanking, locked rotor (DC currents of definite sign): every leg loses Ud·delta/Ts of
// average voltage against its current's sign (paper eqs. 12-13), within 10 % of that figure.
TEST(BlmdDrive, BlankingCostsUdDeltaOverTsAgainstTheCurrentSign) {
  const double Td = 4.0;  // v_a ≈ 62 V commanded; the blanking loss is 31 V per leg
  const double loss = 310.0 * 20e-6 / 200e-6;
  std::vector<double> leg_ideal(3), leg_blanked(3), current_sign(3);
  const char* phases[3] = {"va", "vb", "vc"};
  const char* currents[3] = {"i", "ib", "ic"};
  for (const double delta : {0.0, 20e-6}) {
    RunSetup setup;
    setup.OpenLoop(Td);
    setup.LockRotor(0.0);  // cosines 1, -1/2, -1/2
    setup.values.Set("delta", delta);
    setup.experiment.duration = 0.04;  // 10 current time constants Ls/Rs
    setup.EveryStep();
    const Trace trace = Simulate(setup);
    const std::size_t last = trace.rows() - 1, first = last - 50 * 200;  // last 50 periods
    for (int j = 0; j < 3; ++j) {
      const double mean = MeanOfSteps(LegVoltage(trace, phases[j]), first, last);
      (delta == 0.0 ? leg_ideal : leg_blanked)[j] = mean;
      if (delta > 0.0) {
        const auto& i = trace.Column(currents[j]);
        const double i_min = *std::min_element(i.begin() + first, i.end());
        const double i_max = *std::max_element(i.begin() + first, i.end());
        ASSERT_TRUE(i_min > 0.0 || i_max < 0.0) << "current of " << currents[j] << " changes sign";
        current_sign[j] = i_min > 0.0 ? 1.0 : -1.0;
      }
    }
  }
  double worst = 0.0;
  for (int j = 0; j < 3; ++j) {
    const double lost_against_current = (leg_ideal[j] - leg_blanked[j]) * current_sign[j];
    worst = std::max(worst, std::abs(lost_against_current / loss - 1.0));
  }
  Report("blanking_loss_Ud_delta_over_Ts_V", loss);
  Report("blanking_loss_worst_relative_error", worst);
  EXPECT_LT(worst, 0.10);
}

// Blanking with the rotor turning (sinusoidal currents, open loop at a held speed): the
// phase voltage's fundamental loses (4/pi)·Ud·delta/Ts — the fundamental of a ±Ud·delta/Ts
// square wave following the current's sign — along the current's fundamental, within 10 %.
// Across the current it is shifted by where the distorted current really crosses zero, so
// the whole change is also checked against the fundamental of -Ud·delta/Ts·sign(i_a),
// i_a averaged over each carrier period. Fundamentals are complex amplitudes against
// cos(p theta) over the last three electrical cycles.
TEST(BlmdDrive, BlankingLossOfTheFundamentalOpposesTheCurrent) {
  const double Td = 6.0, w0 = 100.0, p = 3.0;
  const double loss = 310.0 * 20e-6 / 200e-6;
  const double commanded = 310.0 * Td / 20.0;  // fundamental amplitude, along cos(p theta)
  std::complex<double> voltage[2], current[2], sign_model;
  for (const int with_blanking : {0, 1}) {
    RunSetup setup;
    setup.OpenLoop(Td);
    setup.values.Set("delta", with_blanking ? 20e-6 : 0.0);
    setup.values.Set("J", 100.0);  // speed constant to < 0.02 % over the run
    setup.experiment.initial.w = w0;
    setup.experiment.duration = 0.1;
    setup.EveryStep();
    const Trace trace = Simulate(setup);
    const auto &theta = trace.Column("theta"), &va = trace.Column("va"), &ia = trace.Column("i");
    const std::size_t last = trace.rows() - 1, period = 200;  // steps per carrier period
    std::size_t first = last - period;
    while (first > period && p * (theta[last] - theta[first]) < 6.0 * kPi) --first;
    std::vector<double> prefix(ia.size() + 1, 0.0);  // for carrier-period means of i_a
    for (std::size_t k = 0; k < ia.size(); ++k) prefix[k + 1] = prefix[k] + ia[k];
    std::complex<double> v(0.0), i(0.0), s(0.0);
    double span = 0.0;
    for (std::size_t k = first + 1; k <= last; ++k) {
      const double angle = 0.5 * p * (theta[k] + theta[k - 1]);
      const double d_angle = p * (theta[k] - theta[k - 1]);
      const std::complex<double> rotor = std::polar(1.0, -angle) * d_angle;
      v += va[k] * rotor;  // step-average voltage of the step ending at row k
      i += 0.5 * (ia[k] + ia[k - 1]) * rotor;
      // The carrier period centred on row k, shifted back at the end of the run (it read up
      // to 100 rows past the end of `prefix` there; found by AddressSanitizer).
      const std::size_t window_end = std::min(k + period / 2, ia.size());
      const double mean_current = (prefix[window_end] - prefix[window_end - period]) / period;
      s += (mean_current < 0.0 ? loss : -loss) * rotor;
      span += d_angle;
    }
    voltage[with_blanking] = v / (0.5 * span);
    current[with_blanking] = i / (0.5 * span);
    if (with_blanking) sign_model = s / (0.5 * span);
  }
  const double ideal_error = std::abs(voltage[0] - commanded) / commanded;
  const std::complex<double> along_current = current[1] / std::abs(current[1]);
  const std::complex<double> change = voltage[1] - voltage[0];
  const double lost_along_current = -(change * std::conj(along_current)).real();
  const double across_current = (change * std::conj(along_current)).imag();
  const double expected = 4.0 / kPi * loss;
  const double sign_model_error = std::abs(change - sign_model) / std::abs(sign_model);
  Report("rotating_fundamental_error_no_blanking_relative", ideal_error);
  Report("rotating_current_amplitude_A", std::abs(current[1]));
  Report("rotating_blanking_fundamental_loss_V", lost_along_current);
  Report("rotating_blanking_fundamental_expected_V", expected);
  Report("rotating_blanking_fundamental_across_current_V", across_current);
  Report("rotating_blanking_vs_sign_model_relative_error", sign_model_error);
  EXPECT_LT(ideal_error, 0.005);
  EXPECT_NEAR(lost_along_current, expected, 0.10 * expected);
  EXPECT_LT(sign_model_error, 0.10);
}

// Energy: over the run, electrical input = copper loss + magnetic energy change + mechanical
// power (Te w), and Te w = B w² + effects·w + kinetic energy change. The step-average phase
// voltage is integrated against the step's mean current, i.e. the exact integral for the
// piecewise-linear current trajectory the sampler reports.
TEST(BlmdDrive, EnergyBalances) {
  RunSetup setup;
  setup.EveryStep();
  setup.AddEffect("coulomb_friction", {{"Tc", 0.05}});
  setup.AddEffect("load_torque", {{"TL", 0.1}});
  setup.AddEffect("quadratic_drag", {{"Cd", 1e-5}});
  setup.AddEffect("cogging", {{"Tcog", 0.05}, {"periods", 12.0}, {"phase", 0.3}});
  const Trace trace = Simulate(setup);
  const double dt = setup.settings.dt, Rs = 1.0, Ls = 0.004, J = 11.9e-4, B = 5e-4;
  const auto &w = trace.Column("w"), &theta = trace.Column("theta"), &Te = trace.Column("Te");
  const std::vector<const std::vector<double>*> v = {&trace.Column("va"), &trace.Column("vb"),
                                                     &trace.Column("vc")};
  const std::vector<const std::vector<double>*> i = {&trace.Column("i"), &trace.Column("ib"),
                                                     &trace.Column("ic")};
  double input = 0.0, input_right_point = 0.0, copper = 0.0, mechanical = 0.0, viscous = 0.0,
         effects = 0.0;
  const std::size_t n = trace.rows();
  for (std::size_t k = 1; k < n; ++k) {
    for (int j = 0; j < 3; ++j) {
      const double i0 = (*i[j])[k - 1], i1 = (*i[j])[k];
      input += dt * (*v[j])[k] * 0.5 * (i0 + i1);
      input_right_point += dt * (*v[j])[k] * i1;
      copper += dt * Rs * (i0 * i0 + i0 * i1 + i1 * i1) / 3.0;
    }
    const double w_mid = 0.5 * (w[k - 1] + w[k]), theta_mid = 0.5 * (theta[k - 1] + theta[k]);
    mechanical += dt * Te[k] * w_mid;
    viscous += dt * B * w_mid * w_mid;
    const double sign = w_mid > 0.0 ? 1.0 : (w_mid < 0.0 ? -1.0 : 0.0);
    const double effect_torque = 0.05 * sign + 0.1 + 1e-5 * w_mid * std::abs(w_mid) +
                                 0.05 * std::sin(12.0 * theta_mid + 0.3);
    effects += dt * effect_torque * w_mid;
  }
  double magnetic = 0.0;
  for (int j = 0; j < 3; ++j) {
    magnetic += 0.5 * Ls * ((*i[j])[n - 1] * (*i[j])[n - 1] - (*i[j])[0] * (*i[j])[0]);
  }
  const double kinetic = 0.5 * J * (w[n - 1] * w[n - 1] - w[0] * w[0]);
  const double electrical_error = (input - copper - magnetic - mechanical) / input;
  const double mechanical_error = (mechanical - viscous - effects - kinetic) / mechanical;
  Report("energy_input_J", input);
  Report("energy_copper_J", copper);
  Report("energy_magnetic_J", magnetic);
  Report("energy_mechanical_J", mechanical);
  Report("energy_kinetic_J", kinetic);
  Report("energy_viscous_J", viscous);
  Report("energy_effects_J", effects);
  Report("energy_electrical_balance_error_percent", 100.0 * electrical_error);
  Report("energy_mechanical_balance_error_percent", 100.0 * mechanical_error);
  // The same with v·i at the step end: the difference is backward Euler's numerical
  // dissipation (Ls/2) sum (delta i)² per step, reported, not asserted.
  Report("energy_right_point_balance_error_percent",
         100.0 * (input_right_point - copper - magnetic - mechanical) / input_right_point);
  EXPECT_GT(mechanical, 5.0);
  EXPECT_LT(std::abs(electrical_error), 0.01);
  EXPECT_LT(std::abs(mechanical_error), 0.01);
}

// Under a held torque demand: the shaft obeys J dw/dt = Te - B w - T_effects (finite
// differences of the 50 kHz w against the Te column, over 1 ms windows), and the phase-a
// current's frequency is p w / 2 pi (zero crossings of the ripple-free current against the
// mean speed between them).
TEST(BlmdDrive, ShaftObeysNewtonAndCurrentFrequencyIsPOmegaOver2Pi) {
  RunSetup setup;
  setup.AddEffect("coulomb_friction", {{"Tc", 0.05}});
  setup.AddEffect("load_torque", {{"TL", 0.1}});
  setup.AddEffect("quadratic_drag", {{"Cd", 1e-5}});
  setup.AddEffect("cogging", {{"Tcog", 0.05}, {"periods", 12.0}, {"phase", 0.3}});
  const Trace trace = Simulate(setup);
  const double J = 11.9e-4, B = 5e-4, p = 3.0;
  const auto &t = trace.Column("t"), &theta = trace.Column("theta"), &ia = trace.Column("i");

  // Acceleration over 1 ms windows, after the current has built up (5 ms): finite
  // difference of w against the trapezoidal mean of (Te - B w - T_effects)/J. On the 50 kHz
  // trace, and on a trace of every step (where only the quadrature differs from the model's
  // own update).
  auto worst_acceleration_error = [&](const Trace& run) {
    const auto &tr = run.Column("t"), &wr = run.Column("w"), &thr = run.Column("theta"),
               &Ter = run.Column("Te");
    const std::size_t window = static_cast<std::size_t>(std::lround(1e-3 / (tr[1] - tr[0])));
    double worst = 0.0;
    for (std::size_t k0 = 5 * window; k0 + window < run.rows(); k0 += window) {
      const double measured = (wr[k0 + window] - wr[k0]) / (tr[k0 + window] - tr[k0]);
      double sum = 0.0;
      for (std::size_t k = k0; k <= k0 + window; ++k) {
        const double effect =
            0.05 + 0.1 + 1e-5 * wr[k] * wr[k] + 0.05 * std::sin(12.0 * thr[k] + 0.3);
        const double weight = (k == k0 || k == k0 + window) ? 0.5 : 1.0;
        sum += weight * (Ter[k] - B * wr[k] - effect) / J;
      }
      worst = std::max(worst, std::abs(measured / (sum / static_cast<double>(window)) - 1.0));
    }
    return worst;
  };
  const double acceleration_50khz = worst_acceleration_error(trace);
  RunSetup every_step = setup;
  every_step.EveryStep();
  const double acceleration_every_step = worst_acceleration_error(Simulate(every_step));
  Report("acceleration_worst_relative_error_50kHz", acceleration_50khz);
  Report("acceleration_worst_relative_error_every_step", acceleration_every_step);
  EXPECT_LT(acceleration_50khz, 0.01);
  EXPECT_LT(acceleration_every_step, 0.001);

  // Frequency: half periods between successive zero crossings of the current averaged over
  // one carrier period (10 samples), against p times the mean speed over the same interval.
  const std::vector<double> smooth = MovingAverage(ia, 10);
  const std::vector<double> crossings = ZeroCrossings(t, smooth, 0.005, 0.3);
  ASSERT_GE(crossings.size(), 6u);
  double worst_frequency = 0.0;
  for (std::size_t n = 1; n < crossings.size(); ++n) {
    const double half_period = crossings[n] - crossings[n - 1];
    const double measured = 0.5 / half_period;
    const double mean_speed =
        (Interpolate(t, theta, crossings[n]) - Interpolate(t, theta, crossings[n - 1])) /
        half_period;
    const double predicted = p * mean_speed / (2.0 * kPi);
    worst_frequency = std::max(worst_frequency, std::abs(measured / predicted - 1.0));
  }
  Report("frequency_half_periods", static_cast<double>(crossings.size() - 1));
  Report("frequency_worst_relative_error", worst_frequency);
  EXPECT_LT(worst_frequency, 0.02);
}

// Convergence: against a dt = 0.1 µs run, the phase-a current of the 1 µs run, with and
// without regula falsi, at the 50 kHz samples over the 160 ms step response.
TEST(BlmdDrive, ConvergesAndRegulaFalsiHelps) {
  auto run = [](double dt, bool regula_falsi) {
    RunSetup setup;
    setup.settings.dt = dt;
    setup.settings.regula_falsi = regula_falsi;
    setup.settings.diagnostics = false;
    return Simulate(setup).Column("i");
  };
  const std::vector<double> reference = run(1e-7, true);
  double reference_ms = 0.0;
  for (double x : reference) reference_ms += x * x / static_cast<double>(reference.size());
  auto rms_error = [&](const std::vector<double>& i) {
    double sum = 0.0;
    for (std::size_t k = 0; k < i.size(); ++k) sum += (i[k] - reference[k]) * (i[k] - reference[k]);
    return std::sqrt(sum / static_cast<double>(i.size()));
  };
  const double with_rf = rms_error(run(1e-6, true));
  const double without_rf = rms_error(run(1e-6, false));
  const double reference_rms = std::sqrt(reference_ms);
  Report("convergence_reference_rms_A", reference_rms);
  Report("convergence_rms_error_regula_falsi_A", with_rf);
  Report("convergence_rms_error_no_regula_falsi_A", without_rf);
  Report("convergence_relative_error_regula_falsi", with_rf / reference_rms);
  Report("convergence_relative_error_no_regula_falsi", without_rf / reference_rms);
  EXPECT_LT(with_rf, 0.01 * reference_rms);
  EXPECT_LT(with_rf, without_rf);
}

// The paper's test (Figs. 6-7) on the bundled config: a 1 V torque-demand step gives, within
// 160 ms, a constant-amplitude swept-frequency phase current over several electrical cycles
// and a monotonic velocity ramp.
TEST(BlmdDrive, OneVoltStepOnBundledConfigIsAnFmCurrentAndAVelocityRamp) {
  const Config config = LoadConfig(testing::SourcePath("configs/blmd-d31x.json"));
  Trace trace;
  const SimStatus status = RunExperiment(config, &trace);
  ASSERT_TRUE(status.ok()) << status.message;
  ASSERT_EQ(trace.rows(), 8001u);
  const auto &t = trace.Column("t"), &w = trace.Column("w"), &ia = trace.Column("i");
  const std::vector<double> smooth = MovingAverage(ia, 10);
  const std::vector<double> crossings = ZeroCrossings(t, smooth, 0.0, 0.3);
  const double cycles = 0.5 * static_cast<double>(crossings.size());
  Report("step_electrical_cycles", cycles);
  Report("step_final_speed_rad_s", w.back());
  EXPECT_GE(cycles, 3.0);
  // The shaft starts once the first active voltage vector has built up some current (all
  // three legs switch together for the first ~27 µs), then accelerates without a pause.
  for (std::size_t k = 1; k < w.size(); ++k) {
    if (t[k] <= 1e-3) {
      ASSERT_GE(w[k], w[k - 1]) << "at t = " << t[k];
    } else {
      ASSERT_GT(w[k], w[k - 1]) << "at t = " << t[k];
    }
  }
  // Constant amplitude: the peak of every half cycle within 10 % of Kc Td / Kf = 2.2 A.
  ASSERT_GE(crossings.size(), 2u);
  double worst_peak = 0.0;
  for (std::size_t n = 1; n < crossings.size(); ++n) {
    double peak = 0.0;
    for (std::size_t k = 0; k < t.size(); ++k) {
      if (t[k] > crossings[n - 1] && t[k] < crossings[n])
        peak = std::max(peak, std::abs(smooth[k]));
    }
    worst_peak = std::max(worst_peak, std::abs(peak / 2.2 - 1.0));
  }
  Report("step_half_cycle_peak_worst_relative_deviation", worst_peak);
  EXPECT_LT(worst_peak, 0.10);
}

// A recorded demand (zero-order hold of the `u` column) reproduces the run that made it: a
// square demand (edges every 5 ms, on the sample grid) replayed from its own 50 kHz trace
// gives the same currents and speed bit for bit. The square reverses the torque.
TEST(BlmdDrive, RecordedDemandReplaysASquareRunExactly) {
  RunSetup square;
  square.experiment.duration = 0.02;
  square.experiment.input.kind = InputSignal::Kind::kSquare;
  square.experiment.input.period = 0.01;  // +1 V for 5 ms, then -1 V
  const Trace original = Simulate(square);
  RunSetup replay = square;
  replay.experiment.input.kind = InputSignal::Kind::kRecorded;
  replay.experiment.input.times = original.Column("t");
  replay.experiment.input.values = original.Column("u");
  const Trace replayed = Simulate(replay);
  for (const char* column : {"u", "i", "ib", "ic", "w", "theta"}) {
    EXPECT_EQ(original.Column(column), replayed.Column(column)) << column;
  }
  const auto& w = original.Column("w");
  const std::size_t at_5ms = 250, at_10ms = 500;
  EXPECT_GT(w[at_5ms], 0.0);
  EXPECT_LT(w[at_10ms], w[at_5ms]);  // decelerating under the negative demand
}

TEST(BlmdDrive, ValidateRejectsACarrierOffTheStepGrid) {
  const Model& model = FindModel("blmd");
  RunSetup setup;
  EXPECT_EQ(model.Validate(setup.values, setup.settings), "");
  setup.settings.dt = 3e-6;  // Tpwm/2 = 100 µs is not a whole number of steps
  EXPECT_NE(model.Validate(setup.values, setup.settings).find("Tpwm/2"), std::string::npos);
  setup.settings.dt = 1e-6;
  setup.values.Set("delta", 150e-6);
  EXPECT_NE(model.Validate(setup.values, setup.settings).find("delta"), std::string::npos);
}

}  // namespace
}  // namespace blmd
