// Checked outputs (adapter/output_files.hpp). The run lock (DirectoryLock): a held output directory
// refuses a second run at once, naming the holder, from this process or another; the lock dies
// with its holder, also when the holder is killed. The atomic whole-file write: either durability
// replaces the file whole and leaves no temporary; a failed write leaves the old content.
#include "demfem/adapter/output_files.hpp"
#include "support/temp_dir.hpp"

#include <catch2/catch.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>

using namespace demfem;
using demfem::adapter::DirectoryLock;
using demfem::adapter::Durability;
using demfem::adapter::OutputError;

TEST_CASE("a second claim on a held output directory fails at once and names the holder", "[adapter]") {
  const auto dir = support::freshDir("directory-lock") / "run";
  std::optional<DirectoryLock> first(std::in_place, dir);  // creates the directory
  CHECK_THROWS_WITH(DirectoryLock(dir), Catch::Contains(dir.string() + " is in use by another run") &&
                                            Catch::Contains("process " + std::to_string(::getpid())));
  first.reset();
  CHECK_NOTHROW(DirectoryLock(dir));  // released with its holder
}

TEST_CASE("a killed run leaves no stale lock on its output directory", "[adapter]") {
  const auto dir = support::freshDir("directory-lock-killed");
  int ready[2];
  REQUIRE(::pipe(ready) == 0);
  const pid_t child = ::fork();
  REQUIRE(child >= 0);
  if (child == 0) {  // the holder: claims, tells the parent, waits to be killed
    const DirectoryLock lock(dir);
    const char byte = 1;
    if (::write(ready[1], &byte, 1) != 1) ::_exit(2);
    for (;;) ::pause();
  }
  char byte = 0;
  REQUIRE(::read(ready[0], &byte, 1) == 1);
  CHECK_THROWS_WITH(DirectoryLock(dir), Catch::Contains("process " + std::to_string(child)));
  ::kill(child, SIGKILL);
  int status = 0;
  REQUIRE(::waitpid(child, &status, 0) == child);
  CHECK(WIFSIGNALED(status));
  CHECK_NOTHROW(DirectoryLock(dir));
  ::close(ready[0]);
  ::close(ready[1]);
}

namespace {

std::string contentOf(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

TEST_CASE("an atomic write replaces the file whole at either durability and leaves no temporary", "[adapter]") {
  const auto dir = support::freshDir("atomic-write");
  const auto file = dir / "series.pvd";
  for (const Durability durability : {Durability::Synced, Durability::Unsynced}) {
    const std::string bytes(100000 + static_cast<int>(durability), durability == Durability::Synced ? 's' : 'u');
    adapter::writeFileAtomically(file, bytes, durability);
    CHECK(contentOf(file) == bytes);
  }
  CHECK(std::distance(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator()) == 1);
  // A write whose rename fails (the name is taken by a directory) names the file, removes its
  // temporary and leaves what was there.
  const auto taken = dir / "taken";
  std::filesystem::create_directories(taken / "inside");
  CHECK_THROWS_WITH(adapter::writeFileAtomically(taken, "x", Durability::Unsynced), Catch::Contains("renaming") && Catch::Contains(taken.string()));
  CHECK(std::filesystem::is_directory(taken / "inside"));
  CHECK(std::distance(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator()) == 2);
}
