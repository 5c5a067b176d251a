// demfem campaign: the calibration objective, per quantity and case, weighted by the measured
// scatter (docs/calibration.md).
//
// Quantities, computed by the same code for measured and simulated recordings:
// - calibration-weight case (Section 2.10.1, Fig. 8), from the damped step response fitted to the
//   whole record (analysis/step_fit.hpp; a resting baseline or DAQ offset drops out):
//   step_force_N and step_deformation_mm (fitted steady value minus the value before the weight),
//   frequency_Hz and damping_ratio of the deformation signal;
// - soil-bin case (Section 2.3, Fig. 15; analysis/evaluation.hpp): window_mean_force_N,
//   window_std_force_N and, for a deformable tool, window_mean_deformation_mm,
//   window_std_deformation_mm.
// Value: the mean over the case's repeats. Its scatter sigma (the uncertainty of that mean):
// - weight quantities: sqrt(max(s_between^2, mean of the fits' squared standard errors) / R) for R
//   repeats, s_between the standard deviation between the repeats' values (0 for one repeat);
// - window means: sqrt(max(s_between^2, sd^2 / N_window) / R), sd the standard deviation of a
//   repeat's window samples, N_window their number;
// - window spreads: max(s_between, sd / sqrt(2 (N_window - 1))) / sqrt(R);
// where s_between^2 is at least the quantity's between-repeat variance relative to the mean,
// pooled over every case with two or more repeats, times the case's mean squared (with two repeats
// a case's own spread has one degree of freedom and comes out small by chance: repeats that happen
// to agree would make a residual of ordinary size look significant, docs/diagnosis.md),
// and never below `relative_floor` |value| (a noise-free recording would otherwise get an infinite
// weight; the floor is stated in the report). A stated model-form tolerance widens it to
// sqrt(sigma^2 + (m value)^2), m the quantity's entry of `model_form_relative` (none: 0; a diagnosis
// sets it, docs/diagnosis.md).
// Residual r = (simulated - measured) / sigma_measured; chi2 = sum r^2 is what the fit minimises.
#pragma once

#include "demfem/analysis/recording.hpp"
#include "demfem/analysis/workflow.hpp"

#include <nlohmann/json.hpp>

#include <map>
#include <string>
#include <vector>

namespace demfem::campaign {

struct ObjectiveSettings {
  analysis::AnalysisSettings analysis;  // Section 2.3 window and landmarks for soil-bin runs
  double relative_floor = 1e-3;         // sigma >= relative_floor * |value|
  std::map<std::string, double> model_form_relative;  // per quantity name: sigma widened by it * |value| in quadrature
  bool soil_deformation = true;         // soil-bin deformation quantities (false for a rigid tool)
  // Empty: every quantity above. Otherwise only these names (a diagnosis fits and judges a cause on
  // the quantities its signature moves, docs/diagnosis.md); a name that is not a quantity above is
  // an ArgumentError.
  std::vector<std::string> only_quantities;
};

// The quantity names of the header comment, in the order quantities() lists them.
const std::vector<std::string>& quantityNames();

// A calibration-weight recording in N and mm (raw DAQ units times the sidecar's factors).
struct WeightSignals {
  std::vector<double> time_s, force_N, deformation_mm;
};
WeightSignals weightSignals(const analysis::Recording& recording);

// One quantity of one case: the repeats' mean and the scatter of that mean.
struct Quantity {
  analysis::CaseKey key;
  std::string name;  // "step_force_N", "frequency_Hz", "window_mean_force_N", ... (see header comment)
  double value = 0, sigma = 0;
  double repeat_sd = 0;  // standard deviation between the repeats' values (0 for one repeat)
};

// The quantities of every case of `recordings`. tolerate_failures = false: a recording that cannot
// be evaluated throws analysis::InputError naming its file (measured data); true: its case is left
// out (a simulated run at extreme parameters, e.g. no overshoot to fit).
std::vector<Quantity> quantities(const std::vector<analysis::Recording>& recordings, const ObjectiveSettings& settings,
                                 bool tolerate_failures);

struct Residual {
  analysis::CaseKey key;
  std::string quantity;
  double measured = 0, simulated = 0, sigma = 0;
  double normalized = 0;  // (simulated - measured) / sigma
  bool missing = false;   // the simulated side lacks the quantity (a failed run): simulated is 0
};

// Residuals of `simulated` against `measured`, one per measured quantity. A quantity missing on the
// simulated side is scored as a simulated value of 0 (a large but finite penalty, so the optimiser
// can leave the region).
std::vector<Residual> residuals(const std::vector<Quantity>& measured, const std::vector<Quantity>& simulated);

double chi2(const std::vector<Residual>& residuals);

}  // namespace demfem::campaign
