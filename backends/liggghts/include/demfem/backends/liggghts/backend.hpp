// Factory of the liggghts DEM backend: the coupling API (adapter/coupling_api.hpp) on a study's soil
// and tools, run in-process on Debian's libliggghts (LIGGGHTS-PUBLIC 3.8), one instance per MPI rank.
//
// Contract (besides coupling_api.hpp's)
// - The study is translated by translateStudy() (input_deck.hpp) and checked before any command
//   reaches LIGGGHTS: LIGGGHTS stops the process on an input error, so what it would reject is
//   reported here as adapter::CouplingError instead.
// - Construction takes the settled soil from the backend-neutral file adapter::settledSoilFile(study,
//   BackendOptions::soil_directory, default: $DEMFEM_SOIL_DIR, else ./soil), whichever backend
//   deposited it. Without that file, a study whose soil.deposition.backend is "liggghts" is deposited
//   here (depositSoil()) and the file written; any other is BadRequest naming the file (the built-in
//   deposition is not in this library: `demfem deposit` or demfem-dem makes the file). Either way
//   the simulation starts from the file's particles at rest (positions, radii, layer materials; no
//   contact history), so a run gives the same numbers whether its soil was deposited or read. A
//   damaged file or one of another soil is an error (BadRequest naming it), never silently
//   replaced. info().soil_json records the soil (adapter::soilRecordJson). Then the particles in the tools' way are
//   removed and the tools put at their start positions (toolStartOrigin(), velocity zero); time()
//   is 0 after it. With
//   BackendOptions::probes set, the soil is replaced by fixed probe spheres (no deposition, no time
//   integration of particles).
// - Node forces: accumulated at every DEM step from the per-contact forces LIGGGHTS stores for the
//   tool meshes (wall/gran store_force_contact_stress) and split to the contact triangle's keypoints
//   by the barycentric weights of the contact point; reduced over all MPI ranks.
// - Node positions: read from the tool's LIGGGHTS mesh (per-triangle node copies, merged per keypoint
//   and over ranks), minus the rigid motion. setNodePositions() moves every local and ghost copy by
//   the increment; the next simulate() re-runs LIGGGHTS' set-up so normals and neighbour lists follow.
// - Checkpoint/restore are not offered (ErrorCode::Unsupported).
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/adapter/settled_soil.hpp"
#include "demfem/study/backend_capabilities.hpp"
#include "demfem/study/study.hpp"

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace demfem::liggghts {

// What the LIGGGHTS backend offers (docs/liggghts-backend.md): LIGGGHTS' own contact laws, plate
// tools, no checkpoints.
inline study::BackendCapabilities capabilities() {
  using namespace study;
  return {"liggghts", true,
          {NormalModel::Hooke, NormalModel::HookeHysteresis},
          {CohesionModel::None, CohesionModel::Sjkr, CohesionModel::Sjkr2},
          {RollingModel::None, RollingModel::Cdt, RollingModel::Epsd},
          {GeometryKind::Plate}, false};
}

// A sphere in the bin (bin frame, metres) of a particle material of the study.
struct Sphere {
  std::array<double, 3> centre_m{};
  double radius_m = 0;
  std::string material;
};
using ProbeSphere = Sphere;  // held fixed

struct BackendOptions {
  // Empty: deposit the study's soil. Otherwise: only these fixed spheres (contact-law checks).
  std::vector<ProbeSphere> probes;
  // Where settled soils are kept; empty: $DEMFEM_SOIL_DIR if set, else "soil" in the working directory.
  std::filesystem::path soil_directory;
  // Non-empty: the settled soil to start from (particles at rest) instead of the study's settled-soil
  // file; no soil file is read or written and info().soil_json stays empty.
  std::vector<Sphere> settled_soil;
};

// The settled-soil file of a backend and whether its construction deposited the soil and wrote the
// file (true) or read it (false). Empty file for a probe backend or a given settled_soil.
struct SoilOrigin {
  std::filesystem::path file;
  bool deposited = false;
};

// Builds the DEM simulation of `study` (soil, bin, tools at their start positions) ready for the
// coupling cycle. Throws adapter::CouplingError on a study this backend cannot run.
std::unique_ptr<adapter::CouplingApi> makeBackend(const study::Study& study);
std::unique_ptr<adapter::CouplingApi> makeBackend(const study::Study& study, const BackendOptions& options);

// The total force on `geometry` at the last DEM step as LIGGGHTS' stress mesh reports it (fix
// mesh/surface/stress, N, bin frame = local frame as tools are not rotated): an independent check of
// nodeForces(Instantaneous) summed over the keypoints. Throws BadRequest if `backend` was not made by
// this backend's makeBackend(), UnknownGeometry for an unknown name.
std::array<double, 3> meshTotalForce(adapter::CouplingApi& backend, const std::string& geometry);

// Number of particles in the simulation (all ranks). Throws BadRequest as meshTotalForce().
std::int64_t particleCount(adapter::CouplingApi& backend);

// Where the backend's settled soil came from. Throws BadRequest as meshTotalForce().
SoilOrigin soilOrigin(adapter::CouplingApi& backend);

// Every particle's centre and radius (x, y, z, r in m, bin frame) in LIGGGHTS id order. Single MPI
// rank only (Unsupported otherwise); throws BadRequest as meshTotalForce().
std::vector<std::array<double, 4>> particles(adapter::CouplingApi& backend);

// Deposits the study's soil in a LIGGGHTS instance of its own: one insert/pack per layer, settling
// under gravity until the translational kinetic energy is below soil.settle_kinetic_energy_J (at
// most 20 s after twice the fall time; a soil that hits that cap is returned with stages_capped = 1,
// not refused), particles centred above the fill height removed; layer of each particle: the layer
// of its material that covers (or is nearest to) its depth. Not written to any file. Collective over
// the MPI ranks; throws CouplingError (SimulationFailed) if the deposition diverges.
adapter::SettledSoil depositSoil(const study::Study& study);

// MPI (`mpirun -np N demfem-dem --backend liggghts ...`): every rank runs demfem-dem. The leader
// (rank 0) serves the protocol and calls the backend built by makeBackend(); every other rank calls
// followLeader(), which builds its part of the same simulation, executes the operations the leader
// broadcasts and returns after the leader's shutdown(); it must get the study and options the
// leader's makeBackend() got (construction is collective). isLeaderRank() initialises MPI if
// needed; it is true when not started under mpirun.
bool isLeaderRank();
void followLeader(const study::Study& study);
void followLeader(const study::Study& study, const BackendOptions& options);

}  // namespace demfem::liggghts
