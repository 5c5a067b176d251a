#include "demfem/campaign/calibration.hpp"

#include "demfem/analysis/step_fit.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

namespace demfem::campaign {
namespace {

nlohmann::json optionalNumber(const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(nullptr); }

nlohmann::json finiteOrNull(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

nlohmann::json residualsJson(const std::vector<Residual>& residuals) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& r : residuals) out.push_back(toJson(r));
  return out;
}

nlohmann::json stageJson(const Stage& stage, const CalibrationResult& r) {
  nlohmann::json parameters = nlohmann::json::array();
  for (const auto& p : r.parameters)
    parameters.push_back({{"pointer", p.spec.pointer},
                          {"lo", p.spec.lo},
                          {"hi", p.spec.hi},
                          {"log", p.spec.log},
                          {"initial", p.initial},
                          {"value", optionalNumber(p.value)},
                          {"std_dev", finiteOrNull(p.std_dev)},
                          {"identified", p.identified},
                          {"best_point", p.best}});
  nlohmann::json minima = nlohmann::json::array();
  for (const auto& m : r.minima) minima.push_back({{"values", m.values}, {"chi2", m.chi2}});
  nlohmann::json cases = nlohmann::json::array();
  for (const auto& key : stage.cases) cases.push_back(key.label());
  return {{"title", stage.title},
          {"cases", cases},
          {"parameters", parameters},
          {"initial_chi2", r.initial_chi2},
          {"chi2", r.chi2},
          {"residuals_initial", residualsJson(r.initial_residuals)},
          {"residuals", residualsJson(r.residuals)},
          {"minima", minima},
          {"unique", r.minima.size() == 1},
          {"evaluations", r.evaluations},
          {"model_runs", r.model_runs},
          {"failed_runs", r.failed_runs},
          {"cache_hits", r.cache_hits},
          {"wall_time_s", r.wall_time_s}};
}

std::string number(double v) {
  std::ostringstream out;
  out.precision(6);
  out << v;
  return out.str();
}

std::string objectiveText(const CalibrationOptions& o) {
  return "chi2 = sum over cases and quantities of ((simulated - measured) / sigma)^2. Calibration-weight cases: step height of "
         "force_N and deformation_mm, frequency_Hz and damping ratio of the deformation, from the damped step response fitted to "
         "the whole record; soil-bin cases: mean and standard deviation of force_N" +
         std::string(o.objective.soil_deformation ? " and deformation_mm" : "") +
         " over the Section 2.3 window. Measured value = mean over repeats; sigma = its scatter (between repeats, or the fits' "
         "standard errors / the window samples' standard error, whichever is larger, over sqrt(repeats)), at least " +
         number(100 * o.objective.relative_floor) + " % of the measured value. Uncertainty: local curvature (Gauss-Newton, "
         "Delta chi2 = 1); a parameter whose standard deviation exceeds " + number(100 * o.unidentified_fraction) +
         " % of its bounds or " + number(100 * o.unidentified_relative) + " % of its value is unidentified. Distinct minima: starts ending within Delta chi2 = " + number(o.noise_chi2) +
         " of the best and more than 3 sigma away from it.\n";
}

std::string residualTable(const std::vector<Residual>& initial, const std::vector<Residual>& fitted) {
  std::string s = "| case | quantity | measured | sigma | initial | calibrated | residual (sigma) |\n|---|---|---|---|---|---|---|\n";
  for (std::size_t i = 0; i < fitted.size(); ++i)
    s += "| " + fitted[i].key.title() + " | " + fitted[i].quantity + " | " + number(fitted[i].measured) + " | " + number(fitted[i].sigma) +
         " | " + number(initial[i].simulated) + " | " + number(fitted[i].simulated) + " | " + number(fitted[i].normalized) + " |\n";
  return s;
}

std::string stageReport(const Stage& stage, const CalibrationResult& r, const std::vector<std::string>& plots) {
  std::string s = "## " + stage.title + "\n\n| parameter | initial | fitted | std dev | bounds |\n|---|---|---|---|---|\n";
  for (const auto& p : r.parameters)
    s += "| `" + p.spec.pointer + "` | " + number(p.initial) + " | " + (p.value ? number(*p.value) : std::string("unidentified")) + " | " +
         number(p.std_dev) + " | " + number(p.spec.lo) + " - " + number(p.spec.hi) +
         (p.spec.log ? " (log)" : "") + " |\n";
  for (const auto& p : r.parameters)
    if (!p.identified)
      s += "\n`" + p.spec.pointer + "` is not identified by these recordings (the objective is flat along it within the noise); "
           "the calibrated study carries the best point found, " + number(p.best) + ", one of many that fit equally well.\n";
  s += "\nchi2 " + number(r.initial_chi2) + " -> " + number(r.chi2) + " over " + std::to_string(r.residuals.size()) + " quantities. ";
  if (r.minima.size() == 1) {
    s += "Unique: every start ended at the same minimum or one clearly worse.\n";
  } else {
    s += "NOT unique: " + std::to_string(r.minima.size()) + " distinct minima fit within the noise:\n\n";
    for (const auto& m : r.minima) {
      s += "- chi2 " + number(m.chi2) + ":";
      for (std::size_t i = 0; i < m.values.size(); ++i) {
        s += ' ';  // (" " + label trips GCC 12's false -Wrestrict positive)
        s += r.parameters[i].spec.label() + " = " + number(m.values[i]);
      }
      s += "\n";
    }
  }
  s += "\nModel runs " + std::to_string(r.model_runs) + " (cache hits " + std::to_string(r.cache_hits) + ", failed DEM runs " +
       std::to_string(r.failed_runs) + "), objective evaluations " +
       std::to_string(r.evaluations) + ", wall time " + number(r.wall_time_s) + " s.\n\n" + residualTable(r.initial_residuals, r.residuals);
  for (const auto& p : plots) s += "\n![" + p + "](" + p + ")\n";
  return s + "\n";
}

// The first simulated run of `key` in `runs`.
const analysis::Recording* runOf(const std::vector<analysis::Recording>& runs, const analysis::CaseKey& key) {
  for (const auto& r : runs)
    if (r.key == key) return &r;
  return nullptr;
}

std::vector<analysis::CaseKey> casesOfResult(const CalibrationResult& r) {
  std::vector<analysis::CaseKey> keys;
  for (const auto& rec : r.measured)
    if (std::find(keys.begin(), keys.end(), rec.key) == keys.end()) keys.push_back(rec.key);
  return keys;
}

struct Curve {
  std::vector<double> x, force, deformation;
};

// Calibrated signals of a recording against time (weights: shifted so the fitted moment the weight
// was hung is at `step_s`) or tool displacement (soil bin).
Curve curveOf(const analysis::Recording& rec, const analysis::AnalysisSettings& settings, double step_s) {
  Curve c;
  if (rec.key.kind == analysis::CaseKind::CalibrationWeight) {
    const WeightSignals s = weightSignals(rec);
    const double shift = step_s - analysis::fitStepResponse(s.time_s, s.deformation_mm, rec.csv_path.string()).step_time_s;
    for (double t : s.time_s) c.x.push_back(t + shift);
    c.force = s.force_N, c.deformation = s.deformation_mm;
  } else {
    const auto curve = analysis::evaluateSoilBinRun(rec, settings.evaluation).curve;
    c.x = curve.displacement_mm, c.force = curve.force_N, c.deformation = curve.deformation_mm;
  }
  return c;
}

analysis::Figure caseFigure(const analysis::CaseKey& key, const CalibrationResult& r, const analysis::AnalysisSettings& settings) {
  analysis::XYPanel force, deformation;
  force.title = "force", deformation.title = "deformation";
  force.x_label = deformation.x_label = key.kind == analysis::CaseKind::SoilBin ? "tool displacement (mm)" : "time (s)";
  force.y_label = "force (N)", deformation.y_label = "deformation (mm)";
  double step_s = 0;
  bool first = true;
  for (const auto& rec : r.measured) {
    if (rec.key != key) continue;
    if (first && key.kind == analysis::CaseKind::CalibrationWeight)
      step_s = analysis::fitStepResponse(rec.time_s, weightSignals(rec).deformation_mm, rec.csv_path.string()).step_time_s;
    const Curve c = curveOf(rec, settings, step_s);
    const std::string title = first ? "measured" : "";
    force.series.push_back({title, c.x, c.force, analysis::kMeasuredColor});
    deformation.series.push_back({title, c.x, c.deformation, analysis::kMeasuredColor});
    first = false;
  }
  const auto add = [&](const analysis::Recording* rec, const std::string& title, analysis::SeriesStyle style) {
    if (!rec) return;
    try {
      const Curve c = curveOf(*rec, settings, step_s);
      force.series.push_back({title, c.x, c.force, analysis::kSimulatedColor, style});
      deformation.series.push_back({title, c.x, c.deformation, analysis::kSimulatedColor, style});
    } catch (const analysis::InputError&) {
      // a run that cannot be evaluated (no overshoot) is left out of the plot; the residuals say so
    }
  };
  add(runOf(r.initial_runs, key), "initial study", analysis::SeriesStyle::DashedLine);
  add(runOf(r.calibrated_runs, key), "calibrated", analysis::SeriesStyle::Line);
  return {key.title() + ": measured against calibrated", {force, deformation}, 2};
}

}  // namespace

