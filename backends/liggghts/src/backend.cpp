#include "demfem/backends/liggghts/backend.hpp"

namespace demfem::liggghts {

// Placeholder until the liggghts backend issue lands: says clearly which part is missing.
std::unique_ptr<adapter::CouplingApi> makeBackend(const study::Study&) {
  throw adapter::CouplingError(adapter::ErrorCode::Unsupported,
                               "the liggghts DEM backend is not built yet (liggghts backend issue)");
}

bool isLeaderRank() { return true; }

void followLeader(const study::Study&) {
  throw adapter::CouplingError(adapter::ErrorCode::Unsupported,
                               "the liggghts DEM backend is not built yet (liggghts backend issue)");
}

}  // namespace demfem::liggghts
