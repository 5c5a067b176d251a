// demfem analysis: the `demfem evaluate` and `demfem compare` workflows, as library calls the thin
// executables run.
//
// Grouping: every recording's sidecar names its case (tool + depth_mm, or tool + mass_kg) and
// repeat; recordings of one case are pooled. compare() matches measured and simulated cases by
// key; a case present on one side only is listed in `unmatched_cases` and skipped.
//
// evaluate(): soil-bin runs -> Section 2.3 (evaluation.hpp), pooled per case; calibration-weight
// runs -> calibration factors applied, steady value / frequency / damping of force and
// deformation fitted to each whole record (step_response.hpp), pooled per case (mean of the
// repeats' fitted values; spread: cycle by cycle over all repeats, steady value between repeats).
//
// compare(): the simulated tool renamed as singleToolMatch() says, both sides evaluated as above,
// then per soil-bin case the percent difference of the
// pooled means 100 (sim - meas) / meas (Fig. 15), FFT amplitude spectra of the window segment of
// every run and least-squares power laws a f^b fitted to the pooled spectral points of each side
// over the common band (Section 3.6, Fig. 17) with the ratio of the fitted amplitudes; per
// calibration-weight case the differences of steady value, frequency and damping ratio (Fig. 8) and
// the correlation of each measured repeat with the first simulated run after aligning their first
// local maxima (Section 3.1, Fig. 7).
//
// write*(): CSV tables, per-run evaluated curves (calibrated format + sidecar, so they can be fed to
// compare again), SVG plots (unless renderer is null) and report.md, all through StagedOutput:
// nothing appears under its final name unless everything succeeded.
//
// JSON: toJson() gives the settings and, per report table, an array of one object per row keyed by
// the table's column names, the unit in each (`force_mean_N`, `frequency_mean_Hz`; docs/analysis.md):
// evaluate's `soil_bin_runs`, `soil_bin_cases`, `calibration_runs` and `calibration_cases`; compare's
// `means`, `spectra`, `calibration` and `correlations`, with `simulated_tool_matched_as` and
// `unmatched_cases`. Undefined values (e.g. a spread of one repeat) are null.
#pragma once

#include "demfem/analysis/evaluation.hpp"
#include "demfem/analysis/plot.hpp"
#include "demfem/analysis/recording.hpp"
#include "demfem/analysis/spectrum.hpp"
#include "demfem/analysis/staged_output.hpp"
#include "demfem/analysis/step_response.hpp"

#include <nlohmann/json.hpp>

#include <optional>
#include <vector>

namespace demfem::analysis {

struct AnalysisSettings {
  EvaluationSettings evaluation;
  StepResponseSettings step_response;
  // Band of the power-law fits; 0 / infinity mean "the common band of all spectra of the case":
  // from the largest lowest bin to the smallest Nyquist frequency.
  double fft_low_Hz = 0.0;
  double fft_high_Hz = std::numeric_limits<double>::infinity();
};

struct CalibrationRun {
  CaseKey key;
  int repeat = 1;
  std::filesystem::path source;
  std::vector<double> time_s;
  std::vector<double> force_N;
  std::vector<double> deformation_mm;
  StepResponse force;
  StepResponse deformation;
};

// Pooled step-response figures of one signal over the repeats of a case.
struct ResponseSummary {
  SignalStatistics steady;  // over the repeats' fitted steady values (std: between repeats)
  // mean: of the repeats' fitted values; std_dev and samples: over all cycles (decrements) of all
  // repeats, the spread Fig. 8 draws (NaN below two).
  SignalStatistics frequency_Hz;
  SignalStatistics damping_ratio;
};

struct CalibrationCase {
  CaseKey key;
  std::vector<int> repeats;
  ResponseSummary force;
  ResponseSummary deformation;
};

struct EvaluationResult {
  std::vector<EvaluatedRun> soil_bin_runs;
  std::vector<PooledCase> soil_bin_cases;
  std::vector<CalibrationRun> calibration_runs;
  std::vector<CalibrationCase> calibration_cases;
};

EvaluationResult evaluate(const std::vector<Recording>& recordings, const AnalysisSettings& settings);

struct SpectralComparison {
  std::vector<Spectrum> measured;  // one per repeat
  std::vector<Spectrum> simulated;
  PowerLawFit measured_fit;
  PowerLawFit simulated_fit;
  double amplitude_ratio_at_1Hz = 0.0;    // a_sim / a_meas
  double mean_fitted_ratio = 0.0;         // geometric mean of the fitted curves' ratio over the band
};

struct SoilBinComparison {
  CaseKey key;
  PooledCase measured;
  PooledCase simulated;
  double force_difference_percent = 0.0;
  double deformation_difference_percent = 0.0;
  SpectralComparison force_spectrum;
  SpectralComparison deformation_spectrum;
};

struct SignalCorrelation {
  int measured_repeat = 1;
  AlignedCorrelation force;
  AlignedCorrelation deformation;
};

struct CalibrationComparison {
  CaseKey key;
  CalibrationCase measured;
  CalibrationCase simulated;
  std::vector<SignalCorrelation> correlations;  // one per measured repeat, against the first simulated run
};

struct ComparisonResult {
  EvaluationResult measured;
  EvaluationResult simulated;
  std::vector<SoilBinComparison> soil_bin;
  std::vector<CalibrationComparison> calibration;
  std::vector<std::string> unmatched_cases;  // "PMMA, 42 mm depth (measured only)"
  // Set when the simulated tool was matched by case under the measured one (singleToolMatch).
  std::optional<std::pair<std::string, std::string>> simulated_tool_matched_as;  // {simulated name, measured name}
};

// A study with one tool matches recordings by their case: when the simulated recordings name one
// tool, the measured ones one other tool, the measured name (compare() then matches by depth_mm
// or mass_kg); nullopt when the names agree or either side names several tools (then the names
// must match, or the caller renames with readRecordings' tool_override).
std::optional<std::string> singleToolMatch(const std::vector<Recording>& measured, const std::vector<Recording>& simulated);

// Throws InputError when no case appears on both sides.
ComparisonResult compare(const std::vector<Recording>& measured, const std::vector<Recording>& simulated, const AnalysisSettings& settings);

// 100 (simulated - measured) / measured; NaN when measured is 0.
double percentDifference(double measured, double simulated);

nlohmann::json toJson(const EvaluationResult& result, const AnalysisSettings& settings);
nlohmann::json toJson(const ComparisonResult& result, const AnalysisSettings& settings);

// renderer == nullptr: no plots (the report says so).
void writeEvaluation(const EvaluationResult& result, const AnalysisSettings& settings, StagedOutput& out, const GnuplotRenderer* renderer);
void writeComparison(const ComparisonResult& result, const AnalysisSettings& settings, StagedOutput& out, const GnuplotRenderer* renderer);

}  // namespace demfem::analysis
