// Shared test fixture: scratch directories under the system temp directory, and reading back the
// files written there.
#pragma once

#include <filesystem>
#include <fstream>
#include <sstream>
#include <random>
#include <string>
#include <system_error>

#include <unistd.h>

namespace demfem::support {

// demfem-<name>-<pid>, emptied on construction and removed at scope exit.
class TempDir {
 public:
  explicit TempDir(const std::string& name)
      : path_(std::filesystem::temp_directory_path() / ("demfem-" + name + "-" + std::to_string(::getpid()))) {
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

// A new directory demfem-<name>-<random>, left for the caller to remove (so a failed test leaves
// its files to look at).
inline std::filesystem::path freshDir(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("demfem-" + name + "-" + std::to_string(std::random_device{}()));
  std::filesystem::create_directories(dir);
  return dir;
}

// The whole text of `path` ("" when it cannot be opened: the test's checks on the text then fail).
inline std::string readText(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace demfem::support
