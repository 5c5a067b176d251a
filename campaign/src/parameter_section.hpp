// The report table of fitted parameters, shared by calibrate's report (one row per parameter of a
// stage, report.cpp) and diagnose's (one row per parameter of a cause's fit, diagnose_report.cpp);
// demfem/analysis/report_section.hpp says how a section renders.
#pragma once

#include "demfem/analysis/report_section.hpp"
#include "demfem/campaign/calibration.hpp"

#include <string>
#include <vector>

namespace demfem::campaign {

struct ParameterRow {
  analysis::report::CellValue owner;  // the stage's number or the cause's id
  const FittedParameter* parameter;
};

// Columns: `owner_column` (the row's owner), pointer, label, lo, hi, log, initial, value (null when
// unidentified), std_dev, identified, best_point, all in the study file's units. Markdown: the
// pointer, initial, fitted value (or "unidentified"), standard deviation, bounds.
analysis::report::Section<ParameterRow> parameterSection(const std::string& owner_column);

std::vector<ParameterRow> parameterRows(const analysis::report::CellValue& owner, const std::vector<FittedParameter>& parameters);

}  // namespace demfem::campaign
