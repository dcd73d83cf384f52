// Welch-averaged auto and cross spectra of a recorded input and its outputs, for the empirical
// frequency response H1 = Puy/Puu and the coherence γ² = |Puy|²/(Puu·Pyy) (docs/report.md
// "Frequency response").
//
// Welch (1967), "The use of fast Fourier transform for the estimation of power spectra: a
// method based on time averaging over short, modified periodograms", IEEE Trans. Audio
// Electroacoust. 15(2): each record is cut into segments of L samples overlapping by L/2;
// each segment has its least-squares line removed (its mean and drift: an angle that drifts
// would otherwise leak into every bin) and is multiplied by the periodic Hann window
// w(i) = 0.5 - 0.5·cos(2πi/L); the periodograms of the K segments are averaged. Segments of
// several records (traces at one sample rate) are pooled. H1 and γ² as in Bendat & Piersol,
// Random Data: Analysis and Measurement Procedures, 4th ed. (Wiley 2010), ch. 6 and 9: H1 is
// unbiased by noise on the output, γ² = 1 for a noise-free linear system and falls with
// output noise, nonlinearity, or an input with no power at that frequency.
#pragma once

#include <complex>
#include <cstddef>
#include <span>
#include <string>
#include <vector>

namespace blmd {

// The segment length for a record of `samples` samples: the largest power of two not above
// 2·samples/9, i.e. about 8 segments at 50 % overlap as MATLAB's tfestimate and pwelch take
// by default, rounded down to a power of two for the FFT: 8 to 17 segments. 0 when that is
// below 16 samples (too short a record).
std::size_t WelchSegmentLength(std::size_t samples);

// One record: the input and the outputs, sampled together at one uniform rate.
struct SpectralRecord {
  std::span<const double> input;
  std::vector<std::span<const double>> outputs;
};

struct WelchSpectra {
  bool ok = false;
  std::string reason;  // why not ok
  double sample_rate_hz = 0.0;
  std::size_t segment_length = 0;  // L, samples
  std::size_t segments = 0;        // K, over every record
  std::size_t records_used = 0;    // records at least L long
  // Welch (1967): adjacent segments overlapping by L/2 are correlated by
  // ρ = Σ w(i)·w(i + L/2) / Σ w(i)² (1/3 for the Hann window), so the average of K of them
  // has the variance of K²/(K + 2·P·ρ²) independent ones, P the overlapping pairs (K - 1 for
  // one record).
  double overlap_correlation = 0.0;
  double equivalent_averages = 0.0;
  // Bins 1 .. L/2 (the DC bin, removed by the detrending, is left out): f = m·fs/L.
  std::vector<double> f_hz;
  // One-sided spectral densities, (unit of u)²/Hz, (unit of y)²/Hz and (u·y)/Hz;
  // cross = E[conj(U)·Y] (Bendat & Piersol's G_xy), so H1 = cross/input_psd.
  std::vector<double> input_psd;
  std::vector<std::vector<double>> output_psd;               // [output][bin]
  std::vector<std::vector<std::complex<double>>> cross_psd;  // [output][bin]
  // Per bin, how many segments carry the input's power there: (Σ_s P_s)² / Σ_s P_s² over the
  // segments' input periodograms P_s (K when every segment has the same power, 1 when one
  // segment has it all, as for a single step: then γ² = 1 whatever the data, and means nothing).
  std::vector<double> input_segments_effective;
};

// The averaged spectra of `records` (segments of `segment_length` samples, even and >= 16;
// records shorter than that are skipped). Not ok when no record is long enough or a value is
// not finite.
WelchSpectra EstimateWelchSpectra(const std::vector<SpectralRecord>& records, double sample_rate_hz,
                                  std::size_t segment_length);

// Bendat & Piersol (2010) ch. 9: the normalised random error of the gain |H1| (and the
// standard deviation, in radians, of its phase) from the coherence and the number of
// independent averages n_d: sqrt(1 - γ²) / (|γ|·sqrt(2·n_d)). +inf when γ² = 0.
double FrequencyResponseRandomError(double coherence, double averages);

}  // namespace blmd
