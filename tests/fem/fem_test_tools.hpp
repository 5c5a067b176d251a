// Tools of the paper (Section 2.2/2.9, Table 3) and small variants for the FEM tests.
#pragma once

#include "demfem/fem/model.hpp"
#include "demfem/study/study.hpp"
#include "support/study_in_code.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <string>

namespace demfem::fem::testing {

// A 200 x 40 mm tool of the paper (Section 2.2/2.9, Table 3): thickness, FEM material and the
// Rayleigh mass-proportional damping alpha 0.55 ms.
inline study::Tool paperTool(const std::string& name, double thickness_m, double youngs_Pa, double poisson, double density_kg_m3) {
  study::Tool t;
  t.name = name;
  support::usePlate(t, 0.200, 0.040, thickness_m);
  t.fem.youngs_Pa = youngs_Pa;
  t.fem.poisson = poisson;
  t.fem.density_kg_m3 = density_kg_m3;
  t.fem.alpha_s = 0.55e-3;
  return t;
}

// 200 x 40 x 4 mm PMMA tool, Table 3 (E calibrated 4.06 GPa, nu 0.38, rho 1220 kg/m^3).
inline study::Tool pmmaTool() { return paperTool("PMMA", 0.004, 4.06e9, 0.38, 1220); }

// 200 x 40 x 3 mm S235 tool, Table 3 (E 207 GPa, nu 0.3, rho 7933 kg/m^3).
inline study::Tool steelTool() { return paperTool("S235", 0.003, 2.07e11, 0.3, 7933); }

// A small steel strip (100 x 10 x 4 mm, 126 keypoints) for long time-integration runs: clamped over
// the top 20 mm, load cell 30 mm below the top, sensor 50 mm below the top.
inline study::Tool smallStrip() {
  study::Tool t = steelTool();
  t.name = "strip";
  support::usePlate(t, 0.100, 0.010, 0.004);
  t.constraints.clamp_length_m = 0.020;
  t.constraints.load_cell_from_top_m = 0.030;
  t.constraints.sensor_from_top_m = 0.050;
  return t;
}

// A long thin steel strip for the Euler-Bernoulli checks: 340 x 10 x 4 mm, clamped over the top
// 40 mm (free length 300 mm, L/h = 75), the load-cell line on the clamp edge so it adds nothing.
inline study::Tool eulerBernoulliStrip() {
  study::Tool strip = steelTool();
  support::usePlate(strip, 0.340, 0.010, 0.004);
  strip.constraints.clamp_length_m = 0.040;
  strip.constraints.load_cell_from_top_m = 0.040;
  return strip;
}

// Keypoint forces: `total_N` along -z spread evenly over the keypoints of the tip row (y = 0).
inline Eigen::VectorXd tipLoad(const ReducedModel& model, double total_N) {
  Eigen::VectorXd f = Eigen::VectorXd::Zero(model.dofCount());
  std::vector<int> tip;
  for (int k = 0; k < model.keypointCount(); ++k)
    if (std::abs(model.keypoints(k, 1)) < 1e-12) tip.push_back(k);
  for (int k : tip) f(3 * k + 2) = -total_N / static_cast<double>(tip.size());
  return f;
}

inline double tipDeflection(const ReducedModel& model, const Eigen::VectorXd& u) {
  double sum = 0;
  int count = 0;
  for (int k = 0; k < model.keypointCount(); ++k)
    if (std::abs(model.keypoints(k, 1)) < 1e-12) sum += u(3 * k + 2), ++count;
  return sum / count;
}

// Full-model force vector carrying reduced (keypoint) forces `fa`.
inline Eigen::VectorXd expand(const FullModel& full, const Eigen::VectorXd& fa) {
  Eigen::VectorXd f = Eigen::VectorXd::Zero(full.dofCount());
  for (std::size_t k = 0; k < full.keypoint_nodes.size(); ++k)
    for (int d = 0; d < 3; ++d) f(3 * full.keypoint_nodes[k] + d) = fa(3 * static_cast<int>(k) + d);
  return f;
}

inline Eigen::VectorXd restrictToKeypoints(const FullModel& full, const Eigen::VectorXd& u) {
  Eigen::VectorXd ua(3 * static_cast<Eigen::Index>(full.keypoint_nodes.size()));
  for (std::size_t k = 0; k < full.keypoint_nodes.size(); ++k)
    for (int d = 0; d < 3; ++d) ua(3 * static_cast<int>(k) + d) = u(3 * full.keypoint_nodes[k] + d);
  return ua;
}


// Eq (13)-(15) are exact for loads on keypoints only: the reduced static response equals the full
// model's at the keypoints to 1e-9 relative, displacements and reactions.
inline void checkReducedStaticEqualsFull(const study::Tool& tool) {
  const FullModel full = buildPlateModel(tool);
  const ReducedModel reduced = reduce(full);
  Eigen::VectorXd fa = tipLoad(reduced, 2.0);
  // Plus a distributed front-face load against travel and a sideways pull, to load every direction.
  for (int k = 0; k < reduced.keypointCount(); ++k) {
    if (reduced.keypoints(k, 2) > 0) fa(3 * k + 2) -= 0.01;
    fa(3 * k) += 0.002 * reduced.keypoints(k, 1);
  }
  const StaticSolution r = solveStatic(reduced, fa);
  const StaticSolution f = solveStatic(full, expand(full, fa));
  INFO(tool.name);
  const Eigen::VectorXd ua = restrictToKeypoints(full, f.displacement);
  CHECK((r.displacement - ua).norm() / ua.norm() < 1e-9);
  const Eigen::VectorXd ra = restrictToKeypoints(full, f.reaction);
  CHECK((r.reaction - ra).norm() / ra.norm() < 1e-9);
}

// Guyan reduction is a Rayleigh-Ritz projection: reduced frequencies bound the full ones from above.
// The first frequency is required within 0.5 %.
inline void checkReducedFrequencies(const study::Tool& tool) {
  const FullModel full = buildPlateModel(tool);
  const Modes fm = naturalModes(full, 3);
  const Modes rm = naturalModes(reduce(full), 3);
  INFO(tool.name << ": full f1 " << fm.frequencies_Hz[0] << " Hz, reduced f1 " << rm.frequencies_Hz[0] << " Hz");
  CHECK(rm.frequencies_Hz[0] == Approx(fm.frequencies_Hz[0]).epsilon(0.005));
  for (int m = 0; m < 3; ++m) CHECK(rm.frequencies_Hz[m] >= fm.frequencies_Hz[m] * (1 - 1e-12));
}

}  // namespace demfem::fem::testing
