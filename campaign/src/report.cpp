// Outputs of a staged calibration (calibration.hpp): calibrated_study.json, report.md, the tables
// stages.csv, parameters.csv and residuals.csv (report sections: each column declared once, the
// Markdown tables and the JSON document generated from the same declaration) and the plots.
#include "demfem/campaign/calibration.hpp"

#include "demfem/analysis/report_section.hpp"
#include "demfem/analysis/step_fit.hpp"

#include "parameter_section.hpp"

#include <algorithm>
#include <cmath>
#include <map>

namespace demfem::campaign {
namespace {

using namespace analysis::report;

// One stage of a calibration (its number from 1).
struct StageRow {
  long long number;
  const Stage* stage;
  const CalibrationResult* result;
};

// One quantity of one case of a stage, at the study's own values and at the fit (the same measured
// quantities, so the two residual lists pair up by index).
struct ResidualRow {
  long long stage;
  const Residual* initial;
  const Residual* fitted;
};

// stages.csv: chi2, uniqueness, runs and wall time of each stage (the report's prose under its tables).
const Section<StageRow>& stageSection() {
  using R = StageRow;
  static const Section<R> section{
      {{"stage", [](const R& r) -> CellValue { return r.number; }},
       {"title", [](const R& r) -> CellValue { return r.stage->title; }},
       {"initial_chi2", [](const R& r) -> CellValue { return r.result->initial_chi2; }},
       {"chi2", [](const R& r) -> CellValue { return r.result->chi2; }},
       {"quantities", [](const R& r) -> CellValue { return static_cast<long long>(r.result->residuals.size()); }},
       {"unique", [](const R& r) -> CellValue { return r.result->minima.size() == 1; }},
       {"distinct_minima", [](const R& r) -> CellValue { return static_cast<long long>(r.result->minima.size()); }},
       {"evaluations", [](const R& r) -> CellValue { return static_cast<long long>(r.result->evaluations); }},
       {"model_runs", [](const R& r) -> CellValue { return static_cast<long long>(r.result->model_runs); }},
       {"cache_hits", [](const R& r) -> CellValue { return static_cast<long long>(r.result->cache_hits); }},
       {"failed_runs", [](const R& r) -> CellValue { return static_cast<long long>(r.result->failed_runs); }},
       {"wall_time_s", [](const R& r) -> CellValue { return r.result->wall_time_s; }}},
      [](const R& r) { return r.stage->title; },
      {}};
  return section;
}

// residuals.csv: per stage, case and quantity the measured value and its sigma, the simulated value
// and the residual (simulated - measured) / sigma at the study's own values and at the fit.
const Section<ResidualRow>& residualSection() {
  using R = ResidualRow;
  static const Section<R> section{
      {{"stage", [](const R& r) -> CellValue { return r.stage; }},
       {"case", [](const R& r) -> CellValue { return r.fitted->key.label(); }},
       {"quantity", [](const R& r) -> CellValue { return r.fitted->quantity; }},
       {"measured", [](const R& r) -> CellValue { return r.fitted->measured; }},
       {"sigma", [](const R& r) -> CellValue { return r.fitted->sigma; }},
       {"initial_simulated", [](const R& r) -> CellValue { return r.initial->simulated; }},
       {"initial_normalized", [](const R& r) -> CellValue { return r.initial->normalized; }},
       {"initial_missing", [](const R& r) -> CellValue { return r.initial->missing; }},
       {"simulated", [](const R& r) -> CellValue { return r.fitted->simulated; }},
       {"normalized", [](const R& r) -> CellValue { return r.fitted->normalized; }},
       {"missing", [](const R& r) -> CellValue { return r.fitted->missing; }}},
      [](const R& r) { return r.fitted->key.title(); },
      {{"quantity", md::text("quantity")},
       {"measured", md::number("measured", 6)},
       {"sigma", md::number("sigma", 6)},
       {"initial", md::number("initial_simulated", 6)},
       {"calibrated", md::number("simulated", 6)},
       {"residual (sigma)", md::number("normalized", 6)}}};
  return section;
}

std::vector<StageRow> stageRows(const StagedCalibration& c) {
  std::vector<StageRow> rows;
  for (std::size_t i = 0; i < c.results.size(); ++i) rows.push_back({static_cast<long long>(i + 1), &c.stages[i], &c.results[i]});
  return rows;
}

std::vector<ResidualRow> residualRows(const StageRow& stage) {
  std::vector<ResidualRow> rows;
  const CalibrationResult& r = *stage.result;
  for (std::size_t i = 0; i < r.residuals.size(); ++i) rows.push_back({stage.number, &r.initial_residuals[i], &r.residuals[i]});
  return rows;
}

// Every stage's rows of a table, one after another (the CSV files).
template <class Row, class RowsOf>
std::vector<Row> allStages(const std::vector<StageRow>& stages, RowsOf rows_of) {
  std::vector<Row> all;
  for (const StageRow& s : stages)
    for (const Row& row : rows_of(s)) all.push_back(row);
  return all;
}

std::vector<ParameterRow> stageParameterRows(const StageRow& stage) { return parameterRows(stage.number, stage.result->parameters); }

nlohmann::json stageJson(const StageRow& stage) {
  const CalibrationResult& r = *stage.result;
  nlohmann::json minima = nlohmann::json::array();
  for (const auto& m : r.minima) minima.push_back({{"values", m.values}, {"chi2", m.chi2}});
  nlohmann::json cases = nlohmann::json::array();
  for (const auto& key : stage.stage->cases) cases.push_back(key.label());
  nlohmann::json j = stageSection().json(stage);
  j["cases"] = cases;
  j["parameters"] = parameterSection("stage").json(stageParameterRows(stage));
  j["residuals"] = residualSection().json(residualRows(stage));
  j["minima"] = minima;
  return j;
}

// A number of the report's prose: six digits.
std::string number(double v) { return shortNum(v, 6); }

std::string objectiveText(const CalibrationOptions& o) {
  return "chi2 = sum over cases and quantities of ((simulated - measured) / sigma)^2. Calibration-weight cases: step height of "
         "force_N and deformation_mm, frequency_Hz and damping ratio of the deformation, from the damped step response fitted to "
         "the whole record; soil-bin cases: mean and standard deviation of force_N" +
         std::string(o.objective.soil_deformation ? " and deformation_mm" : "") +
         " over the Section 2.3 window. Measured value = mean over repeats; sigma = its scatter (between repeats, or the fits' "
         "standard errors / the window samples' standard error, whichever is larger, over sqrt(repeats)), at least " +
         number(100 * o.objective.relative_floor) + " % of the measured value" +
         std::string(o.kind == ObjectiveKind::Noisy && o.model_scatters_like_repeats
                         ? "; widened by the model's own seed scatter, taken as the measured repeats' standard deviation s: "
                           "sigma' = sqrt(sigma^2 + s^2 / " + std::to_string(std::max(1, o.model_seeds)) + " model seeds)"
                         : "") +
         ". Uncertainty: local curvature (Gauss-Newton, "
         "Delta chi2 = 1); a parameter whose standard deviation exceeds " + number(100 * o.unidentified_fraction) +
         " % of its bounds or " + number(100 * o.unidentified_relative) + " % of its value is unidentified. Distinct minima: starts ending within Delta chi2 = " + number(o.noise_chi2) +
         " of the best and more than 3 sigma away from it.\n";
}

// The sentence on a parameter that the recordings do not identify.
std::string unidentifiedNote(const RowValues& p) {
  return "\n`" + csvText(p["pointer"]) + "` is not identified by these recordings (the objective is flat along it within the noise); "
         "the calibrated study carries the best point found, " + number(p.number("best_point")) + ", one of many that fit equally well.\n";
}

// The distinct minima of a stage (values in the order of its parameters).
std::string minimaText(const CalibrationResult& r) {
  std::string s;
  for (const auto& m : r.minima) {
    s += "- chi2 " + number(m.chi2) + ":";
    for (std::size_t i = 0; i < m.values.size(); ++i) {
      s += ' ';  // (" " + label trips GCC 12's false -Wrestrict positive)
      s += r.parameters[i].spec.label() + " = " + number(m.values[i]);
    }
    s += "\n";
  }
  return s;
}

std::string stageReport(const StageRow& stage, const std::vector<std::string>& plots) {
  const Section<ParameterRow> parameters = parameterSection("stage");
  const std::vector<ParameterRow> parameter_rows = stageParameterRows(stage);
  std::string s = "## " + stage.stage->title + "\n\n" + parameters.markdownOf(parameter_rows);
  for (const ParameterRow& p : parameter_rows) {
    const RowValues v = parameters.values(p);
    if (!v.flag("identified")) s += unidentifiedNote(v);
  }
  const RowValues v = stageSection().values(stage);
  const auto count = [&v](const char* column) { return csvText(v[column]); };
  s += "\nchi2 " + number(v.number("initial_chi2")) + " -> " + number(v.number("chi2")) + " over " + count("quantities") + " quantities. ";
  s += v.flag("unique") ? std::string("Unique: every start ended at the same minimum or one clearly worse.\n")
                        : "NOT unique: " + count("distinct_minima") + " distinct minima fit within the noise:\n\n" + minimaText(*stage.result);
  s += "\nModel runs " + count("model_runs") + " (cache hits " + count("cache_hits") + ", failed DEM runs " + count("failed_runs") +
       "), objective evaluations " + count("evaluations") + ", wall time " + number(v.number("wall_time_s")) + " s.\n\n" +
       residualSection().markdownOf(residualRows(stage));
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
  const std::vector<StageRow> rows = stageRows(c);
  nlohmann::json stages = nlohmann::json::array();
  int runs = 0, hits = 0, evaluations = 0;
  double wall = 0;
  for (const StageRow& row : rows) {
    stages.push_back(stageJson(row));
    runs += row.result->model_runs, hits += row.result->cache_hits, evaluations += row.result->evaluations;
    wall += row.result->wall_time_s;
  }
  // Per pointer, the last stage's fit of it (the value the calibrated study carries).
  nlohmann::json fitted = nlohmann::json::object();
  for (const nlohmann::json& p : parameterSection("stage").json(allStages<ParameterRow>(rows, stageParameterRows)))
    fitted[p.at("pointer").get<std::string>()] = {{"value", p.at("value")}, {"std_dev", p.at("std_dev")}, {"identified", p.at("identified")}};
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
  const std::vector<StageRow> rows = stageRows(c);
  std::string report = "# Calibration report\n\nObjective: " + objectiveText(options) + "\n";
  if (!renderer) report += "Plots were not drawn (--no-plots).\n\n";
  for (const StageRow& row : rows) {
    std::vector<std::string> plots;
    if (renderer)
      for (const auto& key : casesOfResult(*row.result)) {
        const std::string name = "plots/stage" + std::to_string(row.number) + "_" + key.label();
        renderer->render(caseFigure(key, *row.result, options.objective.analysis), out.stage(name + ".gp"), out.stage(name + ".svg"));
        plots.push_back(name + ".svg");
      }
    report += stageReport(row, plots);
  }
  out.writeText("report.md", report);
  out.writeText("stages.csv", stageSection().csv(rows));
  out.writeText("parameters.csv", parameterSection("stage").csv(allStages<ParameterRow>(rows, stageParameterRows)));
  out.writeText("residuals.csv", residualSection().csv(allStages<ResidualRow>(rows, residualRows)));
  out.writeText("calibration.json", toJson(c, options).dump(2) + "\n");
}

}  // namespace demfem::campaign
