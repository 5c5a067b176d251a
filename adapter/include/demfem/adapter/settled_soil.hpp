// The settled soil of a study as one backend-neutral artefact: the particles every DEM backend starts
// a run from, whichever backend deposited them (soil.deposition.backend), with the figures of their
// settling (docs/builtin-dem.md, "Settled soil file").
//
// Contract
// - Particles in the bin frame (study.hpp), metres: centre, radius and the index of the layer in
//   soil.layers (0 = top) whose material the particle has. At rest: no velocities, no contact history.
// - File, little endian (the platforms both backends are built for):
//     8 bytes   magic "DFSOILNT"
//     uint32    format version (kSettledSoilFormatVersion)
//     uint32    byte length H of the header
//     H bytes   header, a JSON object: soil_hash (study::soilHash), deposition {backend, seed, cores},
//               settling {kinetic_energy_J, threshold_J, stages, stages_capped,
//               final_phase_capped, simulated_s, surface_height_m, packing_fraction,
//               bulk_density_kg_m3, coordination_number, target_bulk_density_kg_m3,
//               pour_friction_scale}, particle_count
//     36 bytes per particle: x_m, y_m, z_m, radius_m (float64), layer (int32)
//     uint64    FNV-1a 64 (study::fnv1a64) of every byte before it
//   readSettledSoil() checks magic, version, header, length and checksum and throws
//   std::runtime_error naming the file and what is wrong; nothing is repaired or guessed.
// - writeSettledSoil() writes under a unique temporary name in the same directory and renames, so a
//   reader never sees half a file; every write is checked.
// - The file of a study is settledSoilFile(study, dir) = dir / ("soil-" + soilHash + ".bin"), the
//   same name for every backend and every run's core count (the hash leaves out dem.backend and
//   dem.threads, and holds soil.deposition.threads, the deposition's own). depositOnce() writes it.
#pragma once

#include "demfem/study/study.hpp"

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace demfem::adapter {

inline constexpr std::uint32_t kSettledSoilFormatVersion = 3;

struct SoilParticle {
  std::array<double, 3> x_m{};
  double radius_m = 0;
  std::int32_t layer = 0;
  bool operator==(const SoilParticle&) const = default;
};

// How the deposition ended. The kinetic energy is the deposition backend's criterion: total
// (built-in) or translational (LIGGGHTS, whose laws leave a spin about a contact normal unresisted).
struct SettlingFigures {
  double kinetic_energy_J = 0;   // at the end of the deposition
  double threshold_J = 0;        // soil.settle_kinetic_energy_J it had to fall below
  std::int32_t stages = 0;       // settling phases of the deposition
  std::int32_t stages_capped = 0;  // phases that hit their time cap above the threshold
  bool final_phase_capped = false; // the last phase, whose particles are kept, is one of them
  double simulated_s = 0;        // simulated deposition time
  double surface_height_m = 0;   // soilSurfaceHeight()
  double packing_fraction = 0;   // packingFraction()
  double bulk_density_kg_m3 = 0;  // bulkDensity(): what a core sampler measures
  double coordination_number = 0;  // meanCoordinationNumber()
  // soil.deposition.bulk_density_kg_m3 the deposition had to reach (0: none, the plain gravity pour)
  // and the factor on the inter-particle friction of the pour that reached it (1: the study's).
  double target_bulk_density_kg_m3 = 0;
  double pour_friction_scale = 1;
  bool operator==(const SettlingFigures&) const = default;
};

struct SettledSoil {
  std::string soil_hash;
  std::string backend = "builtin";  // soil.deposition.backend: the backend that deposited it
  std::uint64_t seed = 0;        // soil.deposition.seed
  std::int32_t cores = 1;        // threads or MPI ranks of the deposition (the bits depend on it)
  SettlingFigures settling;
  std::vector<SoilParticle> particles;
  bool operator==(const SettledSoil&) const = default;
};

void writeSettledSoil(const std::filesystem::path& file, const SettledSoil& soil);

// Deposits the settled soil `file` once: under an exclusive lock on `file` + ".lock" (flock,
// waiting for a process that holds it), `deposit()` runs and its soil is written only when the file
// does not exist (or `replace`); a process that waited finds the file and reuses it, so two
// depositions of one soil never both run and a reader never sees the file replaced by another
// packing. Returns whether this call deposited. Throws std::runtime_error naming the lock file when
// it cannot be opened or locked; what `deposit` or the write throws passes through.
bool depositOnce(const std::filesystem::path& file, const std::function<SettledSoil()>& deposit, bool replace = false);
SettledSoil readSettledSoil(const std::filesystem::path& file);
// Same, and the soil must be the study's: same soil hash, every layer index in soil.layers.
SettledSoil readSettledSoil(const std::filesystem::path& file, const study::Study& study);

// The FNV-1a 64 checksum stored at the end of a settled-soil file (16 hex digits); throws like
// readSettledSoil() for a file that is not one.
std::string settledSoilChecksum(const std::filesystem::path& file);

std::filesystem::path settledSoilFile(const study::Study& study, const std::filesystem::path& dir);
// $DEMFEM_SOIL_DIR if set, else "soil" in the working directory.
std::filesystem::path defaultSoilDirectory();

// Mean top (y + r, m above the floor) of the particles whose top lies within one largest diameter
// of the highest top; 0 for no particles.
double soilSurfaceHeight(const std::vector<SoilParticle>& particles, double diameter_max_m);
// Particle volume over bin width x length x fill height.
double packingFraction(const std::vector<SoilParticle>& particles, const study::Soil& soil);
// Bulk density (kg/m^3): particle mass (each particle's volume times the density of its layer's
// material) over bin width x length x fill height. Throws std::invalid_argument for a layer index
// outside soil.layers or a layer material not in soil.materials.
double bulkDensity(const std::vector<SoilParticle>& particles, const study::Soil& soil);
// Mean coordination number: twice the particle pairs whose centre distance is below the sum of their
// radii (touching), over the particle count; wall contacts are not counted. 0 for no particles.
double meanCoordinationNumber(const std::vector<SoilParticle>& particles);

// Why the soil is not settled ("" if it is): the final phase hit its time cap or the final kinetic
// energy is not below the threshold. An earlier phase that hit its cap only poured the next layer
// onto a pack still moving; what is kept is the final phase's soil at rest.
std::string unsettledReason(const SettlingFigures& settling);
// The one refusal text for running on an unsettled soil ("" if it is settled): names the file and
// the reason, and says how to fix it (a higher threshold and a new deposition) or to override it.
std::string unsettledSoilMessage(const std::filesystem::path& file, const SettlingFigures& settling);

// The soil's figures as the JSON object text a run records ("soil" in sensors.json): file,
// file_checksum, soil_hash, deposition_backend, deposition_seed, deposition_cores, particles,
// settled, kinetic_energy_J, threshold_J, stages, stages_capped, final_phase_capped, simulated_s,
// surface_height_mm, packing_fraction, bulk_density_kg_m3, coordination_number,
// target_bulk_density_kg_m3 (null without a target), pour_friction_scale.
std::string soilRecordJson(const SettledSoil& soil, const std::filesystem::path& file, const std::string& checksum);

}  // namespace demfem::adapter
