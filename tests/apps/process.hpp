// Test helper: start an executable with posix_spawn (stdout/stderr to files), wait with a bound.
#pragma once

#include "support/small_study.hpp"
#include "support/spawn.hpp"
#include "support/temp_dir.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>


namespace demfem::testing {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

inline fs::path binaryDir() { return DEMFEM_BINARY_DIR; }
inline fs::path sourceDir() { return DEMFEM_SOURCE_DIR; }
inline std::string app(const std::string& name) { return (binaryDir() / "apps" / name).string(); }
using support::freshDir;
using support::readText;
using support::shippedStudyJson;
using support::useShortStroke;
using support::useSmallBin;
using support::useSmallTool;
using support::writeStudy;

class Process {
 public:
  Process(std::vector<std::string> args, const fs::path& log_stem)
      : stdout_(log_stem.string() + ".out"), stderr_(log_stem.string() + ".err"), pid_(support::spawnLogged(std::move(args), stdout_, stderr_)) {}
  ~Process() {
    if (!status_) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  void signal(int sig) { if (!status_) kill(pid_, sig); }
  pid_t pid() const { return pid_; }
  bool exited() {
    int status = 0;
    if (!status_ && waitpid(pid_, &status, WNOHANG) == pid_) status_ = status;
    return status_.has_value();
  }
  // Waits up to `limit`; returns the raw wait status, or throws if still running (then kills it).
  int wait(std::chrono::milliseconds limit) {
    const auto deadline = std::chrono::steady_clock::now() + limit;
    while (!exited()) {
      if (std::chrono::steady_clock::now() > deadline) {
        signal(SIGKILL);
        waitpid(pid_, nullptr, 0);
        status_ = -1;
        throw std::runtime_error("process did not end within the time limit; stderr: " + readText(stderr_));
      }
      std::this_thread::sleep_for(10ms);
    }
    return *status_;
  }
  std::string err() const { return readText(stderr_); }
  std::string out() const { return readText(stdout_); }

 private:
  std::string stdout_, stderr_;
  pid_t pid_ = -1;
  std::optional<int> status_;
};

inline bool exitedOk(int status) { return WIFEXITED(status) && WEXITSTATUS(status) == 0; }

// Runs `args`, requires exit status 0 within `limit` and returns standard output parsed as one JSON
// document (nlohmann::json::parse rejects anything before or after it: `--json -` prints nothing else).
inline nlohmann::json jsonStdout(const std::vector<std::string>& args, const fs::path& log_stem,
                                 std::chrono::seconds limit = std::chrono::seconds(240)) {
  Process p(args, log_stem);
  const int status = p.wait(limit);
  INFO(p.err());
  REQUIRE(exitedOk(status));
  const std::string out = p.out();
  INFO("standard output:\n" << out);
  nlohmann::json doc;
  REQUIRE_NOTHROW(doc = nlohmann::json::parse(out));
  return doc;
}

// Waits (bounded) until `file` exists, or `process` has exited.
inline bool waitForFile(const fs::path& file, Process& process, std::chrono::milliseconds limit) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (!fs::exists(file)) {
    if (process.exited() || std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(10ms);
  }
  return true;
}

// Reads the first line of an endpoint file written by demfem-dem --endpoint-file.
inline std::string endpointFrom(const fs::path& file) {
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);
  return line;
}

// A copy of studies/quick.json made cheap for tests, written to `dir`: a 120 x 20 mm tool (5 x 25 x 2 =
// 250 keypoints; clamp, load-cell and sensor lines as in the paper) inserted at 300 mm/s.
inline fs::path fastQuickStudy(const fs::path& dir) {
  nlohmann::json study = shippedStudyJson("quick.json");
  useSmallTool(study);
  study["tools"][0]["motion"]["insertion_velocity_mm_s"] = 300;
  return writeStudy(study, dir / "quick_fast.json");
}

// Rows of a sensor CSV (header and '#' lines skipped).
inline std::vector<std::vector<double>> csvRows(const fs::path& file) {
  std::vector<std::vector<double>> rows;
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<double> row;
    std::stringstream cells(line);
    std::string cell;
    while (std::getline(cells, cell, ',')) row.push_back(std::stod(cell));
    rows.push_back(row);
  }
  return rows;
}

}  // namespace demfem::testing
