// Settled soils for the executables (`demfem deposit`, `demfem run`, `demfem-dem`): which DEM
// deposits a study's soil (the backend registry's entry, backend_registry.hpp) and when a soil may
// be run on.
//
// Contract
// - The soil of a study is the backend-neutral file adapter::settledSoilFile(study, dir)
//   (adapter/settled_soil.hpp); it is deposited by the backend soil.deposition.backend names and
//   read by every backend.
// - depositWith() deposits with the backend named `backend` (its BackendEntry::deposit: the
//   built-in DEM on `cores` threads, LIGGGHTS in this process on one MPI rank) and returns the soil
//   with its settling figures, not written. Unless `quiet`, it reports progress with time left and
//   each stage's summary on standard error. Throws InputError for a backend this build lacks or one
//   that simulates no particles.
// - An unsettled soil (a settling stage hit its time cap, or the final kinetic energy is not below
//   soil.deposition.settle_kinetic_energy_J) is refused by requireSettled() unless allowed.
// - openSoilBackend(): the DEM backend of a soil study in this process (demfem-dem serves it,
//   `demfem cpt` pushes its cones).
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/adapter/settled_soil.hpp"
#include "demfem/cli/backend_registry.hpp"
#include "demfem/study/study.hpp"

#include <filesystem>
#include <memory>
#include <string>

namespace demfem::cli {

adapter::SettledSoil depositWith(const std::string& backend, const study::Study& study, int cores, DepositCost& cost, bool quiet);

// Throws InputError naming `file` and the reason when the soil is not settled and !allow_unsettled.
void requireSettled(const adapter::SettledSoil& soil, const std::filesystem::path& file, bool allow_unsettled);

// The soil DEM `backend` (a soil backend of backend_registry.hpp, in this process) on the study's
// settled soil: a soil file missing is deposited first (by the study's deposition backend; a backend
// that deposits its own does so while it is built), then checked by requireSettled().
std::unique_ptr<adapter::CouplingApi> openSoilBackend(const BackendEntry& backend, const study::Study& study, bool allow_unsettled);

}  // namespace demfem::cli
