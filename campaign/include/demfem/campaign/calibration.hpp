// demfem campaign: fitting study parameters to recordings with a bounded derivative-free optimiser
// (NLopt), the paper's calibration procedures as presets, and the outputs of `demfem calibrate`
// (docs/calibration.md).
//
// Contract
// - Problem: a study file (JSON, file units), its origin, measured recordings (their cases say which
//   model runs are needed; caseStudy() derives each case's study) and the parameters. Every case of
//   the recordings must be runnable by the study's kind, otherwise ArgumentError naming the case.
// - Objective: chi2 of objective.hpp over all cases of all recordings. A noisy objective with
//   `model_scatters_like_repeats` widens each measured sigma by the model's own seed scatter,
//   sigma' = sqrt(sigma^2 + s^2 / model_seeds), s the measured repeats' standard deviation: a model
//   of the same process scatters between deposition seeds as the process does between repeats, so
//   a fit, its curvature and its identification see the noise of both sides (a case measured once
//   has no s and is not widened). Residuals carry sigma'.
// - Optimiser (optimiser coordinates x in [0, 1]^n, parameters.hpp): `starts` starts, the first at
//   the study's own values (clamped into the bounds), the others at the points of a Halton
//   sequence; each a local NLopt run: BOBYQA (COBYLA for one parameter) for smooth objectives
//   (weight drops), Subplex for noisy ones (DEM, ObjectiveKind::Noisy); absolute x tolerance
//   `x_tolerance`, initial step 0.1, at most `max_evaluations`
//   per start. Cases of one evaluation (each at `model_seeds` deposition seeds for a soil study)
//   run concurrently on `jobs` threads, after Model::prepare() with the studies of those not in
//   the run cache.
// - Every model run goes through the RunCache in `cache_dir` (empty = none): a repeated or resumed
//   calibration reruns nothing already run; several processes may share one `cache_dir` (entries
//   are written by rename, each process runs in its own scratch directory). A run that fails with
//   adapter::CouplingError SimulationFailed (a DEM blow-up at an extreme value) is not cached, is
//   counted in failed_runs and its case's quantities are missing from that evaluation (scored as
//   objective.hpp says); every other failure is thrown.
// - Uncertainty: local curvature. The Gauss-Newton Hessian H = 2 J^T J of chi2 in optimiser
//   coordinates from central differences of the residuals (step `curvature_step`); covariance
//   2 H^-1 (Delta chi2 = 1 at one standard deviation); converted to file units (log parameters:
//   value * ln(hi / lo) * sigma_x).
// - Identification (Roessler et al. 2019): a parameter is "unidentified" when its standard deviation
//   exceeds `unidentified_fraction` of the bounds (in optimiser coordinates) or
//   `unidentified_relative` of its value, or H is singular along it (the data then bound it at most); it is then reported without a value (the calibrated study carries the best point
//   found, one of many that fit equally well). Distinct
//   minima: local minima of the starts whose chi2 is within `noise_chi2` of the best and that lie
//   more than three standard deviations apart in some parameter are all listed (non-unique fit).
// - Stop request: `stop_requested` is polled before each evaluation; the calibration then throws
//   Interrupted (the cache keeps every finished run).
#pragma once

#include "demfem/analysis/recording.hpp"
#include "demfem/analysis/staged_output.hpp"
#include "demfem/analysis/plot.hpp"
#include "demfem/campaign/model.hpp"
#include "demfem/campaign/objective.hpp"
#include "demfem/campaign/parameters.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace demfem::campaign {

enum class ObjectiveKind { Smooth, Noisy };

struct CalibrationProgress {
  int evaluation = 0, max_evaluations = 0;  // over all starts
  int start = 0, starts = 0;
  double best_chi2 = 0;
  double elapsed_s = 0, eta_s = 0;  // wall clock; eta from the evaluation budget left
};

