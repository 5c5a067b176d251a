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


// One cause of the ranking; fitted causes carry their rank (from 1).
struct CauseRow {
  std::optional<long long> rank;
  const CauseResult* cause;
};

// A fitted cause's number; absent (null, "nan") for a cause that was not fitted.
CellValue ifFitted(const CauseResult& c, double value) { return c.fitted ? std::optional<double>(value) : std::nullopt; }

// "label = value +- sigma; ..." of a cause's fitted parameters, from the parameter table's values.
std::string fittedValues(const CauseResult& c) {
  const Section<ParameterRow> section = parameterSection("cause");
  std::string values;
  for (const ParameterRow& row : parameterRows(c.id, c.parameters)) {
    const RowValues p = section.values(row);
    values += (values.empty() ? "" : "; ") + csvText(p["label"]) + " = " +
              (p.flag("identified") ? shortNum(p.number("value")) + " +- " + shortNum(p.number("std_dev"), 2) : std::string("unidentified"));
  }
  return values;
}

// The quantities a cause is fitted and judged on, space-separated ("all" for every quantity of its domain).
std::string judgedOn(const CauseResult& c) {
  std::string names;
  for (const std::string& q : c.judged_on) names += (names.empty() ? "" : " ") + q;
  return names.empty() ? std::string("all") : names;
}

// "yes", or how many distinct minima fit within the noise.
std::string uniqueness(const RowValues& v) {
  return v.flag("unique_fit") ? std::string("yes") : "no: " + csvText(v["distinct_minima"]) + " distinct minima within the noise";
}

// ranking.csv (and `ranking` of the JSON, each cause with its `parameters`): the causes in rank order.
const Section<CauseRow>& rankingSection() {
  using R = CauseRow;
  const auto whenFitted = [](MarkdownCell cell) { return md::onlyIf("fitted", std::move(cell), ""); };
  static const Section<R> section{
      {{"rank", [](const R& r) -> CellValue { return r.rank ? std::optional<double>(static_cast<double>(*r.rank)) : std::nullopt; }},
       {"id", [](const R& r) -> CellValue { return r.cause->id; }},
       {"plausible", [](const R& r) -> CellValue { return r.cause->match.plausible; }},
       {"fitted", [](const R& r) -> CellValue { return r.cause->fitted; }},
       {"unique_fit", [](const R& r) -> CellValue { return r.cause->fitted && r.cause->minima == 1; }},
       {"distinct_minima", [](const R& r) -> CellValue { return static_cast<long long>(r.cause->minima); }},
       {"held_out", [](const R& r) -> CellValue { return r.cause->held_out; }},
       {"held_out_folds", [](const R& r) -> CellValue { return static_cast<long long>(r.cause->held_out_folds); }},
       {"split", [](const R& r) -> CellValue { return r.cause->split; }},
       {"error_before_percent", [](const R& r) -> CellValue { return ifFitted(*r.cause, r.cause->error_before_percent); }},
       {"error_after_percent", [](const R& r) -> CellValue { return ifFitted(*r.cause, r.cause->error_after_percent); }},
       {"noise_error_percent", [](const R& r) -> CellValue { return ifFitted(*r.cause, r.cause->noise_error_percent); }},
       {"gain_percent", [](const R& r) -> CellValue { return ifFitted(*r.cause, r.cause->gain_percent); }},
       {"chi2", [](const R& r) -> CellValue { return ifFitted(*r.cause, r.cause->chi2); }},
       {"bic", [](const R& r) -> CellValue { return ifFitted(*r.cause, r.cause->bic); }},
       {"delta_bic", [](const R& r) -> CellValue { return ifFitted(*r.cause, r.cause->delta_bic); }},
       {"model_runs", [](const R& r) -> CellValue { return static_cast<long long>(r.cause->model_runs); }},
       {"wall_time_s", [](const R& r) -> CellValue { return r.cause->wall_time_s; }},
       {"description", [](const R& r) -> CellValue { return r.cause->description; }},
       {"expected_signature", [](const R& r) -> CellValue { return r.cause->expected_signature; }},
       {"judged_on", [](const R& r) -> CellValue { return judgedOn(*r.cause); }},
       {"evidence", [](const R& r) -> CellValue { return r.cause->match.evidence; }},
       {"fitted_values", [](const R& r) -> CellValue { return fittedValues(*r.cause); }, Output::MarkdownOnly}},
      [](const R& r) { return r.rank ? std::to_string(*r.rank) : std::string("-"); },
      {{"cause", md::text("id")},
       {"fitted values (+- one sigma)", md::onlyIf("fitted", md::text("fitted_values"), "not fitted: signature absent")},
       {"unique", whenFitted(uniqueness)},
       {"error before (%)", whenFitted(md::number("error_before_percent"))},
       {"error after (%)", whenFitted(md::number("error_after_percent"))},
       {"gain (%)", whenFitted(md::number("gain_percent"))},
       {"delta BIC", whenFitted(md::number("delta_bic"))},
       {"split", whenFitted(md::text("split"))}},
      "rank"};
  return section;
}

