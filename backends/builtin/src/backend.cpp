#include "demfem/backends/builtin/backend.hpp"

namespace demfem::builtin {

// Placeholder until the builtin backend issue lands: says clearly which part is missing.
std::unique_ptr<adapter::CouplingApi> makeBackend(const study::Study&) {
  throw adapter::CouplingError(adapter::ErrorCode::Unsupported,
                               "the builtin DEM backend is not built yet (builtin backend issue)");
}

}  // namespace demfem::builtin
