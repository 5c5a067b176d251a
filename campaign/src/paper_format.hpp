// A number in the Markdown tables of the paper report and the convergence study (printf format).
#pragma once

#include <cstdio>
#include <string>

namespace demfem::campaign {

inline std::string formatNumber(const char* format, double value) {
  char text[64];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

}  // namespace demfem::campaign
