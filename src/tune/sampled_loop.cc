#include "blmd/tune/sampled_loop.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <unsupported/Eigen/MatrixFunctions>

#include "blmd/constants.h"
#include "blmd/format.h"

namespace blmd {
namespace {

using Complex = std::complex<double>;
constexpr double kDegree = kRadiansPerDegree;

std::string Text(double value, int digits = 4) { return FormatSignificant(value, digits); }

// The frequency named in a refusal, rounded towards the feasible side to 4 significant
// digits, so that asking for the number as printed succeeds.
double RoundTowards(double value, bool down) {
  const double scale = std::pow(10.0, std::floor(std::log10(value)) - 3.0);
  return (down ? std::floor(value / scale) : std::ceil(value / scale)) * scale;
}

// The exact ZOH discretisation of the continuous plant, states [w, theta (position), w_load
// and twist (a two-mass shaft), u_a (with the current lag)], input the held command u:
// expm([[A, b], [0, 0]]·Ts) (Franklin, Powell & Workman 1998, ch. 4). w is the motor's.
struct DiscretePlant {
  Eigen::MatrixXd Ad;
  Eigen::VectorXd Bd;
  int theta = -1;  // index of theta, -1 when left out
};

DiscretePlant Discretise(const RigidPlant& p, double wb, bool lag, bool position, double ts) {
  const bool flexible = p.two_mass();
  const int n = 1 + (position ? 1 : 0) + (flexible ? 2 : 0) + (lag ? 1 : 0);
  const int ua = n - 1;
  // The inertia the drive torque accelerates directly: the motor's on a two-mass shaft.
  double Jm = p.J;
  Eigen::MatrixXd augmented = Eigen::MatrixXd::Zero(n + 1, n + 1);
  if (flexible) {
    const int wl = position ? 2 : 1, twist = wl + 1;
    const TwoMassSides sides = p.Sides();
    Jm = sides.Jm;
    sides.SetRows(0, wl, twist, &augmented);
  } else {
    augmented(0, 0) = -p.B / Jm;
  }
  if (position) augmented(1, 0) = 1.0;
  if (lag) {
    augmented(0, ua) = p.Kt / Jm;
    augmented(ua, ua) = -wb;
    augmented(ua, n) = wb;
  } else {
    augmented(0, n) = p.Kt / Jm;
  }
  const Eigen::MatrixXd expm = (augmented * ts).exp();
  DiscretePlant out;
  out.Ad = expm.topLeftCorner(n, n);
  out.Bd = expm.topRightCorner(n, 1);
  out.theta = position ? 1 : -1;
  return out;
}

// The plant behind the drive's notch: the filter's transposed direct form II (states s1, s2;
// y = b0 x + s1, s1+ = −a1 s1 + s2 + (b1 − a1 b0) x, s2+ = −a2 s1 + (b2 − a2 b0) x) in series
// before it, its states appended: [x; s]+ = [[Ad, Bd e1'], [0, Af]] [x; s] + [Bd b0; Bf] u.
DiscretePlant BehindNotch(const DiscretePlant& plant, const NotchFilter& notch, double ts) {
  if (!notch.active()) return plant;
  const Biquad f = DiscreteNotch(notch, ts);
  const int n = static_cast<int>(plant.Ad.rows());
  DiscretePlant out;
  out.theta = plant.theta;
  out.Ad = Eigen::MatrixXd::Zero(n + 2, n + 2);
  out.Ad.topLeftCorner(n, n) = plant.Ad;
  out.Ad.block(0, n, n, 1) = plant.Bd;
  out.Ad(n, n) = -f.a1;
  out.Ad(n, n + 1) = 1.0;
  out.Ad(n + 1, n) = -f.a2;
  out.Bd = Eigen::VectorXd::Zero(n + 2);
  out.Bd.head(n) = plant.Bd * f.b0;
  out.Bd(n) = f.b1 - f.a1 * f.b0;
  out.Bd(n + 1) = f.b2 - f.a2 * f.b0;
  return out;
}

DiscretePlant DrivenPlant(const RigidPlant& p, const SampledDrive& drive, bool position,
                          double ts) {
  return BehindNotch(Discretise(p, kTwoPi * drive.current_bandwidth_hz,
                                drive.current_bandwidth_hz > 0.0, position, ts),
                     drive.notch, ts);
}

// The closed speed loop (or the cascade when position_kp > 0) as x+ = M x + N r: the plant,
// the integral I (in u) and the delay line q_1..q_d of the commands computed, newest first.
// At a sample: e = r_w − w, I += ki·Ts·e, u = kp·e + I, the plant driven by q_d (u when d = 0).
struct ClosedLoopMatrices {
  Eigen::MatrixXd M;
  Eigen::VectorXd N;
};

ClosedLoopMatrices CloseLoop(const DiscretePlant& plant, const CascadeGains& g, int delay,
                             double ts) {
  const int n = static_cast<int>(plant.Ad.rows()), d = delay, size = n + 1 + d;
  const int integral = n;
  // e = e_state·x + e_ref·r.
  Eigen::RowVectorXd e_state = Eigen::RowVectorXd::Zero(size);
  e_state(0) = -1.0;
  double e_ref = 1.0;
  if (plant.theta >= 0 && g.position_kp > 0.0) {
    e_state(plant.theta) = -g.position_kp;
    e_ref = g.position_kp;
  }
  const double kpe = g.speed_kp + g.speed_ki * ts;
  Eigen::RowVectorXd u_state = kpe * e_state;
  u_state(integral) += 1.0;
  const double u_ref = kpe * e_ref;
  ClosedLoopMatrices out;
  out.M = Eigen::MatrixXd::Zero(size, size);
  out.N = Eigen::VectorXd::Zero(size);
  out.M.topLeftCorner(n, n) = plant.Ad;
  if (d == 0) {
    out.M.topRows(n) += plant.Bd * u_state;
    out.N.head(n) = plant.Bd * u_ref;
  } else {
    out.M.block(0, n + d, n, 1) += plant.Bd;  // q_d, the oldest command
    out.M.row(n + 1) = u_state;
    out.N(n + 1) = u_ref;
    for (int j = 2; j <= d; ++j) out.M(n + j, n + j - 1) = 1.0;
  }
  out.M.row(integral) = g.speed_ki * ts * e_state;
  out.M(integral, integral) += 1.0;
  out.N(integral) = g.speed_ki * ts * e_ref;
  return out;
}

Complex Resolvent(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, int row, Complex z) {
  const int n = static_cast<int>(A.rows());
  const Eigen::MatrixXcd zi_a = z * Eigen::MatrixXcd::Identity(n, n) - A.cast<Complex>();
  const Eigen::VectorXcd x = zi_a.partialPivLu().solve(b.cast<Complex>());
  return x(row);
}

// Bisection in log f between a (predicate true) and b (false) to 1e-9 of the frequency.
template <typename Predicate>
double Edge(Predicate holds, double a, double b) {
  for (int k = 0; k < 200 && std::abs(b - a) > 1e-9 * std::max(a, b); ++k) {
    const double mid = std::sqrt(a * b);
    (holds(mid) ? a : b) = mid;
  }
  return a;
}

// The controller phase needed at f and its feasible range.
double NeededPhase(const SampledRigidLoop& loop, double pm, double f) {
  return pm - 180.0 - loop.SpeedPlantPhaseDeg(kTwoPi * f);
}
double MinPiPhase(const SampledRigidLoop& loop, double f) {
  return -(90.0 - 0.5 * kTwoPi * f * loop.period() / kDegree);
}
bool BelowUpper(const SampledRigidLoop& loop, double pm, double f) {
  return NeededPhase(loop, pm, f) <= 0.0;
}
bool AboveLower(const SampledRigidLoop& loop, double pm, double f) {
  return NeededPhase(loop, pm, f) > MinPiPhase(loop, f);
}

std::string DelayText(const SampledDrive& drive) {
  return Text(drive.sample_rate_hz) + " Hz, " + std::to_string(drive.delay_samples) +
         "-sample delay" +
         (drive.current_bandwidth_hz > 0.0
              ? ", current loop " + Text(drive.current_bandwidth_hz) + " Hz"
              : std::string());
}

}  // namespace

struct SampledRigidLoop::Discrete {
  DiscretePlant speed, position;
};

std::string SampledDrive::Validate() const {
  if (!(sample_rate_hz > 0.0) || !std::isfinite(sample_rate_hz))
    return "the controller's sample rate must be > 0 Hz";
  if (delay_samples < 0 || delay_samples > 100) return "the delay must be 0 to 100 samples";
  if (!(current_bandwidth_hz >= 0.0) || !std::isfinite(current_bandwidth_hz))
    return "the current-loop bandwidth must be >= 0 Hz (0: ideal)";
  if (notch.active()) return notch.Validate(sample_rate_hz);
  return "";
}

SampledRigidLoop::SampledRigidLoop(const RigidPlant& plant, const SampledDrive& drive)
    : plant_(plant),
      drive_(drive),
      ts_(1.0 / drive.sample_rate_hz),
      lag_(drive.current_bandwidth_hz > 0.0),
      discrete_(std::make_shared<const Discrete>(
          Discrete{DrivenPlant(plant, drive, false, ts_), DrivenPlant(plant, drive, true, ts_)})) {}

Complex SampledRigidLoop::SpeedPlantAt(double omega) const {
  const DiscretePlant& p = discrete_->speed;
  const Complex z = std::polar(1.0, omega * ts_);
  return Resolvent(p.Ad, p.Bd, 0, z) * std::pow(z, -drive_.delay_samples);
}

// The hold and plant's phase, unwrapped along a logarithmic sweep from ω·1e-6 (where it is
// nearly 0), and the delay's −d·ω·Ts added exactly.
double SampledRigidLoop::SpeedPlantPhaseDeg(double omega) const {
  const DiscretePlant& p = discrete_->speed;
  constexpr int kSteps = 240;
  double phase = 0.0, previous = 0.0;
  for (int k = 0; k <= kSteps; ++k) {
    const double w = omega * std::pow(10.0, -6.0 * (1.0 - static_cast<double>(k) / kSteps));
    const double now = std::arg(Resolvent(p.Ad, p.Bd, 0, std::polar(1.0, w * ts_)));
    if (k == 0) {
      phase = now;
    } else {
      phase += std::remainder(now - previous, kTwoPi);
    }
    previous = now;
  }
  return (phase - drive_.delay_samples * omega * ts_) / kDegree;
}

Complex SampledRigidLoop::PiAt(const CascadeGains& g, double omega) const {
  const Complex z = std::polar(1.0, omega * ts_);
  return g.speed_kp + g.speed_ki * ts_ * z / (z - 1.0);
}

Complex SampledRigidLoop::SpeedLoopAt(const CascadeGains& g, double omega) const {
  return PiAt(g, omega) * SpeedPlantAt(omega);
}

Complex SampledRigidLoop::PositionLoopAt(const CascadeGains& g, double omega) const {
  const DiscretePlant& p = discrete_->position;
  CascadeGains inner = g;
  inner.position_kp = 0.0;
  const ClosedLoopMatrices c = CloseLoop(p, inner, drive_.delay_samples, ts_);
  return g.position_kp * Resolvent(c.M, c.N, p.theta, std::polar(1.0, omega * ts_));
}

Complex SampledRigidLoop::ContinuousSpeedLoopAt(const CascadeGains& g, double omega) const {
  const Complex s(0.0, omega);
  Complex plant = plant_.Kt / (plant_.J * s + plant_.B);
  if (plant_.two_mass()) {
    // Wm/T = (Jl s + Bl + Z) / ((Jm s + Bm + Z)(Jl s + Bl + Z) - Z^2), Z = K/s + c.
    const auto [Jm, Jl, K, c, Bm, Bl] = plant_.Sides();
    const Complex Z = K / s + c;
    plant = plant_.Kt * (Jl * s + Bl + Z) / ((Jm * s + Bm + Z) * (Jl * s + Bl + Z) - Z * Z);
  }
  if (lag_) plant /= 1.0 + s / (kTwoPi * drive_.current_bandwidth_hz);
  plant *= drive_.notch.ContinuousAt(s);
  return (g.speed_kp + g.speed_ki / s) * plant;
}

Complex SampledRigidLoop::ContinuousPositionLoopAt(const CascadeGains& g, double omega) const {
  const Complex l = ContinuousSpeedLoopAt(g, omega);
  return g.position_kp * l / (1.0 + l) / Complex(0.0, omega);
}

ClosedLoopPoles SampledRigidLoop::Poles(const CascadeGains& g, bool position) const {
  const DiscretePlant& p = position ? discrete_->position : discrete_->speed;
  CascadeGains gains = g;
  if (!position) gains.position_kp = 0.0;
  const ClosedLoopMatrices c = CloseLoop(p, gains, drive_.delay_samples, ts_);
  const Eigen::EigenSolver<Eigen::MatrixXd> solver(c.M, false);
  ClosedLoopPoles out;
  out.stable = solver.info() == Eigen::Success;
  double largest = 0.0;
  for (int k = 0; k < solver.eigenvalues().size(); ++k) {
    const Complex pole = solver.eigenvalues()(k);
    out.poles.push_back(pole);
    if (!(std::abs(pole) < 1.0)) out.stable = false;
    largest = std::max(largest, std::abs(pole));
  }
  // The delay line's poles sit at z = 0: a largest |z| of 0 is a dead-beat loop.
  if (out.stable) out.slowest_time_constant = largest > 0.0 ? -ts_ / std::log(largest) : ts_;
  return out;
}

double HighestSampledCrossover(const SampledRigidLoop& loop, double phase_margin_deg) {
  const double top = loop.nyquist_hz() * (1.0 - 1e-9), bottom = loop.nyquist_hz() * 1e-7;
  auto feasible = [&](double f) {
    return BelowUpper(loop, phase_margin_deg, f) && AboveLower(loop, phase_margin_deg, f);
  };
  if (BelowUpper(loop, phase_margin_deg, top)) {
    return feasible(top) ? top : std::numeric_limits<double>::quiet_NaN();
  }
  if (!BelowUpper(loop, phase_margin_deg, bottom)) return std::numeric_limits<double>::quiet_NaN();
  const double edge =
      Edge([&](double f) { return BelowUpper(loop, phase_margin_deg, f); }, bottom, top);
  return feasible(edge) ? edge : std::numeric_limits<double>::quiet_NaN();
}

SampledDesignResult DesignSampledSpeedPi(const SampledRigidLoop& loop, double crossover_hz,
                                         double phase_margin_deg) {
  SampledDesignResult result;
  const double omega = kTwoPi * crossover_hz, ts = loop.period();
  const double pm = phase_margin_deg;
  result.highest_crossover_hz = HighestSampledCrossover(loop, pm);
  const std::string pi = "a sampled PI (" + DelayText(loop.drive()) + ")";
  if (!(crossover_hz < loop.nyquist_hz())) {
    result.reason = "a crossover of " + Text(crossover_hz) +
                    " Hz is not below the Nyquist frequency of the controller's sampling (" +
                    Text(loop.nyquist_hz()) + " Hz)";
  } else {
    const Complex g = loop.SpeedPlantAt(omega);
    result.plant_gain = std::abs(g);
    result.plant_phase_deg = loop.SpeedPlantPhaseDeg(omega);
    result.controller_phase_deg = pm - 180.0 - result.plant_phase_deg;
    result.min_controller_phase_deg = MinPiPhase(loop, crossover_hz);
    const double theta = result.controller_phase_deg;
    if (!(result.plant_gain > 0.0) || !std::isfinite(result.plant_gain)) {
      result.reason = "the sampled plant's gain at " + Text(crossover_hz) + " Hz is " +
                      Text(result.plant_gain) + ": no crossover can be placed there";
      return result;
    }
    if (theta <= 0.0 && theta > result.min_controller_phase_deg) {
      const double m = 1.0 / result.plant_gain, x = omega * ts;
      result.gains.speed_ki =
          std::max(0.0, -2.0 * m * std::sin(theta * kDegree) * std::tan(0.5 * x) / ts);
      result.gains.speed_kp = m * std::cos(theta * kDegree) - 0.5 * result.gains.speed_ki * ts;
      result.ok = true;
      return result;
    }
    result.reason = "the plant's phase there, sampled (ZOH and delay), is " +
                    Text(result.plant_phase_deg) + " deg, so the PI would need " + Text(theta) +
                    " deg, and it gives between " + Text(result.min_controller_phase_deg) +
                    " and 0 deg";
    if (theta <= 0.0) {
      // Too much lag needed: the crossover is below the plant's corner; name the lowest.
      const double top =
          std::isfinite(result.highest_crossover_hz) ? result.highest_crossover_hz : crossover_hz;
      if (AboveLower(loop, pm, top)) {
        const double lowest =
            Edge([&](double f) { return AboveLower(loop, pm, f); }, top, crossover_hz);
        result.reason += "; the lowest crossover with " + Text(pm) +
                         " deg on the sampled loop is " + Text(RoundTowards(lowest, false)) + " Hz";
      }
      result.reason = pi + " cannot give " + Text(pm) + " deg of phase margin at " +
                      Text(crossover_hz) + " Hz: " + result.reason +
                      " (or ask for a smaller phase margin)";
      return result;
    }
  }
  result.reason = pi + " cannot give " + Text(pm) + " deg of phase margin at " +
                  Text(crossover_hz) + " Hz" + (result.reason.empty() ? "" : ": " + result.reason) +
                  "; the highest crossover with " + Text(pm) + " deg on the sampled loop is " +
                  (std::isfinite(result.highest_crossover_hz)
                       ? Text(RoundTowards(result.highest_crossover_hz, true)) + " Hz"
                       : std::string("none")) +
                  " (or ask for a smaller phase margin, a faster sample rate or less delay)";
  return result;
}

bool DesignSampledPositionP(const SampledRigidLoop& loop, double position_crossover_hz,
                            CascadeGains* gains, std::string* reason) {
  const double omega = kTwoPi * position_crossover_hz;
  CascadeGains unit = *gains;
  unit.position_kp = 1.0;
  const Complex t = loop.PositionLoopAt(unit, omega);
  const double margin = 180.0 + std::arg(t) / kDegree;
  if (!(std::abs(t) > 0.0) || !std::isfinite(std::abs(t)) || !(margin > 0.0)) {
    *reason = "the position loop at " + Text(position_crossover_hz) +
              " Hz over the tuned speed loop has no phase margin (" + Text(margin) +
              " deg): ask for a lower --position-crossover";
    return false;
  }
  gains->position_kp = 1.0 / std::abs(t);
  return true;
}

}  // namespace blmd
