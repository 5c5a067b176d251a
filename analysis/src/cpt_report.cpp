#include "demfem/analysis/cpt_report.hpp"

#include "demfem/analysis/recording.hpp"

#include <cmath>
#include <iomanip>
#include <sstream>

namespace demfem::analysis {

namespace {

using nlohmann::json;

std::vector<double> scaled(const std::vector<double>& v, double factor) {
  std::vector<double> out;
  for (const double x : v) out.push_back(x * factor);
  return out;
}

json summaryJson(const CprSummary& s) {
  return {{"profiles", s.profiles},
          {"mean_deviation", s.mean_deviation},
          {"depth_mm", scaled(s.depth_m, 1e3)},
          {"mean_CPR_kPa", scaled(s.mean_Pa, 1e-3)},
          {"std_CPR_kPa", scaled(s.std_Pa, 1e-3)}};
}

// Mean line and mean +- std band of a summary.
void addSummary(XYPanel& panel, const CprSummary& s, const std::string& title, const char* color) {
  std::vector<double> lo, hi;
  for (std::size_t k = 0; k < s.depth_m.size(); ++k) {
    lo.push_back((s.mean_Pa[k] - s.std_Pa[k]) * 1e-3);
    hi.push_back((s.mean_Pa[k] + s.std_Pa[k]) * 1e-3);
  }
  const auto depth = scaled(s.depth_m, 1e3);
  panel.series.push_back({"", depth, lo, color, SeriesStyle::Band, 1.0, hi});
  panel.series.push_back({title, depth, scaled(s.mean_Pa, 1e-3), color, SeriesStyle::Line, 2.0, {}});
}

std::string percent(double fraction) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(1) << 100 * fraction << " %";
  return out.str();
}

}  // namespace

CptResults evaluateCpt(std::vector<CptSoil> soils, const std::vector<MeasuredProfile>& measured, double step_m) {
  CptResults r;
  r.step_m = step_m;
  for (auto& soil : soils) soil.summary = summarize(soil.study, soil.cones, step_m);
  r.soils = std::move(soils);
  if (!measured.empty()) {
    std::vector<CprProfile> repeats;
    for (const auto& m : measured) {
      if (m.soil != measured.front().soil || std::fabs(m.area_m2 - measured.front().area_m2) > 1e-12)
        throw InputError("measured CPR profiles: '" + m.profile.label + "' is of soil '" + m.soil + "' and area " +
                         std::to_string(m.area_m2 * 1e6) + " mm^2, the first of '" + measured.front().soil + "' and " +
                         std::to_string(measured.front().area_m2 * 1e6) + " mm^2");
      repeats.push_back(m.profile);
    }
    r.measured = summarize("measured " + measured.front().soil, repeats, step_m);
    for (const auto& soil : r.soils) r.comparisons.push_back(compare(soil.summary, *r.measured));
  }
  return r;
}

json cptJson(const CptResults& r) {
  json soils = json::array();
  for (const auto& soil : r.soils) {
    json s = summaryJson(soil.summary);
    s["study"] = soil.study;
    s["area_mm2"] = soil.area_m2 * 1e6;
    soils.push_back(s);
  }
  json comparisons = json::array();
  for (const auto& c : r.comparisons)
    comparisons.push_back({{"simulated", c.simulated},
                           {"measured", c.measured},
                           {"depths", c.depths},
                           {"within_measured_band", c.within_measured_band},
                           {"mean_relative_difference", c.mean_relative_difference}});
  json measured = nullptr;
  if (r.measured) {
    measured = summaryJson(*r.measured);
    measured["soil"] = r.measured->soil;
  }
  return {{"depth_step_mm", r.step_m * 1e3}, {"soils", soils}, {"measured", measured}, {"comparisons", comparisons}};
}

std::string cptMarkdown(const CptResults& r) {
  std::ostringstream md;
  md << "## Cone penetration resistance\n\n"
     << "CPR = vertical force / projected cone area against the tip depth below the surface (Section 2.10.3), mean and "
        "standard deviation over the cones (simulated) or repeats (measured) on a "
     << r.step_m * 1e3 << " mm depth grid; mean deviation = mean of std / mean along the curve.\n\n"
     << "| soil | profiles | deepest common depth (mm) | CPR at the deepest (kPa) | mean deviation |\n|---|---|---|---|---|\n";
  const auto row = [&md](const CprSummary& s) {
    md << "| " << s.soil << " | " << s.profiles << " | " << s.depth_m.back() * 1e3 << " | " << std::setprecision(4)
       << s.mean_Pa.back() * 1e-3 << " +- " << s.std_Pa.back() * 1e-3 << " | " << percent(s.mean_deviation) << " |\n";
  };
  for (const auto& soil : r.soils) row(soil.summary);
  if (r.measured) row(*r.measured);
  if (!r.comparisons.empty()) {
    md << "\n| simulated | measured | common depths | simulated mean within measured mean +- std | mean relative difference |\n"
          "|---|---|---|---|---|\n";
    for (const auto& c : r.comparisons)
      md << "| " << c.simulated << " | " << c.measured << " | " << c.depths << " | " << percent(c.within_measured_band) << " | "
         << percent(c.mean_relative_difference) << " |\n";
  }
  md << "\n![CPR against depth](plots/cpr.svg)\n";
  return md.str();
}

Figure cprFigure(const CptResults& r) {
  Figure figure;
  figure.title = "Cone penetration resistance (Fig. 10)";
  figure.columns = static_cast<int>(std::max<std::size_t>(1, r.soils.size()));
  for (const auto& soil : r.soils) {
    XYPanel panel;
    panel.title = soil.study;
    panel.x_label = "tip depth below the surface (mm)";
    panel.y_label = "CPR (kPa)";
    if (r.measured) addSummary(panel, *r.measured, "measured mean +- std", kMeasuredColor);
    addSummary(panel, soil.summary, "simulated mean +- std (" + std::to_string(soil.summary.profiles) + " cones)", kSimulatedColor);
    figure.panels.push_back(panel);
  }
  return figure;
}

void writeCptOutputs(StagedOutput& out, const CptResults& r, const GnuplotRenderer* renderer) {
  out.writeText("cpt.json", cptJson(r).dump(2) + "\n");
  out.writeText("cpt.md", cptMarkdown(r));
  for (const auto& soil : r.soils)
    for (std::size_t c = 0; c < soil.cones.size(); ++c) {
      const auto& cone = soil.cones[c];
      std::ostringstream csv;
      csv << std::setprecision(17) << "depth_mm,CPR_kPa\n";
      for (std::size_t k = 0; k < cone.depth_m.size(); ++k) csv << cone.depth_m[k] * 1e3 << ',' << cone.cpr_Pa[k] * 1e-3 << '\n';
      const std::string stem = "profiles/" + soil.study + "_" + cone.label;
      out.writeText(stem + ".csv", csv.str());
      const json sidecar{{"kind", "cone-penetration"}, {"soil", soil.study}, {"repeat", c + 1}, {"area_mm2", soil.area_m2 * 1e6},
                         {"cone", cone.label}, {"simulated", true}};
      out.writeText(stem + ".json", sidecar.dump(2) + "\n");
    }
  if (renderer) renderSvgAndPng(*renderer, out, cprFigure(r), "plots/cpr");
}

}  // namespace demfem::analysis
