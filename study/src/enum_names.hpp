// Private to the study library: the file spelling of every enumeration of study.hpp, shared by the
// loader (file -> value) and the serializer (value -> file) so the two cannot disagree.
#pragma once

#include "demfem/study/contact_laws.hpp"
#include "demfem/study/study.hpp"

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace demfem::study::detail {

template <class E>
using NameTable = std::vector<std::pair<std::string, E>>;

inline const NameTable<StudyKind> kStudyKinds{{"coupled", StudyKind::Coupled},
                                              {"dem-only", StudyKind::DemOnly},
                                              {"weight-drop", StudyKind::WeightDrop},
                                              {"cone-penetration", StudyKind::ConePenetration},
                                              {"fem-only", StudyKind::FemOnly}};
// The contact laws' spellings come from their traits (contact_laws.hpp).
template <class E, std::size_t N, class With>
NameTable<E> lawNames(const E (&all)[N], With with) {
  NameTable<E> table;
  for (E value : all) table.emplace_back(std::string(with(value, [](auto law) { return decltype(law)::name; })), value);
  return table;
}
inline const NameTable<NormalModel> kNormalModels =
    lawNames(kAllNormalModels, [](NormalModel m, auto f) { return withNormalLaw(m, f); });
inline const NameTable<CohesionModel> kCohesionModels =
    lawNames(kAllCohesionModels, [](CohesionModel m, auto f) { return withCohesionLaw(m, f); });
inline const NameTable<RollingModel> kRollingModels =
    lawNames(kAllRollingModels, [](RollingModel m, auto f) { return withRollingLaw(m, f); });
inline const NameTable<DepositionBackend> kDepositionBackends{{"builtin", DepositionBackend::Builtin},
                                                              {"liggghts", DepositionBackend::Liggghts}};
inline const NameTable<GeometryKind> kGeometryKinds{{"plate", GeometryKind::Plate},
                                                    {"gmsh", GeometryKind::Gmsh},
                                                    {"matrix-market", GeometryKind::MatrixMarket},
                                                    {"cone", GeometryKind::Cone}};
inline const NameTable<ElementOrder> kElementOrders{{"linear", ElementOrder::Linear},
                                                    {"quadratic", ElementOrder::Quadratic}};
inline const NameTable<FemIntegration> kFemIntegrations{{"modal", FemIntegration::Modal},
                                                         {"full", FemIntegration::Full}};
inline const NameTable<TimeStepCriterion> kCriteria{{"rayleigh", TimeStepCriterion::Rayleigh},
                                                    {"stiffest-spring", TimeStepCriterion::StiffestSpring}};
inline const NameTable<ForceAveraging> kForceAveraging{{"interval-mean", ForceAveraging::IntervalMean},
                                                       {"instantaneous", ForceAveraging::Instantaneous}};

template <class E>
const std::string& nameOf(const NameTable<E>& table, E value) {
  for (const auto& [name, v] : table)
    if (v == value) return name;
  throw std::logic_error("study: enumeration value without a file name");
}

}  // namespace demfem::study::detail
