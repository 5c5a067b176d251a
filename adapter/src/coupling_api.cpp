#include "demfem/adapter/coupling_api.hpp"

#include <cmath>

namespace demfem::adapter {

std::int64_t demStepCount(double duration_s, double dt_s, std::int64_t steps_done) {
  if (!(duration_s >= 0) || !std::isfinite(duration_s))
    throw CouplingError(ErrorCode::BadRequest, "simulate(" + std::to_string(duration_s) +
                                                   "): the duration must be finite and >= 0");
  const double steps = std::round(duration_s / dt_s);
  // Compared as doubles before any conversion: 1e20 s must not reach llround.
  if (!(steps <= static_cast<double>(kMaxDemSteps - steps_done)))
    throw CouplingError(ErrorCode::BadRequest, "simulate(" + std::to_string(duration_s) + " s) would take the DEM past " +
                                                   std::to_string(kMaxDemSteps) + " steps of " + std::to_string(dt_s) +
                                                   " s; nothing simulated");
  return static_cast<std::int64_t>(steps);
}

}  // namespace demfem::adapter
