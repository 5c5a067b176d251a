#include "demfem/analysis/step_response.hpp"

#include "demfem/analysis/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>

namespace demfem::analysis {

namespace {

// Sample standard deviation; NaN below two values.
double spread(const std::vector<double>& values) {
  return values.size() < 2 ? std::numeric_limits<double>::quiet_NaN() : meanAndStdDev(values).std_dev;
}

// The cycle-by-cycle part of analyseStepResponse (header comment) on e = +-(y - y_ss).
void countCycles(const std::vector<double>& t, const std::vector<double>& e, double band, double steady, double direction,
                 StepResponse& response) {
  const std::size_t n = e.size();
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
        response.peak_values.push_back(steady + direction * peak_e);
        peak_amplitudes.push_back(peak_e);
        state = State::Below;
      }
    }
    if (state == State::Unknown && e[i] < -band) state = State::Below;
  }
  const auto& u = response.upward_crossing_times_s;
  for (std::size_t k = 1; k < u.size(); ++k) response.cycle_frequencies_Hz.push_back(1.0 / (u[k] - u[k - 1]));
  for (std::size_t k = 1; k < peak_amplitudes.size(); ++k) {
    const double delta = std::log(peak_amplitudes[k - 1] / peak_amplitudes[k]);  // logarithmic decrement
    response.cycle_damping_ratios.push_back(delta / std::sqrt(4.0 * std::numbers::pi * std::numbers::pi + delta * delta));
  }
}

}  // namespace

StepResponse analyseStepResponse(const std::vector<double>& t, const std::vector<double>& y, const StepResponseSettings& settings,
                                 const std::string& what) {
  StepResponse response;
  response.fit = fitStepResponse(t, y, what);
  const StepResponseFit& fit = response.fit;
  response.first_peak_time_s = fit.step_time_s + 0.5 / fit.frequency_Hz;
  const double direction = fit.steady >= fit.initial ? 1.0 : -1.0;
  std::vector<double> e(y.size());
  for (std::size_t i = 0; i < y.size(); ++i) e[i] = direction * (y[i] - fit.steady);
  const double largest_overshoot = *std::max_element(e.begin(), e.end());
  const double band = std::max(settings.noise_band_factor * fit.residual_rms, settings.min_amplitude_fraction * largest_overshoot);
  countCycles(t, e, band, fit.steady, direction, response);
  response.cycle_frequency_std_Hz = spread(response.cycle_frequencies_Hz);
  response.cycle_damping_ratio_std = spread(response.cycle_damping_ratios);
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
