// demfem analysis: the paper's Section 2.3 evaluation of a soil-bin run, window statistics and
// pooling of repeats.
//
// Section 2.3, as implemented by evaluateSoilBinRun() for a raw recording:
//  1. Calibration factors: force_N = force * force_factor, deformation_mm = deformation *
//     deformation_factor. (The paper applies them last; all later steps are invariant to a positive
//     factor, and applying them first keeps "maximum" meaningful for a negative one.)
//  2. Initial deformation d0 = mean of the samples in the first `baseline_duration_s` (at least one
//     sample): the "initial deformation value", averaged so sensor noise does not move it.
//  3. Start: the deformation maximum d_max over the whole run; the first times t10, t20 at which the
//     deformation reaches d0 + 0.10 (d_max - d0) and d0 + 0.20 (d_max - d0) (linear interpolation
//     between samples); the line through those two points meets d = d0 at t_start. The origin moves
//     to (t_start, d0): time is counted from t_start, deformation from d0. Force is not shifted.
//  4. End: the sample where the end signal (force by default: "the force increased significantly at
//     the end ... due to the approaching wall") is largest after t_start; later samples are dropped.
//  5. Displacement: x = stroke * (t - t_start) / (t_end - t_start) for the kept samples with
//     t >= t_start, i.e. 0 at the start, the stroke at the end, divided evenly between samples
//     (exactly even for the paper's constant sample rate).
// A calibrated recording (simulated, or evaluated before) already carries displacement_mm; its
// curve is taken as it is.
//
// Window statistics: mean and sample standard deviation (n - 1) of force and deformation over the
// samples with window_begin_mm <= x <= window_end_mm (the paper's 100-500 mm). A run that does not
// cover the window (within 1 % of its length; e.g. a simulation stopped early) or has fewer than
// min_window_samples samples in it is an input error naming the file.
//
// Units: time s, displacement and deformation mm, force N, tilt deg.
#pragma once

#include "demfem/analysis/recording.hpp"

#include <optional>
#include <vector>

namespace demfem::analysis {

enum class EndSignal { Force, Deformation };

struct EvaluationSettings {
  double start_low_fraction = 0.10;   // Section 2.3: 10 % of the maximum deformation
  double start_high_fraction = 0.20;  // Section 2.3: 20 % of the maximum deformation
  double baseline_duration_s = 0.5;   // span averaged for the initial deformation value
  EndSignal end_signal = EndSignal::Force;
  double window_begin_mm = 100.0;  // Section 2.3 / Fig. 15: 100-500 mm of tool displacement
  double window_end_mm = 500.0;
  std::size_t min_window_samples = 10;
};

// A force/deformation curve against tool displacement (equal-length columns).
struct DisplacementCurve {
  std::vector<double> time_s;  // since the start of the evaluated run
  std::vector<double> displacement_mm;
  std::vector<double> force_N;
  std::vector<double> deformation_mm;
  std::vector<double> tilt_deg;  // empty when the recording has none
  std::size_t size() const { return displacement_mm.size(); }
};

struct SignalStatistics {
  double mean = 0.0;
  double std_dev = 0.0;  // sample standard deviation (n - 1)
  std::size_t samples = 0;
};

struct WindowStatistics {
  SignalStatistics force_N;
  SignalStatistics deformation_mm;
  std::optional<SignalStatistics> tilt_deg;
};

struct EvaluatedRun {
  CaseKey key;
  int repeat = 1;
  std::filesystem::path source;
  bool section_2_3_applied = false;  // false: calibrated input taken as it is
  // Section 2.3 landmarks in the recording's own time (raw recordings only).
  double start_time_s = 0.0;
  double end_time_s = 0.0;
  double initial_deformation_mm = 0.0;
  double max_deformation_mm = 0.0;
  DisplacementCurve curve;
  WindowStatistics window;
};

// Section 2.3 on one soil-bin recording (see the header comment). Throws InputError when the
// landmarks cannot be found (deformation never rises, run too short) or the window is too sparse.
EvaluatedRun evaluateSoilBinRun(const Recording& recording, const EvaluationSettings& settings);

// Mean and sample standard deviation of `values` restricted to window_begin <= x <= window_end.
SignalStatistics windowStatistics(const std::vector<double>& x, const std::vector<double>& values, double window_begin,
                                  double window_end);

// Sample mean and standard deviation (n - 1; 0 for a single value). Pre: values not empty.
SignalStatistics meanAndStdDev(const std::vector<double>& values);

// Repeats of one case pooled (Section 2.3 / Fig. 15).
struct PooledCase {
  CaseKey key;
  std::vector<int> repeats;
  // Mean of the repeat means.
  double force_mean_N = 0.0;
  double deformation_mean_mm = 0.0;
  // Spread between repeats: sample standard deviation of the repeat means (absent for one repeat).
  std::optional<double> force_between_repeats_std_N;
  std::optional<double> deformation_between_repeats_std_mm;
  // Standard deviation of all window samples of all repeats (the Fig. 15 error bars).
  double force_std_N = 0.0;
  double deformation_std_mm = 0.0;
  // Repeats averaged on a common displacement grid (linear interpolation), for plots.
  DisplacementCurve mean_curve;
};

// Pools evaluated runs of ONE case. Pre: runs not empty, all with the same key.
PooledCase poolRepeats(const std::vector<const EvaluatedRun*>& runs, const EvaluationSettings& settings);

// Linear interpolation of (x, y) at xq; x strictly increasing or non-decreasing; xq outside the
// range clamps to the end values.
double interpolate(const std::vector<double>& x, const std::vector<double>& y, double xq);

}  // namespace demfem::analysis
