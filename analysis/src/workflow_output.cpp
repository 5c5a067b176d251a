// Files written by `demfem evaluate` and `demfem compare`: tables (CSV), evaluated curves, SVG plots
// and the Markdown report, all staged (see staged_output.hpp).
#include "demfem/analysis/workflow.hpp"

#include "group_by_case.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <sstream>

namespace demfem::analysis {
namespace {

using nlohmann::json;

std::string num(double value) {
  if (!std::isfinite(value)) return "nan";
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.10g", value);
  return buffer;
}

std::string num(const std::optional<double>& value) { return value ? num(*value) : std::string("nan"); }

// Short fixed-precision number for Markdown tables.
std::string shortNum(double value, int digits = 4) {
  if (!std::isfinite(value)) return "-";
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.*g", digits, value);
  return buffer;
}

struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;

  std::string csv() const {
    std::ostringstream out;
    const auto line = [&out](const std::vector<std::string>& cells) {
      for (std::size_t i = 0; i < cells.size(); ++i) {
        const bool quote = cells[i].find_first_of(",\"") != std::string::npos;
        out << (i ? "," : "");
        if (quote) {
          out << '"';
          for (char c : cells[i]) out << (c == '"' ? "\"\"" : std::string(1, c));
          out << '"';
        } else {
          out << cells[i];
        }
      }
      out << '\n';
    };
    line(header);
    for (const auto& row : rows) line(row);
    return out.str();
  }
};

// Markdown table with its own (shorter) cells.
std::string markdown(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows) {
  std::ostringstream out;
  out << '|';
  for (const auto& h : header) out << ' ' << h << " |";
  out << "\n|";
  for (std::size_t i = 0; i < header.size(); ++i) out << " --- |";
  out << '\n';
  for (const auto& row : rows) {
    out << '|';
    for (const auto& cell : row) out << ' ' << cell << " |";
    out << '\n';
  }
  return out.str();
}

// "mean ± spread"; just the mean when the spread is undefined (NaN).
std::string plusMinus(double mean, double spread, int digits = 4) {
  return std::isfinite(spread) ? shortNum(mean, digits) + " ± " + shortNum(spread, 3) : shortNum(mean, digits);
}

std::string runName(const CaseKey& key, int repeat) { return key.label() + "_r" + std::to_string(repeat); }

std::string curveCsv(const DisplacementCurve& c) {
  Table t;
  t.header = {"t_s", "displacement_mm", "force_N", "deformation_mm"};
  if (!c.tilt_deg.empty()) t.header.push_back("tilt_deg");
  for (std::size_t i = 0; i < c.size(); ++i) {
    t.rows.push_back({num(c.time_s[i]), num(c.displacement_mm[i]), num(c.force_N[i]), num(c.deformation_mm[i])});
    if (!c.tilt_deg.empty()) t.rows.back().push_back(num(c.tilt_deg[i]));
  }
  return t.csv();
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
  Table t;
  t.header = {"frequency_Hz", "force_amplitude_N", "deformation_amplitude_mm"};
  for (std::size_t k = 0; k < force.frequency_Hz.size(); ++k)
    t.rows.push_back({num(force.frequency_Hz[k]), num(force.amplitude[k]), num(deformation.amplitude[k])});
  return t.csv();
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
    Table t;
    t.header = {"t_s", "force_N", "deformation_mm"};
    for (std::size_t i = 0; i < run.time_s.size(); ++i) t.rows.push_back({num(run.time_s[i]), num(run.force_N[i]), num(run.deformation_mm[i])});
    out.writeText(name + ".csv", t.csv());
    const json sidecar{{"tool", run.key.tool}, {"mass_kg", run.key.mass_kg}, {"repeat", run.repeat}, {"complete", true},
                       {"evaluated_from", run.source.string()}};
    out.writeText(name + ".json", sidecar.dump(2) + "\n");
  }
}

