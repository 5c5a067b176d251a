// The tables of the analysis reports (workflow_output.cpp writes their CSV and Markdown,
// workflow_json.cpp their JSON): each declared once, here, with the rows it is made of
// (demfem/analysis/report_section.hpp says how a section renders).
#pragma once

#include "demfem/analysis/report_section.hpp"
#include "demfem/analysis/workflow.hpp"

#include <string>
#include <vector>

namespace demfem::analysis::detail {

// One signal of one calibration-weight run.
struct ResponseRow {
  const CalibrationRun* run;
  std::string signal;
  const StepResponse* response;
};

// One signal (force_N or deformation_mm) of one soil-bin case's spectra.
struct SpectrumRow {
  const SoilBinComparison* c;
  std::string signal;
  const SpectralComparison* s;
};

// One signal (force_N or deformation_mm) of one calibration-weight case, measured against simulated.
struct CalibrationRow {
  const CalibrationComparison* c;
  std::string signal;
  const ResponseSummary* measured;
  const ResponseSummary* simulated;
  double correlation;  // mean over the measured repeats
};

// One signal (force_N or deformation_mm) of one calibration-weight case, repeats pooled.
struct CaseSummaryRow {
  const CalibrationCase* c;
  std::string signal;
  const ResponseSummary* summary;
};

// One measured repeat of a calibration-weight case correlated with the first simulated run.
struct CorrelationRow {
  const CalibrationComparison* c;
  const SignalCorrelation* correlation;
};

// demfem evaluate: soil_bin_runs.csv, soil_bin_cases.csv, calibration_runs.csv; the pooled
// calibration-weight cases in the JSON only.
const report::Section<EvaluatedRun>& soilBinRunsSection();
const report::Section<PooledCase>& soilBinCasesSection();
const report::Section<ResponseRow>& calibrationRunsSection();
const report::Section<CaseSummaryRow>& calibrationCasesSection();
// demfem compare: means.csv (Fig. 15), spectra.csv (Fig. 17), calibration.csv (Figs. 7, 8); the
// correlation of each measured repeat in the JSON only.
const report::Section<const SoilBinComparison*>& meansSection();
const report::Section<SpectrumRow>& spectraSection();
const report::Section<CalibrationRow>& calibrationSection();
const report::Section<CorrelationRow>& correlationsSection();

// The rows of those sections, in the order of the results; each signal's force_N row first for the
// runs, cases and spectra, deformation_mm first for calibration.csv.
std::vector<ResponseRow> calibrationRunRows(const EvaluationResult& result);
std::vector<CaseSummaryRow> calibrationCaseRows(const EvaluationResult& result);
std::vector<const SoilBinComparison*> meansRows(const ComparisonResult& result);
std::vector<SpectrumRow> spectrumRows(const ComparisonResult& result);
std::vector<CalibrationRow> calibrationRows(const ComparisonResult& result);
std::vector<CorrelationRow> correlationRows(const ComparisonResult& result);

}  // namespace demfem::analysis::detail
