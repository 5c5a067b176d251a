// Outputs of a diagnosis (diagnose.hpp): JSON, report.md, extended_study.json, before/after plots.
#include "demfem/campaign/diagnose.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace demfem::campaign {
namespace {

nlohmann::json finiteOrNull(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

std::string number(double v, int precision = 4) {
  std::ostringstream out;
  out.precision(precision);
  out << v;
  return out.str();
}

nlohmann::json parametersJson(const std::vector<FittedParameter>& parameters) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& p : parameters)
    out.push_back({{"pointer", p.spec.pointer},
                   {"lo", p.spec.lo},
                   {"hi", p.spec.hi},
                   {"initial", p.initial},
                   {"value", p.value ? nlohmann::json(*p.value) : nlohmann::json(nullptr)},
                   {"std_dev", finiteOrNull(p.std_dev)},
                   {"identified", p.identified}});
  return out;
}

nlohmann::json causeJson(const CauseResult& c) {
  nlohmann::json j{{"id", c.id},
                   {"description", c.description},
                   {"expected_signature", c.expected_signature},
                   {"plausible", c.match.plausible},
                   {"evidence", c.match.evidence},
                   {"fitted", c.fitted}};
  if (!c.fitted) return j;
  j["parameters"] = parametersJson(c.parameters);
  j["unique_fit"] = c.minima == 1;
  j["held_out"] = c.held_out;
  j["split"] = c.split;
  j["error_before_percent"] = c.error_before_percent;
  j["error_after_percent"] = c.error_after_percent;
  j["noise_error_percent"] = c.noise_error_percent;
  j["gain_percent"] = c.gain_percent;
  j["chi2"] = c.chi2;
  j["bic"] = c.bic;
  j["delta_bic"] = c.delta_bic;
  j["model_runs"] = c.model_runs;
  j["wall_time_s"] = c.wall_time_s;
  return j;
}

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
    md += "| weight | force ratio | deformation ratio | force per weight meas / sim (N/kg) | frequency ratio | damping ratio difference |\n"
          "| --- | --- | --- | --- | --- | --- |\n";
    for (const auto& w : s.weight_drops)
      md += "| " + number(w.key.mass_kg) + " kg | " + number(w.force_ratio.value) + " +- " + number(w.force_ratio.std_error, 2) + " | " +
            number(w.deformation_ratio.value) + " +- " + number(w.deformation_ratio.std_error, 2) + " | " +
            number(w.force_per_weight_measured_N_per_kg) + " / " + number(w.force_per_weight_simulated_N_per_kg) + " | " +
            number(w.frequency_ratio.value) + " +- " + number(w.frequency_ratio.std_error, 2) + " | " + number(w.damping_difference.value) +
            " +- " + number(w.damping_difference.std_error, 2) + " |\n";
    if (s.weight_relations.defined)
      md += "\nAcross the weights (heaviest minus lightest): force ratio " + number(s.weight_relations.force_ratio_change) +
            ", deformation ratio " + number(s.weight_relations.deformation_ratio_change) + ", damping difference " +
            number(s.weight_relations.damping_difference_change) + "; frequency ratio^2 x deformation ratio " +
            number(s.weight_relations.stiffness_consistency) + " (1 for a pure stiffness error).\n";
  }
  if (!s.soil_bins.empty()) {
    md += "\n| depth | force bias (%) | deformation bias (%) | end rise sim - meas | fluctuation ratio | spectral slope meas / sim |\n"
          "| --- | --- | --- | --- | --- | --- |\n";
    for (const auto& b : s.soil_bins)
      md += "| " + number(b.key.depth_mm) + " mm | " + number(b.force_bias_percent) + " | " + number(b.deformation_bias_percent) + " | " +
            number(b.end_rise_difference) + " | " + number(b.fluctuation_ratio) + " | " + number(b.spectral_slope_measured) + " / " +
            number(b.spectral_slope_simulated) + " |\n";
    if (s.force_bias_per_depth_percent_per_mm) md += "\nForce bias against depth: " + number(*s.force_bias_per_depth_percent_per_mm) + " % per mm.\n";
  }
  return md;
}

std::string rankingTable(const Diagnosis& d) {
  std::string md = "| rank | cause | fitted values (+- one sigma) | unique | error before (%) | error after (%) | gain (%) | delta BIC | split |\n"
                   "| --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
  int rank = 0;
  for (const CauseResult& c : d.ranking) {
    if (!c.fitted) {
      md += "| - | " + c.id + " | not fitted: signature absent | | | | | | |\n";
      continue;
    }
    std::string values;
    for (const auto& p : c.parameters)
      values += (values.empty() ? "" : "; ") + p.spec.label() + " = " +
                (p.value ? number(*p.value) + " +- " + number(p.std_dev, 2) : std::string("unidentified"));
    const std::string unique = c.minima == 1 ? "yes" : "no: " + std::to_string(c.minima) + " distinct minima within the noise";
    md += "| " + std::to_string(++rank) + " | " + c.id + " | " + values + " | " + unique + " | " + number(c.error_before_percent) + " | " +
          number(c.error_after_percent) + " | " + number(c.gain_percent) + " | " + number(c.delta_bic) + " | " + c.split + " |\n";
  }
  return md;
}

