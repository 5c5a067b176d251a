#include "run_cost.hpp"

#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/backends/physics/time_step.hpp"
#include "demfem/cli/backend_registry.hpp"
#include "demfem/fem/model.hpp"
#include "demfem/study/contact_laws.hpp"
#include "demfem/study/tool_motion.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace demfem::cli {

namespace {

// Measured on the 2-core development machine; the only place these figures enter the code (the
// DEM speeds are the backend registry's, backend_registry.cpp).
// docs/fem.md ("Measured"): the PMMA plate (738 keypoints): reduction 26 s, a full-integration FEM
// step 23 ms (wall, under load), a modal step 0.13 ms (demfem-bench-coupled, quiet machine).
constexpr double kReferenceKeypoints = 738;
constexpr double kReferenceReductionS = 26.0;

double referenceFemStepS(study::FemIntegration integration) {
  switch (integration) {
    case study::FemIntegration::Full: return 0.023;
    case study::FemIntegration::Modal: return 1.3e-4;
  }
  throw std::logic_error("referenceFemStepS: unknown integration");
}

std::int64_t wholeSteps(double time_s, double dt_s) { return std::max<std::int64_t>(1, std::llround(std::ceil(time_s / dt_s - 1e-9))); }

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
    const physics::DemStep step = physics::demTimeStep(s);
    cost.dem_step_s = study::demStepDividing(step.step_s, s.fem.dt_s);  // the step both backends run (one clock)
    cost.dem_critical_step_s = step.critical_s;
    cost.dem_step_why = step.why;
    if (study::rollingUsesSpinScale(s.soil.contact.rolling)) cost.rolling_regularisation_step_s = physics::rollingRegularisationStep(s);
    cost.dem_steps = wholeSteps(cost.simulated_s, *cost.dem_step_s);
    cost.particles = builtin::estimatedParticleCount(s.soil);
    if (backend.speed)
      cost.dem_wall_s = static_cast<double>(cost.dem_steps) * static_cast<double>(cost.particles) / speed.particle_steps_per_s;
  }
  if (cost.keypoints > 0) {
    const double scale = std::pow(cost.keypoints / kReferenceKeypoints, 2);
    cost.fem_wall_s = scale * (kReferenceReductionS + referenceFemStepS(s.fem.integration) * static_cast<double>(cost.fem_steps));
  }
  return cost;
}

}  // namespace demfem::cli
