// The keypoint reduction (Eq 11-15, fem/include/demfem/fem/model.hpp) with its progress on standard
// error: tens of seconds on the paper's tools, shared by every demfem-fem command.
#pragma once

#include "demfem/cli/progress.hpp"
#include "demfem/fem/model.hpp"

#include <string>

namespace demfem::cli {

inline fem::ReducedModel reduceWithProgress(const fem::FullModel& full, bool show_progress) {
  Progress progress("keypoint reduction", show_progress);
  fem::ReducedModel reduced = fem::reduce(full, [&progress](double fraction) { progress.update(fraction); });
  progress.finish(std::to_string(reduced.keypointCount()) + " keypoints");
  return reduced;
}

}  // namespace demfem::cli
