// Outputs of a diagnosis (diagnose.hpp): JSON, report.md, extended_study.json, the tables ranking.csv
// and parameters.csv (report sections: each column declared once, the Markdown tables and the JSON
// document generated from the same declaration), before/after plots.
#include "demfem/campaign/diagnose.hpp"

#include "demfem/analysis/report_section.hpp"

#include "parameter_section.hpp"

#include <algorithm>
#include <cmath>

namespace demfem::campaign {
namespace {

using namespace analysis::report;


// "label = value +- sigma; ..." of a model's fitted parameters, from the parameter table's values.
std::string fittedValues(const ModelFit& m) {
  const Section<ParameterRow> section = parameterSection("model");
  std::string values;
  for (const ParameterRow& row : parameterRows(m.id(), m.parameters)) {
    const RowValues p = section.values(row);
    values += (values.empty() ? "" : "; ") + csvText(p["label"]) + " = " +
              (p.flag("identified") ? shortNum(p.number("value")) + " +- " + shortNum(p.number("std_dev"), 2) : std::string("unidentified"));
  }
  return values;
}

// models.csv (and `models` of the JSON, each with its `causes` and `parameters`): the calibrated
// baseline, then the models most probable first.
const Section<const ModelFit*>& modelSection() {
  using R = const ModelFit*;
  static const Section<R> section{
      {{"id", [](R m) -> CellValue { return m->id(); }},
       {"log_evidence", [](R m) -> CellValue { return m->log_evidence; }},
       {"probability", [](R m) -> CellValue { return m->probability; }},
       {"ln_bayes_factor", [](R m) -> CellValue { return m->ln_bayes_factor; }},
       {"log_likelihood", [](R m) -> CellValue { return m->log_likelihood; }},
       {"log_occam", [](R m) -> CellValue { return m->log_occam; }},
       {"chi2", [](R m) -> CellValue { return m->chi2; }},
       {"significant_residuals", [](R m) -> CellValue { return static_cast<long long>(m->significant); }},
       {"unique_fit", [](R m) -> CellValue { return m->minima == 1; }},
       {"held_out", [](R m) -> CellValue { return m->heldOut(); }},
       {"held_out_folds", [](R m) -> CellValue { return static_cast<long long>(m->held_out_folds); }},
       {"split", [](R m) -> CellValue { return m->split; }},
       {"error_before_percent", [](R m) -> CellValue { return m->error_before_percent; }},
       {"error_after_percent", [](R m) -> CellValue { return m->error_after_percent; }},
       {"noise_error_percent", [](R m) -> CellValue { return m->noise_error_percent; }},
       {"gain_percent", [](R m) -> CellValue { return m->gain_percent; }},
       {"held_out_chi2_before", [](R m) -> CellValue { return m->held_out_chi2_before; }},
       {"held_out_chi2_after", [](R m) -> CellValue { return m->held_out_chi2_after; }},
       {"chi2_gain_percent", [](R m) -> CellValue { return m->chi2_gain_percent; }},
       {"model_runs", [](R m) -> CellValue { return static_cast<long long>(m->model_runs); }},
       {"wall_time_s", [](R m) -> CellValue { return m->wall_time_s; }},
       {"fitted_values", [](R m) -> CellValue { return fittedValues(*m); }, Output::MarkdownOnly}},
      [](R m) { return "`" + m->id() + "`"; },
      {{"probability", md::number("probability", 3)},
       {"ln B vs baseline", md::number("ln_bayes_factor", 3)},
       {"significant residuals", md::text("significant_residuals")},
       {"held-out error before -> after (%)", md::concat({md::number("error_before_percent", 3), md::literal(" -> "), md::number("error_after_percent", 3)})},
       {"gain (%)", md::number("gain_percent", 3)},
       {"held-out chi2 before -> after", md::concat({md::number("held_out_chi2_before", 3), md::literal(" -> "), md::number("held_out_chi2_after", 3)})},
       {"fitted values (+- one sigma)", md::text("fitted_values")},
       {"split", md::text("split")}},
      "model"};
  return section;
}

std::vector<const ModelFit*> modelRows(const Diagnosis& d) {
  std::vector<const ModelFit*> rows{&d.baseline};
  for (const ModelFit& m : d.models) rows.push_back(&m);
  return rows;
}

// localisation.csv (and `localisation` of the JSON): the calibrated baseline's residuals tested.
const Section<Localisation>& localisationSection() {
  using R = Localisation;
  static const Section<R> section{
      {{"case", [](const R& l) -> CellValue { return l.key.title(); }},
       {"quantity", [](const R& l) -> CellValue { return l.quantity; }},
       {"measured", [](const R& l) -> CellValue { return l.measured; }},
       {"simulated", [](const R& l) -> CellValue { return l.simulated; }},
       {"sigma", [](const R& l) -> CellValue { return l.sigma; }},
       {"residual_percent", [](const R& l) -> CellValue { return l.residual_percent; }},
       {"z", [](const R& l) -> CellValue { return l.z; }},
       {"p_value", [](const R& l) -> CellValue { return l.p_value; }},
       {"significant", [](const R& l) -> CellValue { return l.significant; }}},
      [](const R& l) { return l.key.title(); },
      {{"quantity", md::text("quantity")},
       {"residual (%)", md::number("residual_percent", 3)},
       {"z", md::number("z", 3)},
       {"significant", md::onlyIf("significant", md::literal("**yes**"), "no")}},
      "case"};
  return section;
}

// phase_localisation.csv (and `phase_localisation` of the JSON): soil-bin residuals per stroke phase.
const Section<PhaseLocalisation>& phaseSection() {
  using R = PhaseLocalisation;
  static const Section<R> section{
      {{"case", [](const R& l) -> CellValue { return l.key.title(); }},
       {"model", [](const R& l) -> CellValue { return l.model; }},
       {"phase", [](const R& l) -> CellValue { return l.phase; }},
       {"measured_N", [](const R& l) -> CellValue { return l.measured_N; }},
       {"simulated_N", [](const R& l) -> CellValue { return l.simulated_N; }},
       {"sigma_N", [](const R& l) -> CellValue { return l.sigma_N; }},
       {"residual_percent", [](const R& l) -> CellValue { return l.residual_percent; }},
       {"z", [](const R& l) -> CellValue { return l.z; }},
       {"p_value", [](const R& l) -> CellValue { return l.p_value; }},
       {"significant", [](const R& l) -> CellValue { return l.significant; }}},
      [](const R& l) { return l.key.title(); },
      {{"model", md::text("model")},
       {"phase", md::text("phase")},
       {"measured (N)", md::number("measured_N", 4)},
       {"simulated (N)", md::number("simulated_N", 4)},
       {"residual (%)", md::number("residual_percent", 3)},
       {"z", md::number("z", 3)},
       {"significant", md::onlyIf("significant", md::literal("**yes**"), "no")}},
      "case"};
  return section;
}

// calibration_shifts.csv (and `calibration_shifts` of the JSON): step 6 of diagnose.hpp.
const Section<CalibrationShift>& shiftSection() {
  using R = CalibrationShift;
  static const Section<R> section{
      {{"pointer", [](const R& s) -> CellValue { return s.spec.pointer; }},
       {"label", [](const R& s) -> CellValue { return s.spec.label(); }},
       {"study_value", [](const R& s) -> CellValue { return s.study_value; }},
       {"fitted", [](const R& s) -> CellValue { return s.fitted; }},
       {"std_dev", [](const R& s) -> CellValue { return s.std_dev; }},
       {"model_form_shift", [](const R& s) -> CellValue { return s.model_form_shift; }},
       {"shift_percent", [](const R& s) -> CellValue { return s.shift_percent; }},
       {"z", [](const R& s) -> CellValue { return s.z; }},
       {"p_value", [](const R& s) -> CellValue { return s.p_value; }},
       {"significant", [](const R& s) -> CellValue { return s.significant; }},
       {"cause", [](const R& s) -> CellValue { return s.cause; }}},
      [](const R& s) { return "`" + s.spec.label() + "`"; },
      {{"study", md::number("study_value", 4)},
       {"calibrated", md::number("fitted", 4)},
       {"shift (%)", md::number("shift_percent", 3)},
       {"z", md::number("z", 3)},
       {"significant", md::onlyIf("significant", md::literal("**yes**"), "no")},
       {"cause", md::text("cause")}},
      "parameter"};
  return section;
}

std::vector<ParameterRow> modelParameterRows(const ModelFit& m) { return parameterRows(m.id(), m.parameters); }

// Calibrated channels of a recording (raw ones through their factors).
std::pair<std::vector<double>, std::vector<double>> channels(const analysis::Recording& r) {
  const bool raw = r.format == analysis::RecordingFormat::Raw;
  std::vector<double> force, deformation;
  for (std::size_t i = 0; i < r.size(); ++i) {
    force.push_back(r.force[i] * (raw ? r.force_factor_N_per_unit : 1.0));
    deformation.push_back(r.deformation[i] * (raw ? r.deformation_factor_mm_per_unit : 1.0));
  }
  return {force, deformation};
}

const analysis::Recording* runOf(const std::vector<analysis::Recording>& runs, const analysis::CaseKey& key) {
  for (const auto& r : runs)
    if (r.key == key) return &r;
  return nullptr;
}

// Measured (first repeat), the model as given, the calibrated baseline and the named model of one
// case: force and deformation against time as recorded.
analysis::Figure caseFigure(const analysis::Recording& measured, const analysis::Recording* nominal, const analysis::Recording* baseline,
                            const analysis::Recording* extended, const std::string& extension) {
  analysis::Figure figure;
  figure.title = measured.key.title() + ": measured, model as given, calibrated baseline" + (extended ? ", extended by " + extension : "");
  for (int channel = 0; channel < 2; ++channel) {
    analysis::XYPanel panel;
    panel.x_label = "t (s)";
    panel.y_label = channel == 0 ? "force (N)" : "deformation (mm)";
    panel.key_position = "bottom right";
    const auto add = [&](const analysis::Recording& r, const std::string& title, const char* color, analysis::SeriesStyle style) {
      const auto [force, deformation] = channels(r);
      panel.series.push_back({title, r.time_s, channel == 0 ? force : deformation, color, style, 1.5});
    };
    add(measured, "measured", analysis::kMeasuredColor, analysis::SeriesStyle::Line);
    if (nominal) add(*nominal, "model as given", analysis::kRepeatColor, analysis::SeriesStyle::DashedLine);
    if (baseline) add(*baseline, "calibrated baseline", analysis::kRepeatColor, analysis::SeriesStyle::Line);
    if (extended) add(*extended, "extended: " + extension, analysis::kSimulatedColor, analysis::SeriesStyle::Line);
    figure.panels.push_back(panel);
  }
  return figure;
}

std::string signatureTable(const analysis::Signatures& s) {
  std::string md;
  if (!s.weight_drops.empty()) {
    md += analysis::weightDropSignatureSection().markdownOf(s.weight_drops);
    if (s.weight_relations.defined)
      md += "\nAcross the weights (heaviest minus lightest): force ratio " + shortNum(s.weight_relations.force_ratio_change) +
            ", deformation ratio " + shortNum(s.weight_relations.deformation_ratio_change) + ", damping difference " +
            shortNum(s.weight_relations.damping_difference_change) + "; frequency ratio^2 x deformation ratio " +
            shortNum(s.weight_relations.stiffness_consistency) + " (1 for a pure stiffness error).\n";
  }
  if (!s.soil_bins.empty()) {
    md += "\n" + analysis::soilBinSignatureSection().markdownOf(s.soil_bins);
    if (s.force_bias_per_depth_percent_per_mm) md += "\nForce bias against depth: " + shortNum(*s.force_bias_per_depth_percent_per_mm) + " % per mm.\n";
  }
  return md;
}

nlohmann::json caseLabels(const std::vector<analysis::CaseKey>& cases) {
  nlohmann::json labels = nlohmann::json::array();
  for (const auto& c : cases) labels.push_back(c.label());
  return labels;
}

// Each soil quantity's spread over the baseline's deposition seeds (the model's own scatter).
nlohmann::json seedScatterJson(const std::vector<SeedScatter>& scatter) {
  nlohmann::json out = nlohmann::json::array();
  for (const SeedScatter& s : scatter) out.push_back({{"case", s.key.title()}, {"quantity", s.quantity}, {"sd", s.sd}, {"seeds", s.seeds}});
  return out;
}

nlohmann::json unjudgedJson(const std::vector<UnjudgedQuantity>& unjudged) {
  nlohmann::json out = nlohmann::json::array();
  for (const UnjudgedQuantity& u : unjudged) out.push_back({{"quantity", u.quantity}, {"baseline_error_percent", u.baseline_error_percent}});
  return out;
}

// What no cause was judged on, for report.md ("" when every quantity was).
std::string unjudgedText(const std::vector<UnjudgedQuantity>& unjudged) {
  if (unjudged.empty()) return "";
  std::string md = "Not judged (no cause considered moves these quantities; docs/diagnosis.md): ";
  for (std::size_t i = 0; i < unjudged.size(); ++i)
    md += (i ? ", " : "") + ("`" + unjudged[i].quantity + "` (baseline error " + shortNum(unjudged[i].baseline_error_percent) + " %)");
  return md + ".\n\n";
}

// Per quantity the model-form tolerance in percent ("" for every other quantity).
nlohmann::json modelFormJson(const DiagnosisSettings& settings) {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& [quantity, percent] : settings.model_form_percent) out[quantity.empty() ? "other" : quantity] = percent;
  return out;
}

std::string modelFormText(const DiagnosisSettings& settings) {
  std::string text;
  for (const auto& [quantity, percent] : settings.model_form_percent)
    if (!quantity.empty()) text += shortNum(percent) + " % for " + quantity + ", ";
  return text + shortNum(modelFormPercent(settings, "")) + " % for the other quantities";
}

const ModelFit* namedModel(const Diagnosis& d) { return d.named_model ? &d.models[*d.named_model] : nullptr; }

std::string joinedIds(const std::vector<std::string>& ids) {
  std::string text;
  for (const std::string& id : ids) text += (text.empty() ? "" : "+") + id;
  return text;
}

std::string verdictSentence(const Diagnosis& d) {
  switch (d.verdict) {
    case Verdict::NoSignificantDiscrepancy:
      return "**No significant discrepancy**: " + d.reason + ".";
    case Verdict::Cause:
      return "**Cause: `" + joinedIds(d.causes) + "`** - " + d.reason + ".";
    case Verdict::UnexplainedDiscrepancy:
      return "**Unexplained discrepancy**: " + d.reason + ".";
  }
  return d.reason;
}

}  // namespace