struct CalibrationOptions {
  ObjectiveSettings objective;
  ObjectiveKind kind = ObjectiveKind::Smooth;
  int starts = 3;
  int max_evaluations = 150;  // per start
  double x_tolerance = 1e-5;
  double curvature_step = 1e-3;
  double unidentified_fraction = 0.25;
  double unidentified_relative = 0.3;
  double noise_chi2 = 1.0;
  int jobs = 2;
  // Soil-bin cases run with the stroke cut to objective.analysis.evaluation.window_end_mm when the
  // study's is longer: nothing after the window enters the objective (docs/calibration.md, "Cost").
  bool stroke_ends_with_window = false;
  // Soil studies: each case runs at this many deposition seeds (the study's and the next ones), the
  // runs pooled like measured repeats (objective.hpp): the model's seed scatter averages out as the
  // measured one does.
  int model_seeds = 1;
  // Noisy objectives: widen sigma by the model's seed scatter taken as the measured repeats' (see
  // the contract). Off where the model's scatter is measured instead (diagnose.hpp).
  bool model_scatters_like_repeats = true;
  std::filesystem::path cache_dir;
  std::function<void(const CalibrationProgress&)> on_progress;
  DepositionProgress on_deposit;  // the model's depositions before an evaluation (Model::prepare)
  std::function<bool()> stop_requested;
};

// The optimiser steps of a noisy (DEM) objective: x tolerance 0.02 and curvature step 0.05 of each
// parameter's bounds. A soil run is one realisation of a random packing: its window mean moves by a
// few percent between neighbouring parameter values for no physical reason, so smaller steps only
// resolve that noise (docs/calibration.md, "Optimiser").
inline void useNoisySteps(CalibrationOptions& options) {
  options.x_tolerance = 0.02;
  options.curvature_step = 0.05;
}

struct CalibrationProblem {
  nlohmann::ordered_json study;  // the study file's JSON
  std::string origin;            // the study file (messages, relative paths)
  std::vector<analysis::Recording> recordings;
  std::vector<ParameterSpec> parameters;
};

struct FittedParameter {
  ParameterSpec spec;
  double initial = 0;              // the study's value
  std::optional<double> value;     // absent: unidentified
  double best = 0;                 // the best point found (what the calibrated study carries)
  double std_dev = 0;              // file units (infinite when H is singular along it)
  // File units: the largest shift of the fit a model-form error of the objective's tolerance
  // (objective.hpp, model_form_relative), coherent over the residuals, makes (0 without one).
  double model_form_shift = 0;
  bool identified = true;
};

struct Minimum {
  std::vector<double> values;  // file units
  double chi2 = 0;
};

struct CalibrationResult {
  nlohmann::ordered_json calibrated_study;  // valid study file JSON: fitted values set
  std::vector<FittedParameter> parameters;
  std::vector<Residual> initial_residuals;  // at the study's own values
  std::vector<Residual> residuals;          // at the fit
  double initial_chi2 = 0, chi2 = 0;
  std::vector<Minimum> minima;              // distinct minima within noise_chi2 (>= 1: the best first)
  // Eigenvalues of J^T J at the fit (J: d residual.normalized / dx in optimiser coordinates), i.e.
  // the Gauss-Newton Hessian of -ln L = chi2 / 2: the Laplace evidence's curvature (diagnose.hpp).
  std::vector<double> curvature_eigenvalues;
  int evaluations = 0;                      // objective evaluations
  int model_runs = 0;                       // runs computed (not found in the cache)
  int cache_hits = 0;
  int failed_runs = 0;                      // DEM runs that failed (SimulationFailed): scored as missing quantities
  double wall_time_s = 0;
  // Measured recordings, and the model's recordings at the fit and at the start, per case (plots).
  std::vector<analysis::Recording> measured;
  std::vector<analysis::Recording> calibrated_runs;
  std::vector<analysis::Recording> initial_runs;
};

