#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/backends/builtin/backend.hpp"

#include "demfem/backends/physics/time_step.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <numbers>
#include <numeric>
#include <random>
#include <sstream>
#include <stdexcept>

namespace demfem::builtin {

namespace {
constexpr double kSettledPacking = 0.60;     // solid fraction assumed to size each stage's batch
constexpr double kLatticeGap = 1.10;          // insertion lattice spacing / d_max
constexpr double kStageTimeCap_s = 1.5;        // simulated settling time cap per layer stage, after the fall
constexpr double kFinalTimeCap_s = 3.0;        // the final settling's cap: the soil that is kept
constexpr int kSustainedChecks = 3;            // consecutive energy checks below the threshold
constexpr double kSettlingDamping_per_s = 20;  // background damping once the stage has landed (KE e-folds in 25 ms)
constexpr double kLandingFallTimes = 2.0;      // undamped for this many fall times of the highest particle
constexpr int kEnergyCheckSteps = 200;        // steps between kinetic-energy checks
constexpr double kDepositionStepFraction = 0.1;  // of the stiffest spring's critical step, at least
}  // namespace

Domain binDomain(const study::Soil& soil) {
  const double margin = 2 * soil.diameter_max_m;
  // Room above the fill: the loose insertion lattice of a stage and the tools (up to 0.3 m).
  const double top = std::max(3.0 * soil.fill_height_m, soil.fill_height_m + 0.3);
  return Domain{{-margin, -margin, -margin}, {soil.bin_width_m + margin, top, soil.bin_length_m + margin}};
}

void addBinWalls(DemSimulation& sim, const study::Soil& soil) {
  const int mat = sim.materials().index(soil.bin_material);
  const double w = soil.bin_width_m, l = soil.bin_length_m;
  sim.addPlane({{0, 0, 0}, {0, 1, 0}, mat});
  sim.addPlane({{0, 0, 0}, {1, 0, 0}, mat});
  sim.addPlane({{w, 0, 0}, {-1, 0, 0}, mat});
  sim.addPlane({{0, 0, 0}, {0, 0, 1}, mat});
  sim.addPlane({{0, 0, l}, {0, 0, -1}, mat});
}

int layerAt(const study::Soil& soil, double y) {
  const double depth = soil.fill_height_m - y;
  for (std::size_t l = 0; l < soil.layers.size(); ++l)
    if (depth < soil.layers[l].bottom_depth_m) return static_cast<int>(l);
  return static_cast<int>(soil.layers.size()) - 1;
}

double meanParticleVolume(const study::Soil& soil) {
  const double rmin = soil.diameter_min_m / 2, rmax = soil.diameter_max_m / 2;
  // Mean sphere volume for radii uniform in [rmin, rmax]: E[r^3] = (rmax^4 - rmin^4) / (4 (rmax - rmin)).
  const double mean_r3 = rmax > rmin ? (std::pow(rmax, 4) - std::pow(rmin, 4)) / (4 * (rmax - rmin)) : rmin * rmin * rmin;
  return 4.0 / 3.0 * std::numbers::pi * mean_r3;
}

// Settles `sim` until its kinetic energy has stayed below `threshold_J` for kSustainedChecks checks
// in a row: undamped while the stage falls and lands (`undamped_s`), then with the settling damping,
// for at most `cap_s` more. The damping is off again on return. `tick` gets the fraction of the
// stage's time used.
bool settle(DemSimulation& sim, double threshold_J, double undamped_s, double cap_s, const std::function<void(double)>& tick) {
  const double start = sim.time(), end = undamped_s + cap_s;
  int below = 0;
  while (below < kSustainedChecks && sim.time() - start < end) {
    if (sim.settlingDamping() == 0 && sim.time() - start >= undamped_s) sim.setSettlingDamping(kSettlingDamping_per_s);
    sim.run(kEnergyCheckSteps);
    tick((sim.time() - start) / end);
    below = sim.settlingDamping() > 0 && sim.kineticEnergy() < threshold_J ? below + 1 : 0;
  }
  sim.setSettlingDamping(0);
  return below == kSustainedChecks;
}

std::size_t estimatedParticleCount(const study::Soil& soil) {
  return static_cast<std::size_t>(
      std::llround(kSettledPacking * soil.bin_width_m * soil.bin_length_m * soil.fill_height_m / meanParticleVolume(soil)));
}

adapter::SettledSoil depositSoil(const study::Study& study, int threads, DepositReport& report, const DepositProgress& progress) {
  const auto& soil = study.soil;
  if (soil.layers.empty()) throw std::invalid_argument("builtin DEM: /soil/layers is empty");
  DemSimulation sim(soil, binDomain(soil), threads);
  addBinWalls(sim, soil);
  std::mt19937_64 rng(soil.deposition_seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double rmin = soil.diameter_min_m / 2, rmax = soil.diameter_max_m / 2;
  const double mean_volume = meanParticleVolume(soil);
  const double w = soil.bin_width_m, l = soil.bin_length_m;
  const double spacing = kLatticeGap * soil.diameter_max_m;
  const int nx = std::max(1, static_cast<int>((w - spacing) / spacing) + 1);
  const int nz = std::max(1, static_cast<int>((l - spacing) / spacing) + 1);

  // Stage tops (heights above the floor) from the bottom layer up: the layer boundaries.
  std::vector<double> stage_tops;
  for (auto it = soil.layers.rbegin(); it != soil.layers.rend(); ++it) stage_tops.push_back(soil.fill_height_m - it->top_depth_m);
  const int deepest = static_cast<int>(soil.layers.size()) - 1;
  const int deposit_material = sim.materials().index(soil.layers[deepest].material);

  // Progress: the deposition stages and the final settling, each counted by its time cap.
  const double stages = static_cast<double>(stage_tops.size() + 1);
  adapter::SettledSoil out;
  out.settling.threshold_J = soil.settle_kinetic_energy_J;
  out.settling.stages = static_cast<std::int32_t>(stage_tops.size()) + 1;
  double filled = 0;  // height filled so far
  bool dt_set = false;
  for (std::size_t s = 0; s < stage_tops.size(); ++s) {
    const bool last = s + 1 == stage_tops.size();
    // Overfill the last stage by 5 % so that the trimmed surface reaches the fill height.
    const double volume = w * l * (stage_tops[s] - filled) * (last ? 1.05 : 1.0);
    const auto count = static_cast<std::size_t>(std::ceil(kSettledPacking * volume / mean_volume));
    double ytop = 0;
    for (std::size_t i = 0; i < sim.particleCount(); ++i) ytop = std::max(ytop, sim.particle(i).x[1] + sim.particle(i).radius);
    const double y0 = ytop + spacing / 2 + 0.5 * soil.diameter_max_m;
    for (std::size_t k = 0; k < count; ++k) {
      const std::size_t per_level = static_cast<std::size_t>(nx) * nz;
      const std::size_t level = k / per_level, in_level = k % per_level;
      const double jitter = 0.5 * (spacing - soil.diameter_max_m);
      ParticleState p;
      p.radius = rmin + (rmax - rmin) * unit(rng);
      p.x = {spacing / 2 + spacing * static_cast<double>(in_level % nx) + jitter * (2 * unit(rng) - 1),
             y0 + spacing * static_cast<double>(level) + jitter * (2 * unit(rng) - 1),
             spacing / 2 + spacing * static_cast<double>(in_level / nx) + jitter * (2 * unit(rng) - 1)};
      p.material = deposit_material;
      p.layer = deepest;
      sim.addParticle(p);
    }
    if (!dt_set) {
      // Deposition prepares the soil; it is not the study's physics. It steps at the study's step
      // or at kDepositionStepFraction of the stiffest spring's critical step, whichever is larger:
      // the paper's Rayleigh step (7.93e-7 s) is about 70 times below what the hysteretic spring
      // needs and would make the full bin take hours to settle.
      sim.setTimeStep(std::max(physics::demTimeStep(study).step_s,
                               kDepositionStepFraction * physics::criticalStep(study, study::TimeStepCriterion::StiffestSpring).step_s));
      sim.setRollingRegularisationStep(physics::rollingRegularisationStep(study));
      dt_set = true;
    }
    // The highest particle of the batch falls from its lattice level onto the pack.
    const double drop = y0 + spacing * static_cast<double>((count - 1) / (static_cast<std::size_t>(nx) * nz)) - ytop;
    const double g = std::hypot(sim.gravity()[0], sim.gravity()[1], sim.gravity()[2]);
    const double fall_s = std::sqrt(2 * std::max(drop, 0.0) / g);
    const double start = sim.time();
    const bool settled = settle(sim, soil.settle_kinetic_energy_J, kLandingFallTimes * fall_s, kStageTimeCap_s, [&](double f) {
      if (progress) progress((static_cast<double>(s) + f) / stages, "");
    });
    const double energy = sim.kineticEnergy();
    if (!settled) ++out.settling.stages_capped;
    filled = stage_tops[s];
    if (progress) {
      std::ostringstream line;
      line << "stage " << s + 1 << "/" << stage_tops.size() << ": " << sim.particleCount() << " particles, up to "
           << filled * 1e3 << " mm, kinetic energy " << energy << " J after " << sim.time() - start << " s"
           << (settled ? "" : " (time cap reached before the energy threshold)");
      progress((static_cast<double>(s) + 1.0) / stages, line.str());
    }
  }
  // Trim above the fill height, tag layers by depth, settle again with the layer materials.
  std::vector<char> keep(sim.particleCount());
  for (std::size_t i = 0; i < keep.size(); ++i) keep[i] = sim.particle(i).x[1] <= soil.fill_height_m;
  sim.keepParticles(keep);
  for (std::size_t i = 0; i < sim.particleCount(); ++i) {
    const int layer = layerAt(soil, sim.particle(i).x[1]);
    sim.setParticleMaterial(static_cast<int>(i), sim.materials().index(soil.layers[layer].material), layer);
  }
  const double start = sim.time();
  const bool settled = settle(sim, soil.settle_kinetic_energy_J, 0.0, kFinalTimeCap_s, [&](double f) {
    if (progress) progress((stages - 1.0 + f) / stages, "");
  });
  if (!settled) ++out.settling.stages_capped;
  out.settling.final_phase_capped = !settled;
  if (progress) {
    std::ostringstream line;
    line << "final settling: kinetic energy " << sim.kineticEnergy() << " J after " << sim.time() - start << " s"
         << (settled ? "" : " (time cap reached before the energy threshold)");
    progress(1.0, line.str());
  }

  out.soil_hash = study::soilHash(study);
  out.backend = capabilities().name;
  out.seed = soil.deposition_seed;
  out.cores = threads;
  for (std::size_t i = 0; i < sim.particleCount(); ++i) {
    const auto p = sim.particle(i);
    out.particles.push_back({p.x, p.radius, p.layer});
  }
  out.settling.kinetic_energy_J = sim.kineticEnergy();
  out.settling.simulated_s = sim.time();
  out.settling.surface_height_m = adapter::soilSurfaceHeight(out.particles, soil.diameter_max_m);
  out.settling.packing_fraction = adapter::packingFraction(out.particles, soil);
  report.steps = sim.stepCount();
  report.time_step_s = sim.timeStep();
  return out;
}

void addSettledParticles(DemSimulation& sim, const study::Soil& soil, const adapter::SettledSoil& settled) {
  // Added in spatial order (cells one diameter wide; x fastest, then y, then z along the bin): a
  // particle's neighbours are then within a slab of about 200 indices instead of a deposition
  // lattice layer (about 1,300 in the paper bin), so the pair loop's working set stays in L1/L2.
  const double cell = soil.diameter_max_m;
  const auto key = [cell](const adapter::SoilParticle& p) {
    return std::array<long, 3>{std::lround(std::floor(p.x_m[2] / cell)), std::lround(std::floor(p.x_m[1] / cell)),
                               std::lround(std::floor(p.x_m[0] / cell))};
  };
  std::vector<std::size_t> order(settled.particles.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return key(settled.particles[a]) < key(settled.particles[b]); });
  for (const std::size_t k : order) {
    const auto& p = settled.particles[k];
    if (p.layer < 0 || p.layer >= static_cast<int>(soil.layers.size()))
      throw std::runtime_error("settled soil: layer " + std::to_string(p.layer) + " not in /soil/layers");
    ParticleState s;
    s.x = p.x_m;
    s.radius = p.radius_m;
    s.layer = p.layer;
    s.material = sim.materials().index(soil.layers[p.layer].material);
    sim.addParticle(s);
  }
}

}  // namespace demfem::builtin
