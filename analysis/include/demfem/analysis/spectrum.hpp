// demfem analysis: FFT amplitude spectra and least-squares power-law fits (paper Section 3.6,
// Fig. 17).
//
// amplitudeSpectrum(): the signal is resampled onto a uniform grid at its median time step (linear
// interpolation; a no-op for the constant-rate recordings the paper uses), trimmed to the longest
// length <= n whose only prime factors are 2, 3, 5 (so the FFT is fast; at most a few percent of
// the samples are dropped from the end), its mean removed, and transformed with Eigen's FFT
// (unsupported/Eigen/FFT). Single-sided amplitude: A_k = 2 |X_k| / N for 0 < k < N/2 and
// A_{N/2} = |X_{N/2}| / N, at f_k = k / (N dt). With a rectangular window a sine that falls on a
// bin returns its amplitude exactly. The DC bin is not returned.
//
// fitPowerLaw(): A(f) = a f^b fitted by linear least squares on log10 A = log10 a + b log10 f
// (Eigen QR) over the points with f_low <= f <= f_high and A > 0 (Liang and Marshall's procedure
// the paper cites); reports a, b, their standard errors and R^2 in log space.
//
// Units: time s, frequency Hz, amplitude in the signal's unit.
#pragma once

#include <limits>
#include <string>
#include <vector>

namespace demfem::analysis {

struct Spectrum {
  std::vector<double> frequency_Hz;
  std::vector<double> amplitude;
  double sample_rate_Hz = 0.0;
  std::size_t samples_used = 0;  // N after trimming
};

// Pre: time strictly increasing, equal sizes, at least 4 samples. Throws std::invalid_argument.
Spectrum amplitudeSpectrum(const std::vector<double>& time_s, const std::vector<double>& signal);

struct PowerLawFit {
  double a = 0.0;              // amplitude at 1 Hz, signal unit
  double b = 0.0;              // exponent
  double log10_a_std_error = 0.0;
  double b_std_error = 0.0;
  double r_squared_log = 0.0;  // coefficient of determination of the log-log fit
  std::size_t points = 0;
  double f_low_Hz = 0.0;
  double f_high_Hz = 0.0;
  double evaluate(double f_Hz) const;
};

// Least squares in log-log space over f_low <= f <= f_high. Needs at least 3 usable points
// (throws std::invalid_argument naming how many there were).
PowerLawFit fitPowerLaw(const std::vector<double>& frequency_Hz, const std::vector<double>& amplitude, double f_low_Hz = 0.0,
                        double f_high_Hz = std::numeric_limits<double>::infinity());

// Geometric mean over [f_low, f_high] (log-spaced) of numerator(f) / denominator(f): the average
// ratio of two fitted spectra, 1 when they coincide.
double meanFittedRatio(const PowerLawFit& numerator, const PowerLawFit& denominator, double f_low_Hz, double f_high_Hz);

// Largest n' <= n whose prime factors are 2, 3 and 5 only.
std::size_t largestFftFriendlyLength(std::size_t n);

}  // namespace demfem::analysis
