// Factory of the builtin DEM backend: the coupling API (adapter/coupling_api.hpp) on a study's soil and tools.
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/study/study.hpp"

#include <memory>

namespace demfem::builtin {

// Builds the DEM simulation of `study` (soil, bin, tools at their start positions) ready for the
// coupling cycle. Throws adapter::CouplingError on a study this backend cannot run.
std::unique_ptr<adapter::CouplingApi> makeBackend(const study::Study& study);

}  // namespace demfem::builtin
