// Files written by `demfem evaluate` and `demfem compare`: tables (CSV), evaluated curves, SVG plots
// and the Markdown report, all staged (see staged_output.hpp).
#include "demfem/analysis/workflow.hpp"

#include "group_by_case.hpp"
#include "report_sections.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <sstream>

namespace demfem::analysis {
namespace {

using nlohmann::json;

using namespace detail;
using namespace report;

std::string runName(const CaseKey& key, int repeat) { return key.label() + "_r" + std::to_string(repeat); }

std::string curveCsv(const DisplacementCurve& c) {
  std::vector<std::string> header{"t_s", "displacement_mm", "force_N", "deformation_mm"};
  if (!c.tilt_deg.empty()) header.push_back("tilt_deg");
  std::vector<std::vector<std::string>> rows;
  for (std::size_t i = 0; i < c.size(); ++i) {
    rows.push_back({num(c.time_s[i]), num(c.displacement_mm[i]), num(c.force_N[i]), num(c.deformation_mm[i])});
    if (!c.tilt_deg.empty()) rows.back().push_back(num(c.tilt_deg[i]));
  }
  return csvTable(header, rows);
}

// Renders `figure` to plots/<name>.svg (+ .gp) when a renderer is given; returns the Markdown
// image line (empty without renderer).
std::string plot(StagedOutput& out, const GnuplotRenderer* renderer, const std::string& name, const Figure& figure) {
  if (!renderer) return {};
  const std::string svg = "plots/" + name + ".svg";
  const auto script_path = out.stage("plots/" + name + ".gp");
  const auto svg_path = out.stage(svg);
  renderer->render(figure, script_path, svg_path);
  return "![" + figure.title + "](" + svg + ")\n\n";
}

Series line(std::string title, std::vector<double> x, std::vector<double> y, const char* color, SeriesStyle style = SeriesStyle::Line,
            double width = 1.5) {
  return Series{std::move(title), std::move(x), std::move(y), color, style, width};
}

// Force and deformation against displacement (Figs. 9, 14): repeats thin, the pooled mean bold;
// optionally a simulated case beside it.
Figure curvesFigure(const CaseKey& key, const std::vector<const EvaluatedRun*>& runs, const PooledCase& pooled,
                    const std::vector<const EvaluatedRun*>* simulated_runs, const PooledCase* simulated) {
  Figure figure;
  figure.title = key.title() + ": force and deformation against tool displacement";
  figure.columns = 1;
  XYPanel force{"a) force", "tool displacement (mm)", "force (N)", false, false, {}};
  XYPanel deformation{"b) deformation", "tool displacement (mm)", "deformation (mm)", false, false, {}};
  const bool several = runs.size() > 1;
  for (const auto* run : runs) {
    const std::string title = several ? "" : "measured";
    const char* color = several ? kRepeatColor : kMeasuredColor;
    force.series.push_back(line(title, run->curve.displacement_mm, run->curve.force_N, color, SeriesStyle::Line, several ? 0.8 : 1.5));
    deformation.series.push_back(line(title, run->curve.displacement_mm, run->curve.deformation_mm, color, SeriesStyle::Line, several ? 0.8 : 1.5));
  }
  if (several) {
    const std::string title = "measured, mean of " + std::to_string(runs.size()) + " repeats";
    force.series.push_back(line(title, pooled.mean_curve.displacement_mm, pooled.mean_curve.force_N, kMeasuredColor));
    deformation.series.push_back(line(title, pooled.mean_curve.displacement_mm, pooled.mean_curve.deformation_mm, kMeasuredColor));
  }
  if (simulated_runs) {
    const bool several_sim = simulated_runs->size() > 1;
    const auto& curve = several_sim ? simulated->mean_curve : simulated_runs->front()->curve;
    const std::string title = several_sim ? "simulated, mean of " + std::to_string(simulated_runs->size()) + " runs" : "simulated";
    force.series.push_back(line(title, curve.displacement_mm, curve.force_N, kSimulatedColor, SeriesStyle::DashedLine));
    deformation.series.push_back(line(title, curve.displacement_mm, curve.deformation_mm, kSimulatedColor, SeriesStyle::DashedLine));
  }
  figure.panels = {force, deformation};
  return figure;
}

// Fig. 15: means with standard deviations per case, measured (and simulated).
Figure meansFigure(const std::vector<const PooledCase*>& measured, const std::vector<const PooledCase*>& simulated) {
  Figure figure;
  figure.title = "Mean deformation and force over the evaluation window (error bars: standard deviation of the data)";
  figure.columns = 2;
  figure.row_height_px = 420;
  BarPanel deformation{"a) mean deformation", "deformation (mm)", {}, {}};
  BarPanel force{"b) mean force", "force (N)", {}, {}};
  BarGroup dm{"measured", kMeasuredColor, {}, {}}, fm{"measured", kMeasuredColor, {}, {}};
  BarGroup ds{"simulated", kSimulatedColor, {}, {}}, fs{"simulated", kSimulatedColor, {}, {}};
  for (std::size_t i = 0; i < measured.size(); ++i) {
    const std::string category = measured[i]->key.tool + " " + shortNum(measured[i]->key.depth_mm) + " mm";
    deformation.categories.push_back(category);
    force.categories.push_back(category);
    dm.values.push_back(measured[i]->deformation_mean_mm);
    dm.errors.push_back(measured[i]->deformation_std_mm);
    fm.values.push_back(measured[i]->force_mean_N);
    fm.errors.push_back(measured[i]->force_std_N);
    if (!simulated.empty()) {
      ds.values.push_back(simulated[i]->deformation_mean_mm);
      ds.errors.push_back(simulated[i]->deformation_std_mm);
      fs.values.push_back(simulated[i]->force_mean_N);
      fs.errors.push_back(simulated[i]->force_std_N);
    }
  }
  deformation.groups = {dm};
  force.groups = {fm};
  if (!simulated.empty()) {
    deformation.groups.push_back(ds);
    force.groups.push_back(fs);
  }
  figure.panels = {deformation, force};
  return figure;
}

// Time shifts (s) added to a run's force and deformation histories in a plot.
struct HistoryShift {
  double force_s = 0.0;
  double deformation_s = 0.0;
};

// Fig. 7: calibration-weight histories, each run shifted by its HistoryShift.
Figure historyFigure(const CaseKey& key, const std::vector<const CalibrationRun*>& runs, const std::vector<HistoryShift>& shifts,
                     const CalibrationRun* simulated, const HistoryShift& simulated_shift) {
  Figure figure;
  figure.title = key.title() + ": calibration-weight response" + (simulated ? " (curves shifted so the first local maxima coincide)" : "");
  XYPanel force{"a) force on the tool", "time (s)", "force (N)", false, false, {}, "bottom right"};
  XYPanel deformation{"b) deformation of the tool", "time (s)", "deformation (mm)", false, false, {}, "bottom right"};
  const auto shifted = [](std::vector<double> t, double shift) {
    for (double& v : t) v += shift;
    return t;
  };
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const CalibrationRun& run = *runs[k];
    const std::string title = "measured r" + std::to_string(run.repeat);
    const char* color = k == 0 ? kMeasuredColor : kRepeatColor;
    const double width = k == 0 ? 1.5 : 0.8;
    force.series.push_back(line(title, shifted(run.time_s, shifts[k].force_s), run.force_N, color, SeriesStyle::Line, width));
    force.series.push_back(line("", shifted(run.force.peak_times_s, shifts[k].force_s), run.force.peak_values, "#1f4e79", SeriesStyle::Points));
    deformation.series.push_back(line(title, shifted(run.time_s, shifts[k].deformation_s), run.deformation_mm, color, SeriesStyle::Line, width));
    deformation.series.push_back(
        line("", shifted(run.deformation.peak_times_s, shifts[k].deformation_s), run.deformation.peak_values, "#1f4e79", SeriesStyle::Points));
  }
  if (simulated) {
    force.series.push_back(line("simulated", shifted(simulated->time_s, simulated_shift.force_s), simulated->force_N, kSimulatedColor,
                                SeriesStyle::DashedLine));
    deformation.series.push_back(line("simulated", shifted(simulated->time_s, simulated_shift.deformation_s), simulated->deformation_mm,
                                      kSimulatedColor, SeriesStyle::DashedLine));
  }
  figure.panels = {force, deformation};
  return figure;
}

// Error segment of a bar: none (0) when the spread is undefined.
double errorBar(const SignalStatistics& s) { return std::isfinite(s.std_dev) ? s.std_dev : 0.0; }

// Fig. 8: steady value, frequency and damping ratio, measured against simulated.
Figure responseFigure(const CalibrationComparison& c) {
  Figure figure;
  figure.title = c.key.title() + ": steady value, frequency, damping ratio (bars: fitted to the whole records; error bars: standard deviation over cycles)";
  figure.columns = 3;
  figure.row_height_px = 340;
  const auto bars = [&](const std::string& title, const std::string& unit, const SignalStatistics& m, const SignalStatistics& s) {
    return BarPanel{title, unit, {c.key.title()},
                    {BarGroup{"measured", kMeasuredColor, {m.mean}, {errorBar(m)}}, BarGroup{"simulated", kSimulatedColor, {s.mean}, {errorBar(s)}}}};
  };
  figure.panels = {bars("a.1) deformation: steady value", "deformation (mm)", c.measured.deformation.steady, c.simulated.deformation.steady),
                   bars("a.2) deformation: frequency", "frequency (Hz)", c.measured.deformation.frequency_Hz, c.simulated.deformation.frequency_Hz),
                   bars("a.3) deformation: damping ratio", "damping ratio", c.measured.deformation.damping_ratio, c.simulated.deformation.damping_ratio),
                   bars("b.1) force: steady value", "force (N)", c.measured.force.steady, c.simulated.force.steady),
                   bars("b.2) force: frequency", "frequency (Hz)", c.measured.force.frequency_Hz, c.simulated.force.frequency_Hz),
                   bars("b.3) force: damping ratio", "damping ratio", c.measured.force.damping_ratio, c.simulated.force.damping_ratio)};
  return figure;
}

XYPanel spectrumPanel(const std::string& title, const std::string& unit, const SpectralComparison& s) {
  XYPanel panel{title, "frequency (Hz)", "amplitude (" + unit + ")", true, true, {}, "bottom left"};
  for (std::size_t r = 0; r < s.measured.size(); ++r)
    panel.series.push_back(line(r == 0 ? "measured" : "", s.measured[r].frequency_Hz, s.measured[r].amplitude, kMeasuredColor, SeriesStyle::Points));
  for (std::size_t r = 0; r < s.simulated.size(); ++r)
    panel.series.push_back(
        line(r == 0 ? "simulated" : "", s.simulated[r].frequency_Hz, s.simulated[r].amplitude, kSimulatedColor, SeriesStyle::Points));
  const auto fitted = [](const PowerLawFit& fit) {
    std::vector<double> f, a;
    for (int k = 0; k <= 60; ++k) {
      const double x = std::pow(10.0, std::log10(fit.f_low_Hz) + (std::log10(fit.f_high_Hz) - std::log10(fit.f_low_Hz)) * k / 60.0);
      f.push_back(x);
      a.push_back(fit.evaluate(x));
    }
    return std::make_pair(f, a);
  };
  const auto [fm, am] = fitted(s.measured_fit);
  const auto [fs, as] = fitted(s.simulated_fit);
  panel.series.push_back(line("measured fit " + shortNum(s.measured_fit.a, 3) + " f^" + shortNum(s.measured_fit.b, 3), fm, am, "#1f4e79",
                              SeriesStyle::DashedLine, 2.5));
  panel.series.push_back(line("simulated fit " + shortNum(s.simulated_fit.a, 3) + " f^" + shortNum(s.simulated_fit.b, 3), fs, as, "#c00000",
                              SeriesStyle::DashedLine, 2.5));
  return panel;
}

std::string spectrumCsv(const Spectrum& force, const Spectrum& deformation) {
  std::vector<std::vector<std::string>> rows;
  for (std::size_t k = 0; k < force.frequency_Hz.size(); ++k)
    rows.push_back({num(force.frequency_Hz[k]), num(force.amplitude[k]), num(deformation.amplitude[k])});
  return csvTable({"frequency_Hz", "force_amplitude_N", "deformation_amplitude_mm"}, rows);
}

std::string settingsMarkdown(const AnalysisSettings& s) {
  std::ostringstream out;
  const auto& e = s.evaluation;
  out << "Settings: start from the line through " << shortNum(100 * e.start_low_fraction) << " % and " << shortNum(100 * e.start_high_fraction)
      << " % of the maximum deformation (initial value averaged over the first " << shortNum(e.baseline_duration_s) << " s), end at the maximum of the "
      << (e.end_signal == EndSignal::Force ? "force" : "deformation") << ", statistics over " << shortNum(e.window_begin_mm) << "-"
      << shortNum(e.window_end_mm) << " mm of tool displacement (paper Section 2.3).\n\n";
  return out.str();
}

void writeRunFiles(const EvaluationResult& result, StagedOutput& out) {
  for (const auto& run : result.soil_bin_runs) {
    const std::string name = "runs/" + runName(run.key, run.repeat);
    out.writeText(name + ".csv", curveCsv(run.curve));
    json sidecar{{"tool", run.key.tool}, {"depth_mm", run.key.depth_mm}, {"repeat", run.repeat}, {"complete", true},
                 {"evaluated_from", run.source.string()}, {"section_2_3_applied", run.section_2_3_applied}};
    if (run.section_2_3_applied) {
      sidecar["start_time_s"] = run.start_time_s;
      sidecar["end_time_s"] = run.end_time_s;
      sidecar["initial_deformation_mm"] = run.initial_deformation_mm;
    }
    out.writeText(name + ".json", sidecar.dump(2) + "\n");
  }
  for (const auto& run : result.calibration_runs) {
    const std::string name = "runs/" + runName(run.key, run.repeat);
    std::vector<std::vector<std::string>> rows;
    for (std::size_t i = 0; i < run.time_s.size(); ++i) rows.push_back({num(run.time_s[i]), num(run.force_N[i]), num(run.deformation_mm[i])});
    out.writeText(name + ".csv", csvTable({"t_s", "force_N", "deformation_mm"}, rows));
    const json sidecar{{"tool", run.key.tool}, {"mass_kg", run.key.mass_kg}, {"repeat", run.repeat}, {"complete", true},
                       {"evaluated_from", run.source.string()}};
    out.writeText(name + ".json", sidecar.dump(2) + "\n");
  }
}

// Soil-bin and calibration tables of one evaluation; returns their Markdown.
std::string writeEvaluationTables(const EvaluationResult& result, StagedOutput& out) {
  std::ostringstream md;
  if (!result.soil_bin_runs.empty()) {
    out.writeText("soil_bin_runs.csv", soilBinRunsSection().csv(result.soil_bin_runs));
    md << "### Soil-bin runs\n\n" << soilBinRunsSection().markdownOf(result.soil_bin_runs) << "\n";
    out.writeText("soil_bin_cases.csv", soilBinCasesSection().csv(result.soil_bin_cases));
    md << "### Soil-bin cases (repeats pooled)\n\nMean of the repeat means ± standard deviation of all window samples; spread = standard "
          "deviation of the repeat means.\n\n"
       << soilBinCasesSection().markdownOf(result.soil_bin_cases) << "\n";
  }
  if (!result.calibration_runs.empty()) {
    const std::vector<ResponseRow> rows = calibrationRunRows(result);
    out.writeText("calibration_runs.csv", calibrationRunsSection().csv(rows));
    md << "### Calibration-weight runs\n\nSteady value, frequency and damping ratio fitted to the whole record (damped step response); ± the "
          "standard deviation over the cycles (count in brackets).\n\n"
       << calibrationRunsSection().markdownOf(rows) << "\n";
  }
  return md.str();
}

}  // namespace

