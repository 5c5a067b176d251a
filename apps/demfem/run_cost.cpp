#include "run_cost.hpp"

#include "demfem/backends/builtin/simulation.hpp"
#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/fem/model.hpp"

#include <algorithm>
#include <cmath>

namespace demfem::cli {

namespace {

// Measured on the 2-core development machine; the only place these figures enter the code.
// docs/builtin-dem.md: EDEM laws on the full paper bin, 3.6 M particle-steps/s on 1 thread, 6.3 M on 2.
constexpr double kBuiltinParticleStepsPerS = 3.6e6;
constexpr double kBuiltinExtraThreadGain = 6.3 / 3.6 - 1.0;  // per thread beyond the first
// docs/liggghts-backend.md / README: LIGGGHTS 1.73 M against the built-in's 4.58 M on the same particles.
constexpr double kLiggghtsToBuiltinSpeed = 1.73 / 4.58;
// docs/fem.md: the PMMA plate (738 keypoints): reduction 26 s, 23 ms per FEM step (wall, under load).
constexpr double kReferenceKeypoints = 738;
constexpr double kReferenceReductionS = 26.0;
constexpr double kReferenceFemStepS = 0.023;

std::int64_t wholeSteps(double time_s, double dt_s) { return std::max<std::int64_t>(1, std::llround(std::ceil(time_s / dt_s - 1e-9))); }

// Simulated time of the tool's insertion and drag (see the header).
double motionTime(const study::Study& s, const study::Tool& tool) {
  const auto& m = tool.motion;
  const double clearance = s.soil.diameter_max_m;
  if (s.kind == study::StudyKind::ConePenetration) return (m.depth_m + clearance) / m.velocity_m_s;
  const double dt = s.fem.dt_s;
  return static_cast<double>(wholeSteps((m.depth_m + clearance) / m.insertion_velocity_m_s, dt)) * dt +
         static_cast<double>(std::max<std::int64_t>(1, std::llround(m.stroke_m / m.velocity_m_s / dt))) * dt;
}

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
  cost.threads = s.dem.backend == "liggghts" ? 1 : s.dem.threads;  // LIGGGHTS: one MPI rank unless started by mpirun
  const bool has_soil = study::hasSoil(s.kind);
  if (s.kind == study::StudyKind::WeightDrop && s.weight_drop) {
    cost.simulated_s = s.weight_drop->duration_s;
  } else {
    for (const auto& tool : s.tools) cost.simulated_s = std::max(cost.simulated_s, motionTime(s, tool));
  }
  cost.fem_steps = wholeSteps(cost.simulated_s, s.fem.dt_s);
  cost.simulated_s = static_cast<double>(cost.fem_steps) * s.fem.dt_s;
  for (const auto& tool : s.tools)
    if (tool.fem.deformable && s.kind != study::StudyKind::DemOnly)
      cost.keypoints = std::max(cost.keypoints, static_cast<int>(fem::buildFullModel(tool).keypoint_nodes.size()));
  if (has_soil) {
    cost.dem_step_s = demStep(s);
    cost.dem_steps = wholeSteps(cost.simulated_s, *cost.dem_step_s);
    cost.particles = builtin::estimatedParticleCount(s.soil);
    const double speed = s.dem.backend == "liggghts"
                             ? kBuiltinParticleStepsPerS * kLiggghtsToBuiltinSpeed
                             : kBuiltinParticleStepsPerS * (1.0 + kBuiltinExtraThreadGain * (cost.threads - 1));
    cost.dem_wall_s = static_cast<double>(cost.dem_steps) * static_cast<double>(cost.particles) / speed;
  }
  if (cost.keypoints > 0) {
    const double scale = std::pow(cost.keypoints / kReferenceKeypoints, 2);
    cost.fem_wall_s = scale * (kReferenceReductionS + kReferenceFemStepS * static_cast<double>(cost.fem_steps));
  }
  return cost;
}

}  // namespace demfem::cli
