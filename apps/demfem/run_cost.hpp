// What running a study will cost, estimated before running it (`demfem validate`): DEM step, DEM
// and FEM step counts, particle count and wall time on the measured speeds of docs/builtin-dem.md
// ("Tests and benchmark"), docs/liggghts-backend.md and docs/fem.md ("Measured"), which enter the
// code only in run_cost.cpp.
//
// - FEM steps: the tool motion plan's (study/tool_motion.hpp: insertion and drag in whole FEM
//   steps; the longest of the tools); a weight drop: duration / dt. DEM steps: the same simulated
//   time at the DEM step.
// - DEM step: physics::demTimeStep (backends/physics/time_step.hpp, the one both backends run):
//   dem.dt_s, or dem.dt_fraction of its criterion's critical step, shortened to divide the FEM step
//   (study::demStepDividing); with the critical step and why it is what it is.
// - Particles: builtin::estimatedParticleCount (bin volume below the fill, packing, sizes).
// - Wall time: DEM particle-steps at the measured speed of the study's backend (the backend
//   registry's DemSpeed, backend_registry.hpp: threads and particle-steps per second; none for a
//   test backend, which simulates no particles), plus the keypoint reduction and FEM steps (of the
//   study's fem.integration) scaled
//   from the measured PMMA plate by (keypoints / 738)^2. A machine that is faster or less loaded than the 2-core one measured runs
//   quicker.
#pragma once

#include "demfem/study/study.hpp"

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

namespace demfem::cli {

struct RunCost {
  std::optional<double> dem_step_s;  // absent without soil (weight drop)
  double dem_critical_step_s = 0;    // physics::DemStep::critical_s
  std::string dem_step_why;          // physics::DemStep::why
  // physics::rollingRegularisationStep, on the edem-standard rolling law only: at a DEM step not
  // above it the law is the same at every step.
  std::optional<double> rolling_regularisation_step_s;
  std::int64_t fem_steps = 0;
  std::int64_t dem_steps = 0;
  double simulated_s = 0;
  std::size_t particles = 0;
  int keypoints = 0;  // 0: rigid tool (no FEM model)
  int threads = 1;
  double dem_wall_s = 0;
  double fem_wall_s = 0;  // keypoint reduction + FEM steps
  double wallSeconds() const { return dem_wall_s + fem_wall_s; }
};

// Pre: `study` loaded by study::loadStudy and passed by checkBackends (its backend is in this build).
// Throws std::invalid_argument for a study whose soil or tool the built-in backend cannot set up.
RunCost estimateRunCost(const study::Study& study);

}  // namespace demfem::cli
