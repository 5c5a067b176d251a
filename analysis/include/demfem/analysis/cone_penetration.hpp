// demfem analysis: cone penetration resistance (paper Section 2.10.3, Fig. 10; docs/analysis.md,
// "Cone penetration"). A profile is CPR against depth of one cone (simulated) or one repeat
// (measured); profiles of one soil are summarised by mean, standard deviation and the paper's "mean
// deviation", and measured and simulated summaries are compared by the same metrics.
//
// Contract
// - Units SI inside: depth in m below the soil surface, CPR in Pa. Files carry the units in their
//   column and key names (depth_mm, CPR_kPa).
// - coneResistance_Pa(): CPR = vertical force / projected cone area (Section 2.10.3).
// - summarize(): every profile is averaged onto the depth grid step, 2 step, ... up to the deepest
//   depth all profiles reach (the samples within +- step/2 of a grid depth are averaged; a grid depth
//   whose bin holds no samples or reaches beyond the profile takes the linear interpolation). Mean and sample standard
//   deviation (n - 1) over the profiles at each grid depth; mean deviation = the mean over the grid of
//   std / mean (the paper's "mean deviation", a fraction: 0.3 = +-30 %), over grid depths with mean > 0.
//   Throws InputError for fewer than two profiles, a non-positive step, a profile with fewer than two
//   samples or depths not increasing, or profiles without a common depth range of at least one step.
// - compare(): on the grid depths both summaries have (same step required), the fraction of depths
//   at which the simulated mean lies within the measured mean +- std (the paper's "falls within the
//   range of deviation"), and the mean of (simulated - measured) / measured mean.
// - readMeasuredProfile(): a CSV `depth_mm,CPR_kPa` (recording.hpp's CSV rules: header, '#'
//   comments, every value finite) with a JSON sidecar of the same stem
//   {"kind": "cone-penetration", "soil": NAME, "repeat": N, "area_mm2": A}; depths increasing and
//   >= 0. Problems throw InputError naming file and line or JSON path.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace demfem::analysis {

double coneResistance_Pa(double vertical_force_N, double projected_area_m2);

struct CprProfile {
  std::string label;            // "cone3", "repeat 2"
  std::vector<double> depth_m;  // increasing
  std::vector<double> cpr_Pa;
};

struct CprSummary {
  std::string soil;             // what was summarised ("layered", a study name, "measured")
  double step_m = 0;
  std::vector<double> depth_m;  // grid: step, 2 step, ...
  std::vector<double> mean_Pa, std_Pa;
  std::vector<std::vector<double>> profile_Pa;  // each profile on the grid
  double mean_deviation = 0;    // fraction
  std::size_t profiles = 0;
};

CprSummary summarize(const std::string& soil, const std::vector<CprProfile>& profiles, double step_m);

struct CprComparison {
  std::string simulated, measured;
  std::size_t depths = 0;                 // common grid depths
  double within_measured_band = 0;        // fraction of them
  double mean_relative_difference = 0;    // mean (sim - meas) / meas
};

CprComparison compare(const CprSummary& simulated, const CprSummary& measured);

struct MeasuredProfile {
  CprProfile profile;
  std::string soil;
  int repeat = 1;
  double area_m2 = 0;
};

MeasuredProfile readMeasuredProfile(const std::filesystem::path& csv);

}  // namespace demfem::analysis
