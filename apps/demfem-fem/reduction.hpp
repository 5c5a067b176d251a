// The keypoint reduction (Eq 11-15, fem/include/demfem/fem/model.hpp) through the reduction cache
// (fem/reduction_cache.hpp) with its progress on standard error: tens of seconds on the paper's
// tools when not cached, shared by every demfem-fem command.
#pragma once

#include "demfem/cli/progress.hpp"
#include "demfem/fem/model.hpp"
#include "demfem/fem/reduction_cache.hpp"

#include <filesystem>
#include <string>

namespace demfem::cli {

inline fem::ReducedModel reduceWithProgress(const fem::FullModel& full, bool show_progress) {
  Progress progress("keypoint reduction", show_progress);
  const auto file = fem::reductionFile(full, fem::defaultReductionDirectory());
  const bool cached = std::filesystem::exists(file);
  fem::ReducedModel reduced =
      fem::reduceCached(full, fem::defaultReductionDirectory(), [&progress](double fraction) { progress.update(fraction); });
  progress.finish(std::to_string(reduced.keypointCount()) + " keypoints" + (cached ? ", read from " + file.string() : ""));
  return reduced;
}

}  // namespace demfem::cli
