// The frequency response and step response of the report (report/linear_views.h,
// docs/report.md "Frequency response" and "Step response").
#include "blmd/report/linear_views.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "blmd/ident/residual/spectral.h"
#include "blmd/io/config.h"

namespace blmd {
namespace {

// A bin has content when its input power is at least this fraction of the largest within
// the octave around it (-20 dB: the valleys between a square wave's resolved harmonics and
// the bins at a PRBS's spectral nulls fall out, where what the Hann window leaks from the
// strong bins beside them, its sidelobes at -31 dB and below, would be a fair part of their
// power; a broadband input keeps every bin) and of the largest overall (-60 dB: what lies
// beyond a chirp's band).
constexpr double kLocalContent = 1e-2;
constexpr double kGlobalContent = 1e-6;
// Points per decade above which FFT bins are averaged in log bands.
constexpr double kPointsPerDecade = 100.0;
// Points of the model curve drawn on a log grid.
constexpr int kModelCurvePoints = 200;

// The uniform sample rate of a trace's time column, or 0 when some interval is more than
// 1 % from the mean.
double UniformRate(const std::vector<double>& t) {
  if (t.size() < 2) return 0.0;
  const double mean = (t.back() - t.front()) / static_cast<double>(t.size() - 1);
  if (!(mean > 0.0)) return 0.0;
  for (std::size_t i = 1; i < t.size(); ++i) {
    if (!(std::abs(t[i] - t[i - 1] - mean) <= 0.01 * mean)) return 0.0;
  }
  return 1.0 / mean;
}

// The columns to estimate: observed outputs of the linear part, else every output of it
// that all traces hold.
std::vector<std::string> Outputs(const FitProblem& problem, const LinearModel& model) {
  std::vector<std::string> outputs;
  for (const auto& column : problem.observe()) {
    if (std::find(model.outputs.begin(), model.outputs.end(), column) != model.outputs.end())
      outputs.push_back(column);
  }
  if (!outputs.empty()) return outputs;
  for (const auto& column : model.outputs) {
    bool everywhere = true;
    for (const auto& t : problem.traces()) everywhere = everywhere && t.trace.Has(column);
    if (everywhere) outputs.push_back(column);
  }
  return outputs;
}

// Why the recorded u is not the linear part's input over the whole run; empty when it is.
std::string InputProblem(const FitProblem& problem) {
  const Experiment& experiment = problem.config().experiment;
  if (experiment.closed_loop) {
    return "closed-loop experiment (experiment.pid): the recorded u is the position reference, "
           "not the motor's input";
  }
  if (experiment.coast_off_time >= 0.0) {
    return "the armature is opened during the run (coast_off_time): u does not drive the motor "
           "after it";
  }
  for (const auto& t : problem.traces()) {
    if (t.trace.Has("open")) {
      for (double v : t.trace.Column("open")) {
        if (v != 0.0) return "the armature is opened during the run (column 'open')";
      }
    }
  }
  return "";
}

// The bins with content (see kLocalContent), from the second: the periodic Hann window's
// transform is nonzero at bins 0 and ±1 only, so the first (index 0 here: the DC bin is not
// in the spectra) holds what the detrending left of each segment's mean, not the input's
// content.
std::vector<std::size_t> BinsWithContent(const WelchSpectra& spectra) {
  const std::vector<double>& p = spectra.input_psd;
  std::vector<std::size_t> kept;
  if (p.size() < 2) return kept;
  const double largest = *std::max_element(p.begin() + 1, p.end());
  if (!(largest > 0.0)) return kept;
  const std::vector<double>& f = spectra.f_hz;
  std::size_t low = 1, high = 1;  // the bins within the octave [f/√2, f·√2]
  for (std::size_t m = 1; m < p.size(); ++m) {
    while (f[low] < f[m] / std::numbers::sqrt2) ++low;
    while (high + 1 < p.size() && f[high + 1] <= f[m] * std::numbers::sqrt2) ++high;
    const double local = *std::max_element(p.begin() + static_cast<std::ptrdiff_t>(low),
                                           p.begin() + static_cast<std::ptrdiff_t>(high) + 1);
    if (p[m] >= kGlobalContent * largest && p[m] >= kLocalContent * local) kept.push_back(m);
  }
  return kept;
}

// The kept bins grouped in log bands of 1/kPointsPerDecade decade (a bin alone when the
// bins are sparser than that).
std::vector<std::vector<std::size_t>> Bands(const WelchSpectra& spectra,
                                            const std::vector<std::size_t>& kept) {
  std::vector<std::vector<std::size_t>> bands;
  long last = -1;
  for (std::size_t m : kept) {
    const auto band = static_cast<long>(
        std::floor(kPointsPerDecade * std::log10(spectra.f_hz[m] / spectra.f_hz.front())));
    if (bands.empty() || band != last) bands.emplace_back();
    bands.back().push_back(m);
    last = band;
  }
  return bands;
}

double Mean(const std::vector<double>& v, const std::vector<std::size_t>& at) {
  double sum = 0.0;
  for (std::size_t m : at) sum += v[m];
  return sum / static_cast<double>(at.size());
}

// The model's Bode values at `f_hz` and on a log grid over their range, sampled with a
// zero-order hold at `dt_s` as the trace is (linear_response.h), the phase unwrapped along
// both together (so the points sit on the drawn curve's branch).
void ModelResponse(const LinearModel& model, std::size_t output, double dt_s,
                   FrequencyResponseOutput* out) {
  const double lo = out->f_hz.front(), hi = out->f_hz.back() > lo ? out->f_hz.back() : 2.0 * lo;
  std::vector<std::pair<double, int>> grid;  // (f, index into f_hz, or -1 for the curve)
  for (int k = 0; k < kModelCurvePoints; ++k) {
    const double x = static_cast<double>(k) / (kModelCurvePoints - 1);
    grid.emplace_back(lo * std::pow(hi / lo, x), -1);
  }
  for (std::size_t k = 0; k < out->f_hz.size(); ++k)
    grid.emplace_back(out->f_hz[k], static_cast<int>(k));
  std::stable_sort(grid.begin(), grid.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<double> f;
  for (const auto& g : grid) f.push_back(g.first);
  const BodeCurve all = Bode(model, output, f, dt_s);
  out->model_mag_db.assign(out->f_hz.size(), 0.0);
  out->model_phase_deg.assign(out->f_hz.size(), 0.0);
  for (std::size_t k = 0; k < grid.size(); ++k) {
    if (grid[k].second < 0) {
      out->model_curve.f_hz.push_back(all.f_hz[k]);
      out->model_curve.magnitude_db.push_back(all.magnitude_db[k]);
      out->model_curve.phase_deg.push_back(all.phase_deg[k]);
    } else {
      out->model_mag_db[static_cast<std::size_t>(grid[k].second)] = all.magnitude_db[k];
      out->model_phase_deg[static_cast<std::size_t>(grid[k].second)] = all.phase_deg[k];
    }
  }
}

FrequencyResponseOutput EstimateOutput(const WelchSpectra& spectra, std::size_t o,
                                       const std::vector<std::vector<std::size_t>>& bands,
                                       double threshold) {
  FrequencyResponseOutput out;
  for (const auto& band : bands) {
    const double puu = Mean(spectra.input_psd, band), pyy = Mean(spectra.output_psd[o], band);
    std::complex<double> puy = 0.0;
    for (std::size_t m : band) puy += spectra.cross_psd[o][m];
    puy /= static_cast<double>(band.size());
    const std::complex<double> h = puy / puu;
    const double coherence = std::norm(puy) / (puu * pyy);
    const double segments = Mean(spectra.input_segments_effective, band);
    // The band's frequency: the bins' weighted by the input power, as H1 weights their H.
    double weighted = 0.0;
    for (std::size_t m : band) weighted += spectra.input_psd[m] * spectra.f_hz[m];
    out.f_hz.push_back(weighted / (puu * static_cast<double>(band.size())));
    out.merged_bins.push_back(static_cast<int>(band.size()));
    out.empirical_mag_db.push_back(20.0 * std::log10(std::abs(h)));
    out.empirical_phase_deg.push_back(std::arg(h) * 180.0 / std::numbers::pi);
    out.coherence.push_back(coherence);
    out.random_error.push_back(
        FrequencyResponseRandomError(coherence, std::min(spectra.equivalent_averages, segments)));
    out.low_coherence.push_back(!(coherence >= threshold) || segments < 2.0);
  }
  return out;
}

}  // namespace

FrequencyResponseReport MakeFrequencyResponseReport(const FitProblem& problem,
                                                    const LinearModel& model) {
  FrequencyResponseReport report;
  if (!model.available) {
    report.reason = "no linear part: " + model.reason;
    return report;
  }
  report.input = model.input;
  report.note = "the model curve is the identified model's linear part (" + model.assumption +
                "), sampled with the trace's zero-order hold: what it leaves out shows in the "
                "measured response, not in the curve";
  report.reason = InputProblem(problem);
  if (!report.reason.empty()) return report;
  const std::vector<std::string> columns = Outputs(problem, model);
  if (columns.empty()) {
    report.reason = "the traces hold no output of the linear part";
    return report;
  }
  // The uniformly sampled traces at the first one's rate.
  std::vector<const Trace*> traces;
  for (const auto& t : problem.traces()) {
    const double rate = UniformRate(t.trace.Column("t"));
    if (rate > 0.0 && (traces.empty() ||
                       std::abs(rate - report.sample_rate_hz) <= 1e-6 * report.sample_rate_hz)) {
      if (traces.empty()) report.sample_rate_hz = rate;
      traces.push_back(&t.trace);
    }
  }
  if (traces.empty()) {
    report.reason = "no trace is sampled uniformly (an interval more than 1 % from the mean)";
    return report;
  }
  std::size_t shortest = traces.front()->rows();
  for (const Trace* t : traces) shortest = std::min(shortest, t->rows());
  report.segment_length = WelchSegmentLength(shortest);
  if (report.segment_length == 0) {
    report.reason = "the trace is too short for 8 segments of 16 samples";
    return report;
  }
  std::vector<SpectralRecord> records;
  for (const Trace* t : traces) {
    SpectralRecord record{t->Column("u"), {}};
    for (const auto& c : columns) record.outputs.emplace_back(t->Column(c));
    records.push_back(std::move(record));
  }
  const WelchSpectra spectra =
      EstimateWelchSpectra(records, report.sample_rate_hz, report.segment_length);
  if (!spectra.ok) {
    report.reason = spectra.reason;
    return report;
  }
  report.averages = spectra.segments;
  report.equivalent_averages = spectra.equivalent_averages;
  report.resolution_hz = report.sample_rate_hz / static_cast<double>(report.segment_length);
  report.traces = spectra.records_used;
  report.bins = spectra.f_hz.size();
  const std::vector<std::size_t> kept = BinsWithContent(spectra);
  report.bins_with_content = kept.size();
  if (kept.empty()) {
    report.reason = "the input u has no power at any frequency (it is constant)";
    return report;
  }
  const std::vector<std::vector<std::size_t>> bands = Bands(spectra, kept);
  for (std::size_t o = 0; o < columns.size(); ++o) {
    FrequencyResponseOutput out = EstimateOutput(spectra, o, bands, report.coherence_threshold);
    out.output = columns[o];
    const auto index = static_cast<std::size_t>(
        std::find(model.outputs.begin(), model.outputs.end(), columns[o]) - model.outputs.begin());
    ModelResponse(model, index, 1.0 / report.sample_rate_hz, &out);
    // The measured phase on the model's branch: within ±180° of the model's.
    for (std::size_t k = 0; k < out.f_hz.size(); ++k) {
      const double d = out.empirical_phase_deg[k] - out.model_phase_deg[k];
      out.empirical_phase_deg[k] = out.model_phase_deg[k] + std::remainder(d, 360.0);
    }
    report.outputs.push_back(std::move(out));
  }
  report.available = true;
  return report;
}

StepResponseReport MakeStepResponseReport(const LinearModel& model) {
  StepResponseReport report;
  if (!model.available) {
    report.reason = "no linear part: " + model.reason;
    return report;
  }
  report.input = model.input;
  report.outputs = model.outputs;
  report.response = ComputeStepResponse(model);
  report.available = report.response.ok;
  report.reason = report.response.reason;
  return report;
}

}  // namespace blmd
