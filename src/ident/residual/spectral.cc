#include "blmd/ident/residual/spectral.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <unsupported/Eigen/FFT>

namespace blmd {
namespace {

using Complex = std::complex<double>;

// x minus its least-squares line over the segment, times the window.
void DetrendAndWindow(std::span<const double> x, const std::vector<double>& window,
                      std::vector<double>* out) {
  const std::size_t n = window.size();
  const double centre = 0.5 * static_cast<double>(n - 1);
  double mean = 0.0, slope_num = 0.0, slope_den = 0.0;
  for (std::size_t i = 0; i < n; ++i) mean += x[i];
  mean /= static_cast<double>(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double d = static_cast<double>(i) - centre;
    slope_num += d * (x[i] - mean);
    slope_den += d * d;
  }
  const double slope = slope_num / slope_den;
  out->resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    (*out)[i] = (x[i] - mean - slope * (static_cast<double>(i) - centre)) * window[i];
  }
}

// The sums over segments that the spectra are made of.
struct Sums {
  std::vector<double> uu, uu2;
  std::vector<std::vector<double>> yy;
  std::vector<std::vector<Complex>> uy;
};

}  // namespace

std::size_t WelchSegmentLength(std::size_t samples) {
  const std::size_t target = 2 * samples / 9;
  if (target < 16) return 0;
  std::size_t length = 16;
  while (2 * length <= target) length *= 2;
  return length;
}

double FrequencyResponseRandomError(double coherence, double averages) {
  if (!(coherence > 0.0) || !(averages > 0.0)) return std::numeric_limits<double>::infinity();
  const double g = std::min(coherence, 1.0);
  return std::sqrt(1.0 - g) / (std::sqrt(g) * std::sqrt(2.0 * averages));
}

WelchSpectra EstimateWelchSpectra(const std::vector<SpectralRecord>& records, double sample_rate_hz,
                                  std::size_t segment_length) {
  WelchSpectra spectra;
  const std::size_t L = segment_length;
  if (L < 16 || L % 2 != 0 || !(sample_rate_hz > 0.0) || records.empty()) {
    spectra.reason = "no segment length or sample rate to estimate spectra with";
    return spectra;
  }
  const std::size_t outputs = records.front().outputs.size();
  const std::size_t bins = L / 2;
  std::vector<double> window(L);
  double window_power = 0.0, overlap = 0.0;
  for (std::size_t i = 0; i < L; ++i) {
    window[i] = 0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * static_cast<double>(i) /
                                     static_cast<double>(L));
    window_power += window[i] * window[i];
  }
  for (std::size_t i = 0; i + L / 2 < L; ++i) overlap += window[i] * window[i + L / 2];
  spectra.overlap_correlation = overlap / window_power;

  Sums sums;
  sums.uu.assign(bins, 0.0);
  sums.uu2.assign(bins, 0.0);
  sums.yy.assign(outputs, std::vector<double>(bins, 0.0));
  sums.uy.assign(outputs, std::vector<Complex>(bins, 0.0));
  Eigen::FFT<double> fft;
  std::vector<double> segment;
  std::vector<Complex> u_spectrum, y_spectrum;
  std::size_t overlapping_pairs = 0;
  for (const SpectralRecord& record : records) {
    const std::size_t n = record.input.size();
    if (n < L || record.outputs.size() != outputs) continue;
    ++spectra.records_used;
    std::size_t in_record = 0;
    for (std::size_t start = 0; start + L <= n; start += L / 2, ++in_record) {
      DetrendAndWindow(record.input.subspan(start, L), window, &segment);
      fft.fwd(u_spectrum, segment);
      for (std::size_t m = 1; m <= bins; ++m) {
        const double p = std::norm(u_spectrum[m]);
        sums.uu[m - 1] += p;
        sums.uu2[m - 1] += p * p;
      }
      for (std::size_t o = 0; o < outputs; ++o) {
        DetrendAndWindow(record.outputs[o].subspan(start, L), window, &segment);
        fft.fwd(y_spectrum, segment);
        for (std::size_t m = 1; m <= bins; ++m) {
          sums.yy[o][m - 1] += std::norm(y_spectrum[m]);
          sums.uy[o][m - 1] += std::conj(u_spectrum[m]) * y_spectrum[m];
        }
      }
    }
    spectra.segments += in_record;
    overlapping_pairs += in_record - 1;
  }
  if (spectra.segments == 0) {
    spectra.reason = "no record holds a segment of " + std::to_string(L) + " samples";
    return spectra;
  }
  const auto K = static_cast<double>(spectra.segments);
  const double rho2 = spectra.overlap_correlation * spectra.overlap_correlation;
  spectra.equivalent_averages = K * K / (K + 2.0 * static_cast<double>(overlapping_pairs) * rho2);
  spectra.sample_rate_hz = sample_rate_hz;
  spectra.segment_length = L;
  spectra.output_psd.assign(outputs, std::vector<double>(bins));
  spectra.cross_psd.assign(outputs, std::vector<Complex>(bins));
  for (std::size_t m = 1; m <= bins; ++m) {
    // One-sided density: twice the two-sided, but for the Nyquist bin, which has no mirror.
    const double scale = (m == bins ? 1.0 : 2.0) / (sample_rate_hz * window_power * K);
    const std::size_t b = m - 1;
    spectra.f_hz.push_back(static_cast<double>(m) * sample_rate_hz / static_cast<double>(L));
    spectra.input_psd.push_back(scale * sums.uu[b]);
    spectra.input_segments_effective.push_back(
        sums.uu2[b] > 0.0 ? sums.uu[b] * sums.uu[b] / sums.uu2[b] : 0.0);
    for (std::size_t o = 0; o < outputs; ++o) {
      spectra.output_psd[o][b] = scale * sums.yy[o][b];
      spectra.cross_psd[o][b] = scale * sums.uy[o][b];
    }
  }
  for (double v : spectra.input_psd) {
    if (!std::isfinite(v)) {
      spectra.reason = "the input's spectrum is not finite (a value in the trace is not)";
      return spectra;
    }
  }
  for (const auto& psd : spectra.output_psd) {
    for (double v : psd) {
      if (!std::isfinite(v)) {
        spectra.reason = "an output's spectrum is not finite (a value in the trace is not)";
        return spectra;
      }
    }
  }
  spectra.ok = true;
  return spectra;
}

}  // namespace blmd
