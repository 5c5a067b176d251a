// demfem analysis: the cone penetration report (paper Fig. 10, Section 3.3; docs/analysis.md, "Cone
// penetration"): per soil (study) the cones' CPR profiles and their summary (cone_penetration.hpp),
// the measured profiles' summary, and each soil compared with the measurement.
//
// Contract
// - evaluateCpt(): summarize() of every soil's cones and of the measured profiles (if any) on one
//   depth grid `step_m`; each soil compare()d with the measurement. Throws InputError as they do, and
//   for measured profiles of different soils or projected areas.
// - cptJson(): {"depth_step_mm", "soils": [{"study", "cones", "mean_deviation", "depth_mm": [...],
//   "mean_CPR_kPa": [...], "std_CPR_kPa": [...]}], "measured": {... same keys, "soil", "repeats"} or
//   null, "comparisons": [{"simulated", "measured", "depths", "within_measured_band",
//   "mean_relative_difference"}]}.
// - writeCptOutputs() stages (staged_output.hpp) cpt.json, cpt.md (the Markdown section),
//   profiles/STUDY_CONE.csv with its sidecar (the measured-profile format, so a simulated profile
//   reads back like a measured one) and, with a renderer, plots/cpr.{gp,svg} and plots/cpr-png.gp +
//   plots/cpr.png: one panel per soil, mean +- std band, the measured mean and band over it.
#pragma once

#include "demfem/analysis/cone_penetration.hpp"
#include "demfem/analysis/plot.hpp"
#include "demfem/analysis/staged_output.hpp"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace demfem::analysis {

struct CptSoil {
  std::string study;
  double area_m2 = 0;
  std::vector<CprProfile> cones;
  CprSummary summary;
};

struct CptResults {
  double step_m = 0;
  std::vector<CptSoil> soils;
  std::optional<CprSummary> measured;
  std::vector<CprComparison> comparisons;
};

CptResults evaluateCpt(std::vector<CptSoil> soils, const std::vector<MeasuredProfile>& measured, double step_m);

nlohmann::json cptJson(const CptResults& results);
std::string cptMarkdown(const CptResults& results);
Figure cprFigure(const CptResults& results);

void writeCptOutputs(StagedOutput& out, const CptResults& results, const GnuplotRenderer* renderer);

}  // namespace demfem::analysis
