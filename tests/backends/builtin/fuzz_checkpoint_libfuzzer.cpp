// libFuzzer target for the checkpoint readers (adapter/checkpoint_file.hpp and the backends'
// restore): the input is taken (1) as a whole checkpoint file for the container check and the test
// backend's restore, and (2) as the payload of a correctly checksummed builtin DEM state, so that
// mutations reach the structural checks behind the checksum. A state that is accepted is run for a
// few steps. Only adapter::CouplingError (refused) and builtin::BlowUp (a consistent state that
// blows up) may come out; anything else aborts.
//
// Seed: a valid state of the small simulation below is written to the corpus directory given as
// the first argument when it is empty (tests/CMakeLists.txt does this for the CI run).
#include "demfem/adapter/checkpoint_file.hpp"
#include "demfem/adapter/test_backends.hpp"
#include "demfem/backends/builtin/simulation.hpp"
#include "test_soil.hpp"

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <unistd.h>

namespace {

using namespace demfem;
using namespace demfem::builtin;
namespace fs = std::filesystem;

// 27 grains settling on a plane and on a two-triangle mesh wall, run until contacts exist.
const DemSimulation& reference() {
  static const DemSimulation sim = [] {
    DemSimulation s(testing::makeSoil({}), testing::box(0.1), 1);
    s.addPlane({{0, -0.05, 0}, {0, 1, 0}, 1});
    TriangleMesh floor;
    floor.name = "floor";
    floor.rest_nodes = {{-0.05, -0.02, -0.05}, {0.05, -0.02, -0.05}, {0.05, -0.02, 0.05}, {-0.05, -0.02, 0.05}};
    floor.triangles = {{0, 2, 1}, {0, 3, 2}};
    floor.material = 1;
    s.addMesh(floor);
    for (int k = 0; k < 27; ++k) {
      ParticleState p;
      p.radius = 0.004 + 0.0001 * (k % 5);
      p.x = {0.01 * (k % 3 - 1), -0.015 + 0.01 * (k / 9), 0.01 * ((k / 3) % 3 - 1)};
      s.addParticle(p);
    }
    s.setTimeStep(1e-5);
    s.run(300);
    return s;
  }();
  return sim;
}

std::string validPayload() {
  adapter::PayloadWriter out;
  reference().saveState(out);
  return out.bytes();
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  if (*argc > 1 && fs::is_directory((*argv)[*argc - 1]) && fs::is_empty((*argv)[*argc - 1]))
    std::ofstream(fs::path((*argv)[*argc - 1]) / "valid_state", std::ios::binary) << validPayload();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  // (1) A whole file: the container check, then the test backend's restore through a file.
  try {
    adapter::checkpointPayload(bytes, "builtin", "input");
  } catch (const adapter::CouplingError&) {
  }
  static const fs::path file = fs::temp_directory_path() / ("demfem-fuzz-ckpt-" + std::to_string(getpid()));
  std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
  static auto harmonic = adapter::makeTestBackend("harmonic", {study::Tool{}}, adapter::TestLoad{});
  try {
    harmonic->restore(file);
    harmonic->simulate(1e-3);
    (void)harmonic->nodeForces("tool");
  } catch (const adapter::CouplingError&) {
  }
  // (2) A checksummed builtin state: the structural checks, then a few steps of what they accept.
  const std::string image = adapter::checkpointImage("builtin", bytes);
  try {
    const std::string payload = adapter::checkpointPayload(image, "builtin", "input");
    adapter::PayloadReader in(payload, "input");
    DemSimulation restored = reference().withState(in);
    in.finish();
    restored.run(3);
  } catch (const adapter::CouplingError&) {
  } catch (const BlowUp&) {
  }
  return 0;
}
