#include "demfem/analysis/step_response.hpp"

#include "demfem/analysis/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

namespace demfem::analysis {

StepResponse analyseStepResponse(const std::vector<double>& t, const std::vector<double>& y, const StepResponseSettings& settings,
                                 const std::string& what) {
  const std::size_t n = y.size();
  const auto tail_count = std::max(settings.min_tail_samples, static_cast<std::size_t>(settings.steady_fraction * static_cast<double>(n)));
  if (n < 3 * tail_count)
    throw InputError(what + ": only " + std::to_string(n) + " samples; the steady value needs the last " + std::to_string(tail_count) +
                     " and the cycles before them need at least twice as many");
  StepResponse response;
  const std::vector<double> tail(y.end() - static_cast<std::ptrdiff_t>(tail_count), y.end());
  const SignalStatistics steady = meanAndStdDev(tail);
  response.steady_value = steady.mean;
  response.steady_std = steady.std_dev;

  const double direction = steady.mean >= y.front() ? 1.0 : -1.0;
  std::vector<double> e(n);
  for (std::size_t i = 0; i < n; ++i) e[i] = direction * (y[i] - steady.mean);
  const double largest_overshoot = *std::max_element(e.begin(), e.end());
  if (!(largest_overshoot > 0.0)) throw InputError(what + ": the response never overshoots its steady value: no cycles to measure");
  const double band = std::max(settings.noise_band_factor * steady.std_dev, settings.min_amplitude_fraction * largest_overshoot);

  enum class State { Unknown, Below, Above } state = State::Unknown;
  std::size_t peak_index = 0;
  std::vector<double> peak_amplitudes;
  for (std::size_t i = 0; i < n; ++i) {
    if (state != State::Above && e[i] > band) {
      if (state == State::Below) {
        std::size_t j = i;
        while (j > 0 && e[j - 1] > 0.0) --j;  // e[j-1] <= 0 < e[j]
        const double crossing = j == 0 ? t[0] : t[j - 1] + (0.0 - e[j - 1]) / (e[j] - e[j - 1]) * (t[j] - t[j - 1]);
        response.upward_crossing_times_s.push_back(crossing);
        peak_index = i;
        state = State::Above;
      }
    } else if (state == State::Above) {
      if (e[i] > e[peak_index]) peak_index = i;
      if (e[i] < -band) {
        // Parabola through the samples around the peak (uniform spacing assumed locally).
        double peak_time = t[peak_index], peak_e = e[peak_index];
        if (peak_index > 0 && peak_index + 1 < n) {
          const double y0 = e[peak_index - 1], y1 = e[peak_index], y2 = e[peak_index + 1];
          const double curvature = y0 - 2.0 * y1 + y2;
          if (curvature < 0.0) {
            const double offset = 0.5 * (y0 - y2) / curvature;
            const double step = 0.5 * (t[peak_index + 1] - t[peak_index - 1]);
            peak_time += offset * step;
            peak_e = y1 - 0.25 * (y0 - y2) * offset;
          }
        }
        response.peak_times_s.push_back(peak_time);
        response.peak_values.push_back(steady.mean + direction * peak_e);
        peak_amplitudes.push_back(peak_e);
        state = State::Below;
      }
    }
    if (state == State::Unknown && e[i] < -band) state = State::Below;
  }

  std::vector<double>& frequencies = response.cycle_frequencies_Hz;
  std::vector<double>& damping_ratios = response.cycle_damping_ratios;
  const auto& u = response.upward_crossing_times_s;
  for (std::size_t k = 1; k < u.size(); ++k) frequencies.push_back(1.0 / (u[k] - u[k - 1]));
  for (std::size_t k = 1; k < peak_amplitudes.size(); ++k) {
    const double delta = std::log(peak_amplitudes[k - 1] / peak_amplitudes[k]);  // logarithmic decrement
    damping_ratios.push_back(delta / std::sqrt(4.0 * std::numbers::pi * std::numbers::pi + delta * delta));
  }
  if (frequencies.size() < settings.min_cycles || damping_ratios.size() < settings.min_cycles)
    throw InputError(what + ": only " + std::to_string(frequencies.size()) + " full cycles and " + std::to_string(peak_amplitudes.size()) +
                     " peaks rise above the noise band +-" + std::to_string(band) + " around the steady value " + std::to_string(steady.mean) +
                     " (need " + std::to_string(settings.min_cycles) + " periods and " + std::to_string(settings.min_cycles + 1) + " peaks)");
  const SignalStatistics f = meanAndStdDev(frequencies);
  const SignalStatistics z = meanAndStdDev(damping_ratios);
  response.frequency_mean_Hz = f.mean;
  response.frequency_std_Hz = f.std_dev;
  response.damping_ratio_mean = z.mean;
  response.damping_ratio_std = z.std_dev;
  response.first_peak_time_s = response.peak_times_s.front();
  return response;
}

double pearsonCorrelation(const std::vector<double>& a, const std::vector<double>& b) {
  const double n = static_cast<double>(a.size());
  const double mean_a = std::accumulate(a.begin(), a.end(), 0.0) / n;
  const double mean_b = std::accumulate(b.begin(), b.end(), 0.0) / n;
  double sab = 0, saa = 0, sbb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    sab += (a[i] - mean_a) * (b[i] - mean_b);
    saa += (a[i] - mean_a) * (a[i] - mean_a);
    sbb += (b[i] - mean_b) * (b[i] - mean_b);
  }
  return sab / std::sqrt(saa * sbb);
}

AlignedCorrelation correlateAligned(const std::vector<double>& time_a, const std::vector<double>& value_a, double first_peak_a_s,
                                    const std::vector<double>& time_b, const std::vector<double>& value_b, double first_peak_b_s,
                                    const std::string& what) {
  AlignedCorrelation result;
  result.shift_s = first_peak_a_s - first_peak_b_s;
  std::vector<double> shifted_b(time_b.size());
  for (std::size_t i = 0; i < time_b.size(); ++i) shifted_b[i] = time_b[i] + result.shift_s;
  std::vector<double> a, b;
  for (std::size_t i = 0; i < time_a.size(); ++i) {
    if (time_a[i] < shifted_b.front() || time_a[i] > shifted_b.back()) continue;
    a.push_back(value_a[i]);
    b.push_back(interpolate(shifted_b, value_b, time_a[i]));
  }
  if (a.size() < 3)
    throw InputError(what + ": after aligning the first local maxima the two responses overlap in only " + std::to_string(a.size()) +
                     " samples (need 3)");
  result.samples = a.size();
  result.correlation = pearsonCorrelation(a, b);
  return result;
}

}  // namespace demfem::analysis
