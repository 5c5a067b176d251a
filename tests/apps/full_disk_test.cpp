// `demfem run` on a full disk: a small tmpfs mounted for the test (needs the right to mount, e.g.
// root in a container; otherwise the test prints "SKIPPED:" and ctest reports it skipped). Every
// failed write must stop the run with a message naming the file, a non-zero exit, and no output
// presented as complete.
#include "process.hpp"

#include <sys/mount.h>

#include <catch2/catch.hpp>

#include <cerrno>
#include <cstring>
#include <iostream>

using namespace demfem::testing;

namespace {

// A tmpfs of `size` mounted at `dir` for the guard's lifetime; mounted() false if not permitted.
struct SmallTmpfs {
  SmallTmpfs(const fs::path& dir, const std::string& size) : dir(dir) {
    fs::create_directories(dir);
    const std::string options = "size=" + size;
    if (::mount("tmpfs", dir.c_str(), "tmpfs", 0, options.c_str()) == 0) ok = true;
    else error = std::strerror(errno);
  }
  ~SmallTmpfs() {
    if (ok) ::umount2(dir.c_str(), MNT_DETACH);
  }
  fs::path dir;
  bool ok = false;
  std::string error;
};

void runOnFullDisk(const std::string& size) {
  const fs::path dir = freshDir("full-disk-" + size);
  const fs::path study = fastQuickStudy(dir);
  {
    SmallTmpfs disk(dir / "disk", size);
    if (!disk.ok) {
      std::cout << "SKIPPED: cannot mount a " << size << " tmpfs (" << disk.error << "); run as root to test full disks\n";
      return;
    }
    const fs::path out = disk.dir / "out";
    Process run({app("demfem"), "run", study.string(), "--backend", "harmonic", "--output", out.string(), "--quiet"},
                dir / "demfem");
    const int status = run.wait(180s);
    const std::string err = run.err();
    INFO("tmpfs " << size << "; demfem run stderr:\n" << err);
    CHECK_FALSE(exitedOk(status));
    // The message names the file that could not be written, and why.
    CHECK_THAT(err, Catch::Contains(out.string() + "/") && Catch::Contains("No space left on device"));
    // Nothing looks complete: the sidecar says incomplete, or the message says it could not be marked.
    const bool unmarked = err.find("could not all be marked incomplete") != std::string::npos;
    if (fs::exists(out / "sensors.json")) {
      const auto sidecar = nlohmann::json::parse(readText(out / "sensors.json"));
      CHECK(sidecar["complete"] == false);
    } else {
      CHECK(unmarked);
    }
    if (fs::exists(out / "sensors.csv"))  // renamed: then it carries the trailer
      CHECK(readText(out / "sensors.csv").find("\n# incomplete: ") != std::string::npos);
    else
      CHECK(fs::exists(out / "sensors.csv.partial"));
  }
  fs::remove_all(dir);
}

}  // namespace

TEST_CASE("demfem run on a 64 KiB disk stops with the file that failed and leaves nothing marked complete", "[apps]") {
  runOnFullDisk("64k");
}

TEST_CASE("demfem run on a 3 MiB disk stops mid-run with the file that failed and leaves nothing marked complete", "[apps]") {
  runOnFullDisk("3m");
}
