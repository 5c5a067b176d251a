#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/backends/builtin/backend.hpp"

#include "demfem/backends/physics/time_step.hpp"
#include "demfem/study/tool_motion.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <numbers>
#include <numeric>
#include <random>
#include <sstream>
#include <stdexcept>

namespace demfem::builtin {

namespace {
// The gravity pour (docs/builtin-dem.md, "Soil deposition and reuse"), as LIGGGHTS' insert/pack
// deposits (docs/liggghts-backend.md): each layer's particles are created at random non-overlapping
// positions in a slab above the one below at kInsertSolidFraction, enough of them to fill the layer
// at kPouredSolidFraction (random close packing: a frictional pour settles looser, so the surface
// ends above the fill height and the excess is trimmed).
constexpr double kInsertSolidFraction = 0.20;   // LIGGGHTS' volumefraction_region of the same pour
constexpr double kPouredSolidFraction = 0.64;   // solid fraction each layer's count is sized with
constexpr int kInsertAttempts = 4000;           // random positions tried for a particle before the region grows
constexpr double kRegionGrowth = 1.1;           // the region's height grows by this factor when full
constexpr double kLandingFallTimes = 2.0;       // undamped for this many fall times of the highest particle
constexpr double kUndampedSettle_s = 0.5;       // after landing, undamped for at most this long before the aid
constexpr double kPourTimeCap_s = 3.0;          // simulated settling time cap of the pour, after landing
constexpr double kFinalTimeCap_s = 3.0;         // the final settling's cap: the soil that is kept
constexpr int kMaxTrims = 3;                    // trims of centres risen above the fill height after the final settling
constexpr int kSustainedChecks = 3;             // consecutive energy checks below the threshold
constexpr double kSettlingDamping_per_s = 20;   // the settling aid, -c m v and -c I w (KE e-folds in 25 ms)
constexpr int kEnergyCheckSteps = 200;          // steps between kinetic-energy checks
constexpr double kDepositionStepFraction = 0.1;  // of the stiffest spring's critical step, at least
// The reload phase (docs/builtin-dem.md, "A bed at rest"): windows of kReloadWindow_s, the bed
// reloaded as a run loads it before each, until a window moves no centre by more than
// kReloadRestFraction of the smallest diameter and lifts none above the fill height (those are
// trimmed), at most kMaxReloads windows.
constexpr double kReloadWindow_s = 0.5;
constexpr double kReloadRestFraction = 0.05;
constexpr int kMaxReloads = 10;
// The density protocol: the bed's bulk density within kDensityTolerance of the target, found over
// at most kMaxDensityPours pours with a friction factor in [0, 1].
constexpr double kDensityTolerance = 0.01;
constexpr int kMaxDensityPours = 8;
}  // namespace

Domain binDomain(const study::Soil& soil) {
  const double margin = 2 * soil.diameter_max_m;
  // Room above the fill: the pour's insertion region (up to kPouredSolidFraction /
  // kInsertSolidFraction = 3.2 times a layer above the surface) and the tools (up to 0.3 m).
  const double top = std::max(4.0 * soil.fill_height_m + 2 * soil.diameter_max_m, soil.fill_height_m + 0.3);
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

namespace {

// Settles `sim` until its kinetic energy has stayed below `threshold_J` for kSustainedChecks checks
// in a row, at most `landing_s + cap_s`: undamped while the stage falls and lands (`landing_s`) and
// for up to kUndampedSettle_s more, then with the settling aid (the background damping) if it is
// still moving. The aid only takes out the ringing of a pack that has formed; a pour that comes to
// rest by its contact laws alone never sees it. The aid is off again on return. `tick` gets the
// fraction of the stage's time used.
bool settle(DemSimulation& sim, double threshold_J, double landing_s, double cap_s, const std::function<void(double)>& tick) {
  const double start = sim.time(), end = landing_s + cap_s;
  int below = 0;
  while (below < kSustainedChecks && sim.time() - start < end) {
    if (sim.settlingDamping() == 0 && sim.time() - start >= landing_s + kUndampedSettle_s)
      sim.setSettlingDamping(kSettlingDamping_per_s);
    sim.run(kEnergyCheckSteps);
    tick((sim.time() - start) / end);
    below = sim.time() - start >= landing_s && sim.kineticEnergy() < threshold_J ? below + 1 : 0;
  }
  sim.setSettlingDamping(0);
  return below == kSustainedChecks;
}

// `count` particles at random non-overlapping positions in the box x in [r_max, W - r_max], z in
// [r_max, L - r_max], y in [y0, y0 + height] (each sphere wholly inside, LIGGGHTS' all_in), radii
// uniform in [r_min, r_max]: random sequential insertion, the box growing upwards by kRegionGrowth
// whenever kInsertAttempts positions in a row overlap. Returns the particles and sets `height` to the
// box's final height.
std::vector<ParticleState> randomInsertion(std::mt19937_64& rng, std::size_t count, const study::Soil& soil, double y0,
                                           double& height, int material, int layer) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double rmin = soil.diameter_min_m / 2, rmax = soil.diameter_max_m / 2;
  const double x_lo = rmax, x_hi = soil.bin_width_m - rmax, z_lo = rmax, z_hi = soil.bin_length_m - rmax;
  const double cell = 2 * rmax;
  const auto key = [cell](double x, double y, double z) {
    return std::array<long, 3>{std::lround(std::floor(x / cell)), std::lround(std::floor(y / cell)),
                               std::lround(std::floor(z / cell))};
  };
  std::map<std::array<long, 3>, std::vector<std::size_t>> cells;
  std::vector<ParticleState> out;
  out.reserve(count);
  while (out.size() < count) {
    ParticleState p;
    p.radius = rmin + (rmax - rmin) * unit(rng);
    p.material = material;
    p.layer = layer;
    bool placed = false;
    while (!placed) {
      for (int attempt = 0; attempt < kInsertAttempts && !placed; ++attempt) {
        p.x = {x_lo + p.radius + (x_hi - x_lo - 2 * p.radius) * unit(rng), y0 + p.radius + (height - 2 * p.radius) * unit(rng),
               z_lo + p.radius + (z_hi - z_lo - 2 * p.radius) * unit(rng)};
        const auto k = key(p.x[0], p.x[1], p.x[2]);
        bool free = true;
        for (long dz = -1; dz <= 1 && free; ++dz)
          for (long dy = -1; dy <= 1 && free; ++dy)
            for (long dx = -1; dx <= 1 && free; ++dx) {
              const auto it = cells.find({k[0] + dx, k[1] + dy, k[2] + dz});
              if (it == cells.end()) continue;
              for (const std::size_t j : it->second) {
                const auto& q = out[j];
                const double ex = p.x[0] - q.x[0], ey = p.x[1] - q.x[1], ez = p.x[2] - q.x[2];
                const double reach = p.radius + q.radius;
                if (ex * ex + ey * ey + ez * ez < reach * reach) {
                  free = false;
                  break;
                }
              }
            }
        placed = free;
      }
      if (!placed) height *= kRegionGrowth;
    }
    cells[key(p.x[0], p.x[1], p.x[2])].push_back(out.size());
    out.push_back(p);
  }
  return out;
}

// The reload phase: `particles` left alone as a run loads them (measureRest()) for
// kReloadWindow_s, then again from where they ended, until a window moves no particle centre by
// more than kReloadRestFraction of the smallest diameter and none has risen above the fill height
// (at most kMaxReloads windows). After each window, particles whose centre has risen above the fill
// height are trimmed, as after the final settling: such a grain sits perched on the surface, where
// a reload that drops its springs can topple it (on the paper bin a grain perched at 85.2 mm rolled
// 4.4 mm off the 85 mm surface, with its neighbour, when the bed was loaded). A particle keeps its
// layer: a grain that settles a little does not change its material. Loading
// drops the contact history the final settling built (the tangential and rolling springs, the
// hysteretic springs' plastic overlaps), so the first windows let the bed find the rest a run will
// start from: perched grains held by spring history roll off. Replaces `particles` by the bed at
// the end of the last window.
struct ReloadFigures {
  int windows = 0;
  bool at_rest = false;
  RestFigures last;  // the last window
  double simulated_s = 0;
  long steps = 0;
  double time_step_s = 0;  // the run's
};

ReloadFigures reloadUntilAtRest(const study::Study& study, int threads, std::vector<adapter::SoilParticle>& particles,
                                const std::function<void(const std::string&)>& line) {
  ReloadFigures out;
  adapter::SettledSoil bed;
  bed.particles = std::move(particles);
  while (!out.at_rest && out.windows < kMaxReloads) {
    out.last = measureRest(study, bed, kReloadWindow_s, threads, {});
    ++out.windows;
    out.steps += out.last.steps;
    out.time_step_s = out.last.time_step_s;
    out.simulated_s += kReloadWindow_s;
    bed.particles.clear();
    for (const auto& p : out.last.end)
      if (p.x_m[1] <= study.soil.fill_height_m) bed.particles.push_back(p);
    const std::size_t trimmed = out.last.end.size() - bed.particles.size();
    out.at_rest = out.last.largest_displacement_m <= kReloadRestFraction * study.soil.diameter_min_m && trimmed == 0;
    std::ostringstream text;
    text << "reload " << out.windows << ": largest displacement " << out.last.largest_displacement_m * 1e3 << " mm in "
         << kReloadWindow_s << " s, " << out.last.moved_over_1mm << " particles beyond 1 mm, " << trimmed << " risen above the fill height and trimmed";
    line(text.str());
  }
  particles = std::move(bed.particles);
  return out;
}

// The study's soil with the inter-particle friction (static and rolling, pairs of layer materials)
// times `scale`; walls keep theirs.
study::Soil scaledFriction(const study::Soil& soil, double scale) {
  study::Soil scaled = soil;
  std::set<std::string> layer_materials;
  for (const auto& l : soil.layers) layer_materials.insert(l.material);
  for (auto& i : scaled.interactions)
    if (layer_materials.count(i.a) && layer_materials.count(i.b)) {
      i.static_friction *= scale;
      i.rolling_friction *= scale;
    }
  return scaled;
}

// One gravity pour of the study's soil with the inter-particle friction times `friction_scale`
// (1: the study's), its layers from the bottom up, trimmed at the fill height, and a final settling
// with the study's own friction. `label` prefixes the progress lines.
adapter::SettledSoil pour(const study::Study& study, int threads, double friction_scale, DepositReport& report,
                          const DepositProgress& progress, const std::string& label) {
  const auto& soil = study.soil;
  const double dt = std::max(physics::demTimeStep(study).step_s,
                             kDepositionStepFraction * physics::criticalStep(study, study::TimeStepCriterion::StiffestSpring).step_s);
  const auto make = [&](const study::Soil& laws) {
    auto sim = std::make_unique<DemSimulation>(laws, binDomain(soil), threads);
    addBinWalls(*sim, soil);
    // Deposition prepares the soil; it is not the study's physics. It steps at the study's step
    // or at kDepositionStepFraction of the stiffest spring's critical step, whichever is larger:
    // the paper's Rayleigh step (7.93e-7 s) is about 70 times below what the hysteretic spring
    // needs and would make the full bin take hours to settle.
    sim->setTimeStep(dt);
    sim->setRollingRegularisationStep(physics::rollingRegularisationStep(study));
    return sim;
  };
  std::unique_ptr<DemSimulation> sim = make(friction_scale == 1.0 ? soil : scaledFriction(soil, friction_scale));
  std::mt19937_64 rng(soil.deposition_seed);
  const double mean_volume = meanParticleVolume(soil);
  const double w = soil.bin_width_m, l = soil.bin_length_m;
  const double g = std::hypot(sim->gravity()[0], sim->gravity()[1], sim->gravity()[2]);

  // Progress: the deposition stages and the final settling, each counted by its time cap.
  const double stages = 2;  // the pour and the final settling
  adapter::SettledSoil out;
  out.settling.threshold_J = soil.settle_kinetic_energy_J;
  out.settling.stages = soil.reload_until_at_rest ? 3 : 2;  // the pour, the final settling and the reload phase
  out.settling.pour_friction_scale = friction_scale;
  const auto line = [&](double fraction, const std::string& text) {
    if (progress) progress(fraction, text.empty() ? text : label + text);
  };
  // The layers from the deepest up (paper Section 2.9), each with its layer's material, in slabs
  // stacked one above the other as LIGGGHTS' deposition stacks them: the slab of a layer spans
  // kPouredSolidFraction / kInsertSolidFraction times the layer's height range (its particles fill it
  // at kInsertSolidFraction), from r_max above the floor. They fall as one continuous rain, the
  // deepest layer landing first. (Each layer poured onto the settled one below packs about 0.8 %
  // denser: docs/builtin-dem.md, "Soil deposition and reuse".)
  const double stretch = kPouredSolidFraction / kInsertSolidFraction;
  const double r_max = soil.diameter_max_m / 2;
  double stack_top = 0;  // top of the slabs so far
  for (std::size_t s = 0; s < soil.layers.size(); ++s) {
    const int layer = static_cast<int>(soil.layers.size() - 1 - s);
    const auto& spec = soil.layers[static_cast<std::size_t>(layer)];
    const double thickness = spec.bottom_depth_m - spec.top_depth_m;
    const auto count = static_cast<std::size_t>(std::ceil(kPouredSolidFraction * w * l * thickness / mean_volume));
    const double y0 = std::max(stack_top, stretch * (soil.fill_height_m - spec.bottom_depth_m) + r_max);
    double height = stretch * thickness;
    const auto batch = randomInsertion(rng, count, soil, y0, height, sim->materials().index(spec.material), layer);
    stack_top = y0 + height;
    if (stack_top > binDomain(soil).hi[1])
      throw std::runtime_error("builtin deposition: the pour of layer " + std::to_string(layer) + " reaches " +
                               std::to_string(stack_top * 1e3) + " mm, above the DEM domain");
    for (const auto& p : batch) sim->addParticle(p);
  }
  {
    // The highest particle falls from the top of the stack to the floor.
    const double fall_s = std::sqrt(2 * stack_top / g);
    const double start = sim->time();
    const bool settled = settle(*sim, soil.settle_kinetic_energy_J, kLandingFallTimes * fall_s, kPourTimeCap_s,
                                [&](double f) { line(f / stages, ""); });
    if (!settled) ++out.settling.stages_capped;
    std::ostringstream text;
    text << "pour: " << sim->particleCount() << " particles in " << soil.layers.size() << " layers, kinetic energy "
         << sim->kineticEnergy() << " J after " << sim->time() - start << " s"
         << (settled ? "" : " (time cap reached before the energy threshold)");
    line(1.0 / stages, text.str());
  }
  // Trim above the fill height; tag every particle with the layer covering the depth of its centre
  // (and that layer's material: the pour overfills each layer, so its boundary settles off the
  // study's), settled again below.
  std::vector<char> keep(sim->particleCount());
  for (std::size_t i = 0; i < keep.size(); ++i) keep[i] = sim->particle(i).x[1] <= soil.fill_height_m;
  sim->keepParticles(keep);
  for (std::size_t i = 0; i < sim->particleCount(); ++i) {
    const int layer = layerAt(soil, sim->particle(i).x[1]);
    sim->setParticleMaterial(static_cast<int>(i), sim->materials().index(soil.layers[static_cast<std::size_t>(layer)].material), layer);
  }
  const long pour_steps = sim->stepCount();
  const double pour_time = sim->time();
  if (friction_scale != 1.0) {
    // The study's friction restored: the particles, at rest, in a simulation of the study's laws.
    auto restored = make(soil);
    for (std::size_t i = 0; i < sim->particleCount(); ++i) {
      ParticleState p = sim->particle(i);
      p.v = {0, 0, 0};
      p.w = {0, 0, 0};
      restored->addParticle(p);
    }
    sim = std::move(restored);
  }
  const double start = sim->time();
  bool settled = settle(*sim, soil.settle_kinetic_energy_J, 0.0, kFinalTimeCap_s, [&](double f) {
    line((stages - 1.0 + f) / stages, "");
  });
  // Relieved of the trimmed particles' weight and of their contact history (trimming drops it), the
  // hysteretic springs below spring back: centres rise by up to a few tenths of a millimetre (0.12 mm
  // measured in the 120 mm test bin), some above the fill height, some across a layer boundary.
  // Such particles are trimmed or tagged anew and the bed settles again, at most kMaxTrims times.
  for (int round = 0; round < kMaxTrims; ++round) {
    std::vector<char> below(sim->particleCount());
    bool any_above = false;
    for (std::size_t i = 0; i < below.size(); ++i) {
      below[i] = sim->particle(i).x[1] <= soil.fill_height_m;
      any_above = any_above || !below[i];
    }
    if (any_above) sim->keepParticles(below);
    bool retagged = false;
    for (std::size_t i = 0; i < sim->particleCount(); ++i) {
      const auto p = sim->particle(i);
      const int layer = layerAt(soil, p.x[1]);
      if (layer == p.layer) continue;
      sim->setParticleMaterial(static_cast<int>(i), sim->materials().index(soil.layers[static_cast<std::size_t>(layer)].material), layer);
      retagged = true;
    }
    if (!any_above && !retagged) break;
    settled = settle(*sim, soil.settle_kinetic_energy_J, 0.0, kFinalTimeCap_s, [](double) {});
  }
  if (!settled) ++out.settling.stages_capped;
  out.settling.final_phase_capped = !settled;
  {
    std::ostringstream text;
    text << "final settling" << (friction_scale != 1.0 ? " (the study's friction restored)" : "") << ": kinetic energy "
         << sim->kineticEnergy() << " J after " << sim->time() - start << " s"
         << (settled ? "" : " (time cap reached before the energy threshold)");
    line(1.0, text.str());
  }

  out.soil_hash = study::soilHash(study);
  out.backend = capabilities().name;
  out.seed = soil.deposition_seed;
  out.cores = threads;
  for (std::size_t i = 0; i < sim->particleCount(); ++i) {
    const auto p = sim->particle(i);
    out.particles.push_back({p.x, p.radius, p.layer});
  }
  // The settling figure is the final settling's: the reload phase is judged by how far it moves
  // the bed, not by its kinetic energy (a bed on EDEM's standard rolling law creeps through its
  // windows, and loading it starts a run from rest whatever its energy).
  out.settling.kinetic_energy_J = sim->kineticEnergy();
  ReloadFigures reload;
  if (soil.reload_until_at_rest) {
    reload = reloadUntilAtRest(study, threads, out.particles, [&](const std::string& text) { line(1.0, text); });
    if (!reload.at_rest) ++out.settling.stages_capped;
    std::ostringstream text;
    text << "reloaded as a run loads it: " << (reload.at_rest ? "at rest" : "not at rest") << " after " << reload.windows
         << " windows of " << kReloadWindow_s << " s (largest displacement in the last " << reload.last.largest_displacement_m * 1e3
         << " mm)";
    line(1.0, text.str());
  }
  out.settling.simulated_s = (friction_scale != 1.0 ? pour_time : 0.0) + sim->time() + reload.simulated_s;
  out.settling.surface_height_m = adapter::soilSurfaceHeight(out.particles, soil.diameter_max_m);
  out.settling.packing_fraction = adapter::packingFraction(out.particles, soil);
  out.settling.bulk_density_kg_m3 = adapter::bulkDensity(out.particles, soil);
  out.settling.coordination_number = adapter::meanCoordinationNumber(out.particles);
  report.steps += (friction_scale != 1.0 ? pour_steps : 0) + sim->stepCount();
  report.time_step_s = sim->timeStep();
  report.reload_steps += reload.steps;
  report.reload_time_step_s = reload.time_step_s;
  return out;
}

std::string kgm3(double value) {
  std::ostringstream out;
  out.precision(5);
  out << value << " kg/m3";
  return out.str();
}

}  // namespace

std::size_t estimatedParticleCount(const study::Soil& soil) {
  // What the pour inserts (it settles at about 0.57: docs/builtin-dem.md, "Soil deposition and reuse").
  return static_cast<std::size_t>(
      std::llround(kPouredSolidFraction * soil.bin_width_m * soil.bin_length_m * soil.fill_height_m / meanParticleVolume(soil)));
}

adapter::SettledSoil depositSoil(const study::Study& study, int threads, DepositReport& report, const DepositProgress& progress) {
  const auto& soil = study.soil;
  if (soil.layers.empty()) throw std::invalid_argument("builtin DEM: /soil/layers is empty");
  report = {};
  if (!soil.bulk_density_kg_m3) return pour(study, threads, 1.0, report, progress, "");

  // The density protocol: the plain pour first; a denser bed by a pour with the inter-particle
  // friction times f in [0, 1) (the bulk density falls with f), f found by regula falsi (Illinois),
  // the study's friction then restored and the bed settled.
  const double target = *soil.bulk_density_kg_m3;
  const auto within = [&](const adapter::SettledSoil& s) {
    return std::abs(s.settling.bulk_density_kg_m3 - target) <= kDensityTolerance * target;
  };
  const auto finish = [&](adapter::SettledSoil s) {
    s.settling.target_bulk_density_kg_m3 = target;
    return s;
  };
  int pours = 0;
  const auto pourAt = [&](double f) {
    ++pours;
    std::ostringstream label;
    label << "pour " << pours << " (friction x " << f << "): ";
    auto s = pour(study, threads, f, report, progress, label.str());
    if (progress) progress(1.0, label.str() + "bulk density " + kgm3(s.settling.bulk_density_kg_m3) + ", target " + kgm3(target));
    return s;
  };
  auto hi_f = pourAt(1.0);  // the loosest bed of the protocol
  if (within(hi_f)) return finish(std::move(hi_f));
  if (hi_f.settling.bulk_density_kg_m3 > target)
    throw std::runtime_error("/soil/deposition/bulk_density_kg_m3 = " + kgm3(target) +
                             " is looser than the plain gravity pour's " + kgm3(hi_f.settling.bulk_density_kg_m3) +
                             " by more than 1 %: the deposition protocol only densifies (a pour with reduced friction); "
                             "remove the key for the plain pour or raise the density");
  auto lo_f = pourAt(0.0);  // the densest
  if (within(lo_f)) return finish(std::move(lo_f));
  if (lo_f.settling.bulk_density_kg_m3 < target)
    throw std::runtime_error("/soil/deposition/bulk_density_kg_m3 = " + kgm3(target) +
                             " is denser than the frictionless pour's " + kgm3(lo_f.settling.bulk_density_kg_m3) +
                             " by more than 1 %, the densest bed the deposition protocol makes with these particles");
  double f_lo = 0.0, f_hi = 1.0;
  double r_lo = lo_f.settling.bulk_density_kg_m3 - target, r_hi = hi_f.settling.bulk_density_kg_m3 - target;  // r_lo > 0 > r_hi
  int side = 0;
  std::ostringstream tried;
  tried << "friction x 1: " << kgm3(hi_f.settling.bulk_density_kg_m3) << ", x 0: " << kgm3(lo_f.settling.bulk_density_kg_m3);
  while (pours < kMaxDensityPours) {
    const double f = std::clamp((f_lo * r_hi - f_hi * r_lo) / (r_hi - r_lo), f_lo + 0.02 * (f_hi - f_lo), f_hi - 0.02 * (f_hi - f_lo));
    auto s = pourAt(f);
    if (within(s)) return finish(std::move(s));
    const double r = s.settling.bulk_density_kg_m3 - target;
    tried << ", x " << f << ": " << kgm3(s.settling.bulk_density_kg_m3);
    if (r > 0) {
      f_lo = f, r_lo = r;
      if (side == 1) r_hi /= 2;
      side = 1;
    } else {
      f_hi = f, r_hi = r;
      if (side == -1) r_lo /= 2;
      side = -1;
    }
  }
  throw std::runtime_error("/soil/deposition/bulk_density_kg_m3 = " + kgm3(target) + " was not reached within 1 % in " +
                           std::to_string(kMaxDensityPours) + " pours (" + tried.str() +
                           "): the bed's density does not follow the pour's friction closely enough here");
}

void loadSettledBed(DemSimulation& sim, const study::Soil& soil, const adapter::SettledSoil& settled) {
  addBinWalls(sim, soil);
  addSettledParticles(sim, soil, settled);
}

void setRunTimeStep(DemSimulation& sim, const study::Study& study) {
  // A DEM step that divides the FEM step, so simulate(dt_FEM) lands exactly on the FEM time.
  sim.setTimeStep(study::demStepDividing(physics::demTimeStep(study).step_s, study.fem.dt_s));
  sim.setRollingRegularisationStep(physics::rollingRegularisationStep(study));
}

RestFigures measureRest(const study::Study& study, const adapter::SettledSoil& settled, double rest_s, int threads,
                        const RestObserver& observe, double observe_every_s) {
  DemSimulation sim(study.soil, binDomain(study.soil), threads);
  loadSettledBed(sim, study.soil, settled);
  setRunTimeStep(sim, study);
  std::vector<Vec3> start(sim.particleCount()), half;
  for (std::size_t i = 0; i < start.size(); ++i) start[i] = sim.particle(i).x;
  const long steps = std::lround(rest_s / sim.timeStep());
  const long every = std::max(1L, observe_every_s > 0 ? std::lround(observe_every_s / sim.timeStep()) : steps / 20);
  if (observe) observe(sim);
  for (long done = 0; done < steps;) {
    if (half.empty() && done >= steps / 2)
      for (std::size_t i = 0; i < start.size(); ++i) half.push_back(sim.particle(i).x);
    long next = std::min(steps, (done / every + 1) * every);  // the next observation or the end
    if (half.empty()) next = std::min(next, steps / 2);        // or the half
    sim.run(next - done);
    done = next;
    if (observe && done % every == 0) observe(sim);
  }
  const auto distance = [](const Vec3& a, const Vec3& b) { return std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]); };
  RestFigures out;
  out.steps = steps;
  out.time_step_s = sim.timeStep();
  double v2 = 0;
  for (std::size_t i = 0; i < start.size(); ++i) {
    const auto p = sim.particle(i);
    v2 += p.v[0] * p.v[0] + p.v[1] * p.v[1] + p.v[2] * p.v[2];
    const double d = distance(p.x, start[i]);
    out.largest_displacement_m = std::max(out.largest_displacement_m, d);
    if (d > 1e-3) ++out.moved_over_1mm;
    if (!half.empty()) out.largest_late_displacement_m = std::max(out.largest_late_displacement_m, distance(p.x, half[i]));
    out.end.push_back({p.x, p.radius, p.layer});
  }
  out.rms_speed_m_s = start.empty() ? 0.0 : std::sqrt(v2 / static_cast<double>(start.size()));
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
