// The DEM time step of a study: the one home both backends, the cost estimate and `demfem
// validate` take it from (docs/architecture.md section 11, docs/paper-reproduction.md "Time step").
//
// Contract
// - Inputs: the study's materials, interactions, contact law and smallest particle radius
//   R = soil.diameter_min_m / 2; nothing of a particular packing, so every backend and the cost
//   estimate get the same step for the same study. SI units, seconds out.
// - criticalStep(study, Rayleigh): min over the layers' materials of
//   pi R sqrt(rho / G) / (0.1631 nu + 0.8766) (the paper's Section 2 estimate; 20 % of it at
//   R = 4.75 mm is the paper's 7.93e-7 s).
// - criticalStep(study, StiffestSpring): min over every contact the study's particles can make of
//   the contact half period pi sqrt(m* / k_max) (a linear spring's contact duration):
//   particle-particle between any two layer materials (R* = R / 2, m* = m_a m_b / (m_a + m_b)),
//   particle-wall with the bin's material and every tool's dem_material (R* = R, m* = m);
//   k_max is the stiffest spring of the study's normal law: EDEM hysteretic K2 = K1 / e^2 with
//   K1 = 5 R* min(Y_i, Y_j) (e of that pair's interaction), LIGGGHTS hooke kn at the characteristic
//   velocity, hooke/hysteresis kn * max(1, coefficientMaxElasticStiffness).
// - demTimeStep(study): the step a backend runs before it is shortened to divide the FEM step
//   (study::demStepDividing): dem.dt_s when given (the paper's step stays available that way),
//   else dem.dt_fraction of the critical step of dem.criterion. `critical` is that criterion's
//   critical step, or the stiffest spring's for an explicit dem.dt_s (the step's stability margin);
//   `why` says which contact limits it, with its stiffness and mass, in one line.
// - rollingRegularisationStep(study): the step whose spin scale the edem-standard rolling law keeps
//   at every shorter DEM step (builtin/contact_law.hpp, rollingSpinScale):
//   soil.contact.rolling_regularisation_fraction of the stiffest spring's critical step, shortened
//   to divide the FEM step as the DEM step is, so that at a dem.dt_fraction equal to it (criterion
//   stiffest-spring) the two are the same number.
// - Throws std::invalid_argument for a study without layers, a dt_fraction outside (0, 1] or a
//   non-positive dt_s, and std::out_of_range (study::Study::interaction) for a missing pair.
#pragma once

#include "demfem/backends/physics/dem_formulas.hpp"
#include "demfem/study/study.hpp"
#include "demfem/study/tool_motion.hpp"

#include <cstdio>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

