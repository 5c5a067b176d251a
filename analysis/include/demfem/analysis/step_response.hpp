// demfem analysis: the calibration-weight response (paper Section 2.10.1 / 3.1, Figs. 7 and 8):
// steady value, frequency and damping ratio of a whole record, their cycle-by-cycle spread, and the
// correlation of two responses after aligning their first local maxima.
//
// analyseStepResponse(t, y):
//  - Steady value, frequency and damping ratio: the damped step response fitted to every sample
//    (step_fit.hpp). The first local maximum (first overshoot) is the fitted curve's, t0 + pi / w_d.
//  - Cycle by cycle (the spread Fig. 8 draws as error segments): e = y - y_ss of the fit, sign-
//    flipped when the response falls so overshoots are positive, counted with a hysteresis band +-h,
//    h = max(noise_band_factor * the fit's residual rms, min_amplitude_fraction * largest overshoot):
//    an upward zero crossing counts once e has been below -h and then rises above +h; its time is
//    interpolated linearly where e = 0. Between an upward crossing and the next fall below -h the
//    maximum of e is a peak (time and value refined by a parabola through the three samples around
//    it). f_k = 1 / (u_{k+1} - u_k) from consecutive upward crossings; zeta_k from the logarithmic
//    decrement of consecutive peaks, delta_k = ln(a_k / a_{k+1}), zeta_k = delta_k / sqrt(4 pi^2 +
//    delta_k^2). Their sample standard deviations are the spread (NaN below two estimates).
//  - Throws InputError naming `what` (file and column) when the fit does (too few samples, no step,
//    no overshoot).
//
// Units: time s, value in the signal's unit (N or mm), frequency Hz, damping ratio 1.
#pragma once

#include "demfem/analysis/recording.hpp"
#include "demfem/analysis/step_fit.hpp"

#include <string>
#include <vector>

namespace demfem::analysis {

struct StepResponseSettings {
  double noise_band_factor = 3.0;
  double min_amplitude_fraction = 0.02;
};

struct StepResponse {
  StepResponseFit fit;  // steady value, frequency, damping ratio of the whole record
  double first_peak_time_s = 0.0;  // the fitted curve's first local maximum
  // Cycle by cycle (Fig. 8's spread).
  std::vector<double> cycle_frequencies_Hz;  // one per period
  std::vector<double> cycle_damping_ratios;  // one per pair of consecutive peaks
  double cycle_frequency_std_Hz = 0.0;       // NaN below two periods
  double cycle_damping_ratio_std = 0.0;      // NaN below two decrements
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
