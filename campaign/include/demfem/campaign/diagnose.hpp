// demfem campaign: `demfem diagnose`: what the simulation gets wrong, the most likely cause(s), the
// model extended by them and the measured gain on data not used to fit it (docs/diagnosis.md).
//
// Procedure (diagnose()):
//  1. Nominal prediction: the study as given predicts every case (campaign::predict); the comparison
//     (analysis::compare) gives the signatures (analysis/signatures.hpp), which order the work and
//     are reported as evidence but never keep a cause from being fitted. Soil-bin cases: the model's
//     seed scatter s_model per case and quantity from settings.scatter_seeds deposition seeds.
//  2. Calibrated baseline: the study's nominal uncertain parameters (settings.baseline_fit, else
//     baselineParameters() of the recordings' domain) fitted with campaign::calibrate on all cases
//     and, leaving one case out, on every other case to predict the one left out.
//  3. Test: each residual of the calibrated baseline (fit on all cases) as z = (sim - meas) / sigma,
//     sigma^2 = sigma_meas^2 + s_model^2 / M + (modelFormPercent / 100 meas)^2 (objective.hpp;
//     M the fits' model seeds), two-sided p-values, Holm's step-down at the family-wise level
//     settings.significance_level over all quantities of all cases. None significant: verdict
//     "no significant discrepancy". The per-quantity and per-case residuals are the localisation;
//     for soil-bin cases also per phase of the stroke (PhaseLocalisation).
//  4. Models: every cause of the domains (or settings.causes) fitted together with the baseline's
//     parameters (a cause's own range replaces the baseline's for the same pointer), on all cases and
//     per fold as in step 2. When the best single cause (by evidence) still leaves a significant
//     residual, each of the two best single causes paired with every other cause whose single fit
//     has ln B > 0 over the baseline (settings.all_pairs: every other cause; pairs whose parameters
//     one cause already holds are skipped). Each model's Laplace evidence:
//     ln Z = -chi2 / 2 + sum over the eigen directions of J^T J of min(0, ln sqrt(2 pi / lambda)),
//     the priors uniform in the optimiser coordinates (uniform or log-uniform over each range,
//     parameters.hpp), up to a constant common to all models; posterior probabilities
//     exp(ln Z) / sum exp(ln Z) over the baseline and every model fitted (equal prior odds).
//  5. Held-out benefit: held-out error before (the calibrated baseline's folds) and after (the
//     model's folds) over the folds that identify the model; noise error the RMS of
//     100 sigma / meas; gain = 100 (before - max(after, noise)) / before. The same in chi2 (step 3's
//     sigma, so a quantity with a wide model-form tolerance does not mask the others): chi2 gain =
//     100 (before - max(after, n)) / before, n the held-out residuals.
//  6. Calibration shifts: each baseline parameter of the deciding fit (the named model's, else the
//     calibrated baseline's) against the study's value, z = (fitted - study) / sigma, sigma the
//     fit's standard deviation and the shift a model-form error can make in quadrature, Holm at
//     settings.significance_level over the baseline's parameters. A significant shift of a parameter
//     that a catalogue cause owns alone (E_Pa: young_modulus) names that cause: the study's value is
//     what the simulation gets wrong, even where the baseline's range absorbs it.
//  7. Verdict: a model is named (verdict "cause", its one or two causes) when ln B = ln Z - ln Z_baseline
//     >= settings.min_ln_bayes_factor, none of its residuals is significant by step 3's test, and,
//     when a split can identify it, its chi2 gain is at least settings.min_gain_percent over at least
//     settings.min_held_out_folds folds (a model no split can identify, e.g. two damping terms from
//     one weight, is judged on its evidence and the report says so); of several, the most probable.
//     None: "unexplained discrepancy", naming the significant quantities, cases and sizes. Step 6's
//     causes are added to the named model's; with no residual significant they are the verdict
//     "cause" on their own (the calibrated baseline is then the extended study).
// - Errors are RMS over quantities of 100 (sim - meas) / meas, in percent (errorPercent).
// - Every model run goes through the calibration's run cache (options.cache_dir).
// - Throws ArgumentError for unusable input (no candidate cause, a named cause unknown, a case the
//   study cannot run, no baseline parameter), campaign::Interrupted on a stop request.
#pragma once

#include "demfem/analysis/plot.hpp"
#include "demfem/analysis/signatures.hpp"
#include "demfem/analysis/staged_output.hpp"
#include "demfem/campaign/calibration.hpp"
#include "demfem/campaign/diagnose_causes.hpp"
#include "demfem/campaign/model.hpp"

