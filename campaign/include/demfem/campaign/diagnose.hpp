// demfem campaign: `demfem diagnose`: what the simulation gets wrong, the most likely cause, the
// model extended by it and the measured gain on data not used to fit it (docs/diagnosis.md).
//
// Procedure (diagnose()):
//  1. Baseline: the study as it is predicts every case of the recordings (campaign::predict); the
//     comparison (analysis::compare) gives the signatures (analysis/signatures.hpp).
//  2. Candidates: the catalogue's causes of the recordings' domains (calibration weights, soil-bin
//     runs), or those named in settings.causes. A cause whose signature is absent (Cause::match) is
//     listed with its evidence but not fitted.
//  3. Each plausible cause: its extension (Cause::extend) fitted with campaign::calibrate on every
//     case but one and used to predict the held-out case, for each case in turn (leave one case
//     out; needs two or more cases). If a fold leaves a parameter unidentified, held-out prediction
//     is impossible: this is said (`split`) and the cause is ranked on all cases (in-sample).
//     Finally the extension is fitted on all cases (the values reported, with their standard
//     deviations and identification, and the extended study). Every fit, and every error and BIC
//     of the cause below, uses the quantities of its signature (Cause::judged_on) only.
//  4. Errors: a case's error is the root mean square over its quantities (objective.hpp: steady
//     force and deformation, frequency, damping ratio; window means and spreads) of the relative
//     difference 100 (sim - meas) / meas, in percent; a set of cases: the RMS over all their
//     quantities. Held-out error before = the baseline's on the held-out cases, after = the
//     extended model's from the folds. Noise error: the error a correct model shows from the
//     scatter alone, the RMS over the same quantities of 100 sigma_w / |measured| with sigma_w the
//     widened sigma of step 5; an error after below it is not resolved, so the gain is
//     100 (before - max(after, noise)) / before.
//  5. Information criterion: BIC = chi2 + k ln n with chi2 of the fit on all cases (objective.hpp:
//     residuals normalised by the measured scatter, so chi2 is -2 ln L up to a constant), k the
//     extension's parameters, n the residuals; delta_bic = BIC - chi2 of the baseline (k = 0).
//     Soil-bin cases: a DEM run is one random packing, so the model has a seed scatter of its own.
//     The baseline also runs at settings.scatter_seeds deposition seeds (the study's and the next
//     ones); per case and quantity their standard deviation s_model (seed_scatter) widens the
//     residuals' sigma of the BIC to sqrt(sigma^2 + s_model^2 / M), M the fits' model seeds
//     (calibration.model_seeds): a fit that only absorbs the packing of the seeds it runs earns no
//     evidence.
//  6. Ranking: by held-out error after (ascending; in-sample for causes ranked on all cases), ties by
//     delta_bic. The first cause is named when all hold: the baseline error on all cases is at least
//     min_error_percent (below it the model already agrees with the recordings as well as two
//     independent correct models of the tool agree with each other, docs/diagnosis.md), its gain
//     (step 4) is at least min_gain_percent, delta_bic <= -min_delta_bic, and its error after is a
//     prediction of at least min_held_out_folds held-out cases (an in-sample fit, or the prediction
//     of one case, is ranked but never named: two layer frictions fitted to two depths' means
//     predict a third depth's by chance as often as by cause, docs/diagnosis.md).
//     Otherwise the verdict is "no significant discrepancy" with the reason.
// - Every model run goes through the calibration's run cache (options.cache_dir).
// - Throws ArgumentError for unusable input (no candidate cause, a named cause unknown, a case the
//   study cannot run), campaign::Interrupted on a stop request.
#pragma once

#include "demfem/analysis/plot.hpp"
#include "demfem/analysis/signatures.hpp"
#include "demfem/analysis/staged_output.hpp"
#include "demfem/campaign/calibration.hpp"
#include "demfem/campaign/diagnose_causes.hpp"
#include "demfem/campaign/model.hpp"