void writeEvaluation(const EvaluationResult& result, const AnalysisSettings& settings, StagedOutput& out, const GnuplotRenderer* renderer) {
  writeRunFiles(result, out);
  std::ostringstream md;
  md << "# Evaluation of recordings\n\n" << settingsMarkdown(settings);
  md << "Evaluated curves (same columns as a simulated run, with sidecars): `runs/`. Tables: `soil_bin_runs.csv`, `soil_bin_cases.csv`, "
        "`calibration_runs.csv`.\n\n";
  md << writeEvaluationTables(result, out);
  if (!renderer) md << "Plots were not requested (--no-plots).\n\n";

  const auto runs_by_case = detail::groupByCase(result.soil_bin_runs);
  std::vector<const PooledCase*> pooled;
  if (!result.soil_bin_cases.empty()) md << "## Soil-bin curves\n\n";
  for (const auto& c : result.soil_bin_cases) {
    pooled.push_back(&c);
    md << plot(out, renderer, c.key.label() + "_curves", curvesFigure(c.key, runs_by_case.at(c.key), c, nullptr, nullptr));
  }
  if (!pooled.empty()) md << plot(out, renderer, "means", meansFigure(pooled, {}));
  const auto calibration_by_case = detail::groupByCase(result.calibration_runs);
  if (!calibration_by_case.empty()) md << "## Calibration-weight responses\n\nDots: the peaks used for the damping ratio.\n\n";
  for (const auto& [key, runs] : calibration_by_case)
    md << plot(out, renderer, key.label() + "_history", historyFigure(key, runs, std::vector<HistoryShift>(runs.size()), nullptr, {}));
  out.writeText("report.md", md.str());
}

