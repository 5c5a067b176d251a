// Statistics the benchmarks report over their interleaved rounds.
#pragma once

#include <algorithm>
#include <stdexcept>
#include <vector>

namespace demfem::bench {

// The median of `values` (the mean of the two middle ones for an even count); throws on none.
inline double median(std::vector<double> values) {
  if (values.empty()) throw std::invalid_argument("median of no values");
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

}  // namespace demfem::bench
