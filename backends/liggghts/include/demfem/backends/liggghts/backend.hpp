// Factory of the liggghts DEM backend: the coupling API (adapter/coupling_api.hpp) on a study's soil and tools.
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/study/study.hpp"

#include <memory>

namespace demfem::liggghts {

// Builds the DEM simulation of `study` (soil, bin, tools at their start positions) ready for the
// coupling cycle. Throws adapter::CouplingError on a study this backend cannot run.
std::unique_ptr<adapter::CouplingApi> makeBackend(const study::Study& study);

// MPI (`mpirun -np N demfem-dem --backend liggghts ...`): every rank runs demfem-dem. The leader
// (rank 0) serves the protocol and calls the backend built by makeBackend(); every other rank calls
// followLeader(), which builds its part of the same simulation, executes the operations the leader
// broadcasts and returns after the leader's shutdown(). isLeaderRank() initialises MPI if needed;
// it is true when not started under mpirun.
bool isLeaderRank();
void followLeader(const study::Study& study);

}  // namespace demfem::liggghts
