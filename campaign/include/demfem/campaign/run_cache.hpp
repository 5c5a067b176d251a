// demfem campaign: every model run kept on disk, so an interrupted calibration resumes and a
// repeated one reuses its runs (docs/calibration.md).
//
// Contract
// - Key: FNV-1a 64 (study::fnv1a64) of the model name, the canonical text of the derived case study
//   (study::toJson: every default filled in, file units, sorted keys) and the case label; the study
//   carries the DEM seed (/dem/seed), so study + seed + case identify a run. 16 hex digits.
// - Entry: DIR/<key>.json = {"model", "case", "study", "columns": {"t_s": [...], "force_N": [...],
//   "deformation_mm": [...], "displacement_mm": [...]}}, written to a temporary name and renamed,
//   so a half-written entry never exists under its final name. A file that does not parse or
//   names another study (hash collision) is not used and is replaced.
// - Thread safe: concurrent find()/store() of different keys from several threads.
#pragma once

#include "demfem/analysis/recording.hpp"
#include "demfem/study/study.hpp"

#include <atomic>
#include <filesystem>
#include <optional>
#include <string>

namespace demfem::campaign {

class RunCache {
 public:
  // Creates `directory` if needed. Throws std::runtime_error if it cannot.
  explicit RunCache(std::filesystem::path directory);

  static std::string key(const std::string& model_name, const study::Study& study, const analysis::CaseKey& key);

  std::optional<analysis::Recording> find(const std::string& model_name, const study::Study& study,
                                          const analysis::CaseKey& key) const;
  // Throws std::runtime_error if the entry cannot be written.
  void store(const std::string& model_name, const study::Study& study, const analysis::CaseKey& key,
             const analysis::Recording& recording) const;

  const std::filesystem::path& directory() const { return directory_; }

 private:
  std::filesystem::path directory_;
};

}  // namespace demfem::campaign
