// The soil bin of a study for the built-in DEM: the box, the gravity deposition of the particle
// assembly in layers (paper Section 2.9, Fig. 4a-b) into the backend-neutral settled soil
// (adapter/settled_soil.hpp) that every study on the same soil, on either backend, starts from.
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
//   below the fill height with the layer (and that layer's material) covering that depth, and settle
//   once more. The result carries its settling figures: stages = layers + 1 (the final settling),
//   those that hit the cap, the final total kinetic energy, surface height and packing fraction.
#pragma once

#include "demfem/adapter/settled_soil.hpp"
#include "demfem/backends/builtin/simulation.hpp"
#include "demfem/study/study.hpp"

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace demfem::builtin {

// What a deposition cost, besides the settling figures the soil itself carries.
struct DepositReport {
  long steps = 0;
  double time_step_s = 0;
};

// The DEM domain of a study's bin (room above the fill for deposition and tools).
Domain binDomain(const study::Soil& soil);
// Adds the floor and the four side walls of the bin as planes.
void addBinWalls(DemSimulation& sim, const study::Soil& soil);
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

// Deposits and settles the soil of `study` (deterministic for its seed and `threads`; the soil
// records both). `progress` may be empty.
adapter::SettledSoil depositSoil(const study::Study& study, int threads, DepositReport& report, const DepositProgress& progress);

// Adds the settled particles to `sim` with their layer materials, in spatial order (cells of one
// diameter, x fastest, then y, then z), not in the file's order.
void addSettledParticles(DemSimulation& sim, const study::Soil& soil, const adapter::SettledSoil& settled);

}  // namespace demfem::builtin
