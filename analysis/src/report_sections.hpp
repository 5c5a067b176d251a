// The tables of the analysis reports (workflow_output.cpp writes their CSV and Markdown,
// workflow_json.cpp takes JSON objects of their columns): each declared once, here
// (report_section.hpp says how a section renders).
#pragma once

#include "demfem/analysis/workflow.hpp"

#include "report_section.hpp"

#include <string>

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

// demfem evaluate: soil_bin_runs.csv, soil_bin_cases.csv, calibration_runs.csv.
const Section<EvaluatedRun>& soilBinRunsSection();
const Section<PooledCase>& soilBinCasesSection();
const Section<ResponseRow>& calibrationRunsSection();
// demfem compare: means.csv (Fig. 15), spectra.csv (Fig. 17), calibration.csv (Figs. 7, 8).
const Section<const SoilBinComparison*>& meansSection();
const Section<SpectrumRow>& spectraSection();
const Section<CalibrationRow>& calibrationSection();

}  // namespace demfem::analysis::detail
