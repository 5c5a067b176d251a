#include "demfem/analysis/spectrum.hpp"

#include "demfem/analysis/evaluation.hpp"

#include <Eigen/Dense>
#include <unsupported/Eigen/FFT>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numeric>
#include <stdexcept>

namespace demfem::analysis {

std::size_t largestFftFriendlyLength(std::size_t n) {
  for (std::size_t m = n; m > 1; --m) {
    std::size_t r = m;
    for (std::size_t p : {2u, 3u, 5u})
      while (r % p == 0) r /= p;
    if (r == 1) return m;
  }
  return 1;
}

Spectrum amplitudeSpectrum(const std::vector<double>& time_s, const std::vector<double>& signal) {
  if (time_s.size() != signal.size()) throw std::invalid_argument("amplitudeSpectrum: time and signal differ in length");
  if (time_s.size() < 4) throw std::invalid_argument("amplitudeSpectrum: need at least 4 samples, got " + std::to_string(time_s.size()));
  std::vector<double> steps(time_s.size() - 1);
  for (std::size_t i = 1; i < time_s.size(); ++i) steps[i - 1] = time_s[i] - time_s[i - 1];
  std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
  const double dt = steps[steps.size() / 2];
  if (!(dt > 0.0)) throw std::invalid_argument("amplitudeSpectrum: time must increase");

  const auto uniform_count = static_cast<std::size_t>(std::floor((time_s.back() - time_s.front()) / dt + 1e-9)) + 1;
  const std::size_t n = largestFftFriendlyLength(uniform_count);
  std::vector<double> samples(n);
  for (std::size_t k = 0; k < n; ++k) samples[k] = interpolate(time_s, signal, time_s.front() + static_cast<double>(k) * dt);
  const double mean = std::accumulate(samples.begin(), samples.end(), 0.0) / static_cast<double>(n);
  for (double& s : samples) s -= mean;

  Eigen::FFT<double> fft;
  std::vector<std::complex<double>> bins;
  fft.fwd(bins, samples);

  Spectrum spectrum;
  spectrum.sample_rate_Hz = 1.0 / dt;
  spectrum.samples_used = n;
  const double nd = static_cast<double>(n);
  for (std::size_t k = 1; k <= n / 2; ++k) {
    const double scale = (2 * k == n) ? 1.0 : 2.0;
    spectrum.frequency_Hz.push_back(static_cast<double>(k) / (nd * dt));
    spectrum.amplitude.push_back(scale * std::abs(bins[k]) / nd);
  }
  return spectrum;
}

double PowerLawFit::evaluate(double f_Hz) const { return a * std::pow(f_Hz, b); }

PowerLawFit fitPowerLaw(const std::vector<double>& frequency_Hz, const std::vector<double>& amplitude, double f_low_Hz, double f_high_Hz) {
  std::vector<double> log_f, log_a;
  double used_low = std::numeric_limits<double>::infinity(), used_high = 0.0;
  for (std::size_t i = 0; i < frequency_Hz.size(); ++i) {
    const double f = frequency_Hz[i];
    if (f <= 0.0 || f < f_low_Hz || f > f_high_Hz || !(amplitude[i] > 0.0)) continue;
    log_f.push_back(std::log10(f));
    log_a.push_back(std::log10(amplitude[i]));
    used_low = std::min(used_low, f);
    used_high = std::max(used_high, f);
  }
  const std::size_t m = log_f.size();
  if (m < 3)
    throw std::invalid_argument("power-law fit needs at least 3 spectral points with positive amplitude in " + std::to_string(f_low_Hz) +
                                "-" + std::to_string(f_high_Hz) + " Hz, found " + std::to_string(m));
  Eigen::MatrixXd design(m, 2);
  Eigen::VectorXd rhs(m);
  for (std::size_t i = 0; i < m; ++i) {
    design(static_cast<Eigen::Index>(i), 0) = 1.0;
    design(static_cast<Eigen::Index>(i), 1) = log_f[i];
    rhs(static_cast<Eigen::Index>(i)) = log_a[i];
  }
  const Eigen::Vector2d coef = design.colPivHouseholderQr().solve(rhs);
  const Eigen::VectorXd residual = rhs - design * coef;
  const double ss_res = residual.squaredNorm();
  const double ss_tot = (rhs.array() - rhs.mean()).matrix().squaredNorm();
  const double sigma2 = m > 2 ? ss_res / static_cast<double>(m - 2) : 0.0;
  const Eigen::Matrix2d covariance = sigma2 * (design.transpose() * design).inverse();

  PowerLawFit fit;
  fit.a = std::pow(10.0, coef(0));
  fit.b = coef(1);
  fit.log10_a_std_error = std::sqrt(covariance(0, 0));
  fit.b_std_error = std::sqrt(covariance(1, 1));
  fit.r_squared_log = ss_tot > 0.0 ? 1.0 - ss_res / ss_tot : 1.0;
  fit.points = m;
  fit.f_low_Hz = used_low;
  fit.f_high_Hz = used_high;
  return fit;
}

double meanFittedRatio(const PowerLawFit& numerator, const PowerLawFit& denominator, double f_low_Hz, double f_high_Hz) {
  // log ratio is linear in log f, so its mean over a log-spaced band is its value at the band's
  // logarithmic centre.
  const double log_centre = 0.5 * (std::log10(f_low_Hz) + std::log10(f_high_Hz));
  const double log_ratio = std::log10(numerator.a / denominator.a) + (numerator.b - denominator.b) * log_centre;
  return std::pow(10.0, log_ratio);
}

}  // namespace demfem::analysis
