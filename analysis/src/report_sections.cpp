// The columns of every report table (report_sections.hpp), with the unit in each name.
#include "report_sections.hpp"

#include <array>
#include <vector>

namespace demfem::analysis::detail {
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
       {"deformation_std_mm", [](const R& r) -> CellValue { return r.window.deformation_mm.std_dev; }}},
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
       {"deformation_difference_percent", [](R c) -> CellValue { return c->deformation_difference_percent; }}},
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
       {"mean_fitted_amplitude_ratio", [](const R& r) -> CellValue { return r.s->mean_fitted_ratio; }}},
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

}  // namespace demfem::analysis::detail
