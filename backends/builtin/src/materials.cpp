// Materials of the built-in DEM: the interaction table, the materials a simulation uses and the
// time step they allow (docs/builtin-dem.md, "Time step").
#include "demfem/backends/builtin/simulation.hpp"

#include "demfem/backends/physics/dem_formulas.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace demfem::builtin {

int MaterialTable::index(const std::string& name) const {
  for (std::size_t i = 0; i < materials.size(); ++i)
    if (materials[i].name == name) return static_cast<int>(i);
  throw std::invalid_argument("builtin DEM: material '" + name + "' is not in /soil/materials");
}

MaterialTable MaterialTable::fromSoil(const study::Soil& soil) {
  MaterialTable t;
  t.materials = soil.materials;
  const std::size_t n = t.materials.size();
  if (n == 0) throw std::invalid_argument("builtin DEM: /soil/materials is empty");
  t.laws.resize(n * n);
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = 0; b < n; ++b) {
      const auto& ma = t.materials[a];
      const auto& mb = t.materials[b];
      const study::Interaction* found = nullptr;
      for (const auto& in : soil.interactions)
        if ((in.a == ma.name && in.b == mb.name) || (in.a == mb.name && in.b == ma.name)) found = &in;
      if (!found) continue;  // wall-wall pairs need none; DemSimulation::requirePair() checks use
      if (!(found->restitution > 0 && found->restitution <= 1))
        throw std::invalid_argument("builtin DEM: /soil/interactions '" + ma.name + "' - '" + mb.name +
                                    "': restitution must be in (0, 1], got " + std::to_string(found->restitution));
      PairLaw& law = t.laws[a * n + b];
      law.defined = true;
      law.restitution = found->restitution;
      law.friction = found->static_friction;
      law.rolling_friction = found->rolling_friction;
      law.cohesion_J_m3 = found->cohesion_J_m3;
      // yield_Pa = 0 means "not limiting" (walls): K1 uses the other material's yield strength.
      law.yield_min_Pa = physics::edemYieldMin(ma.yield_Pa, mb.yield_Pa);
      law.youngs_eff_Pa = physics::effectiveYoungs(ma.youngs_Pa, ma.poisson, mb.youngs_Pa, mb.poisson);
      law.log_restitution = std::log(std::min(found->restitution, 1.0 - 1e-12));
    }
  }
  return t;
}

void DemSimulation::useMaterial(int material, bool particle) {
  if (material < 0 || material >= static_cast<int>(table_.materials.size()))
    throw std::invalid_argument("builtin DEM: material index " + std::to_string(material) + " out of range");
  if (particle && model_.normal == study::NormalModel::EdemHysteretic && !(table_.materials[material].yield_Pa > 0))
    throw std::invalid_argument("builtin DEM: particle material '" + table_.materials[material].name +
                                "' needs yield_Pa > 0 for the EDEM hysteretic spring (K1 = 5 R* min(Y))");
  const std::uint8_t flag = particle ? 2 : 1;
  if (used_[material] & flag) return;
  used_[material] |= flag;
  // Every particle material meets every used material (particles and walls).
  for (std::size_t other = 0; other < used_.size(); ++other) {
    if (!used_[other] || (!particle && !(used_[other] & 2))) continue;
    if (!table_.law(material, static_cast<int>(other)).defined)
      throw std::invalid_argument("builtin DEM: /soil/interactions has no entry for the pair '" +
                                  table_.materials[material].name + "' - '" + table_.materials[other].name + "'");
  }
}

ContactStiffness DemSimulation::wallStiffness(int i, int wall_material) const {
  return contactStiffness(model_, table_.law(material_[i], wall_material), radius_[i], mass_[i]);
}

double DemSimulation::stabilityLimit() const {
  // Smallest sqrt(m*/k_max) over particle-particle (smallest particle of each material pair) and
  // particle-wall contacts (every wall material in the table).
  const std::size_t nm = table_.materials.size();
  std::vector<double> rmin(nm, std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < particleCount(); ++i) rmin[material_[i]] = std::min(rmin[material_[i]], radius_[i]);
  double limit = std::numeric_limits<double>::infinity();
  const auto mass = [&](std::size_t m, double r) { return table_.materials[m].density_kg_m3 * 4.0 / 3.0 * std::numbers::pi * r * r * r; };
  for (std::size_t a = 0; a < nm; ++a) {
    if (!std::isfinite(rmin[a])) continue;
    const double ma = mass(a, rmin[a]);
    for (std::size_t b = 0; b < nm; ++b) {
      if (!used_[b]) continue;
      const PairLaw& law = table_.law(static_cast<int>(a), static_cast<int>(b));
      // wall contact (b as wall material)
      const auto sw = contactStiffness(model_, law, rmin[a], ma);
      limit = std::min(limit, 2.0 * std::sqrt(ma / stiffestSpring(model_, law, sw)));
      if (!std::isfinite(rmin[b])) continue;
      const double mb = mass(b, rmin[b]);
      const double meff = ma * mb / (ma + mb), reff = rmin[a] * rmin[b] / (rmin[a] + rmin[b]);
      const auto sp = contactStiffness(model_, law, reff, meff);
      limit = std::min(limit, 2.0 * std::sqrt(meff / stiffestSpring(model_, law, sp)));
    }
  }
  return limit;
}

void DemSimulation::setTimeStep(double dt) {
  if (!(dt > 0)) throw std::invalid_argument("builtin DEM: time step must be > 0");
  if (particleCount() > 0) {
    const double limit = stabilityLimit();
    if (dt > limit)
      throw std::invalid_argument("builtin DEM: time step " + std::to_string(dt) + " s exceeds the stability limit " +
                                  std::to_string(limit) + " s of the stiffest contact spring (2 sqrt(m*/k_max))");
  }
  dt_ = dt;
}

void DemSimulation::setRollingRegularisationStep(double step_s) {
  if (!(step_s >= 0)) throw std::invalid_argument("builtin DEM: rolling regularisation step must be >= 0");
  rolling_step_s_ = step_s;
}

}  // namespace demfem::builtin
