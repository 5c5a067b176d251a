// Driving a tool through any DEM backend's coupling API the way the FEM client does before and
// during the stroke (vertical insertion, then drag along +z); used by the liggghts tests and the
// backend benchmark to run both backends through the same calls.
//
// Contract: frames and units of coupling_api.hpp (bin frame, SI). The rigid motion is continued from
// the tool's current position (no jump); simulate() rounds to whole DEM steps, so the insertion ends
// within half a DEM step of the depth.
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/study/study.hpp"

#include <array>
#include <string>

namespace demfem::liggghts {

// Continues `tool`'s rigid motion from where it is at dem.time() with a new velocity (m/s).
void setToolVelocity(adapter::CouplingApi& dem, const std::string& tool, const std::array<double, 3>& velocity_m_s);

// Lowers the tool at its insertion velocity until its tip is motion.depth_m below the fill surface
// (nothing if it is already there), then sets the drag velocity motion.velocity_m_s along +z.
void insertAndStartDrag(adapter::CouplingApi& dem, const study::Study& study, const study::Tool& tool);

}  // namespace demfem::liggghts