nlohmann::json toJson(const StagedCalibration& c, const CalibrationOptions& options) {
  nlohmann::json stages = nlohmann::json::array();
  int runs = 0, hits = 0, evaluations = 0;
  double wall = 0;
  for (std::size_t i = 0; i < c.results.size(); ++i) {
    stages.push_back(stageJson(c.stages[i], c.results[i]));
    runs += c.results[i].model_runs, hits += c.results[i].cache_hits, evaluations += c.results[i].evaluations;
    wall += c.results[i].wall_time_s;
  }
  nlohmann::json fitted = nlohmann::json::object();
  for (const auto& r : c.results)
    for (const auto& p : r.parameters)
      fitted[p.spec.pointer] = {{"value", optionalNumber(p.value)}, {"std_dev", finiteOrNull(p.std_dev)}, {"identified", p.identified}};
  return {{"objective", objectiveText(options)},
          {"fitted", fitted},
          {"stages", stages},
          {"model_runs", runs},
          {"cache_hits", hits},
          {"evaluations", evaluations},
          {"wall_time_s", wall}};
}

void writeCalibration(const StagedCalibration& c, const CalibrationOptions& options, analysis::StagedOutput& out,
                      const analysis::GnuplotRenderer* renderer) {
  out.writeText("calibrated_study.json", c.calibrated_study.dump(2) + "\n");
  std::string report = "# Calibration report\n\nObjective: " + objectiveText(options) + "\n";
  if (!renderer) report += "Plots were not drawn (--no-plots).\n\n";
  for (std::size_t i = 0; i < c.results.size(); ++i) {
    std::vector<std::string> plots;
    if (renderer)
      for (const auto& key : casesOfResult(c.results[i])) {
        const std::string name = "plots/stage" + std::to_string(i + 1) + "_" + key.label();
        renderer->render(caseFigure(key, c.results[i], options.objective.analysis), out.stage(name + ".gp"), out.stage(name + ".svg"));
        plots.push_back(name + ".svg");
      }
    report += stageReport(c.stages[i], c.results[i], plots);
  }
  out.writeText("report.md", report);
  out.writeText("calibration.json", toJson(c, options).dump(2) + "\n");
}

}  // namespace demfem::campaign
