// The soil bin of a study for the built-in DEM: the box, the gravity deposition of the particle
// assembly in layers (paper Section 2.9, Fig. 4a-b) into the backend-neutral settled soil
// (adapter/settled_soil.hpp) that every study on the same soil, on either backend, starts from.
//
// Contract
// - Bin frame (docs/architecture.md section 10, study.hpp), metres: origin at a bottom corner, x in [0, W],
//   y up from the floor y = 0, z in [0, L]. Walls are planes (floor and four sides, open top) of the study's bin material.
// - Deposition (docs/builtin-dem.md, "Soil deposition and reuse"): a gravity pour as LIGGGHTS'
//   insert/pack deposits. Each layer (paper Section 2.9; the paper deposits the upper 30 mm in 10 mm
//   layers) gets enough particles (diameters uniform in [d_min, d_max], seed soil.deposition_seed) to
//   fill its height range at a solid fraction of 0.64, created at random non-overlapping positions in
//   a slab 3.2 times that range (solid fraction 0.2), the slabs stacked from the deepest layer up,
//   with the layer's own material and contact laws. They fall as one rain, undamped, and settle until
//   the total kinetic energy has stayed below soil.settle_kinetic_energy_J for three checks; a
//   background damping (the settling aid) starts only 0.5 s after the rain has landed, on a pack
//   that is still ringing. The step is the study's or a tenth of the stiffest spring's critical
//   step, whichever is larger. Particles whose centre ends above the fill height are removed; the
//   rest are tagged by the depth of their centre below the fill height with the layer (and that
//   layer's material) covering that depth, and settle once more. Then the reload phase: the bed
//   loaded as a run loads it (loadSettledBed(), setRunTimeStep(): contact history dropped, the run's
//   step) and left alone for 0.5 s, again and again from where it ended, until a window moves no
//   particle centre by more than 0.05 of the smallest diameter and lifts none above the fill height
//   (centres risen above it are trimmed after each window; at most 10 windows; the bed is the end
//   of the last; particles keep the layer the final settling tagged them with). The result carries its settling figures: stages = 3 (the pour, the final
//   settling and the reload phase), those that hit their cap (the reload phase: not at rest after 10
//   windows), the total kinetic energy at the end of the final settling (the reload phase is judged
//   by displacement), surface height, packing fraction, bulk density and coordination number.
// - With soil.bulk_density_kg_m3 (kg/m^3) the density protocol: the plain pour, then pours with the
//   inter-particle static and rolling friction times f in [0, 1) (walls keep theirs), f found by
//   regula falsi until the bed's bulk density is within 1 % of the target (at most 8 pours), the
//   study's friction restored (a new simulation from the particles at rest) and the bed settled.
//   A target looser than the plain pour or denser than the frictionless pour by more than 1 %, or
//   not reached in 8 pours, throws std::runtime_error naming the key and the densities.
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
  long steps = 0;  // of the pours and settlings, at time_step_s
  double time_step_s = 0;
  long reload_steps = 0;  // of the reload phases, at the run's step reload_time_step_s
  double reload_time_step_s = 0;
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
// Particles the pour of `soil` inserts below the fill height (its solid fraction 0.64 of the bin
// volume below the fill over the mean particle volume): an upper bound of the settled count (the
// plain pour keeps about 0.89 of it, the frictionless pour about 0.95).
std::size_t estimatedParticleCount(const study::Soil& soil);

// Progress of depositSoil: the fraction done of the current pour (the pour and the final settling
// counted by their simulated-time caps, so an upper bound on what is left) and, at the end of each
// phase, its summary line (empty otherwise; the density protocol prefixes the pour's number).
using DepositProgress = std::function<void(double fraction, const std::string& stage_line)>;

// Deposits and settles the soil of `study` (deterministic for its seed and `threads`; the soil
// records both). `progress` may be empty. `report` counts the steps of every pour.
adapter::SettledSoil depositSoil(const study::Study& study, int threads, DepositReport& report, const DepositProgress& progress);

// Adds the settled particles to `sim` with their layer materials, in spatial order (cells of one
// diameter, x fastest, then y, then z), not in the file's order.
void addSettledParticles(DemSimulation& sim, const study::Soil& soil, const adapter::SettledSoil& settled);
// The bed as `demfem run` loads a soil file: the bin's walls and addSettledParticles() (positions
// only: no velocities, no contact history).
void loadSettledBed(DemSimulation& sim, const study::Soil& soil, const adapter::SettledSoil& settled);
// The run's steps: the study's DEM step shortened to divide the FEM step, and its rolling
// regularisation step. Set after every wall, mesh and particle is in `sim` (the step is checked
// against the stiffest of their springs).
void setRunTimeStep(DemSimulation& sim, const study::Study& study);

// A bed at rest (docs/builtin-dem.md, "A bed at rest"): `settled` loaded as a run loads it
// (loadSettledBed(), setRunTimeStep()) and left alone for `rest_s` of simulated time with the
// study's laws (no settling aid). `observe` (may be empty) sees the simulation at t = 0 and after
// every `observe_every_s` (rounded to whole steps; 0: every twentieth of the rest).
struct RestFigures {
  double rms_speed_m_s = 0;                // over all particles, at the end
  double largest_displacement_m = 0;       // of a particle centre, start to end
  double largest_late_displacement_m = 0;  // over the second half of the rest alone
  std::size_t moved_over_1mm = 0;          // particles displaced more than 1 mm, start to end
  long steps = 0;
  double time_step_s = 0;                  // the run's
  std::vector<adapter::SoilParticle> end;  // the bed at the end (in the loaded order)
};
using RestObserver = std::function<void(const DemSimulation&)>;
RestFigures measureRest(const study::Study& study, const adapter::SettledSoil& settled, double rest_s, int threads,
                        const RestObserver& observe, double observe_every_s = 0);

}  // namespace demfem::builtin
