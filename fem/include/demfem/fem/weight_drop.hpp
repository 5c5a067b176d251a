// demfem calibration-weight simulation (paper Section 2.10.1, Fig. 5, 7, 8; docs/architecture.md section 4).
//
// The tool is clamped horizontally exactly as in the soil bin (Section 2.9 constraints) with gravity
// along its -z axis (the same direction as the soil load, so force and deformation read positive).
// At t = 0 a weight of mass m is hung on the pan: the force m g is spread uniformly over the z DOFs
// of the keypoints in the pan rows (keypoint rows within pan_rows_from_tip of the tip), and m is
// added as a lumped mass to the diagonal of M in the same rows (the paper's simplification). The
// tool's own weight is tared (the sensors read the response to the weight only), and the run starts
// at rest. The response is integrated with Eq (5)-(10).
//
// Evaluation (Fig. 8): steady value = mean over the last third of the run; frequency = mean of the
// inverse periods between successive maxima of the signal; damping ratio from the logarithmic
// decrement of successive maxima above the steady value, zeta = delta / sqrt(4 pi^2 + delta^2), averaged.
#pragma once

#include "demfem/fem/model.hpp"
#include "demfem/study/study.hpp"

#include <functional>
#include <ostream>
#include <vector>

namespace demfem::fem {

constexpr double kStandardGravity_m_s2 = 9.80665;

struct WeightDropSample {
  double t_s = 0;
  double force_N = 0;        // load-cell force (Sensors sign convention)
  double deformation_mm = 0; // at the sensor line
};

// Steady value, mean frequency and damping ratio of one signal (Fig. 8's three quantities).
struct SignalCharacteristics {
  double steady = 0;
  double frequency_Hz = 0;     // 0 if fewer than two maxima were found
  double damping_ratio = 0;    // 0 if fewer than two maxima above the steady value
  int maxima = 0;              // number of maxima used
};

struct WeightDropResult {
  std::vector<WeightDropSample> samples;  // t = 0, dt, 2 dt, ... duration
  SignalCharacteristics force, deformation;
  int pan_keypoints = 0;                  // keypoints carrying the weight
  double static_force_N = 0;              // static solution under the weight (K u = f)
  double static_deformation_mm = 0;
};

// Characteristics of samples `values` taken every `dt_s` (see evaluation above). Throws
// std::invalid_argument for fewer than 3 samples or dt <= 0.
SignalCharacteristics characterize(const std::vector<double>& values, double dt_s);

// Runs the calibration-weight test on `model` (a reduced model of `tool`; it is copied and the
// lumped mass added to the copy). Throws std::invalid_argument for a non-positive mass or duration,
// or if no keypoint row lies within pan_rows_from_tip of the tip. `progress` (may be empty)
// receives the fraction of the time steps done, every 50 steps and at the end.
WeightDropResult simulateWeightDrop(const ReducedModel& model, const study::Tool& tool, const study::WeightDrop& drop,
                                    double dt_s, const std::function<void(double)>& progress = {});

// Writes "t_s,force_N,deformation_mm" and one line per sample (Fig. 7's columns).
void writeWeightDropCsv(std::ostream& out, const WeightDropResult& result);

}  // namespace demfem::fem
