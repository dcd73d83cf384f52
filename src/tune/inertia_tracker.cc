#include "tune/inertia_tracker.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "blmd/constants.h"
#include "blmd/error.h"
#include "blmd/format.h"
#include "blmd/version.h"

namespace blmd {
namespace {

constexpr double kZ95 = 1.959963984540054;    // the normal 97.5 % quantile
constexpr double kZeta = 0.7071067811865476;  // Butterworth damping of the filter
// The diffuse prior of a load torque the report does not give, over the noise floor: the
// first samples then set TL (gain P / (P + R) ~ 1).
constexpr double kDiffuse = 1e6;

double VarianceOf(const ExportedValue& v, double fallback_std) {
  if (v.has_interval) {
    const double half = 0.5 * (v.high - v.low) / kZ95;
    if (half > 0.0) return half * half;
  }
  return fallback_std * fallback_std;
}

std::string Exact(double v) { return FormatExact17(v); }

}  // namespace

void TrackerFilter(double filter_hz, double dt, double ad[4], double bd[2]) {
  const double wf = 2.0 * kPi * filter_hz;
  // M = I - A dt/2, N = I + A dt/2; Ad = M^-1 N, bd = M^-1 b dt.
  const double m00 = 1.0, m01 = -0.5 * dt, m10 = 0.5 * wf * wf * dt, m11 = 1.0 + kZeta * wf * dt;
  const double det = m00 * m11 - m01 * m10;
  const double i00 = m11 / det, i01 = -m01 / det, i10 = -m10 / det, i11 = m00 / det;
  const double n00 = 1.0, n01 = 0.5 * dt, n10 = -0.5 * wf * wf * dt, n11 = 1.0 - kZeta * wf * dt;
  ad[0] = i00 * n00 + i01 * n10;
  ad[1] = i00 * n01 + i01 * n11;
  ad[2] = i10 * n00 + i11 * n10;
  ad[3] = i10 * n01 + i11 * n11;
  bd[0] = i01 * wf * wf * dt;
  bd[1] = i11 * wf * wf * dt;
}

TrackerSeed MakeTrackerSeed(const Compensation& model, const TrackerSettings& settings, double dt,
                            double speed_noise) {
  if (!(dt > 0.0) || !std::isfinite(dt)) throw InputError("the trace's sample period must be > 0");
  TrackerSeed seed;
  seed.dt = dt;
  seed.filter_hz =
      settings.filter_hz > 0.0 ? settings.filter_hz : std::clamp(1.0 / dt / 50.0, 1.0, 50.0);
  if (!(seed.filter_hz < 0.5 / dt)) {
    throw InputError("--filter-hz " + FormatNumber(seed.filter_hz) +
                     ": the filter's corner must lie below half the sample rate (" +
                     FormatNumber(0.5 / dt) + " Hz)");
  }
  seed.lambda = std::exp(-dt / settings.memory_s);
  seed.change_margin = settings.change_margin;
  // The filtered acceleration's response to white speed noise of unit std: the root sum of
  // squares of its impulse response (Tustin: the impulse enters two steps at half weight).
  TrackerFilter(seed.filter_hz, dt, seed.ad, seed.bd);
  const double* ad = seed.ad;
  const double* bd = seed.bd;
  double x0 = 0.0, x1 = 0.0, sum = 0.0, previous = 1.0;
  const long steps = std::max(1000L, std::lround(20.0 / (seed.filter_hz * dt)));
  for (long k = 0; k < steps; ++k) {
    const double v = 0.5 * previous;  // (v_k + v_{k+1}) / 2 with v_0 = 1, then 0
    previous = 0.0;
    const double n0 = ad[0] * x0 + ad[1] * x1 + bd[0] * v, n1 = ad[2] * x0 + ad[3] * x1 + bd[1] * v;
    x0 = n0;
    x1 = n1;
    sum += x1 * x1;
  }
  seed.acceleration_noise_gain = std::sqrt(sum);
  seed.drive_held = model.torque_is_command;  // rigid_load's u; dc_servo's measured i
  seed.warmup_samples =
      static_cast<long>(std::ceil(10.0 / (kZeta * 2.0 * kPi * seed.filter_hz * dt)));
  const double sigma_a = seed.acceleration_noise_gain * speed_noise;
  seed.gate_acceleration = settings.gate * sigma_a;
  const ExportedValue& J = model.values.at("J");
  seed.J = J.value;
  seed.J_variance = VarianceOf(J, 0.1 * J.value);
  seed.J_low = J.has_interval ? J.low : 0.9 * J.value;
  seed.J_high = J.has_interval ? J.high : 1.1 * J.value;
  seed.noise_floor = std::max((J.value * sigma_a) * (J.value * sigma_a), 1e-300);
  const ExportedValue& TL = model.values.at("TL");
  seed.TL = TL.value;
  seed.TL_variance = TL.has_interval ? VarianceOf(TL, 0.0) : kDiffuse * seed.noise_floor;
  return seed;
}

SpeedNoise SpeedNoiseOf(const TrackerSettings& settings, const StoredReport& report) {
  if (settings.speed_noise > 0.0) return {settings.speed_noise, "--speed-noise"};
  const auto it = report.noise_std().find("w");
  if (it != report.noise_std().end() && it->second > 0.0) {
    return {it->second, "the report's noise of w"};
  }
  return {};
}

InertiaTracker::InertiaTracker(const Compensation& model, const TrackerSeed& seed)
    : model_(model), seed_(seed), J_(seed.J), TL_(seed.TL), noise_(seed.noise_floor) {
  // P is kept in units of the equation noise's variance (normalised RLS), so that the
  // estimates adapt at the rate of the memory whatever that variance turns out to be; the
  // interval is P times the noise variance estimated from the innovations.
  p_[0][0] = seed.J_variance / seed.noise_floor;
  p_[0][1] = p_[1][0] = 0.0;
  p_[1][1] = seed.TL_variance / seed.noise_floor;
}

void InertiaTracker::Update(double drive_torque, double w, double theta) {
  const double known = model_.Viscous(w) + model_.Friction(w) + model_.Cogging(theta) +
                       model_.Spring(theta) + model_.Gravity(theta);
  excited_ = false;
  if (!started_) {  // the filters start in their steady state at the first sample
    a_[0] = w;
    d_[0] = drive_torque;
    k_[0] = known;
    a_[1] = d_[1] = k_[1] = 0.0;
    last_w_ = w;
    last_d_ = drive_torque;
    last_k_ = known;
    started_ = true;
    return;
  }
  // One period of the filter with the input v_mean over it.
  auto step = [&](double* x, double v_mean) {
    const double* ad = seed_.ad;
    const double n0 = ad[0] * x[0] + ad[1] * x[1] + seed_.bd[0] * v_mean;
    const double n1 = ad[2] * x[0] + ad[3] * x[1] + seed_.bd[1] * v_mean;
    x[0] = n0;
    x[1] = n1;
  };
  step(a_, 0.5 * (last_w_ + w));
  step(d_, seed_.drive_held ? last_d_ : 0.5 * (last_d_ + drive_torque));
  step(k_, 0.5 * (last_k_ + known));
  last_w_ = w;
  last_d_ = drive_torque;
  last_k_ = known;
  // The filters start in their steady state at the first sample, which a shaft already
  // accelerating is not: their start's transient is not data.
  if (++samples_ <= seed_.warmup_samples) return;
  const double a = a_[1], yf = d_[0] - k_[0];
  const double e = yf - J_ * a - TL_;
  const double lambda = seed_.lambda;
  // The load torque drifts as a random walk on every sample; J only while excited.
  p_[1][1] /= lambda;
  if (std::abs(a) > seed_.gate_acceleration) {
    excited_ = true;
    p_[0][0] /= lambda;
    p_[0][1] /= lambda;
    p_[1][0] /= lambda;
    // phi = [a, 1]: S = phi' P phi + 1, K = P phi / S, P <- P - K phi' P.
    const double p0 = p_[0][0] * a + p_[0][1], p1 = p_[1][0] * a + p_[1][1];
    const double s = a * p0 + p1 + 1.0;
    const double k0 = p0 / s, k1 = p1 / s;
    J_ += k0 * e;
    TL_ += k1 * e;
    const double q00 = p_[0][0] - k0 * p0, q01 = p_[0][1] - k0 * p1, q11 = p_[1][1] - k1 * p1;
    p_[0][0] = q00;
    p_[0][1] = p_[1][0] = q01;
    p_[1][1] = q11;
  } else {
    // phi = [0, 1] with J held: the gain [0, k] in Joseph's form keeps P a covariance.
    const double s = p_[1][1] + 1.0;
    const double k = p_[1][1] / s;
    TL_ += k * e;
    p_[0][1] *= 1.0 - k;
    p_[1][0] = p_[0][1];
    p_[1][1] = (1.0 - k) * (1.0 - k) * p_[1][1] + k * k;
  }
  // The equation noise's variance, an exponentially weighted mean of the squared innovation
  // over the same memory, never below the speed noise's share.
  noise_ = std::max(seed_.noise_floor, lambda * noise_ + (1.0 - lambda) * e * e);
}

double InertiaTracker::J_low() const {
  return J_ - kZ95 * std::sqrt(std::max(p_[0][0], 0.0) * noise_);
}
double InertiaTracker::J_high() const {
  return J_ + kZ95 * std::sqrt(std::max(p_[0][0], 0.0) * noise_);
}
bool InertiaTracker::changed() const {
  return J_low() > seed_.J_high * (1.0 + seed_.change_margin) ||
         J_high() < seed_.J_low * (1.0 - seed_.change_margin);
}

CFiles TrackerC(const TrackerSeed& seed) {
  const double* ad = seed.ad;
  const double* bd = seed.bd;
  std::ostringstream h;
  h << "/* blmd_tracker.h: an online estimator of the inertia J and the load torque TL, generated\n"
    << " * by blmd-export " << kVersion << " (docs/export.md §7). Recursive least squares with\n"
    << " * forgetting (Kalman form) on the filtered equation of motion\n"
    << " *   F[T_drive - T_known(theta, w)] = J F[dw/dt] + TL,\n"
    << " * F a second-order Butterworth state-variable filter (Tustin) of corner "
    << Exact(seed.filter_hz) << " Hz at\n * the sample period " << Exact(seed.dt)
    << " s (call blmd_tracker_update at that period). J updates only while\n"
    << " * |F[dw/dt]| > " << Exact(seed.gate_acceleration)
    << " rad/s^2 (excitation gating); `changed` is 1 when the 95 % interval\n"
    << " * of J lies beyond the offline interval [" << Exact(seed.J_low) << ", "
    << Exact(seed.J_high) << "] by more than " << Exact(100.0 * seed.change_margin)
    << " %.\n * T_known is blmd_compensation.h's viscous, friction, cogging (harmonic), spring "
       "and\n"
    << " * gravity terms. No allocation; <math.h> only. */\n"
    << "#ifndef BLMD_TRACKER_H\n#define BLMD_TRACKER_H\n\n#include \"blmd_compensation.h\"\n\n"
    << "typedef struct {\n"
    << "  blmd_real J, TL;          /* the estimates */\n"
    << "  blmd_real J_low, J_high;  /* 95 % interval of J */\n"
    << "  int excited, changed;     /* this sample updated J; J left its offline interval */\n"
    << "  blmd_real p00, p01, p11, noise;\n"
    << "  blmd_real a0, a1, d0, d1, k0, k1, last_w, last_d, last_k;\n"
    << "  int started;\n  long samples;\n"
    << "} blmd_tracker;\n\n"
    << "/* Starts at the report's values (J " << Exact(seed.J) << ", TL " << Exact(seed.TL)
    << "). */\n"
    << "void blmd_tracker_init(blmd_tracker *t);\n"
    << "/* One sample: the drive's torque (N m: Kt times the current), the speed (rad/s), the "
       "angle "
       "(rad). */\n"
    << "void blmd_tracker_update(blmd_tracker *t, blmd_real drive_torque, blmd_real w, blmd_real "
       "theta);\n\n"
    << "#endif /* BLMD_TRACKER_H */\n";
  std::ostringstream s;
  s << "/* blmd_tracker.c: generated by blmd-export " << kVersion << " (see blmd_tracker.h). */\n"
    << "#include \"blmd_tracker.h\"\n\n#include <math.h>\n\n"
    << "#define BLMD_TR_AD00 ((blmd_real)" << Exact(ad[0]) << ")\n"
    << "#define BLMD_TR_AD01 ((blmd_real)" << Exact(ad[1]) << ")\n"
    << "#define BLMD_TR_AD10 ((blmd_real)" << Exact(ad[2]) << ")\n"
    << "#define BLMD_TR_AD11 ((blmd_real)" << Exact(ad[3]) << ")\n"
    << "#define BLMD_TR_BD0 ((blmd_real)" << Exact(bd[0]) << ")\n"
    << "#define BLMD_TR_BD1 ((blmd_real)" << Exact(bd[1]) << ")\n"
    << "#define BLMD_TR_LAMBDA ((blmd_real)" << Exact(seed.lambda) << ")\n"
    << "#define BLMD_TR_GATE ((blmd_real)" << Exact(seed.gate_acceleration) << ")\n"
    << "#define BLMD_TR_FLOOR ((blmd_real)" << Exact(seed.noise_floor) << ")\n"
    << "#define BLMD_TR_J_OFF_LOW ((blmd_real)" << Exact(seed.J_low) << ")\n"
    << "#define BLMD_TR_J_OFF_HIGH ((blmd_real)" << Exact(seed.J_high) << ")\n"
    << "#define BLMD_TR_MARGIN ((blmd_real)" << Exact(seed.change_margin) << ")\n"
    << "#define BLMD_TR_Z95 ((blmd_real)1.959963984540054)\n"
    << "#define BLMD_TR_WARMUP " << seed.warmup_samples
    << "L /* samples the filters settle for */\n\n"
    << "static void blmd_tr_interval(blmd_tracker *t) {\n"
    << "  blmd_real half = BLMD_TR_Z95 * (blmd_real)sqrt((double)((t->p00 > 0 ? t->p00 : 0) * "
       "t->noise));\n"
    << "  t->J_low = t->J - half;\n  t->J_high = t->J + half;\n"
    << "  t->changed = t->J_low > BLMD_TR_J_OFF_HIGH * (1 + BLMD_TR_MARGIN) ||\n"
    << "               t->J_high < BLMD_TR_J_OFF_LOW * (1 - BLMD_TR_MARGIN);\n}\n\n"
    << "void blmd_tracker_init(blmd_tracker *t) {\n"
    << "  t->J = (blmd_real)" << Exact(seed.J) << ";\n"
    << "  t->TL = (blmd_real)" << Exact(seed.TL) << ";\n"
    << "  t->p00 = (blmd_real)" << Exact(seed.J_variance / seed.noise_floor) << ";\n"
    << "  t->p01 = 0;\n"
    << "  t->p11 = (blmd_real)" << Exact(seed.TL_variance / seed.noise_floor) << ";\n"
    << "  t->noise = BLMD_TR_FLOOR;\n"
    << "  t->a0 = t->a1 = t->d0 = t->d1 = t->k0 = t->k1 = 0;\n"
    << "  t->last_w = t->last_d = t->last_k = 0;\n"
    << "  t->excited = 0;\n  t->started = 0;\n  t->samples = 0;\n  blmd_tr_interval(t);\n}\n\n"
    << "void blmd_tracker_update(blmd_tracker *t, blmd_real drive_torque, blmd_real w, blmd_real "
       "theta) {\n"
    << "  blmd_real known = blmd_ff_viscous(w) + blmd_ff_friction(w) + "
       "blmd_ff_cogging_harmonic(theta) +\n"
    << "                    blmd_ff_spring(theta) + blmd_ff_gravity(theta);\n"
    << "  blmd_real v, n0, n1, a, e, s, p0, p1, k0, k1, q00, q01, q11;\n"
    << "  t->excited = 0;\n"
    << "  if (!t->started) {\n"
    << "    t->a0 = w; t->d0 = drive_torque; t->k0 = known; t->a1 = t->d1 = t->k1 = 0;\n"
    << "    t->last_w = w; t->last_d = drive_torque; t->last_k = known;\n"
    << "    t->started = 1;\n    return;\n  }\n"
    << "  v = (blmd_real)0.5 * (t->last_w + w);\n"
    << "  n0 = BLMD_TR_AD00 * t->a0 + BLMD_TR_AD01 * t->a1 + BLMD_TR_BD0 * v;\n"
    << "  n1 = BLMD_TR_AD10 * t->a0 + BLMD_TR_AD11 * t->a1 + BLMD_TR_BD1 * v;\n"
    << "  t->a0 = n0; t->a1 = n1;\n"
    << (seed.drive_held ? "  v = t->last_d; /* the command held over the period */\n"
                        : "  v = (blmd_real)0.5 * (t->last_d + drive_torque);\n")
    << "  n0 = BLMD_TR_AD00 * t->d0 + BLMD_TR_AD01 * t->d1 + BLMD_TR_BD0 * v;\n"
    << "  n1 = BLMD_TR_AD10 * t->d0 + BLMD_TR_AD11 * t->d1 + BLMD_TR_BD1 * v;\n"
    << "  t->d0 = n0; t->d1 = n1;\n"
    << "  v = (blmd_real)0.5 * (t->last_k + known);\n"
    << "  n0 = BLMD_TR_AD00 * t->k0 + BLMD_TR_AD01 * t->k1 + BLMD_TR_BD0 * v;\n"
    << "  n1 = BLMD_TR_AD10 * t->k0 + BLMD_TR_AD11 * t->k1 + BLMD_TR_BD1 * v;\n"
    << "  t->k0 = n0; t->k1 = n1;\n"
    << "  t->last_w = w; t->last_d = drive_torque; t->last_k = known;\n"
    << "  if (++t->samples <= BLMD_TR_WARMUP) return; /* the filters' start is not data */\n"
    << "  a = t->a1;\n"
    << "  e = t->d0 - t->k0 - t->J * a - t->TL;\n"
    << "  t->p11 /= BLMD_TR_LAMBDA;\n"
    << "  if ((a < 0 ? -a : a) > BLMD_TR_GATE) {\n"
    << "    t->excited = 1;\n"
    << "    t->p00 /= BLMD_TR_LAMBDA;\n    t->p01 /= BLMD_TR_LAMBDA;\n"
    << "    p0 = t->p00 * a + t->p01;\n    p1 = t->p01 * a + t->p11;\n"
    << "    s = a * p0 + p1 + 1;\n"
    << "    k0 = p0 / s;\n    k1 = p1 / s;\n"
    << "    t->J += k0 * e;\n    t->TL += k1 * e;\n"
    << "    q00 = t->p00 - k0 * p0;\n    q01 = t->p01 - k0 * p1;\n    q11 = t->p11 - k1 * p1;\n"
    << "    t->p00 = q00;\n    t->p01 = q01;\n    t->p11 = q11;\n"
    << "  } else {\n"
    << "    s = t->p11 + 1;\n"
    << "    k1 = t->p11 / s;\n"
    << "    t->TL += k1 * e;\n"
    << "    t->p01 *= 1 - k1;\n"
    << "    t->p11 = (1 - k1) * (1 - k1) * t->p11 + k1 * k1;\n"
    << "  }\n"
    << "  s = BLMD_TR_LAMBDA * t->noise + (1 - BLMD_TR_LAMBDA) * e * e;\n"
    << "  t->noise = s > BLMD_TR_FLOOR ? s : BLMD_TR_FLOOR;\n"
    << "  blmd_tr_interval(t);\n}\n";
  return {h.str(), s.str()};
}

}  // namespace blmd
