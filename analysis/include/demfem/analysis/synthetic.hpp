// demfem analysis: synthetic recordings whose true landmarks and statistics are known by
// construction, for the tests and for the example data (examples/data).
//
// Soil-bin run (SoilBinTruth): the tool rests until `start_time_s`, then moves at `velocity_mm_s`
// for `stroke_mm` and stops (true end = start + stroke / velocity). Force and deformation are
// proportional (an elastic tool) and follow load(x) * steady value, with
//   load(x) = x / ramp_mm for x < ramp_mm (linear rise, so the Section 2.3 line through any two
//             points of the rise meets the initial value exactly at the true start),
//           = 1 up to wall_start_mm,
//           = 1 + wall_gain ((x - wall_start) / (stroke - wall_start))^2 up to the stroke end
//             (the approaching wall, largest at the true end),
//           = relaxed_fraction after the stroke (the bin has stopped),
// plus, while moving, a fluctuation with a power-law amplitude spectrum: sinusoids at spacing
// fluctuation_spacing_Hz from fluctuation_low_Hz to fluctuation_high_Hz with amplitude
// fluctuation_a * f^fluctuation_b (a in units of the steady value) and random phases, multiplied
// by min(load, 1); plus white Gaussian noise of noise_fraction * steady value. The mean over any
// long window of the steady part is the steady value (the fluctuation averages out).
// Raw format divides by the calibration factors and adds the DAQ offsets; calibrated format
// ("simulated") writes displacement_mm = clamp(v (t - start), 0, stroke) and tilt_deg =
// tilt_per_mm * deformation.
//
// Weight drop (WeightDropTruth): the weight is hung at drop_time_s; for tau = t - drop >= 0
//   y = y_ss (1 - exp(-zeta w_n tau) (cos w_d tau + zeta / sqrt(1 - zeta^2) sin w_d tau)),
// w_d = 2 pi frequency_Hz (the damped frequency), w_n = w_d / sqrt(1 - zeta^2); 0 before; plus
// white noise noise_fraction * y_ss, for force and deformation alike.
//
// Deterministic: the same truth (including seed) gives the same samples.
#pragma once

#include "demfem/analysis/recording.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace demfem::analysis {

struct SoilBinTruth {
  std::string tool = "PMMA";
  double depth_mm = 30.0;
  int repeat = 1;
  double sample_rate_Hz = 50.0;
  double start_time_s = 2.0;
  double rest_after_s = 1.5;
  double velocity_mm_s = 30.0;
  double stroke_mm = 600.0;
  double ramp_mm = 40.0;
  double wall_start_mm = 540.0;
  double wall_gain = 1.5;
  double relaxed_fraction = 0.6;
  double force_N = 20.0;
  double deformation_mm = 2.0;
  double fluctuation_a = 0.005;
  double fluctuation_b = -0.8;
  double fluctuation_low_Hz = 0.5;
  double fluctuation_high_Hz = 25.0;
  double fluctuation_spacing_Hz = 0.01;
  double noise_fraction = 0.005;
  double force_factor_N_per_unit = 0.05;
  double deformation_factor_mm_per_unit = 0.002;
  double force_offset_units = 0.0;
  double deformation_offset_units = 150.0;
  double tilt_deg_per_mm = 1.2;
  std::uint64_t seed = 1;

  double endTime() const { return start_time_s + stroke_mm / velocity_mm_s; }
};

struct WeightDropTruth {
  std::string tool = "PMMA";
  double mass_kg = 1.0;
  int repeat = 1;
  double sample_rate_Hz = 50.0;
  double duration_s = 8.0;
  double drop_time_s = 1.0;
  double frequency_Hz = 3.0;  // damped
  double damping_ratio = 0.05;
  double force_N = 4.5;
  double deformation_mm = 9.0;
  double noise_fraction = 0.003;
  double force_factor_N_per_unit = 0.01;
  double deformation_factor_mm_per_unit = 0.005;
  std::uint64_t seed = 1;
};

// Columns (by name) and sidecar of one recording, ready to be written.
struct SyntheticRecording {
  std::vector<std::string> header;
  std::vector<std::vector<double>> columns;
  nlohmann::json sidecar;
};

SyntheticRecording makeSoilBinRecording(const SoilBinTruth& truth, RecordingFormat format);
SyntheticRecording makeWeightDropRecording(const WeightDropTruth& truth, RecordingFormat format);

// Writes `csv_path` and its sidecar (same stem, .json). Throws std::runtime_error on I/O failure.
void writeSyntheticRecording(const SyntheticRecording& recording, const std::filesystem::path& csv_path);

}  // namespace demfem::analysis
