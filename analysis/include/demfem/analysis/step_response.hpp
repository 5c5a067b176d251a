// demfem analysis: the calibration-weight response (paper Section 2.10.1 / 3.1, Figs. 7 and 8):
// steady value, frequency and damping ratio from several cycles, and the correlation of two
// responses after aligning their first local maxima.
//
// analyseStepResponse(t, y):
//  - steady value y_ss = mean of the last `steady_fraction` of the samples (at least
//    `min_tail_samples`); its spread is the standard deviation of those samples.
//  - e = y - y_ss, sign-flipped when the response falls (y_ss < y[0]) so overshoots are positive.
//  - Cycles are counted with a hysteresis band +-h, h = max(noise_band_factor * tail std,
//    min_amplitude_fraction * largest overshoot): an upward zero crossing counts once e has been
//    below -h and then rises above +h; its time is interpolated linearly where e = 0. Between an
//    upward crossing and the next fall below -h the maximum of e is a peak (time and value refined
//    by a parabola through the three samples around it).
//  - Frequency per cycle f_k = 1 / (u_{k+1} - u_k) from consecutive upward crossings (the damped
//    frequency); damping ratio per cycle from the logarithmic decrement of consecutive peaks:
//    delta_k = ln(a_k / a_{k+1}), zeta_k = delta_k / sqrt(4 pi^2 + delta_k^2).
//  - Reported: mean and sample standard deviation over the cycles (Fig. 8 shows them as bars with
//    error segments). Fewer than `min_cycles` periods or decrements throws InputError naming
//    `what` (file and column).
//
// Units: time s, value in the signal's unit (N or mm), frequency Hz, damping ratio 1.
#pragma once

#include "demfem/analysis/recording.hpp"

#include <string>
#include <vector>

namespace demfem::analysis {

struct StepResponseSettings {
  double steady_fraction = 0.2;
  std::size_t min_tail_samples = 10;
  double noise_band_factor = 3.0;
  double min_amplitude_fraction = 0.02;
  std::size_t min_cycles = 2;
};

struct StepResponse {
  double steady_value = 0.0;
  double steady_std = 0.0;
  double frequency_mean_Hz = 0.0;
  double frequency_std_Hz = 0.0;
  double damping_ratio_mean = 0.0;
  double damping_ratio_std = 0.0;
  std::vector<double> cycle_frequencies_Hz;  // one per period
  std::vector<double> cycle_damping_ratios;  // one per pair of consecutive peaks
  double first_peak_time_s = 0.0;  // the first local maximum (of e, i.e. the first overshoot)
  std::vector<double> peak_times_s;
  std::vector<double> peak_values;  // y at the peaks (signal unit)
  std::vector<double> upward_crossing_times_s;
};

// See the header comment. `what` names the signal in messages, e.g. "run.csv: column 'force'".
StepResponse analyseStepResponse(const std::vector<double>& time_s, const std::vector<double>& value, const StepResponseSettings& settings,
                                 const std::string& what);

// Pearson correlation coefficient of two equally long sequences (nan when one is constant).
double pearsonCorrelation(const std::vector<double>& a, const std::vector<double>& b);

struct AlignedCorrelation {
  double shift_s = 0.0;  // added to the second signal's time so the first local maxima coincide
  double correlation = 0.0;
  std::size_t samples = 0;  // samples of the first signal inside the overlap
};

// Section 3.1: shifts the second response in time so its first local maximum coincides with the
// first one's, interpolates it at the first one's samples inside the overlap and returns the Pearson
// correlation there. Throws InputError (naming `what`) with fewer than 3 overlapping samples.
AlignedCorrelation correlateAligned(const std::vector<double>& time_a, const std::vector<double>& value_a, double first_peak_a_s,
                                    const std::vector<double>& time_b, const std::vector<double>& value_b, double first_peak_b_s,
                                    const std::string& what);

}  // namespace demfem::analysis
