// demfem analysis: an output directory whose files appear only when everything succeeded.
//
// Contract
// - stage("plots/a.svg") returns "<dir>/plots/a.svg.<pid>.partial" (creating sub-directories) and
//   remembers the final name. Writers write to the staged path.
// - commit() renames every staged file to its final name (replacing an older file of that name).
//   Until then no final name is touched, so an interrupted or failed run never leaves files that
//   look complete.
// - The destructor of an uncommitted StagedOutput removes the staged files it created.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace demfem::analysis {

class StagedOutput {
 public:
  explicit StagedOutput(std::filesystem::path directory);
  StagedOutput(const StagedOutput&) = delete;
  StagedOutput& operator=(const StagedOutput&) = delete;
  ~StagedOutput();

  const std::filesystem::path& directory() const { return directory_; }
  std::filesystem::path stage(const std::string& relative_path);
  // Writes `content` to the staged file of `relative_path`. Throws std::runtime_error on failure.
  void writeText(const std::string& relative_path, const std::string& content);
  void commit();

 private:
  std::filesystem::path directory_;
  std::vector<std::filesystem::path> final_paths_;
  bool committed_ = false;
};

}  // namespace demfem::analysis
