// demfem study: one trait struct per contact law of the study file (docs/architecture.md section 11,
// docs/builtin-dem.md). A law's file spelling and the `soil.contact` keys it reads are stated once,
// here; every place that depends on the law reaches its trait through a `switch` without `default`
// (withNormalLaw, withCohesionLaw, withRollingLaw), so the compiler names each place a new law must
// fill (docs/architecture.md section 14, "How to add a contact law").
#pragma once

#include "demfem/study/study.hpp"

#include <stdexcept>
#include <string_view>

namespace demfem::study {

// The `soil.contact` parameters a normal law reads (bits of NormalLaw::parameters).
enum ContactParameter : unsigned {
  kStiffnessFactor = 1u << 0,                  // contact.stiffness_factor
  kDampingFactor = 1u << 1,                    // contact.damping_factor
  kCharacteristicVelocity = 1u << 2,           // contact.characteristic_velocity_m_s
  kCoefficientMaxElasticStiffness = 1u << 3,   // contact.coefficient_max_elastic_stiffness
  kCoefficientPlasticityDepth = 1u << 4,       // contact.coefficient_plasticity_depth
  kCoefficientAdhesionStiffness = 1u << 5,     // contact.coefficient_adhesion_stiffness
};

// Normal laws.
struct EdemHystereticLaw {  // EDEM hysteretic spring, K1 = 5 R* Y, K2 = K1 / e^2
  static constexpr NormalModel model = NormalModel::EdemHysteretic;
  static constexpr std::string_view name = "edem-hysteretic";
  static constexpr unsigned parameters = kStiffnessFactor | kDampingFactor;
};
struct HookeLaw {  // LIGGGHTS model hooke
  static constexpr NormalModel model = NormalModel::Hooke;
  static constexpr std::string_view name = "hooke";
  static constexpr unsigned parameters = kCharacteristicVelocity;
};
struct HookeHysteresisLaw {  // LIGGGHTS model hooke/hysteresis
  static constexpr NormalModel model = NormalModel::HookeHysteresis;
  static constexpr std::string_view name = "hooke-hysteresis";
  static constexpr unsigned parameters = kCharacteristicVelocity | kCoefficientMaxElasticStiffness |
                                         kCoefficientPlasticityDepth | kCoefficientAdhesionStiffness;
};

// Cohesion laws; `energy_density` says whether interactions[].cohesion_J_m3 applies.
struct NoCohesionLaw {
  static constexpr CohesionModel model = CohesionModel::None;
  static constexpr std::string_view name = "none";
  static constexpr bool energy_density = false;
};
struct EdemLinearCohesionLaw {
  static constexpr CohesionModel model = CohesionModel::EdemLinear;
  static constexpr std::string_view name = "edem-linear";
  static constexpr bool energy_density = true;
};
struct SjkrCohesionLaw {
  static constexpr CohesionModel model = CohesionModel::Sjkr;
  static constexpr std::string_view name = "sjkr";
  static constexpr bool energy_density = true;
};
struct Sjkr2CohesionLaw {
  static constexpr CohesionModel model = CohesionModel::Sjkr2;
  static constexpr std::string_view name = "sjkr2";
  static constexpr bool energy_density = true;
};

// Rolling-resistance laws; `friction` says whether interactions[].rolling_friction applies,
// `spin_scale` whether soil.contact.rolling_regularisation_fraction does.
struct NoRollingLaw {
  static constexpr RollingModel model = RollingModel::None;
  static constexpr std::string_view name = "none";
  static constexpr bool friction = false;
  static constexpr bool spin_scale = false;
};
struct EdemStandardRollingLaw {
  static constexpr RollingModel model = RollingModel::EdemStandard;
  static constexpr std::string_view name = "edem-standard";
  static constexpr bool friction = true;
  static constexpr bool spin_scale = true;
};
struct CdtRollingLaw {
  static constexpr RollingModel model = RollingModel::Cdt;
  static constexpr std::string_view name = "cdt";
  static constexpr bool friction = true;
  static constexpr bool spin_scale = false;
};
struct EpsdRollingLaw {
  static constexpr RollingModel model = RollingModel::Epsd;
  static constexpr std::string_view name = "epsd";
  static constexpr bool friction = true;
  static constexpr bool spin_scale = false;
};

// Calls `f` with the trait of `model` and returns what it returns.
template <class F>
decltype(auto) withNormalLaw(NormalModel model, F&& f) {
  switch (model) {
    case NormalModel::EdemHysteretic: return f(EdemHystereticLaw{});
    case NormalModel::Hooke: return f(HookeLaw{});
    case NormalModel::HookeHysteresis: return f(HookeHysteresisLaw{});
  }
  throw std::logic_error("withNormalLaw: not a NormalModel value");
}

template <class F>
decltype(auto) withCohesionLaw(CohesionModel model, F&& f) {
  switch (model) {
    case CohesionModel::None: return f(NoCohesionLaw{});
    case CohesionModel::EdemLinear: return f(EdemLinearCohesionLaw{});
    case CohesionModel::Sjkr: return f(SjkrCohesionLaw{});
    case CohesionModel::Sjkr2: return f(Sjkr2CohesionLaw{});
  }
  throw std::logic_error("withCohesionLaw: not a CohesionModel value");
}

template <class F>
decltype(auto) withRollingLaw(RollingModel model, F&& f) {
  switch (model) {
    case RollingModel::None: return f(NoRollingLaw{});
    case RollingModel::EdemStandard: return f(EdemStandardRollingLaw{});
    case RollingModel::Cdt: return f(CdtRollingLaw{});
    case RollingModel::Epsd: return f(EpsdRollingLaw{});
  }
  throw std::logic_error("withRollingLaw: not a RollingModel value");
}

// Every value of each law family, in file order (docs and choice lists).
inline constexpr NormalModel kAllNormalModels[] = {NormalModel::EdemHysteretic, NormalModel::Hooke,
                                                   NormalModel::HookeHysteresis};
inline constexpr CohesionModel kAllCohesionModels[] = {CohesionModel::None, CohesionModel::EdemLinear,
                                                       CohesionModel::Sjkr, CohesionModel::Sjkr2};
inline constexpr RollingModel kAllRollingModels[] = {RollingModel::None, RollingModel::EdemStandard,
                                                     RollingModel::Cdt, RollingModel::Epsd};

inline unsigned normalLawParameters(NormalModel model) {
  return withNormalLaw(model, [](auto law) { return decltype(law)::parameters; });
}
inline bool cohesionUsesEnergyDensity(CohesionModel model) {
  return withCohesionLaw(model, [](auto law) { return decltype(law)::energy_density; });
}
inline bool rollingUsesFriction(RollingModel model) {
  return withRollingLaw(model, [](auto law) { return decltype(law)::friction; });
}
inline bool rollingUsesSpinScale(RollingModel model) {
  return withRollingLaw(model, [](auto law) { return decltype(law)::spin_scale; });
}

}  // namespace demfem::study
