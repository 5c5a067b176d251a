// demfem analysis: signatures of a discrepancy between a simulation and recordings, computed from
// a comparison (workflow.hpp) alone: what differs, by how much, and how it relates across cases
// (docs/diagnosis.md). Pure: depends on nothing of the simulation.
//
// Calibration weights (Section 2.10.1, Fig. 8), per weight, measured over simulated:
//   force_ratio = F_meas / F_sim and deformation_ratio = d_meas / d_sim of the steady values;
//   force per weight F / m (N/kg) on both sides; frequency_ratio = f_meas / f_sim (force channel);
//   damping_difference = zeta_meas - zeta_sim (force channel), all from the whole-record fits
//   (step_fit.hpp). Each with the standard error of the measured side: the larger of the fits'
//   propagated errors and the spread between repeats over sqrt(repeats).
//   Across the lightest and the heaviest weight: the change of both ratios, the change of the
//   damping difference from the light weight (higher frequency) to the heavy one (lower frequency),
//   and stiffness_consistency = frequency_ratio^2 x deformation_ratio averaged over the weights
//   (1 when only the stiffness scale is wrong: f ~ sqrt(k), d ~ 1 / k).
//   What the causes leave (docs/diagnosis.md): a wrong Young's modulus changes frequency and
//   deformation together and leaves force per weight alone; a compliant clamp changes force per
//   weight (the clamp carries less moment, the load cell less force); a sensor gain changes one
//   channel's ratio and nothing else; mass-proportional damping raises the damping difference more
//   at the heavy weight, stiffness-proportional damping more at the light one.
//
// Stroke phases of soil-bin runs, per depth and phase (insertion: displacement before the window;
// window; end of stroke: after it, the approach to the end wall): the mean force of each run over
// the phase, averaged over each side's runs, with the standard error of that average (the spread
// between runs over sqrt(runs); absent for a single run). Where along the stroke a discrepancy lives.
//
// Soil-bin runs (Sections 2.3, 3.6), per depth: bias of the window means 100 (sim - meas) / meas of
// force and deformation; the end-of-stroke rise (mean force over the last `end_fraction` of each
// side's displacement range over the window mean, simulated minus measured); the fluctuation
// amplitude ratio (window standard deviation, simulated / measured) and the spectral slopes b of
// both sides' power laws. Across depths: the least-squares slope of the force bias against depth
// (percent per mm; a depth-dependent strength leaves a bias that changes with depth).
#pragma once

#include "demfem/analysis/report_section.hpp"
#include "demfem/analysis/workflow.hpp"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace demfem::analysis {

struct Estimate {
  double value = 0.0;
  double std_error = 0.0;
};

struct WeightDropSignature {
  CaseKey key;
  Estimate force_ratio;          // measured / simulated, steady load-cell force
  Estimate deformation_ratio;    // measured / simulated, steady deformation
  double force_per_weight_measured_N_per_kg = 0.0;
  double force_per_weight_simulated_N_per_kg = 0.0;
  Estimate frequency_ratio;      // measured / simulated
  Estimate damping_difference;   // measured - simulated damping ratio
};

struct WeightDropRelations {
  bool defined = false;                     // two or more weights
  double force_ratio_change = 0.0;          // heaviest - lightest weight
  double deformation_ratio_change = 0.0;
  double damping_difference_change = 0.0;   // heaviest (lower frequency) - lightest
  double stiffness_consistency = 0.0;       // mean of frequency_ratio^2 x deformation_ratio
};

struct SoilBinSignature {
  CaseKey key;
  double force_bias_percent = 0.0;        // 100 (sim - meas) / meas of the window means
  double deformation_bias_percent = 0.0;
  double end_rise_difference = 0.0;       // simulated minus measured end-of-stroke rise
  double fluctuation_ratio = 0.0;         // window force std, simulated / measured
  double spectral_slope_measured = 0.0;   // b of a f^b, force
  double spectral_slope_simulated = 0.0;
};

enum class StrokePhase { Insertion, Window, EndOfStroke };
std::string phaseName(StrokePhase phase);  // "insertion", "window", "end of stroke"

struct PhaseMean {
  double mean_N = 0.0;
  std::optional<double> std_error_N;  // runs >= 2
  int runs = 0;
};

struct StrokePhaseForce {
  CaseKey key;
  StrokePhase phase = StrokePhase::Window;
  PhaseMean measured, simulated;
};

// Per case on both sides, per phase with samples on both sides (by depth, then phase).
std::vector<StrokePhaseForce> strokePhaseForces(const ComparisonResult& comparison, const EvaluationSettings& settings);

struct Signatures {
  std::vector<WeightDropSignature> weight_drops;  // by mass, ascending
  WeightDropRelations weight_relations;
  std::vector<SoilBinSignature> soil_bins;        // by depth, ascending
  std::optional<double> force_bias_per_depth_percent_per_mm;  // two or more depths
};

struct SignatureSettings {
  double end_fraction = 0.1;  // last part of the stroke whose mean force gives the end rise
};

Signatures signaturesOf(const ComparisonResult& comparison, const SignatureSettings& settings);

// The report tables of the signatures (report_section.hpp): one row per weight (case, mass_kg, each
// ratio and difference beside its `_std_error`, force per weight on both sides in N/kg) and one per
// depth (case, depth_mm, the biases in percent, end rise difference, fluctuation ratio, both
// spectral slopes). `demfem diagnose` writes their CSV and Markdown.
const report::Section<WeightDropSignature>& weightDropSignatureSection();
const report::Section<SoilBinSignature>& soilBinSignatureSection();

// `weight_drops` and `soil_bins` (the two sections' JSON), `weight_relations` (null with fewer than
// two weights) and `force_bias_per_depth_percent_per_mm` (null with fewer than two depths).
nlohmann::json toJson(const Signatures& signatures);

}  // namespace demfem::analysis
