// What running a study will cost, estimated before running it (`demfem validate`): DEM step, DEM
// and FEM step counts, particle count and wall time on the measured speeds of docs/builtin-dem.md
// ("Tests and benchmark"), docs/liggghts-backend.md and docs/fem.md ("Measured"), which enter the
// code only in run_cost.cpp.
//
// - FEM steps: the insertion (depth plus one largest particle diameter of clearance at the
//   insertion speed; a cone: at its velocity) and the drag (stroke / velocity), in whole FEM steps;
//   a weight drop: duration / dt. DEM steps: the same simulated time at the DEM step.
// - DEM step: the study's (dem.dt_s, or dem.dt_fraction of its criterion's critical step on the
//   study's materials, bin walls and smallest particle, as the built-in backend computes it).
// - Particles: builtin::estimatedParticleCount (bin volume below the fill, packing, sizes).
// - Wall time: DEM particle-steps at the measured speed for dem.threads (built-in) or one core
//   (LIGGGHTS), plus the keypoint reduction and FEM steps scaled from the measured PMMA plate by
//   (keypoints / 738)^2. A machine that is faster or less loaded than the 2-core one measured runs
//   quicker; the estimate is within a factor of 2 on that machine (docs/architecture.md).
#pragma once

#include "demfem/study/study.hpp"

#include <cstddef>
#include <cstdint>
#include <optional>

namespace demfem::cli {

struct RunCost {
  std::optional<double> dem_step_s;  // absent without soil (weight drop)
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

// Pre: `study` loaded by study::loadStudy. Throws std::invalid_argument for a study whose soil or
// tool the built-in backend cannot set up.
RunCost estimateRunCost(const study::Study& study);

}  // namespace demfem::cli
