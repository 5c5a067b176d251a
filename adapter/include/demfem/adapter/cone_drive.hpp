// Pushing the penetrometers of a cone-penetration study down through any DEM backend's coupling API
// (paper Section 2.10.3, Fig. 6): every cone follows its motion plan (study/tool_motion.hpp: straight
// down at motion.velocity_m_s from one particle diameter above the surface to motion.depth_m), all
// at once, and the vertical force on each is recorded once per recording interval.
//
// Contract
// - Units SI, bin frame (docs/architecture.md section 10). The backend holds the cones at their
//   plans' start poses (coupling_api.hpp, "After construction"); plan time 0 is dem.time() at the call.
// - Intervals of fem.dt_s (the study's recording interval for cone-penetration studies); a cone that
//   has reached its depth rests there while the others go on. The run has the largest insertion_steps
//   of the cones.
// - Per interval and cone: the time at its end (plan time), the tip depth below the settled surface
//   (settledSurface() minus the tip height at that time; negative above the surface) and the
//   vertical force of the particles on the cone: the sum of the y components of nodeForces() in the
//   study's coupling.force_averaging mode (interval mean by default), positive upwards (resisting).
// - `progress(done, total)` is called after every interval; it may throw to stop the run (the samples
//   so far are lost with the exception).
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/study/study.hpp"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace demfem::adapter {

struct ConeRecord {
  std::string name;
  double area_m2 = 0;            // projected area (study geometry)
  std::vector<double> time_s, tip_depth_m, force_N;
};

// The height of the soil's surface the backend started from: surface_height_mm of its soil record
// (BackendInfo::soil_json, settled_soil.hpp: soilSurfaceHeight), soil.fill_height_m without one.
double settledSurface(const BackendInfo& info, const study::Study& study);

using ConeProgress = std::function<void(std::int64_t done, std::int64_t total)>;

// Throws std::invalid_argument for a study that is not a cone-penetration study.
std::vector<ConeRecord> pushCones(CouplingApi& dem, const study::Study& study, const ConeProgress& progress = {});

}  // namespace demfem::adapter