namespace demfem::physics {

struct CriticalStep {
  double step_s = std::numeric_limits<double>::infinity();
  std::string contact;      // "particle 'sand' - wall 'steel'", empty for Rayleigh
  double stiffness_N_m = 0; // k_max of that contact (stiffest spring)
  double mass_eff_kg = 0;   // m* of that contact
};

struct DemStep {
  double step_s = 0;      // the step before the FEM-clock division
  double critical_s = 0;  // see contract
  study::TimeStepCriterion criterion = study::TimeStepCriterion::StiffestSpring;  // of critical_s
  bool explicit_step = false;  // dem.dt_s given
  std::string why;
};

namespace detail {

inline double sphereMass(const study::DemMaterial& m, double radius_m) {
  return m.density_kg_m3 * 4.0 / 3.0 * std::numbers::pi * radius_m * radius_m * radius_m;
}

// The stiffest spring of the study's normal law for one contact.
inline double stiffestSpring(const study::Study& s, const study::DemMaterial& a, const study::DemMaterial& b,
                             double radius_eff_m, double mass_eff_kg) {
  const study::ContactModel& law = s.soil.contact;
  switch (law.normal) {  // no default: a new normal law must say its stiffest spring here
    case study::NormalModel::EdemHysteretic:
      return edemUnloadingStiffness(edemLoadingStiffness(radius_eff_m, edemYieldMin(a.yield_Pa, b.yield_Pa)),
                                    s.interaction(a.name, b.name).restitution);
    case study::NormalModel::Hooke:
    case study::NormalModel::HookeHysteresis: {
      const double kn = hookeNormalStiffness(effectiveYoungs(a.youngs_Pa, a.poisson, b.youngs_Pa, b.poisson), radius_eff_m,
                                             mass_eff_kg, law.characteristic_velocity_m_s);
      return law.normal == study::NormalModel::Hooke ? kn : hookeHysteresisPeakStiffness(kn, law.coefficient_max_elastic_stiffness);
    }
  }
  throw std::invalid_argument("DEM time step: unknown normal contact law");
}

inline std::vector<const study::DemMaterial*> layerMaterials(const study::Study& s) {
  if (s.soil.layers.empty()) throw std::invalid_argument("DEM time step: /soil/layers is empty, no particle to derive a step from");
  std::vector<const study::DemMaterial*> out;
  for (const study::Layer& layer : s.soil.layers) {
    const study::DemMaterial* m = &s.material(layer.material);
    if (std::find(out.begin(), out.end(), m) == out.end()) out.push_back(m);
  }
  return out;
}

inline void keepShorter(CriticalStep& best, std::string contact, double k, double m) {
  const double t = contactHalfPeriod(m, k);
  if (t < best.step_s) best = {t, std::move(contact), k, m};
}

inline std::string formatSeconds(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4g", v);
  return text;
}

}  // namespace detail

inline CriticalStep criticalStep(const study::Study& s, study::TimeStepCriterion criterion) {
  const double r = s.soil.diameter_min_m / 2;
  const auto particles = detail::layerMaterials(s);
  CriticalStep best;
  switch (criterion) {  // no default: a new criterion must say its step here
    case study::TimeStepCriterion::Rayleigh:
      for (const study::DemMaterial* m : particles)
        best.step_s = std::min(best.step_s, rayleighTimeStep(r, m->density_kg_m3, m->youngs_Pa, m->poisson));
      return best;
    case study::TimeStepCriterion::StiffestSpring: {
      std::vector<std::string> walls{s.soil.bin_material};
      for (const study::Tool& tool : s.tools)
        if (std::find(walls.begin(), walls.end(), tool.dem_material) == walls.end()) walls.push_back(tool.dem_material);
      for (const study::DemMaterial* a : particles) {
        const double ma = detail::sphereMass(*a, r);
        for (const study::DemMaterial* b : particles) {
          const double mb = detail::sphereMass(*b, r), meff = ma * mb / (ma + mb);
          detail::keepShorter(best, "particle '" + a->name + "' - particle '" + b->name + "'",
                              detail::stiffestSpring(s, *a, *b, r / 2, meff), meff);
        }
        for (const std::string& wall : walls)
          detail::keepShorter(best, "particle '" + a->name + "' - wall '" + wall + "'",
                              detail::stiffestSpring(s, *a, s.material(wall), r, ma), ma);
      }
      return best;
    }
  }
  throw std::invalid_argument("DEM time step: unknown criterion");
}

inline DemStep demTimeStep(const study::Study& s) {
  DemStep out;
  out.explicit_step = s.dem.dt_s.has_value();
  out.criterion = out.explicit_step ? study::TimeStepCriterion::StiffestSpring : s.dem.criterion;
  const CriticalStep critical = criticalStep(s, out.criterion);
  out.critical_s = critical.step_s;
  std::string limit = out.criterion == study::TimeStepCriterion::Rayleigh
                          ? "Rayleigh step " + detail::formatSeconds(critical.step_s) + " s of the smallest particle (R = " +
                                detail::formatSeconds(s.soil.diameter_min_m / 2) + " m)"
                          : "stiffest spring: " + critical.contact + ", k_max = " + detail::formatSeconds(critical.stiffness_N_m) +
                                " N/m, m* = " + detail::formatSeconds(critical.mass_eff_kg) + " kg, pi sqrt(m*/k_max) = " +
                                detail::formatSeconds(critical.step_s) + " s";
  if (out.explicit_step) {
    if (!(*s.dem.dt_s > 0)) throw std::invalid_argument("DEM time step: /dem/dt_s must be > 0");
    out.step_s = *s.dem.dt_s;
    out.why = "explicit dem.dt_s, " + detail::formatSeconds(out.step_s / out.critical_s) + " of the " + limit;
    return out;
  }
  if (!(s.dem.dt_fraction > 0 && s.dem.dt_fraction <= 1))
    throw std::invalid_argument("DEM time step: /dem/dt_fraction must be in (0, 1], got " + detail::formatSeconds(s.dem.dt_fraction));
  out.step_s = s.dem.dt_fraction * out.critical_s;
  out.why = "dem.dt_fraction " + detail::formatSeconds(s.dem.dt_fraction) + " of the " + limit;
  return out;
}

inline double rollingRegularisationStep(const study::Study& s) {
  const double fraction = s.soil.contact.rolling_regularisation_fraction;
  if (!(fraction > 0 && fraction <= 1))
    throw std::invalid_argument("DEM time step: /soil/contact/rolling_regularisation_fraction must be in (0, 1], got " +
                                detail::formatSeconds(fraction));
  return study::demStepDividing(fraction * criticalStep(s, study::TimeStepCriterion::StiffestSpring).step_s, s.fem.dt_s);
}

}  // namespace demfem::physics
