// Driving a tool through any DEM backend's coupling API the way the FEM client does before the
// stroke: the insertion of its motion plan (study/tool_motion.hpp), then the drag velocity. Used by
// the backend tests and benchmarks to run every backend through the same calls.
//
// Contract: frames and units of coupling_api.hpp (bin frame, SI). The backend holds the tool at the
// plan's start pose (coupling_api.hpp, "After construction"); the plan's times are counted from
// dem.time() at the call. simulate() rounds to whole DEM steps, so the insertion ends within half a
// DEM step of the depth.
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/study/study.hpp"
#include "demfem/study/tool_motion.hpp"

namespace demfem::adapter {

// The rigid motion of a plan phase on a DEM clock that read `plan_start_s` at plan time 0.
inline RigidMotion rigidMotionOf(const study::LinearMotion& phase, double plan_start_s) {
  return {phase.origin_m, phase.velocity_m_s, plan_start_s + phase.t0_s};
}

// Sets the plan's insertion, simulates it (insertion_steps FEM steps in one call) and sets its drag.
void insertAndStartDrag(CouplingApi& dem, const study::Study& study, const study::Tool& tool);

}  // namespace demfem::adapter