nlohmann::json caseLabels(const std::vector<analysis::CaseKey>& cases) {
  nlohmann::json labels = nlohmann::json::array();
  for (const auto& c : cases) labels.push_back(c.label());
  return labels;
}

nlohmann::json seedScatterJson(const std::vector<SeedScatter>& scatter) {
  nlohmann::json out = nlohmann::json::array();
  for (const SeedScatter& s : scatter) out.push_back({{"case", s.key.title()}, {"quantity", s.quantity}, {"sd", s.sd}, {"seeds", s.seeds}});
  return out;
}

}  // namespace

nlohmann::json toJson(const Diagnosis& d, const DiagnosisSettings& settings, const std::string& extended_study_path) {
  nlohmann::json ranking = nlohmann::json::array();
  for (const CauseResult& c : d.ranking) ranking.push_back(causeJson(c));
  return {{"verdict", d.cause ? "cause" : "no significant discrepancy"},
          {"cause", d.cause ? nlohmann::json(*d.cause) : nlohmann::json(nullptr)},
          {"reason", d.reason},
          {"gain_percent", d.gain_percent},
          {"baseline_error_percent", d.baseline_error_percent},
          {"baseline_chi2", d.baseline_chi2},
          {"failed_baseline_cases", caseLabels(d.failed_baseline_cases)},
          {"residuals", d.residual_count},
          {"seed_scatter", seedScatterJson(d.seed_scatter)},
          {"noise_error_percent", d.noise_error_percent},
          {"thresholds",
           {{"min_error_percent", settings.min_error_percent},
            {"min_gain_percent", settings.min_gain_percent},
            {"min_delta_bic", settings.min_delta_bic},
            {"scatter_seeds", settings.scatter_seeds}}},
          {"ranking", ranking},
          {"signatures", analysis::toJson(d.signatures)},
          {"extended_study", extended_study_path},
          {"wall_time_s", d.wall_time_s}};
}

void writeDiagnosis(const Diagnosis& d, const DiagnosisSettings& settings, analysis::StagedOutput& out,
                    const analysis::GnuplotRenderer* renderer) {
  out.writeText("extended_study.json", d.extended_study.dump(2) + "\n");
  std::string md = "# Diagnosis\n\n";
  md += "**Verdict: " + (d.cause ? "cause `" + *d.cause + "`" : std::string("no significant discrepancy")) + "** - " + d.reason + ".\n\n";
  if (d.cause) md += "Held-out error cut by the extension: " + number(d.gain_percent) + " %. The extended study is `extended_study.json`.\n\n";
  md += "Baseline (the study as given) against all cases: error " + number(d.baseline_error_percent) + " % (RMS of 100 (sim - meas) / meas " +
        "over every quantity of every case), chi2 " + number(d.baseline_chi2) + " over " + std::to_string(d.residual_count) + " residuals.\n\n";
  md += "Noise: a correct model would show an error of " + number(d.noise_error_percent) + " % from the measured scatter" +
        (d.seed_scatter.empty() ? std::string() : " and the model's own seed scatter (the baseline at " + std::to_string(settings.scatter_seeds) +
                                                      " deposition seeds), which also widens the sigma of every BIC") +
        "; an error below it is not counted as gain (docs/diagnosis.md).\n\n";
  if (!d.failed_baseline_cases.empty())
    md += "Left out of every error and BIC: the cases whose baseline run failed (DEM blow-up): " +
          caseLabels(d.failed_baseline_cases).dump() + ".\n\n";
  md += "Thresholds: a cause is named when the baseline error is at least " + number(settings.min_error_percent) +
        " %, its extension cuts the held-out error by at least " + number(settings.min_gain_percent) +
        " % and lowers BIC = chi2 + k ln n by at least " + number(settings.min_delta_bic) + " (docs/diagnosis.md).\n\n";
  md += "## Signatures\n\n" + signatureTable(d.signatures) + "\n## Ranking\n\n" + rankingTable(d) + "\n## Evidence\n\n";
  for (const CauseResult& c : d.ranking)
    md += "- `" + c.id + "` (" + c.description + "): expects " + c.expected_signature + ". " +
          (c.match.plausible ? "Present" : "Absent") + ": " + c.match.evidence + ".\n";
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
  md += "\nWall time " + number(d.wall_time_s, 3) + " s.\n";
  out.writeText("report.md", md);
}

}  // namespace demfem::campaign
