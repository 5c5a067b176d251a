// Factory of the builtin DEM backend: the coupling API (adapter/coupling_api.hpp) on a study's soil and tools.
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/backends/builtin/triangle_mesh.hpp"
#include "demfem/study/backend_capabilities.hpp"
#include "demfem/study/contact_laws.hpp"
#include "demfem/study/study.hpp"

#include <filesystem>
#include <iterator>
#include <memory>

namespace demfem::builtin {

// What the built-in DEM offers (docs/builtin-dem.md): every contact law of the study file, plate
// tools, checkpoints.
inline study::BackendCapabilities capabilities() {
  return {"builtin", true,
          {std::begin(study::kAllNormalModels), std::end(study::kAllNormalModels)},
          {std::begin(study::kAllCohesionModels), std::end(study::kAllCohesionModels)},
          {std::begin(study::kAllRollingModels), std::end(study::kAllRollingModels)},
          {study::GeometryKind::Plate}, true};
}

// Builds the DEM simulation of `study` (soil, bin, tools at their start positions) ready for the
// coupling cycle. The soil is the study's settled-soil file adapter::settledSoilFile(study,
// adapter::defaultSoilDirectory()) (adapter/settled_soil.hpp), whichever backend deposited it; a
// missing file is deposited here (depositSoil(), study.dem.threads, reporting to `deposit_progress`,
// which may be empty) and written when the study deposits with the built-in DEM, and is BadRequest
// naming the file otherwise. info().soil_json records the soil (adapter::soilRecordJson). Throws
// adapter::CouplingError on a study this backend cannot run or a damaged or foreign soil file
// (BadRequest naming it).
std::unique_ptr<adapter::CouplingApi> makeBackend(const study::Study& study, const DepositProgress& deposit_progress = {});

// The study's settled-soil file, deposited and written here when missing, as makeBackend() does, but
// without building the simulation: no tools, no ParaView files (output.vtk_every is not looked at).
// Throws as makeBackend().
std::filesystem::path ensureSettledSoil(const study::Study& study, const DepositProgress& deposit_progress = {});

// The DEM mesh of a tool: its keypoint surface (adapter/tool_surface.hpp: the plate's triangulation
// shared with the FEM, or the cone penetrometer), local frame, material not yet set. Throws
// adapter::CouplingError(Unsupported) for geometries the builtin backend does not mesh.
TriangleMesh toolMesh(const study::Tool& tool);

}  // namespace demfem::builtin
