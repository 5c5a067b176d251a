// The soil bin of a study for the built-in DEM: the box, the gravity deposition of the particle
// assembly in layers (paper Section 2.9, Fig. 4a-b) and the settled-soil file reused by every study
// on the same soil (docs/architecture.md section 5).
//
// Contract
// - Bin frame (docs/architecture.md section 10, study.hpp), metres: origin at a bottom corner, x in [0, W],
//   y up from the floor y = 0, z in [0, L]. Walls are planes (floor and four sides, open top) of the study's bin material.
// - Deposition: particles (diameters uniform in [d_min, d_max], seed soil.deposition_seed) are
//   rained in four stages from the bottom up, one per layer thickness of the study (the paper
//   deposits the upper 30 mm in 10 mm layers), each stage settling under gravity until the total
//   kinetic energy is below soil.settle_kinetic_energy_J (or its time cap, reported). The step is
//   the study's or a tenth of the stiffest spring's critical step, whichever is larger. Particles whose
//   centre ends above the fill height are removed; the rest are tagged by the depth of their centre
//   below the fill height with the layer (and that layer's material) covering that depth.
// - Settled-soil file: binary, little endian, "DFSOIL01", the soil hash (study::soilHash), the
//   particle count, then x y z radius (float64) and layer (int32) per particle. It is found by the
//   hash: soilFile(study, dir) = dir / ("soil-" + hash + ".bin").
#pragma once

#include "demfem/backends/builtin/simulation.hpp"
#include "demfem/study/study.hpp"

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace demfem::builtin {

struct SettledParticle {
  Vec3 x;
  double radius = 0;
  int layer = 0;
};

struct SettledSoil {
  std::string soil_hash;
  std::vector<SettledParticle> particles;
};

struct DepositReport {
  std::size_t particles = 0;
  double simulated_s = 0;
  long steps = 0;
  double time_step_s = 0;
  double final_kinetic_energy_J = 0;
  bool settled = true;            // every stage reached the kinetic-energy threshold
  double surface_height_m = 0;    // highest particle top after trimming
};

// The DEM domain of a study's bin (room above the fill for deposition and tools).
Domain binDomain(const study::Soil& soil);
// Adds the floor and the four side walls of the bin as planes.
void addBinWalls(DemSimulation& sim, const study::Soil& soil);
// The study's time step for `sim` (explicit dt_s, or the criterion times dt_fraction), validated.
double studyTimeStep(const DemSimulation& sim, const study::DemSettings& dem);
// Layer index (into soil.layers) of a particle centre at height y; the deepest layer below the fill.
int layerAt(const study::Soil& soil, double y);

// Mean particle volume (m^3) of the soil's size distribution (radii uniform between the diameter
// bounds' halves).
double meanParticleVolume(const study::Soil& soil);
// Particles a deposition of `soil` settles to, estimated from the bin volume below the fill height,
// the packing each stage is sized with and the mean particle volume (the quick bin: within 5 % of
// the deposited count).
std::size_t estimatedParticleCount(const study::Soil& soil);

// Progress of depositSoil: the fraction done (each stage and the final settling counted by its
// simulated-time cap, so an upper bound on what is left) and, at the end of each stage, its
// summary line (empty otherwise).
using DepositProgress = std::function<void(double fraction, const std::string& stage_line)>;

// Deposits and settles the soil of `study` (deterministic for its seed and `threads`).
// `progress` may be empty.
SettledSoil depositSoil(const study::Study& study, int threads, DepositReport& report, const DepositProgress& progress);

void writeSettledSoil(const std::filesystem::path& file, const SettledSoil& soil);
// Throws std::runtime_error naming the file on a missing, truncated or foreign file.
SettledSoil readSettledSoil(const std::filesystem::path& file);

// Where the settled soil of `study` lives in `dir`.
std::filesystem::path soilFile(const study::Study& study, const std::filesystem::path& dir);
// DEMFEM_SOIL_DIR if set, else "soil" in the working directory.
std::filesystem::path defaultSoilDirectory();

// Adds the settled particles to `sim` with their layer materials, in spatial order (cells of one
// diameter, x fastest, then y, then z), not in the file's order.
void addSettledParticles(DemSimulation& sim, const study::Soil& soil, const SettledSoil& settled);

}  // namespace demfem::builtin