class Interrupted : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Fits problem.parameters (see contract). Throws ArgumentError for unusable input (unrunnable case,
// invalid parameters), Interrupted on a stop request.
CalibrationResult calibrate(const CalibrationProblem& problem, Model& model, const CalibrationOptions& options);

// Residuals of the study as it is against `recordings` (no fitting): the prediction error on
// held-out cases. Model runs go through the cache of options.cache_dir. `runs` receives the model's
// recordings (one per case) when not null.
std::vector<Residual> predict(const nlohmann::ordered_json& study, const std::string& origin,
                              const std::vector<analysis::Recording>& recordings, Model& model,
                              const CalibrationOptions& options, std::vector<analysis::Recording>* runs = nullptr);

// Presets (the paper's procedures, Section 2.10). A preset is a sequence of stages; each stage fits
// its parameters to the recordings of its cases, starting from the previous stage's calibrated study.
struct Stage {
  std::string title;                       // e.g. "depth 30 mm: layer 2 friction"
  std::vector<ParameterSpec> parameters;
  std::vector<analysis::CaseKey> cases;    // the recordings used (all if empty)
};

// `--preset weight-drop`: E_Pa (log, 0.25-4x the study's) and alpha_s (log, 1e-6-1e-2 s) of the
// study's first deformable tool, from every calibration-weight case of the recordings (the paper's
// 0.5 kg and 1 kg). Throws ArgumentError for a study that is not a weight-drop study or no weight case.
std::vector<Stage> weightDropPreset(const nlohmann::ordered_json& study, const std::vector<analysis::Recording>& recordings);

// `--preset layered-soil` (Section 2.10.2): depths of the soil-bin recordings ascending; at each
// depth the static and rolling friction (Table 4: the particle-particle interaction) of the
// material of the deepest layer the tool tip reaches, the shallower layers kept from the previous
// stage; static friction 0.05-1.5, rolling friction 0-0.5 (not fitted with contact.rolling =
// "none"). A depth whose deepest layer was fitted at a shallower depth adds no stage. Throws ArgumentError without soil-bin cases or for a study
// without soil.
std::vector<Stage> layeredSoilPreset(const nlohmann::ordered_json& study, const std::string& origin,
                                     const std::vector<analysis::Recording>& recordings);

struct StagedCalibration {
  std::vector<Stage> stages;
  std::vector<CalibrationResult> results;  // one per stage
  nlohmann::ordered_json calibrated_study;  // after the last stage
};

// Runs the stages in order (each through calibrate()).
StagedCalibration calibrateStages(const nlohmann::ordered_json& study, const std::string& origin,
                                  const std::vector<analysis::Recording>& recordings, const std::vector<Stage>& stages,
                                  Model& model, const CalibrationOptions& options);

// JSON (docs/calibration.md lists the keys): `fitted` (per pointer: value or null, std_dev,
// identified), `stages` (one object per row of stages.csv, each with its `cases`, its `parameters`
// and `residuals`, the rows of parameters.csv and residuals.csv of that stage, and its `minima`),
// totals of model_runs, cache_hits, evaluations and wall_time_s, and the objective in words.
// Numbers that are not finite are null.
nlohmann::json toJson(const StagedCalibration& calibration, const CalibrationOptions& options);

// Writes calibrated_study.json, report.md (objective stated, fitted values, uncertainty,
// residuals, identification, runs, wall time), the tables stages.csv (chi2, uniqueness, runs and
// wall time per stage), parameters.csv (per stage and parameter: bounds, initial, fitted value,
// standard deviation, identification, best point) and residuals.csv (per stage, case and quantity:
// measured, sigma, simulated and residual at the start and at the fit), each cell equal to the
// JSON's value of its column, and, unless renderer is null, plots/stage<k>_<case>.svg (measured
// against calibrated and initial) through `out` (committed by the caller).
void writeCalibration(const StagedCalibration& calibration, const CalibrationOptions& options,
                      analysis::StagedOutput& out, const analysis::GnuplotRenderer* renderer);

}  // namespace demfem::campaign
