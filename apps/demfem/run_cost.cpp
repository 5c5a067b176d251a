#include "run_cost.hpp"

#include "demfem/backends/builtin/simulation.hpp"
#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/cli/backend_registry.hpp"
#include "demfem/fem/model.hpp"
#include "demfem/study/tool_motion.hpp"

#include <algorithm>
#include <cmath>

namespace demfem::cli {

namespace {

// Measured on the 2-core development machine; the only place these figures enter the code (the
// DEM speeds are the backend registry's, backend_registry.cpp).
// docs/fem.md: the PMMA plate (738 keypoints): reduction 26 s, 23 ms per FEM step (wall, under load).
constexpr double kReferenceKeypoints = 738;
constexpr double kReferenceReductionS = 26.0;
constexpr double kReferenceFemStepS = 0.023;

std::int64_t wholeSteps(double time_s, double dt_s) { return std::max<std::int64_t>(1, std::llround(std::ceil(time_s / dt_s - 1e-9))); }

// The built-in backend's DEM step on the bin walls and one smallest particle of each layer material.
double demStep(const study::Study& s) {
  builtin::DemSimulation sim(s.soil, builtin::binDomain(s.soil), 1);
  builtin::addBinWalls(sim, s.soil);
  for (std::size_t l = 0; l < s.soil.layers.size(); ++l) {
    builtin::ParticleState p;
    p.radius = s.soil.diameter_min_m / 2;
    p.x = {s.soil.bin_width_m / 2, s.soil.fill_height_m / 2, s.soil.bin_length_m * (static_cast<double>(l) + 0.5) / static_cast<double>(s.soil.layers.size())};
    p.material = sim.materials().index(s.soil.layers[l].material);
    p.layer = static_cast<int>(l);
    sim.addParticle(p);
  }
  return builtin::studyTimeStep(sim, s.dem);
}

}  // namespace

RunCost estimateRunCost(const study::Study& s) {
  RunCost cost;
  const BackendEntry& backend = findBackend(s.dem.backend);
  const DemSpeed speed = backend.speed ? backend.speed(s) : DemSpeed{};  // a test backend simulates no particles
  cost.threads = speed.threads;
  const bool has_soil = study::hasSoil(s.kind);
  if (s.kind == study::StudyKind::WeightDrop && s.weight_drop) {
    cost.fem_steps = wholeSteps(s.weight_drop->duration_s, s.fem.dt_s);
  } else {
    for (const auto& tool : s.tools) cost.fem_steps = std::max(cost.fem_steps, study::planToolMotion(s, tool).totalSteps());
  }
  cost.simulated_s = static_cast<double>(cost.fem_steps) * s.fem.dt_s;
  for (const auto& tool : s.tools)
    if (tool.fem.deformable && s.kind != study::StudyKind::DemOnly)
      cost.keypoints = std::max(cost.keypoints, static_cast<int>(fem::buildFullModel(tool).keypoint_nodes.size()));
  if (has_soil) {
    cost.dem_step_s = study::demStepDividing(demStep(s), s.fem.dt_s);  // the step both backends run (one clock)
    cost.dem_steps = wholeSteps(cost.simulated_s, *cost.dem_step_s);
    cost.particles = builtin::estimatedParticleCount(s.soil);
    if (backend.speed)
      cost.dem_wall_s = static_cast<double>(cost.dem_steps) * static_cast<double>(cost.particles) / speed.particle_steps_per_s;
  }
  if (cost.keypoints > 0) {
    const double scale = std::pow(cost.keypoints / kReferenceKeypoints, 2);
    cost.fem_wall_s = scale * (kReferenceReductionS + kReferenceFemStepS * static_cast<double>(cost.fem_steps));
  }
  return cost;
}

}  // namespace demfem::cli