std::vector<CauseRow> rankingRows(const Diagnosis& d) {
  std::vector<CauseRow> rows;
  long long rank = 0;
  for (const CauseResult& c : d.ranking) rows.push_back({c.fitted ? std::optional<long long>(++rank) : std::nullopt, &c});
  return rows;
}

std::vector<ParameterRow> causeParameterRows(const CauseRow& row) { return parameterRows(row.cause->id, row.cause->parameters); }

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

// Measured (first repeat), baseline and extended model of one case: force and deformation (or, for
// soil-bin runs, against time as recorded).
analysis::Figure caseFigure(const analysis::Recording& measured, const analysis::Recording* baseline, const analysis::Recording* extended,
                            const std::string& extension) {
  analysis::Figure figure;
  figure.title = measured.key.title() + ": measured, model as given, model extended by " + extension;
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
    if (baseline) add(*baseline, "model as given", analysis::kRepeatColor, analysis::SeriesStyle::DashedLine);
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
  std::string md = "Not explained by any cause considered (none is judged on these quantities; docs/diagnosis.md): ";
  for (std::size_t i = 0; i < unjudged.size(); ++i)
    md += (i ? ", " : "") + ("`" + unjudged[i].quantity + "` (baseline error " + shortNum(unjudged[i].baseline_error_percent) + " %)");
  return md + ".\n\n";
}

}  // namespace

nlohmann::json toJson(const Diagnosis& d, const DiagnosisSettings& settings, const std::string& extended_study_path) {
  nlohmann::json ranking = nlohmann::json::array();
  for (const CauseRow& row : rankingRows(d)) {
    nlohmann::json cause = rankingSection().json(row);
    cause["parameters"] = parameterSection("cause").json(causeParameterRows(row));
    ranking.push_back(cause);
  }
  return {{"verdict", d.cause ? "cause" : "no significant discrepancy"},
          {"cause", d.cause ? nlohmann::json(*d.cause) : nlohmann::json(nullptr)},
          {"reason", d.reason},
          {"gain_percent", d.gain_percent},
          {"baseline_error_percent", d.baseline_error_percent},
          {"baseline_chi2", d.baseline_chi2},
          {"failed_baseline_cases", caseLabels(d.failed_baseline_cases)},
          {"seed_scatter", seedScatterJson(d.seed_scatter)},
          {"noise_error_percent", d.noise_error_percent},
          {"residuals", d.residual_count},
          {"thresholds",
           {{"min_error_percent", settings.min_error_percent},
            {"min_gain_percent", settings.min_gain_percent},
            {"min_delta_bic", settings.min_delta_bic},
            {"min_held_out_folds", settings.min_held_out_folds},
            {"scatter_seeds", settings.scatter_seeds}}},
          {"ranking", ranking},
          {"unjudged", unjudgedJson(d.unjudged)},
          {"signatures", analysis::toJson(d.signatures)},
          {"extended_study", extended_study_path},
          {"wall_time_s", d.wall_time_s}};
}

