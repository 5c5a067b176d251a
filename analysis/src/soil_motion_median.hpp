// The median of the soil-motion measures (soil_motion.hpp: front speeds, streamline lengths).
#pragma once

#include <vector>

namespace demfem::analysis {

// The median of ascending, non-empty values (the mean of the two middle ones for an even count).
inline double medianOfSorted(const std::vector<double>& sorted) {
  const std::size_t m = sorted.size() / 2;
  return sorted.size() % 2 ? sorted[m] : 0.5 * (sorted[m - 1] + sorted[m]);
}

}  // namespace demfem::analysis