#include <nlohmann/json.hpp>

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace demfem::campaign {

// The calibration settings of a diagnosis: one start (each cause fits one or two smooth
// parameters), at most 60 evaluations, tolerance 1e-3 of the bounds (well inside the fits' scatter).
inline CalibrationOptions diagnosisCalibration() {
  CalibrationOptions o;
  o.starts = 1;
  o.max_evaluations = 60;
  o.x_tolerance = 1e-3;
  return o;
}

struct DiagnosisSettings {
  CalibrationOptions calibration = diagnosisCalibration();
  analysis::SignatureSettings signatures;
  SignatureTolerance tolerance;
  std::vector<std::string> causes;  // empty: every cause of the recordings' domains
  double min_error_percent = 5.0;
  double min_gain_percent = 50.0;
  double min_delta_bic = 10.0;
  int min_held_out_folds = 2;  // held-out cases the named cause must predict
  int scatter_seeds = 3;  // soil-bin cases: deposition seeds of the baseline's seed scatter (1: none)
  std::function<void(const std::string&)> on_stage;  // "fitting clamp_compliance, fold 2/2", for progress
};

struct CauseResult {
  std::string id;
  std::string description;
  std::string expected_signature;
  std::vector<std::string> judged_on;        // Cause::judged_on (empty: every quantity of its domain)
  SignatureMatch match;
  bool fitted = false;                       // false: not plausible, not fitted
  std::vector<FittedParameter> parameters;   // the fit on all cases
  int minima = 0;                            // distinct minima within the noise (1 = unique fit)
  bool held_out = false;                     // false: ranked on all cases (see split)
  int held_out_folds = 0;                    // folds that identified the extension and predicted their case
  std::string split;                         // how the error after was obtained
  double error_before_percent = 0.0;         // held-out cases (or all cases), baseline
  double error_after_percent = 0.0;          // the same cases, extended model
  double noise_error_percent = 0.0;          // the same cases, a correct model's error from the scatter alone (step 4)
  double gain_percent = 0.0;                 // 100 (before - max(after, noise)) / before
  double chi2 = 0.0, bic = 0.0, delta_bic = 0.0;
  int model_runs = 0;
  double wall_time_s = 0.0;
  nlohmann::ordered_json extended_study;     // fitted on all cases
  std::vector<Residual> residuals;           // of the fit on all cases
  std::vector<analysis::Recording> runs;     // the extended model's runs (fit on all cases)
};

// The model's own seed scatter of one quantity of one case (step 5 of the header comment): the
// sample standard deviation of the baseline's value over `seeds` deposition seeds, in the quantity's
// unit.
struct SeedScatter {
  analysis::CaseKey key;
  std::string quantity;
  double sd = 0.0;
  int seeds = 0;
};

// A quantity no candidate cause is judged on (Cause::judged_on), with the baseline's error on it:
// what the simulation gets wrong that the catalogue does not explain (the soil runs' window spreads).
struct UnjudgedQuantity {
  std::string quantity;
  double baseline_error_percent = 0.0;  // RMS over the cases whose baseline ran (step 4)
};

struct Diagnosis {
  analysis::Signatures signatures;
  std::vector<Residual> baseline_residuals;
  std::vector<analysis::Recording> baseline_runs;
  std::vector<analysis::Recording> measured;
  double baseline_error_percent = 0.0;      // all cases whose baseline runs ran
  std::vector<analysis::CaseKey> failed_baseline_cases;  // a baseline run failed: left out of every error and BIC
  double baseline_chi2 = 0.0;               // residuals normalised by the measured scatter only
  std::vector<SeedScatter> seed_scatter;     // soil-bin quantities (empty without soil cases or scatter_seeds < 2)
  double noise_error_percent = 0.0;          // all cases whose baseline ran: a correct model's error from the scatter alone (step 4)
  int residual_count = 0;
  std::vector<CauseResult> ranking;         // fitted causes ranked first, then the others
  std::vector<UnjudgedQuantity> unjudged;   // quantities no candidate cause is judged on
  std::optional<std::string> cause;         // the named cause
  std::string reason;                       // why it was named, or why none was
  double gain_percent = 0.0;                // the named cause's; 0 without one
  nlohmann::ordered_json extended_study;    // the named cause's fitted study, else the study itself
  double wall_time_s = 0.0;
};

// Relative error of residuals (step 4 of the header comment), percent.
double errorPercent(const std::vector<Residual>& residuals);

Diagnosis diagnose(const nlohmann::ordered_json& study, const std::string& origin, const std::vector<analysis::Recording>& recordings,
                   Model& model, const DiagnosisSettings& settings);

// `verdict`, `cause`, `reason`, `ranking` (one object per row of ranking.csv: rank, id, held-out
// error before/after in percent, gain, BIC, evidence, ...; null numbers for a cause not fitted;
// each with its `parameters`, the rows of parameters.csv of that cause: value, std_dev,
// identification), `gain_percent`, `signatures` (analysis::toJson), `extended_study` (the path
// given), thresholds and wall time (docs/diagnosis.md lists the keys).
nlohmann::json toJson(const Diagnosis& diagnosis, const DiagnosisSettings& settings, const std::string& extended_study_path);

// extended_study.json, report.md (signatures, ranking, the gain, before/after plots unless renderer
// is null), the tables weight_signatures.csv, soil_signatures.csv, ranking.csv and parameters.csv
// (each cell equal to the JSON's value of its column) through `out` (committed by the caller).
void writeDiagnosis(const Diagnosis& diagnosis, const DiagnosisSettings& settings, analysis::StagedOutput& out,
                    const analysis::GnuplotRenderer* renderer);

}  // namespace demfem::campaign
