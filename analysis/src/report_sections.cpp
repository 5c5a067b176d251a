// The columns of every report table (report_sections.hpp), with the unit in each name.
#include "report_sections.hpp"

#include <array>
#include <optional>
#include <utility>
#include <vector>

namespace demfem::analysis::detail {

using namespace report;

namespace {

// "a f^b" of the fit whose columns start with `side` (measured_ / simulated_).
MarkdownCell powerLaw(const std::string& side) {
  return md::concat({md::number(side + "a", 3), md::literal(" f^"), md::number(side + "b", 3)});
}

// The five columns of one statistic of the responses: measured mean and spread, simulated mean and
// spread, and the difference of the means in percent.
void addStatistic(std::vector<Column<CalibrationRow>>& columns, const std::array<std::string, 5>& names,
                  SignalStatistics ResponseSummary::*statistic) {
  using R = CalibrationRow;
  columns.push_back({names[0], [statistic](const R& r) -> CellValue { return (r.measured->*statistic).mean; }});
  columns.push_back({names[1], [statistic](const R& r) -> CellValue { return (r.measured->*statistic).std_dev; }});
  columns.push_back({names[2], [statistic](const R& r) -> CellValue { return (r.simulated->*statistic).mean; }});
  columns.push_back({names[3], [statistic](const R& r) -> CellValue { return (r.simulated->*statistic).std_dev; }});
  columns.push_back({names[4], [statistic](const R& r) -> CellValue {
                       return percentDifference((r.measured->*statistic).mean, (r.simulated->*statistic).mean);
                     }});
}

// "measured ± spread / simulated ± spread" of a statistic's first four columns.
MarkdownCell measuredSlashSimulated(const std::array<std::string, 5>& names) {
  return md::concat({md::plusMinus(names[0], names[1]), md::literal(" / "), md::plusMinus(names[2], names[3])});
}

// A Section 2.3 landmark of a raw run; absent for a calibrated run taken as it is.
std::optional<double> landmark(const EvaluatedRun& r, double value) {
  return r.section_2_3_applied ? std::optional<double>(value) : std::nullopt;
}

// A statistic of the window's tip tilt; absent when the recording has no tilt.
std::optional<double> tilt(const EvaluatedRun& r, double SignalStatistics::*statistic) {
  return r.window.tilt_deg ? std::optional<double>((*r.window.tilt_deg).*statistic) : std::nullopt;
}

// The number of cycles (or decrements) behind a pooled statistic.
CellValue cycles(const SignalStatistics& s) { return static_cast<long long>(s.samples); }

// The two signals of a calibration-weight record, in the order of the runs' tables.
template <class Summary>
std::array<std::pair<std::string, const Summary*>, 2> bothSignals(const Summary& force, const Summary& deformation) {
  return {{{"force_N", &force}, {"deformation_mm", &deformation}}};
}

}  // namespace

// --- evaluation sections: soil-bin runs and cases, calibration-weight runs ---

const Section<EvaluatedRun>& soilBinRunsSection() {
  using R = EvaluatedRun;
  static const Section<R> section{
      {{"case", [](const R& r) -> CellValue { return r.key.label(); }},
       {"tool", [](const R& r) -> CellValue { return r.key.tool; }},
       {"depth_mm", [](const R& r) -> CellValue { return r.key.depth_mm; }},
       {"repeat", [](const R& r) -> CellValue { return static_cast<long long>(r.repeat); }},
       {"source", [](const R& r) -> CellValue { return r.source.string(); }},
       {"section_2_3_applied", [](const R& r) -> CellValue { return r.section_2_3_applied; }},
       {"start_time_s", [](const R& r) -> CellValue { return r.start_time_s; }},
       {"end_time_s", [](const R& r) -> CellValue { return r.end_time_s; }},
       {"samples", [](const R& r) -> CellValue { return static_cast<long long>(r.curve.size()); }},
       {"force_mean_N", [](const R& r) -> CellValue { return r.window.force_N.mean; }},
       {"force_std_N", [](const R& r) -> CellValue { return r.window.force_N.std_dev; }},
       {"deformation_mean_mm", [](const R& r) -> CellValue { return r.window.deformation_mm.mean; }},
       {"deformation_std_mm", [](const R& r) -> CellValue { return r.window.deformation_mm.std_dev; }},
       {"window_samples", [](const R& r) -> CellValue { return static_cast<long long>(r.window.force_N.samples); }, Output::JsonOnly},
       {"initial_deformation_mm", [](const R& r) -> CellValue { return landmark(r, r.initial_deformation_mm); }, Output::JsonOnly},
       {"max_deformation_mm", [](const R& r) -> CellValue { return landmark(r, r.max_deformation_mm); }, Output::JsonOnly},
       {"tilt_mean_deg", [](const R& r) -> CellValue { return tilt(r, &SignalStatistics::mean); }, Output::JsonOnly},
       {"tilt_std_deg", [](const R& r) -> CellValue { return tilt(r, &SignalStatistics::std_dev); }, Output::JsonOnly}},
      [](const R& r) { return r.key.title(); },
      {{"repeat", md::text("repeat")},
       {"start (s)", md::onlyIf("section_2_3_applied", md::number("start_time_s"))},
       {"end (s)", md::onlyIf("section_2_3_applied", md::number("end_time_s"))},
       {"force (N)", md::plusMinus("force_mean_N", "force_std_N")},
       {"deformation (mm)", md::plusMinus("deformation_mean_mm", "deformation_std_mm")}}};
  return section;
}

const Section<PooledCase>& soilBinCasesSection() {
  using R = PooledCase;
  static const Section<R> section{
      {{"case", [](const R& c) -> CellValue { return c.key.label(); }},
       {"tool", [](const R& c) -> CellValue { return c.key.tool; }},
       {"depth_mm", [](const R& c) -> CellValue { return c.key.depth_mm; }},
       {"repeats", [](const R& c) -> CellValue { return static_cast<long long>(c.repeats.size()); }},
       {"force_mean_N", [](const R& c) -> CellValue { return c.force_mean_N; }},
       {"force_std_N", [](const R& c) -> CellValue { return c.force_std_N; }},
       {"force_between_repeats_std_N", [](const R& c) -> CellValue { return c.force_between_repeats_std_N; }},
       {"deformation_mean_mm", [](const R& c) -> CellValue { return c.deformation_mean_mm; }},
       {"deformation_std_mm", [](const R& c) -> CellValue { return c.deformation_std_mm; }},
       {"deformation_between_repeats_std_mm", [](const R& c) -> CellValue { return c.deformation_between_repeats_std_mm; }}},
      [](const R& c) { return c.key.title(); },
      {{"repeats", md::text("repeats")},
       {"force (N)", md::plusMinus("force_mean_N", "force_std_N")},
       {"force spread (N)", md::number("force_between_repeats_std_N", 3)},
       {"deformation (mm)", md::plusMinus("deformation_mean_mm", "deformation_std_mm")},
       {"deformation spread (mm)", md::number("deformation_between_repeats_std_mm", 3)}}};
  return section;
}


const Section<ResponseRow>& calibrationRunsSection() {
  using R = ResponseRow;
  static const Section<R> section{
      {{"case", [](const R& r) -> CellValue { return r.run->key.label(); }},
       {"tool", [](const R& r) -> CellValue { return r.run->key.tool; }},
       {"mass_kg", [](const R& r) -> CellValue { return r.run->key.mass_kg; }},
       {"repeat", [](const R& r) -> CellValue { return static_cast<long long>(r.run->repeat); }},
       {"source", [](const R& r) -> CellValue { return r.run->source.string(); }},
       {"signal", [](const R& r) -> CellValue { return r.signal; }},
       {"steady_value", [](const R& r) -> CellValue { return r.response->fit.steady; }},
       {"steady_error", [](const R& r) -> CellValue { return r.response->fit.steady_error; }},
       {"frequency_Hz", [](const R& r) -> CellValue { return r.response->fit.frequency_Hz; }},
       {"frequency_error_Hz", [](const R& r) -> CellValue { return r.response->fit.frequency_error_Hz; }},
       {"frequency_cycle_std_Hz", [](const R& r) -> CellValue { return r.response->cycle_frequency_std_Hz; }},
       {"periods", [](const R& r) -> CellValue { return static_cast<long long>(r.response->cycle_frequencies_Hz.size()); }},
       {"damping_ratio", [](const R& r) -> CellValue { return r.response->fit.damping_ratio; }},
       {"damping_ratio_error", [](const R& r) -> CellValue { return r.response->fit.damping_ratio_error; }},
       {"damping_ratio_cycle_std", [](const R& r) -> CellValue { return r.response->cycle_damping_ratio_std; }},
       {"decrements", [](const R& r) -> CellValue { return static_cast<long long>(r.response->cycle_damping_ratios.size()); }},
       {"residual_rms", [](const R& r) -> CellValue { return r.response->fit.residual_rms; }},
       {"step_time_s", [](const R& r) -> CellValue { return r.response->fit.step_time_s; }},
       {"initial_value", [](const R& r) -> CellValue { return r.response->fit.initial; }, Output::JsonOnly},
       {"first_peak_time_s", [](const R& r) -> CellValue { return r.response->first_peak_time_s; }}},
      [](const R& r) { return r.run->key.title(); },
      {{"repeat", md::text("repeat")},
       {"signal", md::text("signal")},
       {"steady value", md::number("steady_value")},
       {"frequency (Hz)",
        md::concat({md::plusMinus("frequency_Hz", "frequency_cycle_std_Hz"), md::literal(" ("), md::text("periods"), md::literal(")")})},
       {"damping ratio", md::concat({md::plusMinus("damping_ratio", "damping_ratio_cycle_std"), md::literal(" ("),
                                     md::text("decrements"), md::literal(")")})}}};
  return section;
}

// --- soil-bin section: means (Fig. 15) and spectra (Fig. 17) ---

const Section<const SoilBinComparison*>& meansSection() {
  using R = const SoilBinComparison*;
  static const Section<R> section{
      {{"case", [](R c) -> CellValue { return c->key.label(); }},
       {"tool", [](R c) -> CellValue { return c->key.tool; }},
       {"depth_mm", [](R c) -> CellValue { return c->key.depth_mm; }},
       {"measured_force_mean_N", [](R c) -> CellValue { return c->measured.force_mean_N; }},
       {"measured_force_std_N", [](R c) -> CellValue { return c->measured.force_std_N; }},
       {"simulated_force_mean_N", [](R c) -> CellValue { return c->simulated.force_mean_N; }},
       {"simulated_force_std_N", [](R c) -> CellValue { return c->simulated.force_std_N; }},
       {"force_difference_percent", [](R c) -> CellValue { return c->force_difference_percent; }},
       {"measured_deformation_mean_mm", [](R c) -> CellValue { return c->measured.deformation_mean_mm; }},
       {"measured_deformation_std_mm", [](R c) -> CellValue { return c->measured.deformation_std_mm; }},
       {"simulated_deformation_mean_mm", [](R c) -> CellValue { return c->simulated.deformation_mean_mm; }},
       {"simulated_deformation_std_mm", [](R c) -> CellValue { return c->simulated.deformation_std_mm; }},
       {"deformation_difference_percent", [](R c) -> CellValue { return c->deformation_difference_percent; }},
       {"measured_repeats", [](R c) -> CellValue { return static_cast<long long>(c->measured.repeats.size()); }, Output::JsonOnly},
       {"simulated_repeats", [](R c) -> CellValue { return static_cast<long long>(c->simulated.repeats.size()); }, Output::JsonOnly},
       {"measured_force_between_repeats_std_N", [](R c) -> CellValue { return c->measured.force_between_repeats_std_N; }, Output::JsonOnly},
       {"simulated_force_between_repeats_std_N", [](R c) -> CellValue { return c->simulated.force_between_repeats_std_N; }, Output::JsonOnly},
       {"measured_deformation_between_repeats_std_mm",
        [](R c) -> CellValue { return c->measured.deformation_between_repeats_std_mm; }, Output::JsonOnly},
       {"simulated_deformation_between_repeats_std_mm",
        [](R c) -> CellValue { return c->simulated.deformation_between_repeats_std_mm; }, Output::JsonOnly}},
      [](R c) { return c->key.title(); },
      {{"measured force (N)", md::plusMinus("measured_force_mean_N", "measured_force_std_N")},
       {"simulated force (N)", md::plusMinus("simulated_force_mean_N", "simulated_force_std_N")},
       {"force diff. (%)", md::number("force_difference_percent", 3)},
       {"measured deformation (mm)", md::plusMinus("measured_deformation_mean_mm", "measured_deformation_std_mm")},
       {"simulated deformation (mm)", md::plusMinus("simulated_deformation_mean_mm", "simulated_deformation_std_mm")},
       {"deformation diff. (%)", md::number("deformation_difference_percent", 3)}}};
  return section;
}


const Section<SpectrumRow>& spectraSection() {
  using R = SpectrumRow;
  static const Section<R> section{
      {{"case", [](const R& r) -> CellValue { return r.c->key.label(); }},
       {"signal", [](const R& r) -> CellValue { return r.signal; }},
       {"f_low_Hz", [](const R& r) -> CellValue { return r.s->measured_fit.f_low_Hz; }},
       {"f_high_Hz", [](const R& r) -> CellValue { return r.s->measured_fit.f_high_Hz; }},
       {"measured_a", [](const R& r) -> CellValue { return r.s->measured_fit.a; }},
       {"measured_b", [](const R& r) -> CellValue { return r.s->measured_fit.b; }},
       {"measured_b_std_error", [](const R& r) -> CellValue { return r.s->measured_fit.b_std_error; }},
       {"simulated_a", [](const R& r) -> CellValue { return r.s->simulated_fit.a; }},
       {"simulated_b", [](const R& r) -> CellValue { return r.s->simulated_fit.b; }},
       {"simulated_b_std_error", [](const R& r) -> CellValue { return r.s->simulated_fit.b_std_error; }},
       {"amplitude_ratio_at_1Hz", [](const R& r) -> CellValue { return r.s->amplitude_ratio_at_1Hz; }},
       {"mean_fitted_amplitude_ratio", [](const R& r) -> CellValue { return r.s->mean_fitted_ratio; }},
       {"tool", [](const R& r) -> CellValue { return r.c->key.tool; }, Output::JsonOnly},
       {"depth_mm", [](const R& r) -> CellValue { return r.c->key.depth_mm; }, Output::JsonOnly},
       {"measured_log10_a_std_error", [](const R& r) -> CellValue { return r.s->measured_fit.log10_a_std_error; }, Output::JsonOnly},
       {"measured_r_squared_log", [](const R& r) -> CellValue { return r.s->measured_fit.r_squared_log; }, Output::JsonOnly},
       {"measured_points", [](const R& r) -> CellValue { return static_cast<long long>(r.s->measured_fit.points); }, Output::JsonOnly},
       {"simulated_log10_a_std_error", [](const R& r) -> CellValue { return r.s->simulated_fit.log10_a_std_error; }, Output::JsonOnly},
       {"simulated_r_squared_log", [](const R& r) -> CellValue { return r.s->simulated_fit.r_squared_log; }, Output::JsonOnly},
       {"simulated_points", [](const R& r) -> CellValue { return static_cast<long long>(r.s->simulated_fit.points); }, Output::JsonOnly}},
      [](const R& r) { return r.c->key.title(); },
      {{"signal", md::text("signal")},
       {"band (Hz)", md::concat({md::number("f_low_Hz", 3), md::literal("-"), md::number("f_high_Hz", 3)})},
       {"measured fit", powerLaw("measured_")},
       {"simulated fit", powerLaw("simulated_")},
       {"ratio", md::number("mean_fitted_amplitude_ratio", 3)}}};
  return section;
}

// --- calibration section (Section 3.1, Figs. 7, 8) ---


const Section<CalibrationRow>& calibrationSection() {
  using R = CalibrationRow;
  static const std::array<std::string, 5> steady{"measured_steady_value", "measured_steady_std", "simulated_steady_value",
                                                 "simulated_steady_std", "steady_value_difference_percent"};
  static const std::array<std::string, 5> frequency{"measured_frequency_mean_Hz", "measured_frequency_std_Hz", "simulated_frequency_mean_Hz",
                                                    "simulated_frequency_std_Hz", "frequency_difference_percent"};
  static const std::array<std::string, 5> damping{"measured_damping_ratio_mean", "measured_damping_ratio_std", "simulated_damping_ratio_mean",
                                                  "simulated_damping_ratio_std", "damping_ratio_difference_percent"};
  static const Section<R> section = [] {
    std::vector<Column<R>> c{{"case", [](const R& r) -> CellValue { return r.c->key.label(); }},
                                     {"signal", [](const R& r) -> CellValue { return r.signal; }}};
    addStatistic(c, steady, &ResponseSummary::steady);
    addStatistic(c, frequency, &ResponseSummary::frequency_Hz);
    addStatistic(c, damping, &ResponseSummary::damping_ratio);
    c.push_back({"correlation_mean", [](const R& r) -> CellValue { return r.correlation; }});
    c.push_back({"tool", [](const R& r) -> CellValue { return r.c->key.tool; }, Output::JsonOnly});
    c.push_back({"mass_kg", [](const R& r) -> CellValue { return r.c->key.mass_kg; }, Output::JsonOnly});
    c.push_back({"measured_frequency_cycles", [](const R& r) -> CellValue { return cycles(r.measured->frequency_Hz); }, Output::JsonOnly});
    c.push_back({"simulated_frequency_cycles", [](const R& r) -> CellValue { return cycles(r.simulated->frequency_Hz); }, Output::JsonOnly});
    c.push_back({"measured_damping_decrements", [](const R& r) -> CellValue { return cycles(r.measured->damping_ratio); }, Output::JsonOnly});
    c.push_back({"simulated_damping_decrements", [](const R& r) -> CellValue { return cycles(r.simulated->damping_ratio); }, Output::JsonOnly});
    return Section<R>{
        std::move(c),
        [](const R& r) { return r.c->key.title(); },
        {{"signal", md::text("signal")},
         {"steady value", md::concat({md::number(steady[0]), md::literal(" / "), md::number(steady[2])})},
         {"frequency (Hz)", measuredSlashSimulated(frequency)},
         {"damping ratio", measuredSlashSimulated(damping)},
         {"correlation", md::number("correlation_mean", 3)}}};
  }();
  return section;
}

// --- JSON-only sections: pooled calibration-weight cases, correlations (Section 3.1) ---

const Section<CaseSummaryRow>& calibrationCasesSection() {
  using R = CaseSummaryRow;
  static const Section<R> section{
      {{"case", [](const R& r) -> CellValue { return r.c->key.label(); }},
       {"tool", [](const R& r) -> CellValue { return r.c->key.tool; }},
       {"mass_kg", [](const R& r) -> CellValue { return r.c->key.mass_kg; }},
       {"repeats", [](const R& r) -> CellValue { return static_cast<long long>(r.c->repeats.size()); }},
       {"signal", [](const R& r) -> CellValue { return r.signal; }},
       {"steady_value_mean", [](const R& r) -> CellValue { return r.summary->steady.mean; }},
       {"steady_value_std", [](const R& r) -> CellValue { return r.summary->steady.std_dev; }},
       {"frequency_mean_Hz", [](const R& r) -> CellValue { return r.summary->frequency_Hz.mean; }},
       {"frequency_std_Hz", [](const R& r) -> CellValue { return r.summary->frequency_Hz.std_dev; }},
       {"frequency_cycles", [](const R& r) -> CellValue { return cycles(r.summary->frequency_Hz); }},
       {"damping_ratio_mean", [](const R& r) -> CellValue { return r.summary->damping_ratio.mean; }},
       {"damping_ratio_std", [](const R& r) -> CellValue { return r.summary->damping_ratio.std_dev; }},
       {"damping_decrements", [](const R& r) -> CellValue { return cycles(r.summary->damping_ratio); }}},
      [](const R& r) { return r.c->key.title(); },
      {}};
  return section;
}

const Section<CorrelationRow>& correlationsSection() {
  using R = CorrelationRow;
  static const Section<R> section{
      {{"case", [](const R& r) -> CellValue { return r.c->key.label(); }},
       {"measured_repeat", [](const R& r) -> CellValue { return static_cast<long long>(r.correlation->measured_repeat); }},
       {"force_correlation", [](const R& r) -> CellValue { return r.correlation->force.correlation; }},
       {"force_shift_s", [](const R& r) -> CellValue { return r.correlation->force.shift_s; }},
       {"deformation_correlation", [](const R& r) -> CellValue { return r.correlation->deformation.correlation; }},
       {"deformation_shift_s", [](const R& r) -> CellValue { return r.correlation->deformation.shift_s; }}},
      [](const R& r) { return r.c->key.title(); },
      {}};
  return section;
}

// --- the rows ---

std::vector<ResponseRow> calibrationRunRows(const EvaluationResult& result) {
  std::vector<ResponseRow> rows;
  for (const auto& r : result.calibration_runs)
    for (const auto& [signal, response] : bothSignals(r.force, r.deformation)) rows.push_back({&r, signal, response});
  return rows;
}

std::vector<CaseSummaryRow> calibrationCaseRows(const EvaluationResult& result) {
  std::vector<CaseSummaryRow> rows;
  for (const auto& c : result.calibration_cases)
    for (const auto& [signal, summary] : bothSignals(c.force, c.deformation)) rows.push_back({&c, signal, summary});
  return rows;
}

std::vector<const SoilBinComparison*> meansRows(const ComparisonResult& result) {
  std::vector<const SoilBinComparison*> rows;
  for (const auto& c : result.soil_bin) rows.push_back(&c);
  return rows;
}

std::vector<SpectrumRow> spectrumRows(const ComparisonResult& result) {
  std::vector<SpectrumRow> rows;
  for (const auto& c : result.soil_bin)
    for (const auto& [signal, spectrum] : bothSignals(c.force_spectrum, c.deformation_spectrum)) rows.push_back({&c, signal, spectrum});
  return rows;
}

// Deformation first, then force (the order of calibration.csv); the correlation is the mean over
// the measured repeats.
std::vector<CalibrationRow> calibrationRows(const ComparisonResult& result) {
  std::vector<CalibrationRow> rows;
  for (const auto& c : result.calibration)
    for (const bool is_force : {false, true}) {
      double correlation = 0.0;
      for (const auto& corr : c.correlations) correlation += (is_force ? corr.force : corr.deformation).correlation;
      correlation /= static_cast<double>(c.correlations.size());
      rows.push_back({&c, is_force ? "force_N" : "deformation_mm", is_force ? &c.measured.force : &c.measured.deformation,
                      is_force ? &c.simulated.force : &c.simulated.deformation, correlation});
    }
  return rows;
}

std::vector<CorrelationRow> correlationRows(const ComparisonResult& result) {
  std::vector<CorrelationRow> rows;
  for (const auto& c : result.calibration)
    for (const auto& corr : c.correlations) rows.push_back({&c, &corr});
  return rows;
}

}  // namespace demfem::analysis::detail