void writeDiagnosis(const Diagnosis& d, const DiagnosisSettings& settings, analysis::StagedOutput& out,
                    const analysis::GnuplotRenderer* renderer) {
  out.writeText("extended_study.json", d.extended_study.dump(2) + "\n");
  std::string md = "# Diagnosis\n\n";
  md += "**Verdict: " + (d.cause ? "cause `" + *d.cause + "`" : std::string("no significant discrepancy")) + "** - " + d.reason + ".\n\n";
  if (d.cause) md += "Held-out error cut by the extension: " + shortNum(d.gain_percent) + " %. The extended study is `extended_study.json`.\n\n";
  md += "Baseline (the study as given) against all cases: error " + shortNum(d.baseline_error_percent) + " % (RMS of 100 (sim - meas) / meas " +
        "over every quantity of every case), chi2 " + shortNum(d.baseline_chi2) + " over " + std::to_string(d.residual_count) + " residuals.\n\n";
  md += "Noise: a correct model would show an error of " + shortNum(d.noise_error_percent) + " % from the measured scatter" +
        (d.seed_scatter.empty() ? std::string() : " and the model's own seed scatter (the baseline at " + std::to_string(settings.scatter_seeds) +
                                                      " deposition seeds), which also widens the sigma of every BIC") +
        "; an error below it is not counted as gain (docs/diagnosis.md).\n\n";
  if (!d.failed_baseline_cases.empty())
    md += "Left out of every error and BIC: the cases whose baseline run failed (DEM blow-up): " +
          caseLabels(d.failed_baseline_cases).dump() + ".\n\n";
  md += unjudgedText(d.unjudged);
  md += "Thresholds: a cause is named when the baseline error is at least " + shortNum(settings.min_error_percent) +
        " %, its extension cuts the held-out error by at least " + shortNum(settings.min_gain_percent) +
        " % and lowers BIC = chi2 + k ln n by at least " + shortNum(settings.min_delta_bic) + ", predicting at least " +
        std::to_string(settings.min_held_out_folds) + " held-out cases (docs/diagnosis.md).\n\n";
  md += "## Signatures\n\n" + signatureTable(d.signatures) + "\n## Ranking\n\n" + rankingSection().markdownOf(rankingRows(d)) + "\n## Evidence\n\n";
  for (const CauseResult& c : d.ranking)
    md += "- `" + c.id + "` (" + c.description + "): expects " + c.expected_signature + "; fitted and judged on " + judgedOn(c) +
          " quantities. " + (c.match.plausible ? "Present" : "Absent") + ": " + c.match.evidence + ".\n";
  md += "\n## Plots\n\n";
  const CauseResult* shown = d.ranking.empty() || !d.ranking.front().fitted ? nullptr : &d.ranking.front();
  if (!renderer) md += "Plots were not drawn (--no-plots).\n";
  std::vector<analysis::CaseKey> done;
  for (const analysis::Recording& m : d.measured) {
    if (std::find(done.begin(), done.end(), m.key) != done.end()) continue;
    done.push_back(m.key);
    if (!renderer) continue;
    const std::string name = "plots/" + m.key.label();
    renderer->render(caseFigure(m, runOf(d.baseline_runs, m.key), shown ? runOf(shown->runs, m.key) : nullptr, shown ? shown->id : "none"),
                     out.stage(name + ".gp"), out.stage(name + ".svg"));
    md += "![" + m.key.title() + "](" + name + ".svg)\n\n";
  }
  md += "\nWall time " + shortNum(d.wall_time_s, 3) + " s.\n";
  out.writeText("report.md", md);
  const std::vector<CauseRow> rows = rankingRows(d);
  std::vector<ParameterRow> parameters;
  for (const CauseRow& row : rows)
    for (const ParameterRow& p : causeParameterRows(row)) parameters.push_back(p);
  out.writeText("weight_signatures.csv", analysis::weightDropSignatureSection().csv(d.signatures.weight_drops));
  out.writeText("soil_signatures.csv", analysis::soilBinSignatureSection().csv(d.signatures.soil_bins));
  out.writeText("ranking.csv", rankingSection().csv(rows));
  out.writeText("parameters.csv", parameterSection("cause").csv(parameters));
}

}  // namespace demfem::campaign
