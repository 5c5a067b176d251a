// FFT amplitude spectra and power-law fits against closed forms.
#include "demfem/analysis/spectrum.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <random>

using namespace demfem::analysis;

TEST_CASE("the spectrum of a pure sine recovers its amplitude and frequency", "[analysis]") {
  // 1000 samples at 50 Hz (a 2-3-5 length, nothing trimmed); 3.5 Hz lies on bin 70.
  const double fs = 50.0, f0 = 3.5, amplitude = 1.7;
  std::vector<double> t, y;
  for (int i = 0; i < 1000; ++i) {
    t.push_back(i / fs);
    y.push_back(4.0 + amplitude * std::sin(2.0 * std::numbers::pi * f0 * t.back() + 0.3));
  }
  const Spectrum s = amplitudeSpectrum(t, y);
  CHECK(s.samples_used == 1000);
  CHECK(s.sample_rate_Hz == Approx(fs));
  const auto peak = std::max_element(s.amplitude.begin(), s.amplitude.end()) - s.amplitude.begin();
  CHECK(s.frequency_Hz[static_cast<std::size_t>(peak)] == Approx(f0).epsilon(1e-12));
  CHECK(s.amplitude[static_cast<std::size_t>(peak)] == Approx(amplitude).epsilon(1e-9));
  // Everything else (and the removed mean) is at round-off level.
  double largest_other = 0.0;
  for (std::size_t k = 0; k < s.amplitude.size(); ++k)
    if (static_cast<std::ptrdiff_t>(k) != peak) largest_other = std::max(largest_other, s.amplitude[k]);
  CHECK(largest_other < 1e-9);
  CHECK(s.frequency_Hz.back() == Approx(fs / 2));
}

TEST_CASE("a signal of awkward length is trimmed to a 2-3-5 length without losing the sine", "[analysis]") {
  CHECK(largestFftFriendlyLength(1021) == 1000);  // 1021 is prime
  CHECK(largestFftFriendlyLength(1024) == 1024);
  CHECK(largestFftFriendlyLength(7) == 6);
  std::vector<double> t, y;
  for (int i = 0; i < 1021; ++i) {
    t.push_back(i * 0.02);
    y.push_back(0.5 * std::cos(2.0 * std::numbers::pi * 5.0 * t.back()));  // 5 Hz: bin 100 of 1000
  }
  const Spectrum s = amplitudeSpectrum(t, y);
  CHECK(s.samples_used == 1000);
  CHECK(*std::max_element(s.amplitude.begin(), s.amplitude.end()) == Approx(0.5).epsilon(1e-9));
}

TEST_CASE("a power law sampled with multiplicative noise recovers a and b", "[analysis]") {
  // A = a f^b exp(e), e ~ N(0, 0.2): log-space least squares is unbiased for log a and b; with 500
  // points the standard errors are ~0.02 (b) and ~0.01 (log10 a), the tolerances are 4 of them.
  const double a = 0.35, b = -1.2;
  std::mt19937_64 rng(42);
  std::normal_distribution<double> noise(0.0, 0.2);
  std::vector<double> f, amp;
  for (int k = 1; k <= 500; ++k) {
    f.push_back(0.05 * k);
    amp.push_back(a * std::pow(f.back(), b) * std::exp(noise(rng)));
  }
  const PowerLawFit fit = fitPowerLaw(f, amp);
  CHECK(fit.b == Approx(b).margin(0.08));
  CHECK(std::log10(fit.a) == Approx(std::log10(a)).margin(0.04));
  // Standard error of the slope: sigma_log10 / (sqrt(m) * spread of log10 f), within 20 %.
  double mean_log_f = 0.0, var_log_f = 0.0;
  for (double x : f) mean_log_f += std::log10(x) / 500.0;
  for (double x : f) var_log_f += std::pow(std::log10(x) - mean_log_f, 2) / 500.0;
  CHECK(fit.b_std_error == Approx(0.2 / std::log(10.0) / std::sqrt(500.0 * var_log_f)).epsilon(0.2));
  CHECK(fit.points == 500);
  CHECK(fit.r_squared_log > 0.8);

  // Exact data: exact fit; a band restricts the points.
  std::vector<double> exact;
  for (double x : f) exact.push_back(a * std::pow(x, b));
  const PowerLawFit exact_fit = fitPowerLaw(f, exact, 1.0, 10.0);
  CHECK(exact_fit.a == Approx(a).epsilon(1e-10));
  CHECK(exact_fit.b == Approx(b).epsilon(1e-10));
  CHECK(exact_fit.f_low_Hz == Approx(1.0));
  CHECK(exact_fit.f_high_Hz == Approx(10.0));
  CHECK(exact_fit.points == 181);
  CHECK_THROWS_WITH(fitPowerLaw(f, exact, 1.0, 1.06), Catch::Contains("at least 3"));
}

TEST_CASE("the mean ratio of two fitted power laws is their ratio at the band's log centre", "[analysis]") {
  PowerLawFit measured, simulated;
  measured.a = 2.0;
  measured.b = -1.0;
  simulated.a = 3.0;
  simulated.b = -0.5;
  // ratio(f) = 1.5 f^0.5; log centre of 1..100 Hz is 10 Hz.
  CHECK(meanFittedRatio(simulated, measured, 1.0, 100.0) == Approx(1.5 * std::sqrt(10.0)));
  simulated.b = -1.0;
  CHECK(meanFittedRatio(simulated, measured, 0.2, 25.0) == Approx(1.5));
}
