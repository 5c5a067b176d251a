// JSON form of the evaluate / compare results: units in every key name, null for undefined values.
#include "demfem/analysis/workflow.hpp"

#include "report_sections.hpp"

#include <cmath>

namespace demfem::analysis {
namespace {

using nlohmann::json;

json number(double value) { return std::isfinite(value) ? json(value) : json(nullptr); }

json caseJson(const CaseKey& key) {
  json j{{"tool", key.tool}, {"label", key.label()}};
  if (key.kind == CaseKind::SoilBin) j["depth_mm"] = key.depth_mm;
  else j["mass_kg"] = key.mass_kg;
  return j;
}

json statsJson(const SignalStatistics& s, const std::string& unit) {
  return {{"mean_" + unit, number(s.mean)}, {"std_" + unit, number(s.std_dev)}, {"samples", s.samples}};
}

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

json runJson(const EvaluatedRun& run) {
  json j = caseJson(run.key);
  j["repeat"] = run.repeat;
  j["source"] = run.source.string();
  j["section_2_3_applied"] = run.section_2_3_applied;
  if (run.section_2_3_applied) {
    j["start_time_s"] = run.start_time_s;
    j["end_time_s"] = run.end_time_s;
    j["initial_deformation_mm"] = run.initial_deformation_mm;
    j["max_deformation_mm"] = run.max_deformation_mm;
  }
  j["samples"] = run.curve.size();
  j["window_force"] = statsJson(run.window.force_N, "N");
  j["window_deformation"] = statsJson(run.window.deformation_mm, "mm");
  if (run.window.tilt_deg) j["window_tilt"] = statsJson(*run.window.tilt_deg, "deg");
  return j;
}

// The case, its repeats and the numbers of its row of soil_bin_cases.csv.
json pooledJson(const PooledCase& c) {
  json j = caseJson(c.key);
  j.update(detail::soilBinCasesSection().values(c).json({"case", "tool", "depth_mm", "repeats"}));
  j["repeats"] = c.repeats;
  return j;
}

json responseJson(const StepResponse& r, const std::string& unit) {
  const StepResponseFit& f = r.fit;
  return {{"steady_value_" + unit, number(f.steady)},
          {"steady_error_" + unit, number(f.steady_error)},
          {"initial_value_" + unit, number(f.initial)},
          {"step_time_s", number(f.step_time_s)},
          {"frequency_Hz", number(f.frequency_Hz)},
          {"frequency_error_Hz", number(f.frequency_error_Hz)},
          {"frequency_cycle_std_Hz", number(r.cycle_frequency_std_Hz)},
          {"damping_ratio", number(f.damping_ratio)},
          {"damping_ratio_error", number(f.damping_ratio_error)},
          {"damping_ratio_cycle_std", number(r.cycle_damping_ratio_std)},
          {"residual_rms_" + unit, number(f.residual_rms)},
          {"periods", r.cycle_frequencies_Hz.size()},
          {"decrements", r.cycle_damping_ratios.size()},
          {"first_peak_time_s", number(r.first_peak_time_s)}};
}

json summaryJson(const ResponseSummary& s, const std::string& unit) {
  return {{"steady_value_mean_" + unit, number(s.steady.mean)},   {"steady_value_std_" + unit, number(s.steady.std_dev)},
          {"frequency_mean_Hz", number(s.frequency_Hz.mean)},      {"frequency_std_Hz", number(s.frequency_Hz.std_dev)},
          {"frequency_cycles", s.frequency_Hz.samples},            {"damping_ratio_mean", number(s.damping_ratio.mean)},
          {"damping_ratio_std", number(s.damping_ratio.std_dev)}, {"damping_decrements", s.damping_ratio.samples}};
}

json calibrationCaseJson(const CalibrationCase& c) {
  json j = caseJson(c.key);
  j["repeats"] = c.repeats;
  j["force"] = summaryJson(c.force, "N");
  j["deformation"] = summaryJson(c.deformation, "mm");
  return j;
}

json fitJson(const PowerLawFit& fit, const std::string& unit) {
  return {{"a_" + unit + "_at_1Hz", number(fit.a)}, {"b", number(fit.b)}, {"log10_a_std_error", number(fit.log10_a_std_error)},
          {"b_std_error", number(fit.b_std_error)}, {"r_squared_log", number(fit.r_squared_log)}, {"points", fit.points},
          {"f_low_Hz", number(fit.f_low_Hz)},       {"f_high_Hz", number(fit.f_high_Hz)}};
}

json spectralJson(const SpectralComparison& s, const std::string& unit) {
  return {{"measured_fit", fitJson(s.measured_fit, unit)},
          {"simulated_fit", fitJson(s.simulated_fit, unit)},
          {"amplitude_ratio_at_1Hz", number(s.amplitude_ratio_at_1Hz)},
          {"mean_fitted_amplitude_ratio", number(s.mean_fitted_ratio)}};
}

// The percent differences of one signal's row of calibration.csv.
json differencesJson(const CalibrationComparison& c, const ResponseSummary& m, const ResponseSummary& s) {
  const detail::CalibrationRow row{&c, "", &m, &s, std::nan("")};
  return detail::calibrationSection().values(row).jsonEndingWith("_difference_percent");
}

}  // namespace

json toJson(const EvaluationResult& result, const AnalysisSettings& settings) {
  json j;
  j["settings"] = settingsJson(settings);
  j["soil_bin_runs"] = json::array();
  for (const auto& r : result.soil_bin_runs) j["soil_bin_runs"].push_back(runJson(r));
  j["soil_bin_cases"] = json::array();
  for (const auto& c : result.soil_bin_cases) j["soil_bin_cases"].push_back(pooledJson(c));
  j["calibration_runs"] = json::array();
  for (const auto& r : result.calibration_runs) {
    json run = caseJson(r.key);
    run["repeat"] = r.repeat;
    run["source"] = r.source.string();
    run["force"] = responseJson(r.force, "N");
    run["deformation"] = responseJson(r.deformation, "mm");
    j["calibration_runs"].push_back(run);
  }
  j["calibration_cases"] = json::array();
  for (const auto& c : result.calibration_cases) j["calibration_cases"].push_back(calibrationCaseJson(c));
  return j;
}

json toJson(const ComparisonResult& result, const AnalysisSettings& settings) {
  json j;
  j["settings"] = settingsJson(settings);
  j["simulated_tool_matched_as"] = result.simulated_tool_matched_as
                                       ? json{{"simulated", result.simulated_tool_matched_as->first},
                                              {"measured", result.simulated_tool_matched_as->second}}
                                       : json(nullptr);
  j["soil_bin_cases"] = json::array();
  for (const auto& c : result.soil_bin) {
    json item = caseJson(c.key);
    item["measured"] = pooledJson(c.measured);
    item["simulated"] = pooledJson(c.simulated);
    item["force_mean_difference_percent"] = number(c.force_difference_percent);
    item["deformation_mean_difference_percent"] = number(c.deformation_difference_percent);
    item["force_spectrum"] = spectralJson(c.force_spectrum, "N");
    item["deformation_spectrum"] = spectralJson(c.deformation_spectrum, "mm");
    j["soil_bin_cases"].push_back(item);
  }
  j["calibration_cases"] = json::array();
  for (const auto& c : result.calibration) {
    json item = caseJson(c.key);
    item["measured"] = calibrationCaseJson(c.measured);
    item["simulated"] = calibrationCaseJson(c.simulated);
    item["force_differences"] = differencesJson(c, c.measured.force, c.simulated.force);
    item["deformation_differences"] = differencesJson(c, c.measured.deformation, c.simulated.deformation);
    item["correlations"] = json::array();
    for (const auto& corr : c.correlations)
      item["correlations"].push_back({{"measured_repeat", corr.measured_repeat},
                                      {"force_correlation", number(corr.force.correlation)},
                                      {"force_shift_s", number(corr.force.shift_s)},
                                      {"deformation_correlation", number(corr.deformation.correlation)},
                                      {"deformation_shift_s", number(corr.deformation.shift_s)}});
    j["calibration_cases"].push_back(item);
  }
  j["unmatched_cases"] = result.unmatched_cases;
  return j;
}

}  // namespace demfem::analysis