nlohmann::json toJson(const Diagnosis& d, const DiagnosisSettings& settings, const std::string& extended_study_path) {
  nlohmann::json models = nlohmann::json::array();
  for (const ModelFit* m : modelRows(d)) {
    nlohmann::json model = modelSection().json(m);
    model["causes"] = m->causes;
    model["parameters"] = parameterSection("model").json(modelParameterRows(*m));
    models.push_back(model);
  }
  nlohmann::json localisation = nlohmann::json::array();
  for (const Localisation& l : d.localisation) localisation.push_back(localisationSection().json(l));
  nlohmann::json phases = nlohmann::json::array();
  for (const PhaseLocalisation& l : d.phases) phases.push_back(phaseSection().json(l));
  nlohmann::json shifts = nlohmann::json::array();
  for (const CalibrationShift& c : d.shifts) shifts.push_back(shiftSection().json(c));
  nlohmann::json considered = nlohmann::json::array();
  for (const CauseEvidence& c : d.considered)
    considered.push_back({{"id", c.id}, {"signature_present", c.match.plausible}, {"evidence", c.match.evidence}, {"judged_on", c.judged_on}});
  return {{"verdict", verdictText(d.verdict)},
          {"causes", d.causes},
          {"cause", d.causes.empty() ? nlohmann::json(nullptr) : nlohmann::json(d.causes.front())},
          {"reason", d.reason},
          {"gain_percent", d.gain_percent},
          {"localisation", localisation},
          {"calibration_shifts", shifts},
          {"phase_localisation", phases},
          {"models", models},
          {"nominal_error_percent", d.nominal_error_percent},
          {"failed_baseline_cases", caseLabels(d.failed_baseline_cases)},
          {"seed_scatter", seedScatterJson(d.seed_scatter)},
          {"settings",
           {{"model_form_percent", modelFormJson(settings)},
            {"significance_level", settings.significance_level},
            {"min_ln_bayes_factor", settings.min_ln_bayes_factor},
            {"min_gain_percent", settings.min_gain_percent},
            {"min_held_out_folds", settings.min_held_out_folds},
            {"pairs", settings.pairs},
            {"all_pairs", settings.all_pairs},
            {"scatter_seeds", settings.scatter_seeds}}},
          {"considered", considered},
          {"unjudged", unjudgedJson(d.unjudged)},
          {"signatures", analysis::toJson(d.signatures)},
          {"extended_study", extended_study_path},
          {"wall_time_s", d.wall_time_s}};
}

