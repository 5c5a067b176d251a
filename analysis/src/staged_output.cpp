#include "demfem/analysis/staged_output.hpp"

#include <unistd.h>

#include <fstream>
#include <stdexcept>

namespace demfem::analysis {

namespace fs = std::filesystem;

namespace {
// Unique to the writing process, so two writers of one directory never share a staged file.
fs::path partialOf(const fs::path& final_path) { return fs::path(final_path).concat("." + std::to_string(::getpid()) + ".partial"); }
}  // namespace

StagedOutput::StagedOutput(fs::path directory) : directory_(std::move(directory)) {}

StagedOutput::~StagedOutput() {
  if (committed_) return;
  std::error_code ignored;
  for (const auto& path : final_paths_) fs::remove(partialOf(path), ignored);
}

fs::path StagedOutput::stage(const std::string& relative_path) {
  const fs::path final_path = directory_ / relative_path;
  fs::create_directories(final_path.parent_path());
  final_paths_.push_back(final_path);
  return partialOf(final_path);
}

void StagedOutput::writeText(const std::string& relative_path, const std::string& content) {
  const fs::path path = stage(relative_path);
  std::ofstream out(path);
  out << content;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

void StagedOutput::commit() {
  for (const auto& path : final_paths_) fs::rename(partialOf(path), path);
  committed_ = true;
}

}  // namespace demfem::analysis
