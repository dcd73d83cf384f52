// blmd-tune's library call (docs/tuning.md): the identified model in (a config, with the
// final model and 95 % intervals of a blmd-ident report when given), the gains for a
// requested crossover and phase margin out, checked on the linear loop (margins, poles), on
// the nonlinear model in closed loop (a simulated reference step with the drive's limits),
// and over the corners of the parameters' 95 % box. Options in (TuneRequest), summary out
// (TuneResult): a request the plant cannot meet is a status (`refused` with the reason), not
// an exception; bad input is an InputError.
#pragma once

#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "blmd/io/config.h"
#include "blmd/sim/linear_model.h"
#include "blmd/tune/controller_design.h"
#include "blmd/tune/loop.h"
#include "blmd/tune/sampled_loop.h"

namespace blmd {

// A parameter's 95 % interval: one axis of the box whose corners are checked.
struct ParameterInterval {
  std::string name;
  double value = 0.0;  // the nominal (identified) value
  double low = 0.0, high = 0.0;
  bool clipped = false;  // low was below the parameter's lower bound and was raised to it
};

// The model to tune: the config's, with the values, effects and intervals of the
// identification when given.
struct TuneInput {
  Config config;                           // model, parameter values, effects, numerics
  std::vector<ParameterInterval> box;      // empty: no intervals known
  std::string box_source;                  // "report", "config notes" or "" (no box)
  std::string report_path, report_sha256;  // --from-report ("" when not given)
  std::string config_sha256;
  // Why the report's model is not to be acted on (ReportInadequacy, io/stored_report.h);
  // empty when it is, or without a report. Tune adds the warning report_inadequate.
  std::vector<std::string> report_inadequacy;
  bool report_ran_discovery = false;  // the report's identification ran --discover
};

// Reads `config_path` and, when `report_path` is not empty, a blmd-ident report of the same
// model: its final model's parameter values replace the config's, its final effects (with
// their values) are added where the config lacks them, and its free parameters' 95 %
// intervals (`ci95`) are the box. Without a report, the intervals a blmd-ident
// --write-config config records under notes.parameters.<name>.ci95 are the box. InputError
// (file, line, column) for a bad file, a report of another model, a model without the
// closed-loop (pid) experiment or without a linear part.
TuneInput LoadTuneInput(const std::string& config_path, const std::string& report_path);
// The same from a config and an identification report (null: none) that may be texts in
// memory (JsonSource, io/config.h).
TuneInput LoadTuneInput(const JsonSource& config, const JsonSource* report);

enum class NotchMode { kAuto, kOff };

struct TuneRequest {
  ControllerDesignOptions design;
  double u_max = 0.0;  // the drive's input limit (dc_servo: V), > 0
  double i_max = 0.0;  // A, the drive's current limit; 0: not checked
  // rad/s, the speed the drive can hold (Model::SpeedLimit: blmd's DC bus); +inf: none.
  double w_max = std::numeric_limits<double>::infinity();
  double step = 0.0;      // reference step (rad; speed loop rad/s); 0: the default
  double duration = 0.0;  // s, of the simulated step; 0: from the closed loop's poles
  int threads = 0;        // for the corners' simulations; 0: every hardware thread
  // rigid_load and blmd (models with the sampled_pid trait): the drive's digital loop, designed on
  // the sampled loop (sampled_loop.h, docs/tuning.md §7). design.crossover_hz is then the
  // speed loop's; the position loop (a P over it) crosses over at position_crossover_hz
  // (0: kDefaultPositionRatio of the speed crossover). u_min: the lower limit (NaN: −u_max).
  SampledDrive drive;
  bool sample_rate_assumed = false;  // drive.sample_rate_hz not given: 1/simulation.dt
  double position_crossover_hz = 0.0;
  double u_min = std::numeric_limits<double>::quiet_NaN();
  // The notch on the torque command (docs/tuning.md §7.7). kAuto: the drive's own
  // (drive.notch, from experiment.pid.notch) is kept; on a two-mass shaft whose resonance does
  // not allow the request without one, a notch is designed at the resonance. kOff: none (the
  // drive's own left out), a request the resonance does not allow is refused.
  NotchMode notch = NotchMode::kAuto;
  double LowerLimit() const { return std::isnan(u_min) ? -u_max : u_min; }
  // "" when the request can be used, else what is wrong (one line).
  std::string Validate() const;
};

// The position loop's crossover over the speed loop's when not given: a fifth, the usual
// separation of a cascade's loops (the inner loop nearly 1 at the outer crossover).
inline constexpr double kDefaultPositionRatio = 0.2;

// The simulated closed-loop step response (ComputeStepMetrics, run.h) of the loop's measured
// column (theta, or w), towards its own final value, and what the drive had to give.
struct ClosedLoopStep {
  bool simulated = false;  // false: the simulation failed (failure says why)
  std::string failure;
  bool valid = false;  // the metrics exist (the response rose through 10 % and 90 %)
  double rise_time_s = std::numeric_limits<double>::quiet_NaN();
  double overshoot_percent = std::numeric_limits<double>::quiet_NaN();
  double settling_time_s = std::numeric_limits<double>::quiet_NaN();
  double final_value = std::numeric_limits<double>::quiet_NaN();
  double steady_state_error = std::numeric_limits<double>::quiet_NaN();  // step − final value
  double peak_u = std::numeric_limits<double>::quiet_NaN();  // max |u|, V (the input's unit)
  double peak_i = std::numeric_limits<double>::quiet_NaN();  // max |i|, A
  double peak_w = std::numeric_limits<double>::quiet_NaN();  // max |w|, rad/s
  bool saturated = false;                                    // |u| reached u_max
};

// The linear loop and the simulated step at one parameter point.
struct LoopCheck {
  std::vector<std::pair<std::string, double>> values;  // the box parameters at this point
  LoopMargins margins;
  ClosedLoopPoles poles;
  ClosedLoopStep step;
};

// The worst of each figure over the nominal model and the box's corners, with the index of
// the corner that gives it (-1: the nominal model).
struct WorstFigure {
  double value = std::numeric_limits<double>::quiet_NaN();
  int corner = -1;
};
struct WorstCase {
  WorstFigure crossover_low_hz, crossover_high_hz;              // lowest and highest crossover
  WorstFigure phase_margin_deg;                                 // smallest
  WorstFigure gain_margin_db;                                   // smallest (+inf: none anywhere)
  WorstFigure rise_time_s, overshoot_percent, settling_time_s;  // largest
  WorstFigure steady_state_error;                               // largest |.|, signed
  WorstFigure peak_u, peak_i;                                   // largest
  int unstable = 0;   // corners whose closed loop is unstable
  int saturated = 0;  // corners whose step reached u_max
  int invalid = 0;    // corners without step metrics (the response never rose through 90 %)
};

// rigid_load's sampled design: the gains of the cascade and each loop's margins, on the
// sampled loop and, with the same gains, on the continuous one (no hold, no delay).
struct SampledTuning {
  bool used = false;  // the model's loop is the drive's digital one (rigid_load)
  bool linear_axis = false;
  CascadeGains gains;
  SampledDesignResult design;                 // the speed PI's (and the position crossover)
  LoopMargins speed, speed_continuous;        // the speed loop (the cascade's inner loop)
  LoopMargins position, position_continuous;  // the position loop (cascade only)
  ClosedLoopPoles speed_poles;                // z plane
  // A two-mass shaft whose resonance does not allow the request without a notch: the
  // resonance (Hz) and the highest crossover without one (resonance.h; NaN otherwise).
  double resonance_hz = std::numeric_limits<double>::quiet_NaN();
  double resonance_limited_crossover_hz = std::numeric_limits<double>::quiet_NaN();
  // The notch the loop was tuned and checked with (not active: none): the drive's own, or
  // designed here (notch_designed), its depth from the resonance's peak (notch_peak_ratio,
  // before the limits of resonance.h) and the smallest margin it keeps on the plants at the
  // ends of the resonance's range (deg).
  NotchFilter notch{};
  bool notch_designed = false;
  double notch_peak_ratio = std::numeric_limits<double>::quiet_NaN();
  double notch_worst_variant_margin_deg = std::numeric_limits<double>::quiet_NaN();
};

struct TuneResult {
  bool refused = false;
  std::string refusal;       // why the request cannot be met (refused)
  std::string plant_output;  // "w" or "theta": the loop's measured column
  TransferFunction plant;    // u -> the measured output, at the nominal values
  ControllerDesignResult design;
  LoopCheck nominal;
  // The simulated step: its size, length and sample rate (also written by --write-config).
  double step = 0.0, duration = 0.0, sample_rate = 0.0;
  double demand_peak_u = std::numeric_limits<double>::quiet_NaN();  // refused: unlimited peak
  std::vector<LoopCheck> corners;  // 2^k corners of the box (k = box size), in binary order
  WorstCase worst;
  std::vector<std::pair<std::string, std::string>> warnings;  // code, message
  SampledTuning sampled;                                      // rigid_load only
};

// Designs, checks and evaluates (docs/tuning.md). Throws InputError for a request that does
// not validate.
TuneResult Tune(const TuneInput& input, const TuneRequest& request);

// The experiment that simulates the tuned loop's step: a step of `step` at t = 0 from rest,
// the PID of `controller` (tau_d = 1/(2π f_d), 1 ms when there is no filter) limited at
// u_max, for `duration` s at `sample_rate` Hz.
Experiment StepExperiment(PidSettings::Loop loop, const Controller& controller, double u_max,
                          double step, double duration, double sample_rate);

// The units of a rigid_load's u (N·m, N for a linear axis, when Kt = 1; else "u", the
// drive's own unit) and of its speed or position (rad/s, rad; m/s, m for a linear axis).
std::string SampledInputUnit(const Config& config);
std::string SampledOutputUnit(const Config& config, bool speed);

// rigid_load's: the drive's digital loop of `gains` (PidSettings' sampled fields) limited to
// [request.LowerLimit(), u_max].
Experiment SampledStepExperiment(const TuneRequest& request, const CascadeGains& gains, double step,
                                 double duration, double sample_rate);

}  // namespace blmd