void writeDiagnosis(const Diagnosis& d, const DiagnosisSettings& settings, analysis::StagedOutput& out,
                    const analysis::GnuplotRenderer* renderer) {
  out.writeText("extended_study.json", d.extended_study.dump(2) + "\n");
  std::string md = "# Diagnosis\n\n" + verdictSentence(d) + "\n\n";
  md += "Test: each residual of the calibrated baseline as z = (sim - meas) / sigma, sigma from the measured scatter, the model's seed "
        "scatter and a model-form tolerance (" + modelFormText(settings) + "); Holm's step-down at a "
        "family-wise level of " + shortNum(settings.significance_level) + ". A model is named when ln B >= " +
        shortNum(settings.min_ln_bayes_factor) + " over the calibrated baseline, no residual is left significant and, where a split "
        "identifies it, it cuts the held-out chi2 by at least " + shortNum(settings.min_gain_percent) + " % (docs/diagnosis.md).\n\n";
  md += "The study as given: error " + shortNum(d.nominal_error_percent) + " % (RMS of 100 (sim - meas) / meas over every quantity of every case).\n\n";
  if (!d.failed_baseline_cases.empty())
    md += "Left out of every error and test: the cases whose nominal run failed (DEM blow-up): " + caseLabels(d.failed_baseline_cases).dump() + ".\n\n";
  md += unjudgedText(d.unjudged);
  md += "## Where the residual lives (calibrated baseline)\n\n" + localisationSection().markdownOf(d.localisation);
  if (!d.phases.empty())
    md += "\n## Along the stroke (soil-bin runs)\n\nMean force per phase of the stroke (insertion: before the window; end of stroke: "
          "after it), the study as given (whole stroke) and the calibrated baseline (its fits' runs); Holm per model at the same level. "
          "Reported, not part of the verdict.\n\n" + phaseSection().markdownOf(d.phases);
  md += "\n## Calibration shifts (" + std::string(namedModel(d) ? "the named model" : "the calibrated baseline") +
        ")\n\nThe baseline's parameters against the study's values, z = (calibrated - study) / sigma, Holm at the same level; a "
        "significant shift of a parameter one cause owns names that cause.\n\n" + shiftSection().markdownOf(d.shifts);
  md += "\n## Model probabilities\n\nLaplace evidence, equal prior odds; held-out errors against the calibrated baseline's folds.\n\n" +
        modelSection().markdownOf(modelRows(d));
  md += "\n## Signatures (the study as given)\n\n" + signatureTable(d.signatures) + "\n## Causes considered\n\n";
  for (const CauseEvidence& c : d.considered)
    md += "- `" + c.id + "` (" + c.description + "): expects " + c.expected_signature + ". Signature " + (c.match.plausible ? "present" : "absent") +
          ": " + c.match.evidence + ".\n";
  md += "\n## Before and after\n\n";
  const ModelFit* named = namedModel(d);
  if (!renderer) md += "Plots were not drawn (--no-plots).\n";
  std::vector<analysis::CaseKey> done;
  for (const analysis::Recording& m : d.measured) {
    if (std::find(done.begin(), done.end(), m.key) != done.end()) continue;
    done.push_back(m.key);
    if (!renderer) continue;
    const std::string name = "plots/" + m.key.label();
    renderer->render(caseFigure(m, runOf(d.nominal_runs, m.key), runOf(d.baseline.runs, m.key), named ? runOf(named->runs, m.key) : nullptr,
                                named ? named->id() : ""),
                     out.stage(name + ".gp"), out.stage(name + ".svg"));
    md += "![" + m.key.title() + "](" + name + ".svg)\n\n";
  }
  md += "\n## Extended study\n\n`extended_study.json`: " +
        (named ? "the study extended by " + named->id() + " (" + fittedValues(*named) + ")"
               : "the calibrated baseline (" + fittedValues(d.baseline) + ")") + ".\n";
  md += "\nWall time " + shortNum(d.wall_time_s, 3) + " s.\n";
  out.writeText("report.md", md);
  std::vector<ParameterRow> parameters;
  for (const ModelFit* m : modelRows(d))
    for (const ParameterRow& p : modelParameterRows(*m)) parameters.push_back(p);
  out.writeText("weight_signatures.csv", analysis::weightDropSignatureSection().csv(d.signatures.weight_drops));
  out.writeText("soil_signatures.csv", analysis::soilBinSignatureSection().csv(d.signatures.soil_bins));
  out.writeText("localisation.csv", localisationSection().csv(d.localisation));
  out.writeText("calibration_shifts.csv", shiftSection().csv(d.shifts));
  out.writeText("phase_localisation.csv", phaseSection().csv(d.phases));
  out.writeText("models.csv", modelSection().csv(modelRows(d)));
  out.writeText("parameters.csv", parameterSection("model").csv(parameters));
}

}  // namespace demfem::campaign