// Soil-bin and calibration tables of one evaluation; returns their Markdown.
std::string writeEvaluationTables(const EvaluationResult& result, StagedOutput& out) {
  std::ostringstream md;
  if (!result.soil_bin_runs.empty()) {
    Table runs;
    runs.header = {"case", "tool", "depth_mm", "repeat", "source", "section_2_3_applied", "start_time_s", "end_time_s", "samples",
                   "force_mean_N", "force_std_N", "deformation_mean_mm", "deformation_std_mm"};
    std::vector<std::vector<std::string>> md_rows;
    for (const auto& r : result.soil_bin_runs) {
      runs.rows.push_back({r.key.label(), r.key.tool, num(r.key.depth_mm), std::to_string(r.repeat), r.source.string(),
                           r.section_2_3_applied ? "true" : "false", num(r.start_time_s), num(r.end_time_s), std::to_string(r.curve.size()),
                           num(r.window.force_N.mean), num(r.window.force_N.std_dev), num(r.window.deformation_mm.mean),
                           num(r.window.deformation_mm.std_dev)});
      md_rows.push_back({r.key.title(), std::to_string(r.repeat), r.section_2_3_applied ? shortNum(r.start_time_s) : "-",
                         r.section_2_3_applied ? shortNum(r.end_time_s) : "-", plusMinus(r.window.force_N.mean, r.window.force_N.std_dev),
                         plusMinus(r.window.deformation_mm.mean, r.window.deformation_mm.std_dev)});
    }
    out.writeText("soil_bin_runs.csv", runs.csv());
    md << "### Soil-bin runs\n\n"
       << markdown({"case", "repeat", "start (s)", "end (s)", "force (N)", "deformation (mm)"}, md_rows) << "\n";

    Table cases;
    cases.header = {"case", "tool", "depth_mm", "repeats", "force_mean_N", "force_std_N", "force_between_repeats_std_N",
                    "deformation_mean_mm", "deformation_std_mm", "deformation_between_repeats_std_mm"};
    md_rows.clear();
    for (const auto& c : result.soil_bin_cases) {
      cases.rows.push_back({c.key.label(), c.key.tool, num(c.key.depth_mm), std::to_string(c.repeats.size()), num(c.force_mean_N),
                            num(c.force_std_N), num(c.force_between_repeats_std_N), num(c.deformation_mean_mm), num(c.deformation_std_mm),
                            num(c.deformation_between_repeats_std_mm)});
      md_rows.push_back({c.key.title(), std::to_string(c.repeats.size()), plusMinus(c.force_mean_N, c.force_std_N),
                         c.force_between_repeats_std_N ? shortNum(*c.force_between_repeats_std_N, 3) : "-",
                         plusMinus(c.deformation_mean_mm, c.deformation_std_mm),
                         c.deformation_between_repeats_std_mm ? shortNum(*c.deformation_between_repeats_std_mm, 3) : "-"});
    }
    out.writeText("soil_bin_cases.csv", cases.csv());
    md << "### Soil-bin cases (repeats pooled)\n\nMean of the repeat means ± standard deviation of all window samples; spread = standard "
          "deviation of the repeat means.\n\n"
       << markdown({"case", "repeats", "force (N)", "force spread (N)", "deformation (mm)", "deformation spread (mm)"}, md_rows) << "\n";
  }
  if (!result.calibration_runs.empty()) {
    Table runs;
    runs.header = {"case", "tool", "mass_kg", "repeat", "source", "signal", "steady_value", "steady_error", "frequency_Hz", "frequency_error_Hz",
                   "frequency_cycle_std_Hz", "periods", "damping_ratio", "damping_ratio_error", "damping_ratio_cycle_std", "decrements",
                   "residual_rms", "step_time_s", "first_peak_time_s"};
    std::vector<std::vector<std::string>> md_rows;
    for (const auto& r : result.calibration_runs) {
      for (const auto& [signal, response] : {std::pair<std::string, const StepResponse*>{"force_N", &r.force}, {"deformation_mm", &r.deformation}}) {
        const StepResponseFit& f = response->fit;
        runs.rows.push_back({r.key.label(), r.key.tool, num(r.key.mass_kg), std::to_string(r.repeat), r.source.string(), signal, num(f.steady),
                             num(f.steady_error), num(f.frequency_Hz), num(f.frequency_error_Hz), num(response->cycle_frequency_std_Hz),
                             std::to_string(response->cycle_frequencies_Hz.size()), num(f.damping_ratio), num(f.damping_ratio_error),
                             num(response->cycle_damping_ratio_std), std::to_string(response->cycle_damping_ratios.size()), num(f.residual_rms),
                             num(f.step_time_s), num(response->first_peak_time_s)});
        md_rows.push_back({r.key.title(), std::to_string(r.repeat), signal, shortNum(f.steady),
                           plusMinus(f.frequency_Hz, response->cycle_frequency_std_Hz) + " (" +
                               std::to_string(response->cycle_frequencies_Hz.size()) + ")",
                           plusMinus(f.damping_ratio, response->cycle_damping_ratio_std) + " (" +
                               std::to_string(response->cycle_damping_ratios.size()) + ")"});
      }
    }
    out.writeText("calibration_runs.csv", runs.csv());
    md << "### Calibration-weight runs\n\nSteady value, frequency and damping ratio fitted to the whole record (damped step response); ± the "
          "standard deviation over the cycles (count in brackets).\n\n"
       << markdown({"case", "repeat", "signal", "steady value", "frequency (Hz)", "damping ratio"}, md_rows) << "\n";
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

// One column of a report section's CSV table: its name (the unit in the name) and its cell of a row.
template <class Row>
struct Column {
  std::string name;
  std::function<std::string(const Row&)> cell;
};

template <class Row>
Table tableOf(const std::vector<Column<Row>>& columns, const std::vector<Row>& rows) {
  Table table;
  for (const Column<Row>& c : columns) table.header.push_back(c.name);
  for (const Row& row : rows) {
    std::vector<std::string>& cells = table.rows.emplace_back();
    for (const Column<Row>& c : columns) cells.push_back(c.cell(row));
  }
  return table;
}

// --- soil-bin section: means (Fig. 15) and spectra (Fig. 17) ---

const std::vector<Column<const SoilBinComparison*>>& meansColumns() {
  using R = const SoilBinComparison*;
  static const std::vector<Column<R>> columns{
      {"case", [](R c) { return c->key.label(); }},
      {"tool", [](R c) { return c->key.tool; }},
      {"depth_mm", [](R c) { return num(c->key.depth_mm); }},
      {"measured_force_mean_N", [](R c) { return num(c->measured.force_mean_N); }},
      {"measured_force_std_N", [](R c) { return num(c->measured.force_std_N); }},
      {"simulated_force_mean_N", [](R c) { return num(c->simulated.force_mean_N); }},
      {"simulated_force_std_N", [](R c) { return num(c->simulated.force_std_N); }},
      {"force_difference_percent", [](R c) { return num(c->force_difference_percent); }},
      {"measured_deformation_mean_mm", [](R c) { return num(c->measured.deformation_mean_mm); }},
      {"measured_deformation_std_mm", [](R c) { return num(c->measured.deformation_std_mm); }},
      {"simulated_deformation_mean_mm", [](R c) { return num(c->simulated.deformation_mean_mm); }},
      {"simulated_deformation_std_mm", [](R c) { return num(c->simulated.deformation_std_mm); }},
      {"deformation_difference_percent", [](R c) { return num(c->deformation_difference_percent); }}};
  return columns;
}

struct SpectrumRow {
  const SoilBinComparison* c;
  std::string signal;
  const SpectralComparison* s;
};

const std::vector<Column<SpectrumRow>>& spectraColumns() {
  using R = SpectrumRow;
  static const std::vector<Column<R>> columns{
      {"case", [](const R& r) { return r.c->key.label(); }},
      {"signal", [](const R& r) { return r.signal; }},
      {"f_low_Hz", [](const R& r) { return num(r.s->measured_fit.f_low_Hz); }},
      {"f_high_Hz", [](const R& r) { return num(r.s->measured_fit.f_high_Hz); }},
      {"measured_a", [](const R& r) { return num(r.s->measured_fit.a); }},
      {"measured_b", [](const R& r) { return num(r.s->measured_fit.b); }},
      {"measured_b_std_error", [](const R& r) { return num(r.s->measured_fit.b_std_error); }},
      {"simulated_a", [](const R& r) { return num(r.s->simulated_fit.a); }},
      {"simulated_b", [](const R& r) { return num(r.s->simulated_fit.b); }},
      {"simulated_b_std_error", [](const R& r) { return num(r.s->simulated_fit.b_std_error); }},
      {"amplitude_ratio_at_1Hz", [](const R& r) { return num(r.s->amplitude_ratio_at_1Hz); }},
      {"mean_fitted_amplitude_ratio", [](const R& r) { return num(r.s->mean_fitted_ratio); }}};
  return columns;
}

void writeSoilBinSection(const ComparisonResult& result, StagedOutput& out, const GnuplotRenderer* renderer,
                         std::ostringstream& md) {
  std::vector<const SoilBinComparison*> cases;
  std::vector<SpectrumRow> spectrum_rows;
  std::vector<std::vector<std::string>> md_means, md_spectra;
  std::vector<const PooledCase*> measured, simulated;
  for (const auto& c : result.soil_bin) {
    cases.push_back(&c);
    measured.push_back(&c.measured);
    simulated.push_back(&c.simulated);
    md_means.push_back({c.key.title(), plusMinus(c.measured.force_mean_N, c.measured.force_std_N),
                        plusMinus(c.simulated.force_mean_N, c.simulated.force_std_N), shortNum(c.force_difference_percent, 3),
                        plusMinus(c.measured.deformation_mean_mm, c.measured.deformation_std_mm),
                        plusMinus(c.simulated.deformation_mean_mm, c.simulated.deformation_std_mm), shortNum(c.deformation_difference_percent, 3)});
    for (const auto& [signal, s] : {std::pair<std::string, const SpectralComparison*>{"force_N", &c.force_spectrum}, {"deformation_mm", &c.deformation_spectrum}}) {
      spectrum_rows.push_back({&c, signal, s});
      md_spectra.push_back({c.key.title(), signal, shortNum(s->measured_fit.f_low_Hz, 3) + "-" + shortNum(s->measured_fit.f_high_Hz, 3),
                            shortNum(s->measured_fit.a, 3) + " f^" + shortNum(s->measured_fit.b, 3),
                            shortNum(s->simulated_fit.a, 3) + " f^" + shortNum(s->simulated_fit.b, 3), shortNum(s->mean_fitted_ratio, 3)});
    }
    const auto sim_runs = detail::groupByCase(result.simulated.soil_bin_runs).at(c.key);
    const auto meas_runs = detail::groupByCase(result.measured.soil_bin_runs).at(c.key);
    for (std::size_t r = 0; r < meas_runs.size(); ++r)
      out.writeText("spectra/" + runName(c.key, meas_runs[r]->repeat) + "_measured.csv",
                    spectrumCsv(c.force_spectrum.measured[r], c.deformation_spectrum.measured[r]));
    for (std::size_t r = 0; r < sim_runs.size(); ++r)
      out.writeText("spectra/" + runName(c.key, sim_runs[r]->repeat) + "_simulated.csv",
                    spectrumCsv(c.force_spectrum.simulated[r], c.deformation_spectrum.simulated[r]));
  }
  out.writeText("means.csv", tableOf(meansColumns(), cases).csv());
  out.writeText("spectra.csv", tableOf(spectraColumns(), spectrum_rows).csv());
  md << "## Soil-bin cases\n\n### Means over the window (Fig. 15)\n\nDifference = 100 (simulated - measured) / measured.\n\n"
     << markdown({"case", "measured force (N)", "simulated force (N)", "force diff. (%)", "measured deformation (mm)",
                  "simulated deformation (mm)", "deformation diff. (%)"},
                 md_means)
     << "\n" << plot(out, renderer, "means", meansFigure(measured, simulated));
  md << "### Force and deformation against displacement (Figs. 9, 14)\n\n";
  const auto measured_runs = detail::groupByCase(result.measured.soil_bin_runs);
  const auto simulated_runs = detail::groupByCase(result.simulated.soil_bin_runs);
  for (const auto& c : result.soil_bin)
    md << plot(out, renderer, c.key.label() + "_curves",
               curvesFigure(c.key, measured_runs.at(c.key), c.measured, &simulated_runs.at(c.key), &c.simulated));
  md << "### FFT amplitude spectra of the window segment with power-law fits a f^b (Section 3.6, Fig. 17)\n\nRatio = geometric mean of "
        "fitted simulated / fitted measured amplitude over the band.\n\n"
     << markdown({"case", "signal", "band (Hz)", "measured fit", "simulated fit", "ratio"}, md_spectra) << "\n";
  for (const auto& c : result.soil_bin) {
    Figure figure;
    figure.title = c.key.title() + ": FFT amplitude spectra and fitted power laws";
    figure.columns = 2;
    figure.row_height_px = 420;
    figure.panels = {spectrumPanel("a) deformation", "mm", c.deformation_spectrum), spectrumPanel("b) force", "N", c.force_spectrum)};
    md << plot(out, renderer, c.key.label() + "_spectra", figure);
  }
}

// --- calibration section (Section 3.1, Figs. 7, 8) ---

struct CalibrationRow {
  const CalibrationComparison* c;
  std::string signal;
  const ResponseSummary* measured;
  const ResponseSummary* simulated;
  double correlation;  // mean over the measured repeats
};

// The five columns of one statistic of the responses: measured mean and spread, simulated mean and
// spread, and the difference of the means in percent.
void addStatistic(std::vector<Column<CalibrationRow>>& columns, const std::array<std::string, 5>& names,
                  SignalStatistics ResponseSummary::*statistic) {
  using R = CalibrationRow;
  columns.push_back({names[0], [statistic](const R& r) { return num((r.measured->*statistic).mean); }});
  columns.push_back({names[1], [statistic](const R& r) { return num((r.measured->*statistic).std_dev); }});
  columns.push_back({names[2], [statistic](const R& r) { return num((r.simulated->*statistic).mean); }});
  columns.push_back({names[3], [statistic](const R& r) { return num((r.simulated->*statistic).std_dev); }});
  columns.push_back({names[4], [statistic](const R& r) {
                       return num(percentDifference((r.measured->*statistic).mean, (r.simulated->*statistic).mean));
                     }});
}

const std::vector<Column<CalibrationRow>>& calibrationColumns() {
  using R = CalibrationRow;
  static const std::vector<Column<R>> columns = [] {
    std::vector<Column<R>> c{{"case", [](const R& r) { return r.c->key.label(); }},
                             {"signal", [](const R& r) { return r.signal; }}};
    addStatistic(c, {"measured_steady_value", "measured_steady_std", "simulated_steady_value", "simulated_steady_std",
                     "steady_value_difference_percent"},
                 &ResponseSummary::steady);
    addStatistic(c, {"measured_frequency_mean_Hz", "measured_frequency_std_Hz", "simulated_frequency_mean_Hz",
                     "simulated_frequency_std_Hz", "frequency_difference_percent"},
                 &ResponseSummary::frequency_Hz);
    addStatistic(c, {"measured_damping_ratio_mean", "measured_damping_ratio_std", "simulated_damping_ratio_mean",
                     "simulated_damping_ratio_std", "damping_ratio_difference_percent"},
                 &ResponseSummary::damping_ratio);
    c.push_back({"correlation_mean", [](const R& r) { return num(r.correlation); }});
    return c;
  }();
  return columns;
}

void writeCalibrationSection(const ComparisonResult& result, StagedOutput& out, const GnuplotRenderer* renderer,
                             std::ostringstream& md) {
  std::vector<CalibrationRow> rows;
  std::vector<std::vector<std::string>> md_rows;
  const auto simulated_runs = detail::groupByCase(result.simulated.calibration_runs);
  const auto measured_runs = detail::groupByCase(result.measured.calibration_runs);
  md << "## Calibration-weight cases (Section 3.1, Figs. 7, 8)\n\n";
  std::ostringstream figures;
  for (const auto& c : result.calibration) {
    for (const bool is_force : {false, true}) {
      const ResponseSummary& m = is_force ? c.measured.force : c.measured.deformation;
      const ResponseSummary& s = is_force ? c.simulated.force : c.simulated.deformation;
      double correlation = 0.0;
      for (const auto& corr : c.correlations) correlation += (is_force ? corr.force : corr.deformation).correlation;
      correlation /= static_cast<double>(c.correlations.size());
      const std::string signal = is_force ? "force_N" : "deformation_mm";
      rows.push_back({&c, signal, &m, &s, correlation});
      md_rows.push_back({c.key.title(), signal, shortNum(m.steady.mean) + " / " + shortNum(s.steady.mean),
                         plusMinus(m.frequency_Hz.mean, m.frequency_Hz.std_dev) + " / " + plusMinus(s.frequency_Hz.mean, s.frequency_Hz.std_dev),
                         plusMinus(m.damping_ratio.mean, m.damping_ratio.std_dev) + " / " + plusMinus(s.damping_ratio.mean, s.damping_ratio.std_dev),
                         shortNum(correlation, 3)});
    }
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
  out.writeText("calibration.csv", tableOf(calibrationColumns(), rows).csv());
  md << "Measured / simulated; correlation after aligning the first local maxima (mean over the measured repeats).\n\n"
     << markdown({"case", "signal", "steady value", "frequency (Hz)", "damping ratio", "correlation"}, md_rows) << "\n"
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
