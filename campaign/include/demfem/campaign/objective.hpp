// demfem campaign: the calibration objective, per quantity and case, weighted by the measured
// scatter (docs/calibration.md).
//
// Quantities (analysis::evaluate() on measured and simulated recordings alike; docs/analysis.md):
// - calibration-weight case: steady force_N, steady deformation_mm, frequency_Hz and damping ratio
//   of the deformation signal (Section 2.10.1, Fig. 8);
// - soil-bin case: window mean and window standard deviation of force_N and deformation_mm over the
//   Section 2.3 window (Fig. 15).
// Residual r = (simulated - measured) / sigma, with sigma the measured scatter of the quantity:
// - steady values and window means: the larger of the standard deviation between the repeats'
//   values (two or more repeats) and the standard error of the tail / window samples
//   (their standard deviation over sqrt(samples));
// - frequency and damping ratio: the standard deviation of the per-cycle estimates over all repeats
//   divided by sqrt(cycles) (the scatter of their mean);
// - window spreads: spread / sqrt(2 (samples - 1)) (the sampling error of a standard deviation);
// and never below `relative_floor` |measured| (a noise-free recording would otherwise give an
// infinite weight; the floor is reported). chi2 = sum r^2; the fit minimises chi2.
#pragma once

#include "demfem/analysis/workflow.hpp"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace demfem::campaign {

struct ObjectiveSettings {
  analysis::AnalysisSettings analysis;
  double relative_floor = 1e-3;  // sigma >= relative_floor * |measured|
  bool soil_deformation = true;  // soil-bin deformation quantities (false for a rigid tool)
};

struct Residual {
  analysis::CaseKey key;
  std::string quantity;  // "steady_force_N", "steady_deformation_mm", "frequency_Hz", "damping_ratio",
                         // "window_mean_force_N", "window_std_force_N", "window_mean_deformation_mm", ...
  double measured = 0, simulated = 0, sigma = 0;
  double normalized = 0;  // (simulated - measured) / sigma
};

// One measured quantity with its scatter.
struct Target {
  analysis::CaseKey key;
  std::string quantity;
  double measured = 0, sigma = 0;
};

// The targets of every case in `measured` (see header comment). Throws analysis::InputError when a
// case lacks what a quantity needs (e.g. a weight recording with fewer than two cycles).
std::vector<Target> targets(const analysis::EvaluationResult& measured, const ObjectiveSettings& settings);

// analysis::evaluate() case by case: a simulated run that cannot be evaluated (e.g. no oscillation
// to count) is left out instead of failing the whole evaluation.
analysis::EvaluationResult evaluateEach(const std::vector<analysis::Recording>& runs, const ObjectiveSettings& settings);

// Residuals of `simulated` (one run per case) against `targets`. A target whose case is missing in
// `simulated`, or whose simulated quantity cannot be evaluated (no oscillation), gets the residual
// of a simulated value of 0 (a large but finite penalty, so the optimiser can leave the region).
std::vector<Residual> residuals(const std::vector<Target>& targets, const analysis::EvaluationResult& simulated);

double chi2(const std::vector<Residual>& residuals);

nlohmann::json toJson(const Residual& residual);

}  // namespace demfem::campaign
