// Private to the study library: the file spelling of every enumeration of study.hpp, shared by the
// loader (file -> value) and the serializer (value -> file) so the two cannot disagree.
#pragma once

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
inline const NameTable<NormalModel> kNormalModels{{"edem-hysteretic", NormalModel::EdemHysteretic},
                                                  {"hooke", NormalModel::Hooke},
                                                  {"hooke-hysteresis", NormalModel::HookeHysteresis}};
inline const NameTable<CohesionModel> kCohesionModels{{"none", CohesionModel::None},
                                                      {"edem-linear", CohesionModel::EdemLinear},
                                                      {"sjkr", CohesionModel::Sjkr},
                                                      {"sjkr2", CohesionModel::Sjkr2}};
inline const NameTable<RollingModel> kRollingModels{{"none", RollingModel::None},
                                                    {"edem-standard", RollingModel::EdemStandard},
                                                    {"cdt", RollingModel::Cdt},
                                                    {"epsd", RollingModel::Epsd}};
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
