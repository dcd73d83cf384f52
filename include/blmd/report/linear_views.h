// The frequency-domain and step views of the identified model (docs/report.md "Frequency
// response", "Step response"): the empirical frequency response of the traces (Welch-averaged
// H1 with its coherence, ident/residual/spectral.h) beside the Bode plot of the final model's
// linear part, and that linear part's step response with its rise time, overshoot and settling
// time. Built once by Identify; the JSON (report.frequency_response, report.step_response) and the
// HTML page only render them.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "blmd/ident/fit/problem.h"
#include "blmd/sim/linear_model.h"
#include "blmd/sim/linear_response.h"

namespace blmd {

// One output's empirical and model frequency response at the frequencies where the input has
// power (docs/report.md: "frequencies with content"); above the FFT's resolution the bins
// are averaged in bands of 1/100 decade, so there are at most about 100 points per decade.
struct FrequencyResponseOutput {
  std::string output;            // the trace column (i, w, theta)
  std::vector<double> f_hz;      // the mean frequency of the bins averaged in each point
  std::vector<int> merged_bins;  // how many FFT bins each point averages
  std::vector<double> empirical_mag_db, empirical_phase_deg;  // 20·log10|H1|, arg H1
  std::vector<double> coherence;                              // γ², 0..1
  std::vector<double> random_error;  // normalised random error of |H1| (Bendat & Piersol)
  std::vector<bool> low_coherence;   // γ² below the threshold, or one segment's power only
  // The linear part at f_hz, sampled as the trace is: u held between samples (zero-order
  // hold), so it is the transfer from the recorded samples of u to those of y that H1
  // estimates (linear_response.h FrequencyResponse with the sample interval).
  std::vector<double> model_mag_db, model_phase_deg;
  BodeCurve model_curve;  // the linear part on a log grid over the same range
};

struct FrequencyResponseReport {
  bool available = false;
  std::string reason;  // why there is none
  std::string input;   // the linear part's input, e.g. "u (V)"
  std::string note;    // what the model curve leaves out (its linear part only)
  // Set when the record looks closed loop (ResidualAnalysis::closed_loop): what the measured
  // response then is. Identify sets it.
  std::string caveat;
  double sample_rate_hz = 0.0;
  std::size_t segment_length = 0;  // samples per Welch segment (WelchSegmentLength)
  std::size_t averages = 0;        // segments averaged, over every trace used
  double equivalent_averages = 0.0;
  double resolution_hz = 0.0;  // fs / segment_length
  std::size_t traces = 0;      // traces pooled
  std::size_t bins = 0, bins_with_content = 0;
  double coherence_threshold = 0.5;
  std::vector<FrequencyResponseOutput> outputs;
};

// The empirical frequency response of `problem`'s traces from the recorded input u to each
// observed column that is an output of `model` (with the equation error, which observes u:
// every output of `model` that the traces hold), against `model`'s Bode curve. Not available
// (reason set) without a linear part, in closed loop (u is then the reference, not the
// plant's input), with an armature opened during the run, when no trace is sampled uniformly
// (every interval within 1 % of the mean) or none is long enough for 8 segments of 16 samples.
FrequencyResponseReport MakeFrequencyResponseReport(const FitProblem& problem,
                                                    const LinearModel& model);

struct StepResponseReport {
  bool available = false;
  std::string reason;
  std::string input;  // the linear part's input: the step is 1 of its unit
  std::vector<std::string> outputs;
  StepResponse response;  // linear_response.h
};
StepResponseReport MakeStepResponseReport(const LinearModel& model);

}  // namespace blmd