#include <nlohmann/json.hpp>

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace demfem::campaign {

// The calibration settings of a diagnosis: one start, at most 200 evaluations (a model fits the
// baseline's two parameters and up to four of its causes, in a valley as narrow as the model-form
// tolerance), tolerance 1e-4 of the bounds.
inline CalibrationOptions diagnosisCalibration() {
  CalibrationOptions o;
  o.starts = 1;
  o.max_evaluations = 200;
  o.x_tolerance = 1e-4;
  return o;
}

// The verdict of a diagnosis (JSON `verdict`: verdictText()).
enum class Verdict { NoSignificantDiscrepancy, Cause, UnexplainedDiscrepancy };
std::string verdictText(Verdict verdict);

struct DiagnosisSettings {
  CalibrationOptions calibration = diagnosisCalibration();
  analysis::SignatureSettings signatures;
  SignatureTolerance tolerance;
  std::vector<std::string> causes;           // empty: every cause of the recordings' domains
  std::vector<ParameterSpec> baseline_fit;   // empty: baselineParameters() of the recordings' domain
  // Model-form tolerance, percent of each quantity (key: quantity name, "" every other one): what
  // two correct models of one tool differ by, the narrow test tool's plate model against the
  // independent beam after calibration (docs/diagnosis.md, "Model-form tolerance").
  std::map<std::string, double> model_form_percent{{"", 0.3}, {"step_force_N", 1.5}};
  double significance_level = 0.01;          // family-wise, Holm over every residual
  double min_ln_bayes_factor = 2.3;          // Jeffreys: B >= 10, "strong"
  double min_gain_percent = 10.0;            // held-out chi2 cut a named model must reach (step 5)
  int min_held_out_folds = 2;                // when a split identifies it: held-out cases it must predict
  bool pairs = true;                         // try two causes at once (step 4)
  bool all_pairs = false;                    // pair with every cause, not only those with ln B > 0 alone
  int scatter_seeds = 3;  // soil-bin cases: deposition seeds of the baseline's seed scatter (1: none)
  std::function<void(const std::string&)> on_stage;  // "fitting clamp_compliance, fold 2/2", for progress
};

// One model fitted: the calibrated baseline (no cause), one cause, or a pair.
struct ModelFit {
  std::vector<std::string> causes;           // empty: the calibrated baseline
  std::vector<FittedParameter> parameters;   // the fit on all cases (the baseline's and the causes')
  int minima = 0;                            // distinct minima within the noise (1 = unique fit)
  int held_out_folds = 0;                    // folds that identified the model and predicted their case
  std::vector<analysis::CaseKey> held_out_cases;
  std::vector<Residual> held_out;            // the folds' predictions
  std::string split;                         // how the held-out error was obtained
  double error_before_percent = 0.0;         // held-out cases: the calibrated baseline's folds (all cases without folds)
  double error_after_percent = 0.0;          // the same cases, this model's folds (all cases: its fit)
  double noise_error_percent = 0.0;          // the same cases, RMS of 100 sigma / meas (step 5)
  double gain_percent = 0.0;                 // 100 (before - max(after, noise)) / before
  // The same cases in step 3's sigma: chi2 before and after, and the gain the verdict asks for,
  // 100 (before - max(after, n)) / before with n the residuals (a correct model's expected chi2).
  double held_out_chi2_before = 0.0, held_out_chi2_after = 0.0, chi2_gain_percent = 0.0;
  double chi2 = 0.0;                         // fit on all cases, sigma of step 3
  double log_likelihood = 0.0;               // -chi2 / 2
  double log_occam = 0.0;                    // the Gaussian volume in the prior box, ln (<= 0)
  double log_evidence = 0.0;                 // ln Z (step 4)
  double ln_bayes_factor = 0.0;              // ln Z - ln Z of the calibrated baseline
  double probability = 0.0;                  // posterior over the baseline and every model fitted
  int significant = 0;                       // residuals of the fit on all cases significant by step 3
  int model_runs = 0;
  double wall_time_s = 0.0;
  nlohmann::ordered_json extended_study;     // fitted on all cases
  std::vector<Residual> residuals;           // of the fit on all cases
  std::vector<analysis::Recording> runs;     // its runs (fit on all cases)
  std::string id() const;                    // "baseline", "young_modulus", "young_modulus+force_sensor_gain"
  bool heldOut() const { return held_out_folds > 0; }
};

// A cause of the catalogue considered, with its signature's evidence (step 1).
struct CauseEvidence {
  std::string id;
  std::string description;
  std::string expected_signature;
  std::vector<std::string> judged_on;        // Cause::judged_on (empty: every quantity of its domain)
  SignatureMatch match;
};

// One residual of the calibrated baseline (step 3): where the discrepancy lives.
struct Localisation {
  analysis::CaseKey key;
  std::string quantity;
  double measured = 0.0, simulated = 0.0, sigma = 0.0;
  double residual_percent = 0.0;  // 100 (sim - meas) / meas
  double z = 0.0;                 // (sim - meas) / sigma
  double p_value = 1.0;           // two-sided
  bool significant = false;       // by Holm's step-down at the family-wise level
};

// Where along the stroke a soil-bin discrepancy lives (step 3, reported, not part of the verdict):
// the mean force of one phase (analysis::strokePhaseForces) of `model` ("study as given": its
// whole-stroke runs; "calibrated baseline": its fit's runs, which end with the window when the fits
// cut the stroke) against the measured. sigma^2: the measured repeats' standard error squared, the
// model's (its runs' spread; with one run the measured repeats' taken for it; without repeats the
// window mean's seed scatter over sqrt(M) scaled to the phase's mean), and the window mean's
// model-form tolerance times the measured mean. Holm over every row of one model at the level.
struct PhaseLocalisation {
  analysis::CaseKey key;
  std::string model;  // "study as given" or "calibrated baseline"
  std::string phase;  // analysis::phaseName
  double measured_N = 0.0, simulated_N = 0.0, sigma_N = 0.0;
  double residual_percent = 0.0;  // 100 (sim - meas) / meas
  double z = 0.0;
  double p_value = 1.0;
  bool significant = false;
};

// The model's own seed scatter of one quantity of one case (step 1): the sample standard deviation
// of the study's value over `seeds` deposition seeds, in the quantity's unit.
// A baseline parameter's calibrated value against the study's (step 6).
struct CalibrationShift {
  ParameterSpec spec;
  double study_value = 0.0, fitted = 0.0, std_dev = 0.0;  // file units
  double model_form_shift = 0.0;  // file units: FittedParameter::model_form_shift
  double shift_percent = 0.0;     // 100 (fitted - study) / study
  // (fitted - study) / sqrt(std_dev^2 + model_form_shift^2); 0 when the fit leaves it unidentified
  double z = 0.0;
  double p_value = 1.0;        // two-sided
  bool significant = false;    // Holm over the baseline's parameters
  std::string cause;           // the catalogue cause owning this parameter alone ("" none)
};

struct SeedScatter {
  analysis::CaseKey key;
  std::string quantity;
  double sd = 0.0;
  int seeds = 0;
};

// A quantity no candidate cause is judged on (Cause::judged_on), with the study as given's
// error on it: what the simulation gets wrong that the catalogue does not consider (soil spreads).
struct UnjudgedQuantity {
  std::string quantity;
  double baseline_error_percent = 0.0;  // the study as given: RMS over the cases whose nominal run ran
};

struct Diagnosis {
  analysis::Signatures signatures;
  std::vector<Residual> nominal_residuals;  // the study as given
  std::vector<analysis::Recording> nominal_runs;
  std::vector<analysis::Recording> measured;
  double nominal_error_percent = 0.0;       // all cases whose nominal runs ran
  std::vector<analysis::CaseKey> failed_baseline_cases;  // a nominal run failed: left out of every error and test
  std::vector<SeedScatter> seed_scatter;     // soil-bin quantities (empty without soil cases or scatter_seeds < 2)
  std::vector<CauseEvidence> considered;     // the candidate causes, in catalogue order
  ModelFit baseline;                         // the calibrated baseline
  std::vector<Localisation> localisation;    // its residuals tested (step 3)
  std::vector<PhaseLocalisation> phases;     // soil-bin cases: per stroke phase (step 3)
  std::vector<ModelFit> models;              // causes and pairs, most probable first
  std::optional<std::size_t> named_model;    // index into models of the named model (verdict Cause)
  std::vector<CalibrationShift> shifts;      // step 6, of the deciding fit
  std::vector<UnjudgedQuantity> unjudged;
  Verdict verdict = Verdict::NoSignificantDiscrepancy;
  std::vector<std::string> causes;           // the named model's causes and step 6's (verdict Cause)
  std::string reason;                        // one sentence: why
  double gain_percent = 0.0;                 // the named model's; 0 without one
  nlohmann::ordered_json extended_study;     // the named model's fitted study, else the calibrated baseline's
  double wall_time_s = 0.0;
};

// The model-form tolerance of `quantity` (DiagnosisSettings::model_form_percent), percent.
double modelFormPercent(const DiagnosisSettings& settings, const std::string& quantity);

// Relative error of residuals (step 4 of the header comment), percent.
double errorPercent(const std::vector<Residual>& residuals);

Diagnosis diagnose(const nlohmann::ordered_json& study, const std::string& origin, const std::vector<analysis::Recording>& recordings,
                   Model& model, const DiagnosisSettings& settings);

// `verdict`, `causes`, `cause` (the first or null), `reason`, `localisation` (rows of
// localisation.csv), `models` (rows of models.csv, the calibrated baseline first: ids, log_evidence,
// probability, held-out errors, gain, each with its `parameters`), `baseline`, `signatures`,
// settings and wall time (docs/diagnosis.md lists the keys).
nlohmann::json toJson(const Diagnosis& diagnosis, const DiagnosisSettings& settings, const std::string& extended_study_path);

// extended_study.json, report.md (the verdict in one sentence, localisation, model probabilities,
// before/after plots unless renderer is null, the extended study), the tables localisation.csv,
// models.csv, parameters.csv, weight_signatures.csv and soil_signatures.csv (each cell equal to the
// JSON's value of its column) through `out` (committed by the caller).
void writeDiagnosis(const Diagnosis& diagnosis, const DiagnosisSettings& settings, analysis::StagedOutput& out,
                    const analysis::GnuplotRenderer* renderer);

}  // namespace demfem::campaign
