// JSON form of the evaluate / compare results: the settings, and one array per report section
// (report_sections.hpp) of one object per row keyed by the section's column names, units in the
// names; null for undefined values.
#include "demfem/analysis/workflow.hpp"

#include "report_sections.hpp"

#include <cmath>

namespace demfem::analysis {
namespace {

using nlohmann::json;

json number(double value) { return std::isfinite(value) ? json(value) : json(nullptr); }

json settingsJson(const AnalysisSettings& settings) {
  const auto& e = settings.evaluation;
  return {{"start_fractions", {e.start_low_fraction, e.start_high_fraction}},
          {"baseline_duration_s", e.baseline_duration_s},
          {"end_signal", e.end_signal == EndSignal::Force ? "force" : "deformation"},
          {"window_begin_mm", e.window_begin_mm},
          {"window_end_mm", e.window_end_mm},
          {"noise_band_factor", settings.step_response.noise_band_factor},
          {"fft_low_Hz", number(settings.fft_low_Hz)},
          {"fft_high_Hz", number(settings.fft_high_Hz)}};
}

}  // namespace

json toJson(const EvaluationResult& result, const AnalysisSettings& settings) {
  return {{"settings", settingsJson(settings)},
          {"soil_bin_runs", detail::soilBinRunsSection().json(result.soil_bin_runs)},
          {"soil_bin_cases", detail::soilBinCasesSection().json(result.soil_bin_cases)},
          {"calibration_runs", detail::calibrationRunsSection().json(detail::calibrationRunRows(result))},
          {"calibration_cases", detail::calibrationCasesSection().json(detail::calibrationCaseRows(result))}};
}

json toJson(const ComparisonResult& result, const AnalysisSettings& settings) {
  const auto& renamed = result.simulated_tool_matched_as;
  return {{"settings", settingsJson(settings)},
          {"simulated_tool_matched_as", renamed ? json{{"simulated", renamed->first}, {"measured", renamed->second}} : json(nullptr)},
          {"means", detail::meansSection().json(detail::meansRows(result))},
          {"spectra", detail::spectraSection().json(detail::spectrumRows(result))},
          {"calibration", detail::calibrationSection().json(detail::calibrationRows(result))},
          {"correlations", detail::correlationsSection().json(detail::correlationRows(result))},
          {"unmatched_cases", result.unmatched_cases}};
}

}  // namespace demfem::analysis
