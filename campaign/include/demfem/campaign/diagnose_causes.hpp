// demfem campaign: the catalogue of causes a diagnosis considers (docs/diagnosis.md). Each cause is
// one entry: what it is, the signature it leaves in a comparison (analysis/signatures.hpp), and its
// model extension: how to apply it to a study file (keys added at neutral values) and which numbers
// of the extended study to fit, as JSON pointers with ranges (parameters.hpp). Adding a cause is
// adding one entry to causeCatalogue() in diagnose_causes.cpp.
//
// Contract
// - Study files are JSON in file units (docs/study-file.md); extend() never changes a number the
//   extension does not own, and the extended study at the returned start values is valid.
// - match() reads the signatures only; it says whether the cause is plausible (its signature is
//   present beyond the measured scatter) and gives the evidence in one sentence.
// - judged_on: what the cause is fitted and judged on. The soil causes move the draught's level, so
//   they are judged on the window means; the window spreads belong to the fluctuation signature,
//   which none of them claims (fitting them together trades one against the other,
//   docs/diagnosis.md, "The small bin").
// - extend() throws ArgumentError naming the cause when the study cannot take the extension (e.g.
//   no deformable tool, no soil).
#pragma once

#include "demfem/analysis/recording.hpp"
#include "demfem/analysis/signatures.hpp"
#include "demfem/campaign/parameters.hpp"

#include <nlohmann/json.hpp>

#include <functional>
#include <string>
#include <vector>

namespace demfem::campaign {

struct SignatureMatch {
  bool plausible = false;
  std::string evidence;  // one sentence with the numbers
};

struct Extension {
  nlohmann::ordered_json study;           // the extended study at the start values
  std::vector<ParameterSpec> parameters;  // what to fit (pointers into `study`, file units)
};

// How far a ratio must be from 1 (or a difference from 0) to count as a signature: the larger of
// `relative` and `scatter_factor` standard errors.
struct SignatureTolerance {
  double relative = 0.02;
  double damping = 0.002;  // damping-ratio difference
  double scatter_factor = 3.0;
};

struct Cause {
  std::string id;
  analysis::CaseKind domain = analysis::CaseKind::CalibrationWeight;  // the recordings it explains
  std::string description;
  std::string expected_signature;
  // The quantities (objective.hpp names) the signature moves: the extension is fitted on them and
  // judged by them (held-out error, noise, BIC). Empty: every quantity of the domain.
  std::vector<std::string> judged_on;
  std::function<SignatureMatch(const analysis::Signatures&, const SignatureTolerance&)> match;
  // `depths_mm`: the soil-bin recordings' depths (soil causes split or pick layers by them).
  std::function<Extension(const nlohmann::ordered_json& study, const std::vector<double>& depths_mm)> extend;
};

// Every cause, in a fixed order: young_modulus, clamp_compliance, mass_damping, damping_form,
// added_mass, force_sensor_gain, deformation_sensor_gain (calibration weights); layered_soil,
// cohesion, end_wall, tool_friction (soil-bin runs).
const std::vector<Cause>& causeCatalogue();

// The calibrated baseline's parameters of one domain (docs/diagnosis.md, "Calibrated baseline"): the
// study's nominal uncertain parameters within their nominal uncertainty. Calibration weights: E_Pa
// of the deformable tool within 1/1.1-1.1 x the study's (log: a sheet's modulus known to 10 %) and
// alpha_s within 0.5-2 x (log; 1e-6-1e-2 s when the study's is 0). Soil-bin runs: the static and
// rolling friction of the self pair of the deepest layer each depth reaches (the parameters of
// layeredSoilPreset, calibration.hpp: for a single-layer study, that layer's two frictions).
// Throws ArgumentError when the study has none of them.
std::vector<ParameterSpec> baselineParameters(const nlohmann::ordered_json& study, const std::string& origin,
                                              const std::vector<analysis::Recording>& recordings, analysis::CaseKind domain);

// The entry of `id`; throws ArgumentError listing the ids.
const Cause& findCause(const std::string& id);

}  // namespace demfem::campaign
