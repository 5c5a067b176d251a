// Factory of the builtin DEM backend: the coupling API (adapter/coupling_api.hpp) on a study's soil and tools.
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/backends/builtin/triangle_mesh.hpp"
#include "demfem/study/study.hpp"

#include <memory>

namespace demfem::builtin {

// Builds the DEM simulation of `study` (soil, bin, tools at their start positions) ready for the
// coupling cycle; deposits the soil first unless it is saved (soil_bin.hpp), reporting to
// `deposit_progress` (may be empty). Throws adapter::CouplingError on a study this backend cannot run.
std::unique_ptr<adapter::CouplingApi> makeBackend(const study::Study& study, const DepositProgress& deposit_progress = {});

// The DEM mesh of a tool: the plate's keypoint triangulation shared with the FEM
// (adapter/plate_surface.hpp), local frame, material not yet set. Throws
// adapter::CouplingError(Unsupported) for geometries the builtin backend does not mesh.
TriangleMesh toolMesh(const study::Tool& tool);

}  // namespace demfem::builtin
