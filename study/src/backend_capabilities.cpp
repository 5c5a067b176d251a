// A study judged against the capabilities of the backends it names (backend_capabilities.hpp).
#include "demfem/study/backend_capabilities.hpp"

#include "enum_names.hpp"

#include <algorithm>

namespace demfem::study {

namespace {

const BackendCapabilities* find(const std::vector<BackendCapabilities>& registry, const std::string& name) {
  for (const BackendCapabilities& b : registry)
    if (b.name == name) return &b;
  return nullptr;
}

// One law family: `chosen` must be among `offered`; the message suggests the offered laws other than
// "none".
template <class E>
void checkLaw(const BackendCapabilities& backend, const char* path, E chosen, const std::vector<E>& offered,
              const detail::NameTable<E>& names, std::vector<Issue>& issues) {
  if (std::find(offered.begin(), offered.end(), chosen) != offered.end()) return;
  std::string alternatives;
  std::size_t count = 0;
  for (E law : offered) {
    const std::string& name = detail::nameOf(names, law);
    if (name == "none") continue;
    alternatives += (count++ ? " or \"" : "\"") + name + "\"";
  }
  issues.push_back({path, "\"" + detail::nameOf(names, chosen) + "\" is not available in the " + backend.name +
                              " backend; use " + alternatives});
}

void checkLaws(const BackendCapabilities& backend, const ContactModel& c, std::vector<Issue>& issues) {
  checkLaw(backend, "/soil/contact/normal", c.normal, backend.normal_laws, detail::kNormalModels, issues);
  checkLaw(backend, "/soil/contact/cohesion", c.cohesion, backend.cohesion_laws, detail::kCohesionModels, issues);
  checkLaw(backend, "/soil/contact/rolling", c.rolling, backend.rolling_laws, detail::kRollingModels, issues);
}

}  // namespace

std::vector<Issue> backendIssues(const Study& study, const std::vector<BackendCapabilities>& registry) {
  std::vector<Issue> issues;
  if (!hasSoil(study.kind)) return issues;
  const BackendCapabilities* run = find(registry, study.dem.backend);
  if (!run) {
    std::string names;
    for (const BackendCapabilities& b : registry) names += (names.empty() ? "" : ", ") + b.name;
    issues.push_back({"/dem/backend", "unknown backend \"" + study.dem.backend + "\" (this build offers " + names + ")"});
  }
  const std::string& deposition = study.soil.deposition_backend;
  const BackendCapabilities* deposits = find(registry, deposition);
  if (!deposits) {
    issues.push_back({"/soil/deposition/backend", "the " + deposition + " backend is not in this build"});
  } else if (!deposits->simulates_soil) {
    issues.push_back({"/soil/deposition/backend", "the " + deposition + " backend simulates no particles: it cannot deposit a soil"});
    deposits = nullptr;
  }
  // The density protocol (docs/builtin-dem.md, "Soil deposition and reuse") is the built-in deposition's.
  if (study.soil.bulk_density_kg_m3 && deposition != "builtin")
    issues.push_back({"/soil/deposition/bulk_density_kg_m3",
                      "a bed at a stated bulk density is deposited by the builtin backend only (the " + deposition +
                          " deposition is the plain gravity pour): remove the key or deposit with builtin"});
  // Each backend that touches the soil once: the deposition's, and the run's if it is another.
  std::vector<Issue> laws;
  if (deposits) checkLaws(*deposits, study.soil.contact, laws);
  if (run && run != deposits && run->simulates_soil) checkLaws(*run, study.soil.contact, laws);
  issues.insert(issues.end(), laws.begin(), laws.end());
  return issues;
}

}  // namespace demfem::study
