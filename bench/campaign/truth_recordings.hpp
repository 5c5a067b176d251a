// Weight-drop recordings of the project's modal model at known parameters, written as raw DAQ
// recordings (the benchmarks' measured data; docs/calibration.md, docs/diagnosis.md).
#pragma once

#include "demfem/analysis/synthetic.hpp"
#include "demfem/campaign/model.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>

namespace demfem::bench {

inline analysis::CaseKey weight(double mass_kg) { return {analysis::CaseKind::CalibrationWeight, "PMMA", 0, mass_kg}; }

// Raw recordings of the model of `truth` (0.5 and 1 kg, two repeats each) into `dir`: 0.2 s at
// rest, 0.3 % white noise, DAQ quanta.
inline void writeTruth(const nlohmann::ordered_json& truth, const std::string& origin, const std::filesystem::path& dir) {
  campaign::WeightDropModel model;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal(0, 1);
  for (double mass : {0.5, 1.0}) {
    const analysis::Recording r = model.run(campaign::caseStudy(truth, origin, weight(mass)), weight(mass), {});
    for (int repeat = 1; repeat <= 2; ++repeat) {
      analysis::SyntheticRecording rec;
      rec.header = {"t", "force", "deformation"};
      rec.columns.assign(3, {});
      const double force_unit = 0.01, deformation_unit = 1e-3, noise = 0.003;
      const double force_scale = r.force.back(), deformation_scale = r.deformation.back();
      for (std::size_t i = 0; i < r.size(); ++i) {
        rec.columns[0].push_back(r.time_s[i] + 0.1);
        rec.columns[1].push_back(std::round((r.force[i] + noise * force_scale * normal(rng)) / force_unit));
        rec.columns[2].push_back(std::round((r.deformation[i] + noise * deformation_scale * normal(rng)) / deformation_unit));
      }
      rec.sidecar = {{"tool", "PMMA"},   {"mass_kg", mass},           {"sample_rate_hz", 1000.0}, {"force_factor", force_unit},
                     {"repeat", repeat}, {"deformation_factor", deformation_unit}};
      char name[64];
      std::snprintf(name, sizeof name, "pmma_%gkg_r%d.csv", mass, repeat);
      analysis::writeSyntheticRecording(rec, dir / name);
    }
  }
}

}  // namespace demfem::bench
