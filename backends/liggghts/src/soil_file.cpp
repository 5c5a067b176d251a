// The settled soil of the LIGGGHTS backend (session.hpp): gathered from the ranks, converted to and
// from the backend-neutral soil file, and deposited by gravity in an instance of its own.
#include "session.hpp"

#include <mpi.h>

#include <atom.h>
#include <lammps.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace demfem::liggghts::detail {

namespace {

using adapter::CouplingError;
using adapter::ErrorCode;

// Deposition: kinetic energy is checked every kSettleCheck_s of simulated time; settling that takes
// longer than kSettleLimit_s (after the particles had time to fall) is reported as a failure.
constexpr double kSettleCheck_s = 0.01;
constexpr double kSettleLimit_s = 20.0;

// The layer of a particle LIGGGHTS deposited with atom `type` at height y: the layer covering y if
// it is of the particle's material, else the nearest layer (in depth) of that material.
std::int32_t layerOfDeposited(const study::Study& study, int type, double y) {
  const auto& layers = study.soil.layers;
  const double depth = study.soil.fill_height_m - y;
  std::int32_t best = -1;
  double best_distance = std::numeric_limits<double>::infinity();
  for (std::size_t l = 0; l < layers.size(); ++l) {
    if (atomType(study, layers[l].material) != type) continue;
    const double distance = std::max({0.0, layers[l].top_depth_m - depth, depth - layers[l].bottom_depth_m});
    if (distance < best_distance) best_distance = distance, best = static_cast<std::int32_t>(l);
  }
  if (best < 0) throw CouplingError(ErrorCode::Internal, "deposited particle of atom type " + std::to_string(type) +
                                                             " matches no layer material");
  return best;
}

}  // namespace

SettledParticles gatherParticles(LAMMPS_NS::LAMMPS* lmp) {
  const LAMMPS_NS::Atom* atom = lmp->atom;
  std::vector<double> local;  // id, then the kParticleValues values
  for (int i = 0; i < atom->nlocal; ++i)
    local.insert(local.end(), {static_cast<double>(atom->tag[i]), atom->x[i][0], atom->x[i][1], atom->x[i][2],
                               atom->radius[i], static_cast<double>(atom->type[i])});
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const int local_count = static_cast<int>(local.size());
  std::vector<int> counts(static_cast<std::size_t>(size)), offsets(static_cast<std::size_t>(size), 0);
  MPI_Allgather(&local_count, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  for (std::size_t r = 1; r < counts.size(); ++r) offsets[r] = offsets[r - 1] + counts[r - 1];
  std::vector<double> all(static_cast<std::size_t>(offsets.back() + counts.back()));
  MPI_Allgatherv(local.data(), local_count, MPI_DOUBLE, all.data(), counts.data(), offsets.data(), MPI_DOUBLE,
                 MPI_COMM_WORLD);
  constexpr std::size_t stride = kParticleValues + 1;
  std::vector<std::size_t> order(all.size() / stride);
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&all](std::size_t a, std::size_t b) { return all[stride * a] < all[stride * b]; });
  SettledParticles particles;
  particles.reserve(order.size() * kParticleValues);
  for (const std::size_t i : order)
    particles.insert(particles.end(), all.begin() + static_cast<std::ptrdiff_t>(stride * i + 1),
                     all.begin() + static_cast<std::ptrdiff_t>(stride * (i + 1)));
  return particles;
}

std::filesystem::path soilDirectory(const BackendOptions& options) {
  return options.soil_directory.empty() ? adapter::defaultSoilDirectory() : options.soil_directory;
}

adapter::SettledSoil toNeutral(const study::Study& study, const SettledParticles& particles) {
  adapter::SettledSoil soil;
  for (std::size_t i = 0; i < particles.size(); i += kParticleValues)
    soil.particles.push_back({{particles[i], particles[i + 1], particles[i + 2]},
                              particles[i + 3],
                              layerOfDeposited(study, static_cast<int>(particles[i + 4]), particles[i + 1])});
  return soil;
}

SettledParticles fromNeutral(const study::Study& study, const adapter::SettledSoil& soil) {
  SettledParticles particles;
  particles.reserve(soil.particles.size() * kParticleValues);
  for (const auto& p : soil.particles)
    particles.insert(particles.end(), {p.x_m[0], p.x_m[1], p.x_m[2], p.radius_m,
                                       static_cast<double>(atomType(study, study.soil.layers[static_cast<std::size_t>(p.layer)].material))});
  return particles;
}

// Inserts the layers (deck.deposition) in an instance of its own and lets them settle under gravity
// until the translational kinetic energy is below soil.settle_kinetic_energy_J (checked every
// kSettleCheck_s, after twice the fall time, for at most kSettleLimit_s more: then the soil is
// reported as capped, not settled), then removes the particles above the fill height (deck.trim).
// Rotational energy is not part of the criterion: a spin about the contact normal is resisted by
// none of LIGGGHTS' laws here (no torsional friction), so a particle can keep drilling in place while
// the packing is at rest; the saved state has no spin. Collective.
adapter::SettledSoil depositInInstance(const study::Study& study, const InputDeck& deck,
                                       const std::filesystem::path& work_dir) {
  Instance deposition(work_dir, "deposition");
  for (const auto& line : deck.setup) deposition.command(line);
  deposition.command("fix integrate all nve/sphere");
  for (const auto& line : deck.deposition) deposition.command(line);
  const double dt = deck.time_step_s;
  const auto chunk = std::max<long long>(1, std::llround(kSettleCheck_s / dt));
  const double fall_time = 2 * deck.fall_time_s;
  double t = 0, energy = 0;
  bool capped = false;
  while (true) {
    deposition.command("run " + std::to_string(chunk) + " post no");
    t += static_cast<double>(chunk) * dt;
    energy = deposition.computeScalar("kinetic_energy");
    if (!std::isfinite(energy))
      throw CouplingError(ErrorCode::SimulationFailed, "deposition diverged (kinetic energy is not finite); "
                                                       "reduce dem.dt_fraction or dem.dt_s");
    if (t >= fall_time && energy < study.soil.settle_kinetic_energy_J) break;
    if (t > fall_time + kSettleLimit_s) {
      capped = true;
      break;
    }
  }
  for (const auto& line : deck.trim) deposition.command(line);
  adapter::SettledSoil soil = toNeutral(study, gatherParticles(deposition.get()));
  soil.soil_hash = study::soilHash(study);
  soil.backend = capabilities().name;
  soil.seed = study.soil.deposition_seed;
  soil.cores = worldSize();
  soil.settling.kinetic_energy_J = energy;
  soil.settling.threshold_J = study.soil.settle_kinetic_energy_J;
  soil.settling.stages = 1;
  soil.settling.stages_capped = capped ? 1 : 0;
  soil.settling.final_phase_capped = capped;
  soil.settling.simulated_s = t;
  soil.settling.surface_height_m = adapter::soilSurfaceHeight(soil.particles, study.soil.diameter_max_m);
  soil.settling.packing_fraction = adapter::packingFraction(soil.particles, study.soil);
  soil.settling.bulk_density_kg_m3 = adapter::bulkDensity(soil.particles, study.soil);
  soil.settling.coordination_number = adapter::meanCoordinationNumber(soil.particles);
  return soil;
}

}  // namespace demfem::liggghts::detail
