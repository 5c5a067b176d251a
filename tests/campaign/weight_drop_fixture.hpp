// Test fixture: calibration-weight recordings made by the project's own model integrated directly
// (fem::simulateWeightDrop: Eq 5-10 on the reduced model, not the modal path of campaign's
// WeightDropModel) with known parameters, then written like a DAQ would: a resting lead-in, white
// noise, quantisation to DAQ units, raw format with calibration factors.
#pragma once

#include "demfem/analysis/synthetic.hpp"
#include "demfem/fem/model.hpp"
#include "demfem/fem/weight_drop.hpp"
#include "demfem/study/study.hpp"
#include "support/temp_dir.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

namespace demfem::campaign::test {

inline std::filesystem::path fixtureStudyPath() {
  return std::filesystem::path(DEMFEM_SOURCE_DIR) / "tests/campaign/data/strip_weight_drop.json";
}

inline nlohmann::ordered_json fixtureStudyJson() {
  std::ifstream in(fixtureStudyPath());
  return nlohmann::ordered_json::parse(in);
}

using TempDir = support::TempDir;

struct TruthSettings {
  double E_Pa = 4.5e9;
  double alpha_s = 8e-4;
  double beta_per_s = 0;
  double noise_fraction = 0.003;         // white noise, of the steady value
  double force_N_per_unit = 0.002;       // DAQ quantum of the load cell
  double deformation_mm_per_unit = 2e-4; // DAQ quantum of the deformation sensor
  double rest_s = 0.2;                   // resting lead-in before the weight is hung
};

// Writes `repeats` raw recordings of each mass into `dir` (named w<mass>_r<repeat>.csv + sidecar).
inline void writeRecordings(const std::filesystem::path& dir, const std::vector<double>& masses_kg, int repeats, const TruthSettings& truth) {
  nlohmann::ordered_json json = fixtureStudyJson();
  json["tools"][0]["fem"]["E_Pa"] = truth.E_Pa;
  json["tools"][0]["fem"]["alpha_s"] = truth.alpha_s;
  json["tools"][0]["fem"]["beta_per_s"] = truth.beta_per_s;
  const study::Study study = study::parseStudy(json.dump(), fixtureStudyPath().string());
  const study::Tool& tool = study.tools.front();
  const fem::ReducedModel model = fem::reduce(fem::buildFullModel(tool));
  std::mt19937_64 rng(42);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (double mass : masses_kg) {
    study::WeightDrop drop = *study.weight_drop;
    drop.mass_kg = mass;
    const fem::WeightDropResult r = fem::simulateWeightDrop(model, tool, drop, study.fem.dt_s);
    const double rest_steps = std::round(truth.rest_s / study.fem.dt_s);
    for (int rep = 1; rep <= repeats; ++rep) {
      analysis::SyntheticRecording rec;
      rec.header = {"t", "force", "deformation"};
      rec.columns.assign(3, {});
      const auto sample = [&](double t, double force, double deformation) {
        rec.columns[0].push_back(t);
        rec.columns[1].push_back(std::round((force + truth.noise_fraction * r.static_force_N * normal(rng)) / truth.force_N_per_unit));
        rec.columns[2].push_back(
            std::round((deformation + truth.noise_fraction * r.static_deformation_mm * normal(rng)) / truth.deformation_mm_per_unit));
      };
      for (int i = 0; i < rest_steps; ++i) sample(i * study.fem.dt_s, 0, 0);
      for (const auto& s : r.samples) sample(s.t_s + truth.rest_s, s.force_N, s.deformation_mm);
      rec.sidecar = {{"tool", "strip"},
                     {"mass_kg", mass},
                     {"sample_rate_hz", 1 / study.fem.dt_s},
                     {"force_factor", truth.force_N_per_unit},
                     {"deformation_factor", truth.deformation_mm_per_unit},
                     {"repeat", rep}};
      char name[64];
      std::snprintf(name, sizeof name, "w%g_r%d.csv", mass, rep);
      analysis::writeSyntheticRecording(rec, dir / name);
    }
  }
}

}  // namespace demfem::campaign::test