namespace {

void writeSoilBinSection(const ComparisonResult& result, StagedOutput& out, const GnuplotRenderer* renderer,
                         std::ostringstream& md) {
  const std::vector<const SoilBinComparison*> cases = meansRows(result);
  const std::vector<SpectrumRow> spectrum_rows = spectrumRows(result);
  std::vector<const PooledCase*> measured, simulated;
  for (const auto& c : result.soil_bin) {
    measured.push_back(&c.measured);
    simulated.push_back(&c.simulated);
    const auto sim_runs = detail::groupByCase(result.simulated.soil_bin_runs).at(c.key);
    const auto meas_runs = detail::groupByCase(result.measured.soil_bin_runs).at(c.key);
    for (std::size_t r = 0; r < meas_runs.size(); ++r)
      out.writeText("spectra/" + runName(c.key, meas_runs[r]->repeat) + "_measured.csv",
                    spectrumCsv(c.force_spectrum.measured[r], c.deformation_spectrum.measured[r]));
    for (std::size_t r = 0; r < sim_runs.size(); ++r)
      out.writeText("spectra/" + runName(c.key, sim_runs[r]->repeat) + "_simulated.csv",
                    spectrumCsv(c.force_spectrum.simulated[r], c.deformation_spectrum.simulated[r]));
  }
  out.writeText("means.csv", meansSection().csv(cases));
  out.writeText("spectra.csv", spectraSection().csv(spectrum_rows));
  md << "## Soil-bin cases\n\n### Means over the window (Fig. 15)\n\nDifference = 100 (simulated - measured) / measured.\n\n"
     << meansSection().markdownOf(cases) << "\n" << plot(out, renderer, "means", meansFigure(measured, simulated));
  md << "### Force and deformation against displacement (Figs. 9, 14)\n\n";
  const auto measured_runs = detail::groupByCase(result.measured.soil_bin_runs);
  const auto simulated_runs = detail::groupByCase(result.simulated.soil_bin_runs);
  for (const auto& c : result.soil_bin)
    md << plot(out, renderer, c.key.label() + "_curves",
               curvesFigure(c.key, measured_runs.at(c.key), c.measured, &simulated_runs.at(c.key), &c.simulated));
  md << "### FFT amplitude spectra of the window segment with power-law fits a f^b (Section 3.6, Fig. 17)\n\nRatio = geometric mean of "
        "fitted simulated / fitted measured amplitude over the band.\n\n"
     << spectraSection().markdownOf(spectrum_rows) << "\n";
  for (const auto& c : result.soil_bin) {
    Figure figure;
    figure.title = c.key.title() + ": FFT amplitude spectra and fitted power laws";
    figure.columns = 2;
    figure.row_height_px = 420;
    figure.panels = {spectrumPanel("a) deformation", "mm", c.deformation_spectrum), spectrumPanel("b) force", "N", c.force_spectrum)};
    md << plot(out, renderer, c.key.label() + "_spectra", figure);
  }
}

void writeCalibrationSection(const ComparisonResult& result, StagedOutput& out, const GnuplotRenderer* renderer,
                             std::ostringstream& md) {
  const std::vector<CalibrationRow> rows = calibrationRows(result);
  const auto simulated_runs = detail::groupByCase(result.simulated.calibration_runs);
  const auto measured_runs = detail::groupByCase(result.measured.calibration_runs);
  md << "## Calibration-weight cases (Section 3.1, Figs. 7, 8)\n\n";
  std::ostringstream figures;
  for (const auto& c : result.calibration) {
    // Align every curve on the first measured repeat: repeat k moves by (its shift to the
    // simulation) - (the first repeat's), the simulation by the first repeat's shift.
    const auto& first = c.correlations.front();
    std::vector<HistoryShift> shifts;
    for (const auto& corr : c.correlations)
      shifts.push_back({first.force.shift_s - corr.force.shift_s, first.deformation.shift_s - corr.deformation.shift_s});
    figures << plot(out, renderer, c.key.label() + "_history",
                    historyFigure(c.key, measured_runs.at(c.key), shifts, simulated_runs.at(c.key).front(),
                                  {first.force.shift_s, first.deformation.shift_s}));
    figures << plot(out, renderer, c.key.label() + "_response", responseFigure(c));
  }
  out.writeText("calibration.csv", calibrationSection().csv(rows));
  md << "Measured / simulated; correlation after aligning the first local maxima (mean over the measured repeats).\n\n"
     << calibrationSection().markdownOf(rows) << "\n"
     << figures.str();
}

}  // namespace

void writeComparison(const ComparisonResult& result, const AnalysisSettings& settings, StagedOutput& out, const GnuplotRenderer* renderer) {
  std::ostringstream md;
  md << "# Measured against simulated\n\n" << settingsMarkdown(settings);
  if (const auto& renamed = result.simulated_tool_matched_as)
    md << "The simulated tool '" << renamed->first << "' is compared with the measured tool '" << renamed->second
       << "' (one tool on each side: cases matched by depth or mass).\n\n";
  if (!result.unmatched_cases.empty()) {
    md << "Cases without a counterpart (not compared):\n\n";
    for (const auto& u : result.unmatched_cases) md << "- " << u << "\n";
    md << "\n";
  }
  if (!renderer) md << "Plots were not requested (--no-plots).\n\n";
  if (!result.soil_bin.empty()) writeSoilBinSection(result, out, renderer, md);
  if (!result.calibration.empty()) writeCalibrationSection(result, out, renderer, md);
  out.writeText("report.md", md.str());
}

}  // namespace demfem::analysis
