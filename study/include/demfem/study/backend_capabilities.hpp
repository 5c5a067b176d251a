// demfem study: what a DEM backend offers, as the study sees it (docs/architecture.md section 14,
// "How to add a backend"). Each backend declares its capabilities next to its factory; the backend
// registry of the commands (apps/common, backend_registry.hpp) lists them, and backendIssues()
// judges a study against that list, so the study layer names no backend.
#pragma once

#include "demfem/study/study.hpp"

#include <string>
#include <vector>

namespace demfem::study {

struct BackendCapabilities {
  std::string name;                         // the spelling of dem.backend (and of soil.deposition.backend)
  bool simulates_soil = true;               // false: an analytic test backend, no particles
  std::vector<NormalModel> normal_laws;     // contact laws it implements (soil backends)
  std::vector<CohesionModel> cohesion_laws;
  std::vector<RollingModel> rolling_laws;
  std::vector<GeometryKind> geometries;     // tool geometries it meshes
  bool checkpoint = false;                  // offers checkpoint()/restore()
};

// The problems of `study` with the backends of `registry`: dem.backend must be one of them; for a
// study with soil, the backend that runs it and the one that deposits its soil
// (soil.deposition.backend) must implement its contact laws. Each issue names its JSON path. Empty
// for a study that passes.
std::vector<Issue> backendIssues(const Study& study, const std::vector<BackendCapabilities>& registry);

}  // namespace demfem::study
